"""The reward-term registry: the paper's Table II, one entry per term (name, default weight, formula, NumPy reference).

The entry is the one place a term is named. From :data:`TERMS` (:data:`TABLE_II`, then :data:`BEYOND_PAPER`)
derive: the names and kernel columns (:data:`REWARD_TERMS`), the weight fields of ``wqwarp.rl.config.RewardConfig``,
the logs (``Episode_Reward/<term>``), the CLI's ``--reward TERM=WEIGHT`` and the summing kernel
(``wqwarp.kernels.rewards.make_reward_kernel``). Each term's computation is the ``@wp.func`` of the same name in
``wqwarp.kernels.rewards`` (or the func given in the entry, for a term defined outside the package).

Adding a term: one ``@wp.func`` in ``wqwarp.kernels.rewards`` and one :class:`RewardTerm` in :data:`BEYOND_PAPER` at
weight 0, so that every preset keeps the paper's reward, with ``migration=Migration(0.0, why)`` so that the
checkpoints written before it load without it (plus its test in ``tests/kernels/test_rewards.py``). A term
defined elsewhere (a study, a test) is passed to the env instead:
``WheeledGo1Env(cfg, reward_terms=(*TERMS, RewardTerm("mine", -1.0, "...", func=my_func)))``.

This module imports no physics engine (``wqwarp.rl.config`` reads it).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from wqwarp.utils.migration import Migration

Inputs = dict[str, np.ndarray]
"""NumPy inputs of the references: the fields of ``wqwarp.kernels.rewards.RewardInputs`` by name (``sigma`` and
``dt`` as floats), except the base frame, called ``v`` (``base_lin_vel``), ``w`` (``base_ang_vel``) and ``g``
(``projected_gravity``), (N, 3) each."""


@dataclass(frozen=True)
class RewardTerm:
    """One reward term r_k; the step reward is sum_k w_k r_k dt."""

    name: str
    """Term name: the weight field of ``RewardConfig``, the log ``Episode_Reward/<name>``, the func's name."""
    weight: float
    """Default weight w_k (the paper's Table II)."""
    doc: str
    """The formula and units (the help of the weight field)."""
    reference: Callable[[Inputs], np.ndarray] | None = None
    """NumPy version of r_k: inputs -> (N,) (tests compare the Warp func with it)."""
    func: object = None
    """The ``@wp.func`` computing r_k (signature of ``wqwarp.kernels.rewards``); None: the func called ``name`` in
    ``wqwarp.kernels.rewards`` (so that this registry imports no Warp)."""
    migration: Migration | None = None
    """A term added after checkpoints existed: the weight of the configurations written before it (0: the term was
    not there) and why, the migration of its ``RewardConfig`` field (``wqwarp.utils.migration``). None: a term of
    every configuration (Table II)."""

    def resolve(self):
        """The term's ``@wp.func``."""
        if self.func is not None:
            return self.func
        from wqwarp.kernels import rewards as kernels

        return getattr(kernels, self.name)


def _track(x: Inputs, col: int, actual: np.ndarray) -> np.ndarray:
    return np.exp(-x["sigma"] * (x["command"][:, col] - actual) ** 2)


def soft_joint_limits(fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """(low, high) (12,) of the leg joints' ranges (``wqwarp.robot.constants.LEG_JOINT_RANGES``) shrunk about their
    centres to ``fraction`` of their widths [rad] (legged_gym's soft limits): the bounds of the joint_limits term."""
    from wqwarp.robot.constants import LEG_JOINT_RANGES

    r = np.asarray(LEG_JOINT_RANGES, np.float64)
    mid, half = r.mean(1), 0.5 * fraction * (r[:, 1] - r[:, 0])
    return mid - half, mid + half


def _beyond_soft_limits(x: Inputs) -> np.ndarray:
    q = x["actuated_q"][:, : len(x["joint_soft_low"])]
    return (np.maximum(x["joint_soft_low"] - q, 0.0) + np.maximum(q - x["joint_soft_high"], 0.0)).sum(1)


TABLE_II: tuple[RewardTerm, ...] = (
    RewardTerm("track_vx", 2.0, "exp(-4 (v_x^cmd - v_x)^2), base frame.", lambda x: _track(x, 0, x["v"][:, 0])),
    RewardTerm("track_vy", 2.0, "exp(-4 (v_y^cmd - v_y)^2).", lambda x: _track(x, 1, x["v"][:, 1])),
    RewardTerm("track_wz", 3.0, "exp(-4 (w^cmd - w_z)^2).", lambda x: _track(x, 2, x["w"][:, 2])),
    RewardTerm("residual", -0.3, "||a_t|| (L2 norm of the raw action).", lambda x: np.linalg.norm(x["action"], axis=1)),
    RewardTerm("orientation", -2.0, "||g_xy||^2, projected gravity.", lambda x: (x["g"][:, :2] ** 2).sum(1)),
    RewardTerm("lin_vel_z", -2.0, "v_z^2.", lambda x: x["v"][:, 2] ** 2),
    RewardTerm("ang_vel_xy", -0.05, "||w_xy||^2.", lambda x: (x["w"][:, :2] ** 2).sum(1)),
    RewardTerm(
        "joint_acc",
        -2.5e-7,
        "||qdd||^2 over the 16 joints, finite difference over a policy step.",
        lambda x: (((x["actuated_qd"] - x["prev_actuated_qd"]) / x["dt"]) ** 2).sum(1),
    ),
    RewardTerm("torques", -1e-5, "||tau||^2.", lambda x: x["torque_sq"]),
    RewardTerm(
        "action_smoothness",
        -0.01,
        "||a_t + a_{t-2} - 2 a_{t-1}||^2.",
        lambda x: ((x["action"] + x["prev2_action"] - 2 * x["prev_action"]) ** 2).sum(1),
    ),
    RewardTerm(
        "collision",
        -2.0,
        "Number of trunk / thigh / calf bodies touching the ground.",
        lambda x: x["body_collision"].sum(1).astype(float),
    ),
    RewardTerm("energy", -1e-5, "||tau * qd||^2.", lambda x: x["power_sq"]),
)
"""The paper's Table II in kernel-column order."""

BEYOND_PAPER: tuple[RewardTerm, ...] = (
    RewardTerm(
        "p_cost",
        0.0,
        "sum_j |tau_j| |qd_j| [W]: the paper's power cost (its evaluation metric, Sec. IV-A) "
        "as a reward term, substep average; not in Table II (0: off). Training draws 100-400 W (exploration "
        "noise, randomisation; the deterministic policy 11-64 W per task), so -0.01 per W costs 1-4 per "
        "second of a reward that ends near 5 (docs/studies/residual_energy).",
        lambda x: x["p_cost"],
        migration=Migration(0.0, "no power-cost term before the setting existed"),
    ),
    RewardTerm(
        "joint_limits",
        0.0,
        "sum_j max(0, l_j - q_j) + max(0, q_j - u_j) [rad] over the 12 leg joints, (l_j, "
        "u_j) the joint range shrunk about its centre to reward.soft_joint_limit of its width (legged_gym's "
        "dof_pos_limits: -10 with soft_dof_pos_limit 0.9 in legged_gym/envs/a1/a1_config.py); not in Table II "
        "(0: off).",
        lambda x: _beyond_soft_limits(x),
        migration=Migration(0.0, "no joint-limit term before the setting existed"),
    ),
)
"""Terms beyond the paper's reward, each at weight 0 by default (options measured side by side)."""

TERMS: tuple[RewardTerm, ...] = TABLE_II + BEYOND_PAPER
"""Every term of the package, in the order of the reward kernel's output columns."""

REWARD_TERMS: tuple[str, ...] = tuple(t.name for t in TERMS)
"""Names of the terms, in the order of the reward kernel's output columns."""


def check_terms(terms: tuple[RewardTerm, ...]) -> None:
    """ValueError for duplicate term names."""
    names = [t.name for t in terms]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"reward terms registered twice: {', '.join(dup)}")
