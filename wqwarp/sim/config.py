"""Physics and low-level control settings of :class:`wqwarp.sim.simulator.Simulator` (no physics imported here:
reading a config never loads Newton or MuJoCo)."""

from __future__ import annotations

import os
import typing
from dataclasses import dataclass, field
from typing import Literal

from wqwarp.robot import constants as C
from wqwarp.utils.checked_config import CheckedConfig, check_positive, require
from wqwarp.utils.migration import migrate, since_default

BACKEND_CLASSES: dict[str, str] = {
    "mujoco_cpu": "wqwarp.sim.backends.mujoco_cpu:MujocoCpuBackend",
    "mujoco_warp": "wqwarp.sim.backends.mujoco_warp:MujocoWarpBackend",
    "featherstone": "wqwarp.sim.backends.featherstone:FeatherstoneBackend",
}
"""The physics backends, registered once: ``SimConfig.backend`` name -> its class as ``"module:Class"`` (imported
by ``wqwarp.sim.backends``, never by reading a config). Adding a backend: its class and one entry here."""
Backend = Literal[("auto", *BACKEND_CLASSES)]  # the choices of SimConfig.backend, derived from the registry
JointModel = Literal["asset", "authors"]
BACKENDS: tuple[str, ...] = typing.get_args(Backend)
JOINT_MODELS: tuple[str, ...] = typing.get_args(JointModel)


@dataclass
class SimConfig(CheckedConfig):
    """Physics and low-level control settings. Units in brackets."""

    num_envs: int = 64
    """Number of robots, one per world."""
    device: str = "cpu"
    """Warp device of the Newton model and all buffers: ``cpu`` or ``cuda:N``."""
    backend: Backend = "auto"
    """``mujoco_cpu`` (mujoco.rollout on all cores), ``mujoco_warp`` (Newton SolverMuJoCo), ``featherstone``
    (Newton SolverFeatherstone with spring-damper contacts, the physics of the differentiable path
    ``wqwarp.diff.rollout``; slow, for few robots), or ``auto``: ``mujoco_cpu`` on the CPU device, ``mujoco_warp`` on
    CUDA."""
    dt: float = 0.005
    """Physics substep [s]. The paper uses 0.001 with decimation 20; 0.005 x 4 costs ~5x less per policy step."""
    decimation: int = 4
    """Physics substeps per policy step; policy rate = 1 / (dt * decimation) (50 Hz by default)."""
    leg_kp: float = 40.0
    """Leg PD stiffness [N m/rad] (authors' public harness: Kp 40)."""
    leg_kd: float = 1.0
    """Leg PD damping [N m s/rad] (harness: Kd 1)."""
    wheel_kp: float = 0.5
    """Wheel velocity-PID proportional gain [N m s/rad]. Bounded by the airborne wheel: the loop computes its torque
    from the velocity at the start of each substep (explicit feedback), which is stable on a free wheel only for
    kp dt / I < 2 and free of ringing for kp dt / I <= 1, I = ``constants.WHEEL_AIRBORNE_INERTIA`` = 2.75e-3 kg m^2.
    kp 0.5 gives 0.91 at dt 0.005 and 0.18 at dt 0.001, so swing wheels neither chatter nor ring at either step;
    kp 2 (the authors' harness gain, whose wheel armature is 0.01) gives 3.6 at dt 0.005: +-6 N m every substep,
    131 W for four idle wheels. Measured with ``tools/studies/wheel_step_response.py`` (docs/simulation.md)."""
    wheel_ki: float = 2.0
    """Wheel velocity-PID integral gain [N m/rad]: removes the steady error under a load torque (slopes, friction)
    that the small kp alone would leave. ki 5 overshoots a loaded 0.5 m/s step by 25 %, ki 2 by 16 % (P alone 11 %),
    with 0.6 % steady error after 2 s (docs/simulation.md, "Wheel control")."""
    wheel_kd: float = 0.0
    """Wheel velocity-PID derivative gain [N m s^2/rad]; 0: any kd acts on a velocity difference (an acceleration)
    and with the substep's explicit update destabilises the airborne loop first."""
    wheel_i_limit: float = 2.5
    """Anti-windup bound of the wheel-PID integral [rad]: ki * limit = 5 N m, under the 6 N m torque limit, so the
    integral can hold a wheel against the ~2 N m scrub torque of skid-steer turning."""
    check_wheel_stability: bool = True
    """Refuse wheel gains whose airborne loop is unstable (kp dt / I >= 2). Off only to study that loop."""
    joint_model: JointModel = field(
        default="asset", metadata=migrate("asset", "the USD's joint model, the only one before the setting existed")
    )
    """Passive model of the 16 actuated joints: ``asset`` (the USD's: armature 0.01 kg m^2 on the legs and 2.19e-3
    on the wheels, no damping, no dry friction; ``tools/build_wheeled_go1.py`` says why) or ``authors`` (the authors'
    MuJoCo robot: damping 0.01 N m s/rad, armature 0.01 kg m^2 and friction loss 0.2 N m on every joint,
    ``constants.AUTHORS_JOINT_MODEL``), a second physics for sim-to-sim evaluation."""
    robot: str = field(
        default="", metadata=since_default("the packaged USD, the only robot before the setting existed")
    )
    """The robot description: empty for the packaged wheeled Go1 USD (or ``$WQWARP_ROBOT_USD``), else the path of
    a USD or an MJCF (``.xml``) with the joints ``{FR,FL,RR,RL}_{hip,thigh,calf,wheel}_joint``, e.g. the paper
    authors' MuJoCo robot for sim-to-sim (``wqwarp.robot.asset.add_robot``). Its own masses, shapes and joint model
    are kept (``joint_model`` ``asset``)."""
    nthread: int | None = None
    """CPU threads for ``mujoco_cpu`` (default: all cores)."""
    cuda_graph: bool = True
    """Capture the decimation loop into a CUDA graph (``mujoco_warp`` on CUDA only)."""
    contact_threshold: float = 1.0
    """Normal-force magnitude above which a wheel counts as in contact [N]."""
    solver_iterations: int = 100
    """MuJoCo constraint-solver iterations (MuJoCo default)."""
    ls_iterations: int = 50
    """MuJoCo line-search iterations (MuJoCo default)."""
    unstable_position_limit: float = field(
        default=1.0e3, metadata=since_default("the divergence guard's default; before it, a diverged robot went unseen")
    )
    """A robot whose coordinate exceeds this magnitude [m or rad] counts as diverged (``Simulator.unstable``)."""
    unstable_velocity_limit: float = field(
        default=1.0e3, metadata=since_default("the divergence guard's default; before it, a diverged robot went unseen")
    )
    """A robot whose velocity exceeds this magnitude [m/s or rad/s] counts as diverged (wheels run below 50 rad/s)."""
    contact_ke: float = field(
        default=2.0e4,
        metadata=since_default("its default; read only by the featherstone backend, which no training used before"),
    )
    """``featherstone`` only: normal stiffness of the spring-damper ground contact [N/m]. With ~37 N per wheel it
    penetrates ~2 mm; stiffer contacts need a smaller dt (explicit contact forces). See ``wqwarp.diff.rollout``."""
    contact_kd: float = field(
        default=300.0,
        metadata=since_default("its default; read only by the featherstone backend, which no training used before"),
    )
    """``featherstone`` only: normal contact damping [N s/m] (damping ratio ~0.5 for a quarter of the robot)."""
    contact_kf: float = field(
        default=100.0,
        metadata=since_default("its default; read only by the featherstone backend, which no training used before"),
    )
    """``featherstone`` only: slope of the regularised Coulomb friction below the slip limit [N s/m]; a wheel's
    spin is stable under it for kf dt / (m + I / R^2) < 2, i.e. kf < ~240 at dt 0.005."""
    contact_mu: float = field(
        default=1.0,
        metadata=since_default("its default; read only by the featherstone backend, which no training used before"),
    )
    """``featherstone`` only: Coulomb friction coefficient [-] (the MuJoCo paths' default friction is 1.0 too)."""
    njmax: int | None = None
    """Constraint rows per world for ``mujoco_warp`` (default: Newton's estimate)."""
    nconmax: int | None = None
    """Contacts per world for ``mujoco_warp`` (default: Newton's estimate)."""

    def resolved_backend(self) -> str:
        """The backend ``auto`` stands for on this device: ``mujoco_cpu`` on the CPU, ``mujoco_warp`` on CUDA."""
        if self.backend != "auto":
            return self.backend
        return "mujoco_cpu" if self.device == "cpu" else "mujoco_warp"

    def check(self) -> None:
        """Counts and steps positive, gains non-negative, the device a Warp device name (at construction)."""
        require(self.num_envs >= 1, "SimConfig.num_envs", f"must be >= 1, got {self.num_envs}")
        require(self.decimation >= 1, "SimConfig.decimation", f"must be >= 1, got {self.decimation}")
        require(
            str(self.device) == "cpu" or str(self.device).startswith("cuda"),
            "SimConfig.device",
            f"must be cpu or cuda:N, got {self.device!r}",
        )
        check_positive(self, "dt", "solver_iterations", "ls_iterations")
        check_positive(self, "leg_kp", "leg_kd", "wheel_kp", "wheel_ki", "wheel_kd", "wheel_i_limit", strict=False)
        require(not self.robot or os.path.isfile(self.robot), "SimConfig.robot", f"no such robot file {self.robot!r}")
        for n in ("nthread", "njmax", "nconmax"):
            v = getattr(self, n)
            require(v is None or v >= 1, f"SimConfig.{n}", f"must be None or >= 1, got {v}")

    def validate(self) -> None:
        """:meth:`check` and the airborne wheel loop's stability (the simulator calls it before building)."""
        self.check()
        margin = self.wheel_kp * self.dt / C.WHEEL_AIRBORNE_INERTIA
        if self.check_wheel_stability and margin >= 2.0:
            raise ValueError(
                f"wheel_kp {self.wheel_kp} at dt {self.dt} makes an airborne wheel's speed loop unstable "
                f"(kp dt / I = {margin:.2f} >= 2, I = {C.WHEEL_AIRBORNE_INERTIA:.2e} kg m^2): use "
                f"wheel_kp < {2.0 * C.WHEEL_AIRBORNE_INERTIA / self.dt:.2f}"
            )
