"""Physics variants of the evaluation (sim-to-sim) and the evaluation configuration built from a checkpoint's.

A variant is one :class:`PhysicsVariant` entry of :data:`PHYSICS_VARIANTS`: its name, what it changes in the trained
configuration (physics step, joint model, ground friction) and why. Adding a variant is one entry.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

from wqwarp.rl.config import EnvConfig
from wqwarp.robot.constants import AUTHORS_GROUND_FRICTION


@dataclass(frozen=True)
class PhysicsVariant:
    """Overrides of the trained physics; None keeps the trained value."""

    name: str
    doc: str
    dt: float | None = None
    """Physics step [s]; the 50 Hz policy step is kept (decimation = policy step / dt)."""
    joint_model: str | None = None
    """``SimConfig.joint_model``: ``asset`` (the USD's joints) or ``authors`` (the authors' MuJoCo damping, armature
    and friction loss)."""
    friction: float | None = None
    """Ground friction of every contact (``domain_rand.nominal_friction``) [-]."""
    robot: bool = False
    """Build the robot from the description the evaluation is given (``--robot PATH``, ``SimConfig.robot``: a USD or
    an MJCF such as the paper authors' ``wheeled_go1.xml``) with its own masses, shapes and joint model."""
    sim: tuple[tuple[str, object], ...] = ()
    """Further ``SimConfig`` fields, (name, value) pairs (the control law's gains)."""

    def overrides(self) -> dict:
        """The set fields as a dict (recorded as ``"overrides"`` in result files)."""
        out = {
            k: v
            for k, v in (("dt", self.dt), ("joint_model", self.joint_model), ("friction", self.friction))
            if v is not None
        }
        if self.robot:
            out["robot"] = "given"
        return {**out, **{f"sim.{k}": v for k, v in self.sim}}


PHYSICS_VARIANTS = {
    v.name: v
    for v in (
        PhysicsVariant("train", "as trained (no randomisation: every contact at domain_rand.nominal_friction)"),
        PhysicsVariant("dt0.001", "the paper's physics step, 0.001 s x 20 per policy step", dt=0.001),
        PhysicsVariant(
            "authors",
            "the authors' MuJoCo robot's joint damping, armature and friction loss and their ground friction 0.6",
            joint_model="authors",
            friction=AUTHORS_GROUND_FRICTION,
        ),
        PhysicsVariant(
            "authors_dt0.001",
            "authors and dt0.001 together",
            dt=0.001,
            joint_model="authors",
            friction=AUTHORS_GROUND_FRICTION,
        ),
        PhysicsVariant(
            "authors_robot",
            "the robot built from --robot (the paper authors' MuJoCo robot: their masses, collision shapes and joint "
            "model) on their ground friction 0.6, under this project's control law",
            friction=AUTHORS_GROUND_FRICTION,
            robot=True,
        ),
        PhysicsVariant(
            "authors_robot_control",
            "authors_robot under the authors' control law: legs PD Kp 40 Kd 1 (this project's too), wheels a "
            "proportional gain 2 N m s/rad on the speed target (their harness's Kd 2) with no integral; the airborne "
            "wheel check is off, it assumes this project's wheel inertia (theirs carries armature 0.01 kg m^2)",
            friction=AUTHORS_GROUND_FRICTION,
            robot=True,
            sim=(("wheel_kp", 2.0), ("wheel_ki", 0.0), ("wheel_kd", 0.0), ("check_wheel_stability", False)),
        ),
    )
}
"""Physics configurations of sim-to-sim evaluation, by name."""

PHYSICS = {name: v.overrides() for name, v in PHYSICS_VARIANTS.items()}
"""Name -> overrides of the trained physics (derived from :data:`PHYSICS_VARIANTS`)."""


def physics_variant(name: str) -> PhysicsVariant:
    """The variant ``name``; ValueError naming the choices otherwise."""
    if name not in PHYSICS_VARIANTS:
        raise ValueError(f"unknown physics {name!r}; choose from {', '.join(PHYSICS_VARIANTS)}")
    return PHYSICS_VARIANTS[name]


def evaluation_config(
    trained: EnvConfig,
    num_envs: int,
    device: str = "cpu",
    dt: float | None = None,
    domain_randomisation: bool = False,
    evaluation_selection: str | None = None,
    criterion: str | None = None,
    physics: str = "train",
    seed: int | None = None,
    robot: str | None = None,
) -> EnvConfig:
    """A new config for evaluation from a checkpoint's ``trained`` one, with these named overrides only: robot count,
    device, domain randomisation and pushes (off by default; the protocol applies its own pushes), the physics step
    ``dt`` [s] (the 50 Hz policy step is kept: decimation = policy step / dt), the predictive selection outside
    training (``argmin`` or ``sample``), the selection ``criterion`` (a rule A/B on one policy), a
    :data:`PHYSICS_VARIANTS` entry (its dt yields to an explicit ``dt``) and the env's random ``seed`` (spawn yaws,
    pushes, sampled gaits), and for a variant that builds the robot from a description, its path ``robot``.
    ``trained`` is not modified."""
    variant = physics_variant(physics)
    if variant.robot and not robot:
        raise ValueError(
            f"physics {physics!r} builds the robot from a description: give its path (--robot PATH, e.g. the paper "
            "authors' MJCF, tests/data/authors_wheeled_go1/wheeled_go1.xml)"
        )
    dt = dt if dt is not None else variant.dt
    cfg = copy.deepcopy(trained)
    cfg.sim.num_envs = num_envs
    cfg.sim.device = device
    cfg.domain_rand.enabled = domain_randomisation
    cfg.seed = cfg.seed if seed is None else int(seed)
    if variant.joint_model is not None:
        cfg.sim.joint_model = variant.joint_model
    if variant.friction is not None:
        cfg.domain_rand.nominal_friction = variant.friction
    if variant.robot:
        cfg.sim.robot = robot
    for name, value in variant.sim:
        setattr(cfg.sim, name, value)
    if dt is not None:
        policy_dt = cfg.sim.dt * cfg.sim.decimation
        dec = round(policy_dt / dt) if dt > 0 else 0
        if dt <= 0 or dec < 1 or abs(dec * dt - policy_dt) > 1e-9:
            raise ValueError(f"dt {dt} s does not divide the policy step {policy_dt} s")
        cfg.sim.dt, cfg.sim.decimation = dt, dec
    if evaluation_selection is not None:
        cfg.predictor.evaluation_selection = evaluation_selection
    if criterion is not None:
        cfg.predictor.criterion = criterion
    return cfg
