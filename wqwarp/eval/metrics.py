"""The paper's evaluation tasks (Sec. IV-A, Table III) and the metrics of one task: tracking error, power, cost of
transport, and the change of each metric between two physics.

Tracking and energy: one command axis at a time (v_x in [-1, 1] m/s, v_y in [-0.7, 0.7] m/s, w in [-0.7, 0.7]
rad/s), the others zero. We report per task the mean squared and mean absolute tracking error (after a settling
time), the mean p_cost (sum |tau| |qd| over 16 joints) [W], and the share of robots that never touched the ground
with the trunk. Every metric is over all robots: a robot that falls is reset where it is and keeps counting, and the
number of falls is reported beside the metrics.

Cost of transport (translation tasks): CoT = P / (m g v), the mean p_cost over the mean planar speed of all robots
(energy per metre of travel over m g, without unit), m the robot's mass; reported for the v_x and v_y tasks where the
mean speed is at least 0.1 m/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from wqwarp.kernels.power import REPORTED_POWER

TASKS = {"vx": (0, (-1.0, 1.0)), "vy": (1, (-0.7, 0.7)), "wz": (2, (-0.7, 0.7)), "stand": (0, (0.0, 0.0))}
"""Task -> (command axis, range) of the paper's tracking evaluation (Sec. IV-A)."""

PUSH_TASKS = {"stand": (0, (0.0, 0.0)), "vx": (0, (-1.0, 1.0)), "vy": (1, (-1.0, 1.0)), "wz": (2, (-1.0, 1.0))}
"""Task -> (command axis, range) of the paper's push-recovery evaluation (Table III: all commands zero, and v_x, v_y,
w each in [-1, 1])."""

MIN_COT_SPEED = 0.1
"""Mean planar speed [m/s] below which no cost of transport is reported."""


@dataclass
class EvalResult:
    task: str
    num_robots: int
    seconds: float
    mse: float
    """Mean squared tracking error of the commanded axis [(m/s)^2 or (rad/s)^2]."""
    mean_abs_error: float
    """Mean absolute tracking error of the commanded axis [m/s or rad/s]."""
    mean_p_cost: float
    """Mean p_cost [W]."""
    mean_p_cost_legs: float
    """Mean p_cost of the 12 leg joints [W]."""
    mean_p_cost_wheels: float
    """Mean p_cost of the 4 wheels [W]."""
    upright: float
    """Share of robots whose trunk never touched the ground [-]."""
    falls: int = 0
    """Trunk-ground contacts over the run (a robot that falls is reset where it is and keeps counting)."""
    max_push: float = 0.0
    command_range: list | None = None
    """[lo, hi] of the task's command axis."""
    outside_training_range: bool = False
    """True when the task's commands leave the range the policy was trained on (the env's ``commands`` config)."""
    gait_usage: dict | None = None
    """Share of robot-steps in each running gait (all robots, settling included) [-]."""
    gait_switches_per_robot_minute: float = 0.0
    """Changes of the running gait per robot and minute."""
    falls_within_1s_of_switch: int = 0
    """Trunk-ground contacts within 1 s after a gait switch."""
    mse_axes: list | None = None
    """Mean squared error of each axis (v_x, v_y, w_z) against its command (0 off the task's axis)."""
    mean_p_mech: float = 0.0
    """Mean positive mechanical power sum max(tau qd, 0) over the 16 joints [W] (``wqwarp.kernels.power``)."""
    mean_p_elec: float = 0.0
    """Mean electrical power the battery pays for the 16 motors [W] (``wqwarp.robot.motors``; electronics apart).
    Result files before 2026-12-07 hold ``mean_p_joule`` instead: sum max(0.3 tau^2 + tau qd, 0), one coefficient
    for every motor."""
    mean_p_elec_legs: float = 0.0
    """Mean electrical power of the 12 leg motors [W]."""
    mean_p_elec_wheels: float = 0.0
    """Mean electrical power of the 4 wheel motors [W]."""
    mean_p_copper_legs: float = 0.0
    """Mean copper (I^2 R) loss of the leg motors [W], part of ``mean_p_elec_legs``."""
    mean_p_copper_wheels: float = 0.0
    """Mean copper loss of the wheel motors [W], part of ``mean_p_elec_wheels``."""
    electronics_w: float = 0.0
    """The motor model's constant electronics draw [W], not in ``mean_p_elec``."""
    cost_of_transport_elec: float | None = None
    """(mean_p_elec + electronics_w) / (m g mean_speed) [-]: what the battery pays per weight and distance; None
    where ``cost_of_transport`` is."""
    predicted_power: dict | None = None
    """Predictive selection: the power predictor's mean output per gait over the measured steps [W]."""
    mean_speed: float = 0.0
    """Mean planar speed |(v_x, v_y)| of the base over the measured steps, all robots [m/s]."""
    cost_of_transport: float | None = None
    """mean_p_cost / (m g mean_speed) [-]; None for stand and yaw, and where mean_speed < 0.1 m/s."""
    mean_p_mech_legs: float = 0.0
    """Mean positive mechanical power of the 12 leg joints [W]."""
    mean_p_mech_wheels: float = 0.0
    """Mean positive mechanical power of the 4 wheels [W]."""
    predicted_power_running: float | None = None
    """Predictive selection: mean predicted power of the gait running at each measured step [W] (compare with
    ``mean_p_cost`` over the same robots and steps)."""
    fallen_commands: list | None = None
    """The task-axis command of each robot whose trunk touched the ground, ascending (where the falls come from,
    e.g. the push protocol's commands past the training range)."""


def check_task(task: str) -> None:
    """ValueError naming the choices unless ``task`` is one of :data:`TASKS`."""
    if task not in TASKS:
        raise ValueError(f"unknown task {task!r}; choose from {', '.join(TASKS)}")


class TaskMetrics:
    """Running sums of one task's tracking and power metrics over N robots: :meth:`add` once per measured policy
    step, :meth:`summary` for the means over all robots and steps."""

    def __init__(self, task: str, commands: torch.Tensor):
        check_task(task)
        self.task, self.axis, self.cmd = task, TASKS[task][0], commands
        n, dev = commands.shape[0], commands.device
        self.sq_axes = torch.zeros(n, 3, device=dev)
        self.abs_err = torch.zeros(n, device=dev)
        self.speed = torch.zeros(n, device=dev)
        self.power = {k: torch.zeros(n, device=dev) for k in REPORTED_POWER}
        self.steps = 0

    def add(self, velocity: torch.Tensor, power: dict) -> None:
        """``velocity`` (N, 3): measured (v_x, v_y, w_z) in the base frame; ``power``: (N,) tensors of
        :data:`REPORTED_POWER` [W]."""
        err = velocity - self.cmd
        self.sq_axes += err**2
        self.abs_err += err[:, self.axis].abs()
        self.speed += torch.linalg.vector_norm(velocity[:, :2], dim=1)
        for k in REPORTED_POWER:
            self.power[k] += power[k]
        self.steps += 1

    def summary(self, robot_mass: float, electronics_w: float = 0.0) -> dict:
        """Means over all robots and measured steps: the :class:`EvalResult` fields of tracking and power;
        ``electronics_w`` [W] is the motor model's constant draw, counted in the electrical cost of transport."""
        c = max(self.steps, 1)
        m = {k: float(v.mean()) / c for k, v in self.power.items()}
        mse_axes = [float(x) / c for x in self.sq_axes.mean(0)]
        speed = float(self.speed.mean()) / c
        translating = self.task in ("vx", "vy") and speed >= MIN_COT_SPEED  # a yawing or standing base moves too
        return {
            "mse": mse_axes[self.axis],
            "mean_abs_error": float(self.abs_err.mean()) / c,
            "mse_axes": mse_axes,
            "mean_p_cost": m["p_cost"],
            "mean_p_cost_legs": m["p_cost_legs"],
            "mean_p_cost_wheels": m["p_cost_wheels"],
            "mean_p_mech": m["p_mech_legs"] + m["p_mech_wheels"],
            "mean_p_mech_legs": m["p_mech_legs"],
            "mean_p_mech_wheels": m["p_mech_wheels"],
            "mean_p_elec": m["p_elec"],
            "mean_p_elec_legs": m["p_elec_legs"],
            "mean_p_elec_wheels": m["p_elec_wheels"],
            "mean_p_copper_legs": m["p_copper_legs"],
            "mean_p_copper_wheels": m["p_copper_wheels"],
            "electronics_w": electronics_w,
            "mean_speed": speed,
            "cost_of_transport": m["p_cost"] / (robot_mass * 9.81 * speed) if translating else None,
            "cost_of_transport_elec": (
                (m["p_elec"] + electronics_w) / (robot_mass * 9.81 * speed) if translating else None
            ),
        }


DELTA_KEYS = (
    "mse",
    "mean_abs_error",
    "mean_p_cost",
    "mean_p_cost_legs",
    "mean_p_cost_wheels",
    "mean_p_mech",
    "mean_p_elec",
    "upright",
    "falls",
)
"""Metrics whose change between two physics the sim-to-sim protocol reports."""


def task_label(result: dict) -> str:
    """``task`` or ``task@push`` of a result (an :class:`EvalResult` as a dict)."""
    return f"{result['task']}@{result['max_push']:g}" if result["max_push"] else result["task"]


def physics_delta(train: dict, other: dict) -> dict:
    """Change of each metric of one task from the training physics (``train``) to another (``other``)."""
    out = {"task": train["task"], "max_push": train["max_push"], "label": task_label(train)}
    out.update({k: other[k] - train[k] for k in DELTA_KEYS})
    out["mean_p_cost_rel"] = out["mean_p_cost"] / train["mean_p_cost"] if train["mean_p_cost"] else float("nan")
    return out
