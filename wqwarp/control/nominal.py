"""The augmented nominal gait for a batch of robots: gait library + phases + Eq. (1)-(3) + leg IK.

:class:`NominalGait` owns the gait state and turns (command, requested gait, phase residuals, measured legs and wheel
contacts) into nominal leg joint targets and nominal wheel velocities once per policy step. The residual-RL
environment adds the policy's residuals on top; the gait trace tool and open-loop tests use it alone.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from wqwarp.control.gaits import TABLE_I, Gait, gait_index, gait_library_arrays
from wqwarp.kernels import gait as gait_kernels
from wqwarp.robot import constants as C


class NominalGait:
    """Nominal gait of ``world_count`` robots on ``device``.

    Inputs per :meth:`step` (Warp arrays, float32 unless noted): ``command`` (W, 3) (v_x, v_y, w_z) in the base
    frame [m/s, m/s, rad/s]; ``gait_id`` (W,) int32 requested gait (index into ``library``); ``phase_residual``
    (W, 4) [cycles]. Outputs (views, updated in place): ``phase`` (W, 4), ``swing_psi`` (W, 4) (-1 in stance),
    ``foot_target`` (W, 4) vec3 foot points (calf ends) in the hip frames [m], ``leg_joint_target`` (W, 12) [rad],
    ``wheel_velocity`` (W, 4) [rad/s], ``active_gait_id`` (W,) int32.
    """

    def __init__(
        self,
        world_count: int,
        device: wp.context.Devicelike = "cpu",
        library: tuple[Gait, ...] = TABLE_I,
        body_height: float = C.NOMINAL_BODY_HEIGHT,
        swing_height: float = C.NOMINAL_SWING_HEIGHT,
        swing_x_amplitude: float = C.MAX_HORIZONTAL_OFFSET,
        phase_mode: str = "increment",
        lateral_gain: float = 0.0,
        lateral_limit: float = 0.0,
    ):
        self.world_count = world_count
        self.device = wp.get_device(device)
        self.library = library
        self.arrays = gait_library_arrays(self.device, library)
        self.state = gait_kernels.NominalGaitState.allocate(world_count, self.device)
        self.body_height = float(body_height)
        """h_b: foot point (calf end) below the hip in stance [m]."""
        self.swing_height = float(swing_height)
        """h_s: swing clearance [m]."""
        self.swing_x_amplitude = float(swing_x_amplitude)
        """Horizontal swing amplitude of the foot point [m]."""
        if phase_mode not in gait_kernels.PHASE_MODES:
            raise ValueError(f"unknown phase_mode {phase_mode!r}; choose one of {', '.join(gait_kernels.PHASE_MODES)}")
        self.phase_mode = phase_mode
        """How the phase residual enters: ``increment`` (accumulated) or ``offset`` (from the gait clock)."""
        self.lateral_gain = float(lateral_gain)
        """Lateral feed-forward gain: stroke amplitude per m/s of v_y command [s] (0: off, the paper)."""
        self.lateral_limit = float(lateral_limit)
        """|amplitude| bound of the lateral feed-forward [m]."""
        self.command = wp.zeros((world_count, 3), dtype=wp.float32, device=self.device)
        self.gait_id = wp.zeros(world_count, dtype=wp.int32, device=self.device)
        self.phase_residual = wp.zeros((world_count, 4), dtype=wp.float32, device=self.device)
        # The gait state's buffers (allocated once, updated in place by reset and step; see NominalGaitState).
        st = self.state
        self.clock, self.phase, self.active_gait_id = st.clock, st.phase, st.active_gait_id
        self.wheel_velocity, self.swing_psi, self.foot_target = st.wheel_velocity, st.swing_psi, st.foot_target
        self.leg_joint_target = st.leg_joint_target

    def gait_ids(self, name: str) -> int:
        """Index of gait ``name`` in this library (clear ValueError for an unknown name)."""
        return gait_index(name, self.library)

    def reset(self, env_ids, gait_id: int | np.ndarray | None = None) -> None:
        """Restart the phases of ``env_ids`` in gait ``gait_id`` (default: the currently requested gait).
        ``env_ids`` may be a Warp array or torch tensor on the device (no host copy) or a list / NumPy array."""
        from wqwarp.sim.model import index_array

        ids = index_array(env_ids, self.device, self.world_count)
        if ids.shape[0] == 0:
            return
        if gait_id is not None:
            rows = ids.numpy()
            g = self.gait_id.numpy()
            g[rows] = gait_id
            self.gait_id.assign(g)
        gait_kernels.reset_nominal_gait(self.state, ids, self.gait_id, self.arrays)

    def step(self, leg_joint_pos: wp.array, wheel_contact: wp.array, dt: float) -> None:
        """Advance one policy step of length ``dt`` [s] from the measured leg joints (W, 12) [rad] and wheel
        contact flags (W, 4) int32."""
        gait_kernels.step_nominal_gait(
            self.state,
            self.arrays,
            self.gait_id,
            self.command,
            self.phase_residual,
            leg_joint_pos,
            wheel_contact,
            dt,
            self.body_height,
            self.swing_height,
            self.swing_x_amplitude,
            self.phase_mode,
            self.lateral_gain,
            self.lateral_limit,
        )
