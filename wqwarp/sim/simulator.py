"""Batched simulation of N wheeled Go1 robots behind one interface, on CPU or CUDA.

The physics engines share every buffer and kernel except the physics step itself, which a backend class
(``wqwarp.sim.backends``, chosen by ``SimConfig.backend``) does:

* ``mujoco_cpu`` - N MuJoCo robot states stepped with ``mujoco.rollout`` on all cores, mirrored into Newton's state;
* ``mujoco_warp`` - Newton ``SolverMuJoCo`` (mujoco_warp), one MuJoCo world per robot; CUDA-graph replay on CUDA;
* ``featherstone`` - Newton ``SolverFeatherstone`` with spring-damper contacts (the differentiable path's physics).

All expose Newton ``State`` arrays (``joint_q``, ``joint_qd``, ``body_q``, ``body_qd``) as per-world 2-D Warp views,
plus the per-robot arrays of :class:`~wqwarp.sim.buffers.SimBuffers` (applied joint torques, power, wheel contact
forces / flags, body-collision flags, base-frame state), all viewable by torch without copies
(:meth:`Simulator.torch_views`).

Every physics substep runs the actuation kernel (leg PD, wheel PID; ``wqwarp.kernels.actuation``) and accumulates
the power metrics (``wqwarp.kernels.power``) averaged over the substeps of one policy step; after every step, reset
and state write the base frame (velocities, projected gravity, height, yaw; ``kernels.state.compute_base_frame``)
is computed once for every consumer.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from wqwarp.kernels import actuation, power
from wqwarp.kernels.state import (
    BASE_FRAME_OUTPUTS,
    clear_contact_rows,
    compute_base_frame,
    flag_unstable,
    gather_actuated,
    scatter_state_rows,
)
from wqwarp.robot import asset as robot
from wqwarp.robot.motors import MotorModel
from wqwarp.sim.backends import BACKENDS, PhysicsBackend
from wqwarp.sim.backends.mujoco_cpu import MujocoCpuBackend
from wqwarp.sim.buffers import BUFFER_NAMES, SimBuffers
from wqwarp.sim.config import SimConfig
from wqwarp.sim.model import apply_joint_model, index_array

__all__ = ["SimBuffers", "Simulator"]


@wp.kernel
def _wheel_contact_flags(force: wp.array2d(dtype=wp.float32), threshold: float, flags: wp.array2d(dtype=wp.int32)):
    w, k = wp.tid()
    flags[w, k] = wp.where(force[w, k] > threshold, 1, 0)


class Simulator(SimBuffers):
    """N wheeled Go1 robots stepped at ``dt`` with ``decimation`` substeps per :meth:`step`.

    Control inputs (write before :meth:`step`): ``leg_q_target`` (N, 12) [rad], ``wheel_qd_target`` (N, 4) [rad/s],
    ``motor_strength`` (N, 16) [-]. Outputs after :meth:`step`: ``joint_q`` (N, 23), ``joint_qd`` (N, 22),
    ``body_q`` (N, 21) transforms, ``body_qd`` (N, 21) spatial vectors, and every array of
    :class:`~wqwarp.sim.buffers.SimBuffers` (its attributes are the simulator's own): ``joint_torque`` (N, 16) [N m]
    (last substep), ``p_cost`` / ``p_mech`` / ``p_elec`` (N,) [W] averaged over the substeps, each also split into
    ``*_legs`` and ``*_wheels``, the copper loss ``p_copper_legs`` / ``p_copper_wheels`` (N,) [W], ``torque_sq`` /
    ``power_sq`` (N,), ``wheel_force`` (N, 4) [N], ``wheel_contact`` (N, 4) and ``body_collision`` (N, 9) int32 flags,
    ``unstable`` (N,) int32: 1 for a robot whose simulation diverged in this step (MuJoCo reset its data, or a
    coordinate, velocity or torque is non-finite or beyond the ``SimConfig.unstable_*`` limits; the caller must reset
    it), ``actuated_q`` / ``actuated_qd`` (N, 16) the actuated joints in project order, and the base frame
    ``base_lin_vel`` / ``base_ang_vel`` / ``projected_gravity`` (N, 3), ``base_height`` / ``base_yaw`` (N,).
    """

    def __init__(self, cfg: SimConfig):
        cfg.validate()
        self.cfg = cfg
        self.backend = cfg.resolved_backend()
        """Name of the physics backend (``SimConfig.backend`` with ``auto`` resolved)."""
        backend_cls = BACKENDS[self.backend]
        self.device = wp.get_device(cfg.device)
        if backend_cls.requires_cpu and not self.device.is_cpu:
            raise ValueError(f"backend {self.backend!r} needs device 'cpu'")
        n = cfg.num_envs
        self.num_envs = n
        with wp.ScopedDevice(self.device):
            self.model = robot.scene_builder(n, cfg.robot or None).finalize(device=self.device)
            self.layout = robot.robot_layout(self.model)
            apply_joint_model(self.model, self.layout, cfg.joint_model)
            self.robot_mass = float(self.model.body_mass.numpy()[: self.layout.bodies_per_world].sum())
            """Mass of one robot as built [kg] (trunk, legs, wheels; without randomised added mass)."""
            lay = self.layout
            self.state = self.model.state()
            self.joint_q = self.state.joint_q.reshape((n, lay.coords_per_world))
            self.joint_qd = self.state.joint_qd.reshape((n, lay.dofs_per_world))
            self.body_q = self.state.body_q.reshape((n, lay.bodies_per_world))
            self.body_qd = self.state.body_qd.reshape((n, lay.bodies_per_world))
            self.control = self.model.control()
            if self.control.joint_f is None:
                self.control.joint_f = wp.zeros(self.model.joint_dof_count, dtype=wp.float32)
            self.joint_f = self.control.joint_f.reshape((n, lay.dofs_per_world))
            self.coord_index = wp.array(lay.actuated_coord, dtype=wp.int32)
            self.dof_index = wp.array(lay.actuated_dof, dtype=wp.int32)
            self.motor_model = MotorModel()
            """The motors as the battery sees them (``wqwarp.robot.motors``): the electrical power ``p_elec``."""
            self._motor_arrays = power.MotorArrays.build(**self.motor_model.kernel_inputs())
            SimBuffers.__init__(self, **SimBuffers.allocate(n))
            self._default_q = robot.default_joint_q(lay)
            self._all_ids = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32)
            self._actuation_cmds = self._record_actuation()
            self.physics: PhysicsBackend = backend_cls(self)
            """The physics engine stepping this simulator (``wqwarp.sim.backends``)."""
            all_ids = np.arange(n, dtype=np.int32)
            self.reset(all_ids, np.tile(self._default_q, (n, 1)), np.zeros((n, lay.dofs_per_world), np.float32))

    # --- public control / output views -------------------------------------------------------------------------
    @property
    def policy_dt(self) -> float:
        """Time of one :meth:`step` [s]."""
        return self.cfg.dt * self.cfg.decimation

    def torch_views(self) -> dict:
        """Zero-copy torch tensors of every state, control and measurement array (shared memory with Warp)."""
        names = ["joint_q", "joint_qd", "joint_f"]
        out = {k: wp.to_torch(getattr(self, k)) for k in names}
        out["body_q"] = wp.to_torch(self.body_q)  # (N, B, 7): position, quaternion xyzw
        out["body_qd"] = wp.to_torch(self.body_qd)  # (N, B, 6): linear, angular (world frame)
        for k in BUFFER_NAMES:
            out[k] = wp.to_torch(getattr(self, k))
        return out

    # --- stepping ---------------------------------------------------------------------------------------------
    def _record_actuation(self) -> list:
        """Prepared launches of one substep's actuation and power kernels (packed once, replayed every substep)."""
        cfg = self.cfg
        act = actuation.launch_actuation(
            self.joint_q,
            self.joint_qd,
            self.leg_q_target,
            self.wheel_qd_target,
            self.torque_limit,
            self.motor_strength,
            self.wheel_integral,
            self.wheel_prev_error,
            self.joint_torque,
            self.joint_f,
            self.coord_index,
            self.dof_index,
            leg_kp=cfg.leg_kp,
            leg_kd=cfg.leg_kd,
            wheel_kp=cfg.wheel_kp,
            wheel_ki=cfg.wheel_ki,
            wheel_kd=cfg.wheel_kd,
            wheel_i_limit=cfg.wheel_i_limit,
            dt=cfg.dt,
            device=self.device,
            record_cmd=True,
        )
        pwr = power.launch_power(
            self.joint_torque,
            self.joint_qd,
            [getattr(self, k) for k in power.POWER_OUTPUTS],
            self.dof_index,
            self._motor_arrays,
            weight=1.0 / cfg.decimation,
            device=self.device,
            record_cmd=True,
        )
        return [act, pwr]

    def actuate_substep(self) -> None:
        """One substep's actuation kernel (torques into ``joint_f``) and power accumulation; backends call it before
        each physics substep."""
        for cmd in self._actuation_cmds:
            cmd.launch()

    def step(self, actuate: bool = True) -> None:
        """Advance one policy step: ``decimation`` substeps of actuation + physics, then body poses and contacts.

        ``actuate=False`` skips the actuation and power kernels and keeps the last joint torques (benchmarks)."""
        for name in power.POWER_OUTPUTS:
            getattr(self, name).zero_()
        self.unstable.zero_()
        self.physics.step_substeps(actuate)
        cfg = self.cfg
        wp.launch(
            flag_unstable,
            dim=self.num_envs,
            inputs=[
                self.joint_q,
                self.joint_qd,
                self.joint_torque,
                cfg.unstable_position_limit,
                cfg.unstable_velocity_limit,
            ],
            outputs=[self.unstable],
            device=self.device,
        )
        self._post_step()

    def _post_step(self) -> None:
        """Per policy step: contact flags, the project-order joint arrays and the base frame."""
        wp.launch(
            _wheel_contact_flags,
            dim=(self.num_envs, 4),
            inputs=[self.wheel_force, self.cfg.contact_threshold],
            outputs=[self.wheel_contact],
            device=self.device,
        )
        self._refresh_joints()

    def _refresh_joints(self) -> None:
        """The project-order joint arrays (``actuated_q``, ``actuated_qd``) and the base frame from Newton's state."""
        wp.launch(
            gather_actuated,
            dim=(self.num_envs, 16),
            inputs=[self.joint_q, self.joint_qd, self.coord_index, self.dof_index],
            outputs=[self.actuated_q, self.actuated_qd],
            device=self.device,
        )
        self._update_base_frame()

    def _update_base_frame(self) -> None:
        """Base-frame velocities, projected gravity, height and yaw of every robot from ``joint_q`` / ``joint_qd``."""
        wp.launch(
            compute_base_frame,
            dim=self.num_envs,
            inputs=[self.joint_q, self.joint_qd],
            outputs=[getattr(self, name) for name, _ in BASE_FRAME_OUTPUTS],
            device=self.device,
        )

    # --- resets and state writes -----------------------------------------------------------------------------------
    def _ids(self, env_ids) -> wp.array:
        return index_array(env_ids, self.device, self.num_envs)

    def _rows(self, rows, k: int, width: int, what: str) -> wp.array:
        """(k, width) float32 Warp array on the device from a Warp array, torch tensor or NumPy array."""
        import torch

        if isinstance(rows, torch.Tensor):
            rows = wp.from_torch(rows.to(torch.float32).contiguous())
        elif not isinstance(rows, wp.array):
            rows = wp.array(np.ascontiguousarray(rows, dtype=np.float32), dtype=wp.float32, device=self.device)
        if tuple(rows.shape) != (k, width):
            raise ValueError(f"{what} must have shape {(k, width)}, got {tuple(rows.shape)}")
        return rows

    def reset(self, env_ids, joint_q=None, joint_qd=None) -> None:
        """Set robots ``env_ids`` to the given Newton coordinates ((k, 23) / (k, 22); default pose and rest if
        omitted), zero their wheel PID state, recompute their body poses and clear their contact summaries.

        ``env_ids`` and the coordinates may be Warp arrays or torch tensors on the simulator's device (what the
        environment passes: the reset runs in kernels, with no host copy) or NumPy arrays / lists."""

        ids = self._ids(env_ids)
        k = ids.shape[0]
        if k == 0:
            return
        lay = self.layout
        if joint_q is None:
            joint_q = np.tile(self._default_q, (k, 1))
        if joint_qd is None:
            joint_qd = wp.zeros((k, lay.dofs_per_world), dtype=wp.float32, device=self.device)
        self._write_rows(ids, joint_q, joint_qd)
        actuation.launch_reset_wheel_pid(ids, self.wheel_integral, self.wheel_prev_error, self.device)
        wp.launch(
            clear_contact_rows,
            dim=k,
            inputs=[ids],
            outputs=[self.wheel_force, self.wheel_contact, self.body_collision, self.unstable],
            device=self.device,
        )
        self.physics.reset_rows(ids)
        self._post_step()

    def set_state(self, env_ids, joint_q, joint_qd) -> None:
        """Overwrite the coordinates of robots ``env_ids`` ((k, 23) / (k, 22)) mid-episode, keeping controller state
        and the last step's contact summaries; their body poses, the project-order joint arrays (``actuated_q``,
        ``actuated_qd``) and the base frame follow the new coordinates. Accepts Warp arrays or torch tensors on the
        device (no host copy) or NumPy arrays."""
        ids = self._ids(env_ids)
        if ids.shape[0] == 0:
            return
        self._write_rows(ids, joint_q, joint_qd)
        self._refresh_joints()

    def _write_rows(self, ids: wp.array, joint_q, joint_qd) -> None:
        """Scatter the coordinates of robots ``ids`` into Newton's state, recompute their body poses and hand them to
        the physics (the joint arrays and the base frame are left to the caller: :meth:`_refresh_joints`)."""
        import newton

        k, lay = ids.shape[0], self.layout
        q = self._rows(joint_q, k, lay.coords_per_world, "joint_q")
        qd = self._rows(joint_qd, k, lay.dofs_per_world, "joint_qd")
        wp.launch(
            scatter_state_rows, dim=k, inputs=[ids, q, qd], outputs=[self.joint_q, self.joint_qd], device=self.device
        )
        newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state, indices=ids)
        self.physics.state_written(ids)

    def state_written(self, env_ids=None) -> None:
        """Tell the physics that ``joint_q`` / ``joint_qd`` of robots ``env_ids`` (default all) were written in place
        (e.g. through :meth:`torch_views`): ``mujoco_cpu`` copies them into its MuJoCo states; the Newton-state
        backends read Newton's state at every step and need nothing. The base-frame arrays (``base_lin_vel``, ...)
        of every robot are recomputed."""
        self._update_base_frame()
        ids = self._all_ids if env_ids is None else self._ids(env_ids)
        if ids.shape[0] == 0:
            return
        self.physics.state_written(ids)

    # --- dynamics and MuJoCo access ---------------------------------------------------------------------------------
    def set_dynamics(self, friction: np.ndarray, restitution: np.ndarray, added_mass: np.ndarray) -> None:
        """Per-robot contact friction [-], restitution [-] and mass added to the trunk [kg], each (N,).

        MuJoCo has no restitution coefficient; e is mapped to the contact damping ratio of a spring-damper whose
        bounce has that coefficient: zeta = -ln(e) / sqrt(pi^2 + ln(e)^2) (e -> 0 gives MuJoCo's default 1).
        """
        n = self.num_envs
        mu = np.broadcast_to(np.asarray(friction, np.float64), (n,))
        e = np.clip(np.broadcast_to(np.asarray(restitution, np.float64), (n,)), 1e-6, 0.99)
        dm = np.broadcast_to(np.asarray(added_mass, np.float64), (n,))
        log_e = np.log(e)
        zeta = np.minimum(-log_e / np.sqrt(np.pi**2 + log_e**2), 1.0)
        self.physics.set_dynamics(mu, zeta, dm)

    def _mujoco_cpu(self, what: str) -> MujocoCpuBackend:
        if not isinstance(self.physics, MujocoCpuBackend):
            raise RuntimeError(f"{what} needs the mujoco_cpu backend (device cpu)")
        return self.physics

    @property
    def mj_model(self):
        """The one-robot ``MjModel`` of the ``mujoco_cpu`` backend (render or inspect a robot with MuJoCo's tools)."""
        return self._mujoco_cpu("mj_model").mj_model

    def mujoco_qpos(self) -> np.ndarray:
        """(N, nq) MuJoCo ``qpos`` of every robot now, in the order of :attr:`mj_model` (``mujoco_cpu`` only): set it
        on an ``MjData`` of ``mj_model`` and call ``mj_forward`` to render or inspect a robot with MuJoCo's tools."""
        return self._mujoco_cpu("mujoco_qpos").mujoco_qpos()
