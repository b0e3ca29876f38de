"""The observation-term registry: actor o_t and critic x_t, each term with its size, scales, noise and mirror.

Actor observation o_t (paper, "Observation Space of the Actor"), in the order of :data:`ACTOR_TERMS`:
    base_ang_vel (3)  base angular velocity, base frame, x0.25 [rad/s]
    gravity (3)       projected gravity, base frame [-]
    leg_pos (12)      leg joint positions minus the default pose [rad]
    joint_vel (16)    all 16 joint velocities x0.05 [rad/s]
    gait (18)         p_t: sin(2 pi phi) (4), cos(2 pi phi) (4), phase residuals (4), f [Hz], DF_swing, nominal
                      wheel speeds x0.05 (4) [rad/s]; zeros without a nominal gait
    estimate (3)      z_t: estimated v_x, v_y x2 [m/s] and base height [m] (inserted at ``estimate_index``)
    command (3)       v_x, v_y x2 [m/s], w_z x0.25 [rad/s]
    prev_action (A), prev2_action (A)   a_{t-1}, a_{t-2}; A = 20 (16 for the baseline)
The paper states previous actions of dimension 22 while its action list sums to 20; we use the action size.
Uniform noise (``ObservationConfig.noise_*``) is added to the sensor terms before scaling. The proprioceptive
observation (the estimator's history row and the exported policy's input) is o_t without z_t.

Critic observation = o_t plus privileged x_t (:data:`PRIVILEGED_TERMS`): true base velocity (3, base frame, x2), height
[m], friction, restitution, added mass [kg], wheel contact forces (4, /100 N), the current push (2) [m/s], running
gait one-hot (one per gait of the library; zeros without a nominal gait).

Mirror: the only symmetry of this robot is the left-right (x-z plane) mirror (knees all point backwards). Legs FR<->FL
and RR<->RL swap; hip angles, angular velocity x and z, gravity y, every y velocity, the yaw command, foot-y residuals
and the lateral push change sign. Each term declares its mirror as (permutation, signs) over its columns:
``mirrored[:, j] = signs[j] * x[:, perm[j]]``. The gait one-hot keeps its gait: driving and trotting are their own
mirror images up to a clock shift, Table I's walking is not (``wqwarp.control.gaits.is_mirror_symmetric``), so
mirrored walking samples show a swing sequence (FL, FR, RL, RR) that the library never runs.

Adding a term: one function ``f(env, base) -> (N, size)`` and one :class:`ObservationTerm` in the tuple it belongs to.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import torch
import warp as wp
from tensordict import TensorDict

LEG_SWAP = (1, 0, 3, 2)
"""Mirror image of each leg, legs FR, FL, RR, RL."""

Mirror = tuple[tuple[int, ...], tuple[float, ...]]
"""(perm, signs) over a term's columns: ``mirrored[:, j] = signs[j] * x[:, perm[j]]``."""


def same(*signs: float) -> Mirror:
    """Columns stay in place, with ``signs``."""
    return tuple(range(len(signs))), tuple(float(s) for s in signs)


def by_leg(*signs: float) -> Mirror:
    """Leg-major columns (4 legs x len(signs)) swapped to the mirror leg, each leg's columns with ``signs``."""
    k = len(signs)
    perm = tuple(LEG_SWAP[leg] * k + c for leg in range(4) for c in range(k))
    return perm, tuple(float(s) for s in signs) * 4


def concat(*parts: Mirror) -> Mirror:
    """Mirror of consecutive column blocks."""
    perm, signs, offset = [], [], 0
    for p, s in parts:
        perm += [offset + j for j in p]
        signs += list(s)
        offset += len(p)
    return tuple(perm), tuple(signs)


LEG_JOINTS = by_leg(-1, 1, 1)
"""12 leg joints (hip, thigh, calf per leg): hip abduction changes sign."""
WHEELS = by_leg(1)
"""4 per-leg values (wheel speeds, phases, contact forces): legs swap."""


def action_mirror(num_actions: int) -> Mirror:
    """Mirror of the policy action (``wqwarp.kernels.actions``): 20 residual actions dphi (4), dp (4 legs x, y, z),
    dv (4); 16 baseline actions joint offsets (12), wheel speeds (4)."""
    if num_actions == 20:
        return concat(WHEELS, by_leg(1, -1, 1), WHEELS)
    if num_actions == 16:
        return concat(LEG_JOINTS, WHEELS)
    raise ValueError(f"no mirror for {num_actions} actions (20 residual or 16 baseline)")


def action_groups(num_actions: int) -> dict[str, slice]:
    """Columns of each action group: ``phase`` dphi (4), ``foot`` dp (12), ``wheel`` dv (4) for the 20 residual
    actions; ``joint`` (12), ``wheel`` (4) for the baseline's 16 (the order of
    ``TrainConfig.init_noise_std_groups``)."""
    if num_actions == 20:
        return {"phase": slice(0, 4), "foot": slice(4, 16), "wheel": slice(16, 20)}
    if num_actions == 16:
        return {"joint": slice(0, 12), "wheel": slice(12, 16)}
    raise ValueError(f"no action groups for {num_actions} actions (20 residual or 16 baseline)")


@dataclass(frozen=True)
class Dims:
    """What term sizes depend on."""

    num_actions: int
    """A: 20 residual actions or 16 baseline actions."""
    num_gaits: int
    """Gaits in the library (``GaitConfig.library``)."""


@dataclass(frozen=True)
class ObservationTerm:
    """One block of columns of an observation."""

    name: str
    size: int | Callable[[Dims], int]
    """Number of columns, or a function of the env's :class:`Dims`."""
    compute: Callable | None
    """``compute(env, base) -> (N, size)`` before noise and scale (``base``: ``env.base_state()``); None for z_t,
    which the env's estimator writes."""
    mirror: Mirror | Callable[[Dims], Mirror]
    """Left-right mirror over the term's columns, or a function of :class:`Dims`."""
    noise: str | None = None
    """``ObservationConfig`` field of the uniform noise amplitude added before scaling."""
    scale: str | None = None
    """``ObservationConfig`` field of the scale applied after the noise."""

    def dim(self, dims: Dims) -> int:
        """Number of columns."""
        return self.size(dims) if callable(self.size) else self.size

    def mirror_of(self, dims: Dims) -> Mirror:
        """The mirror over this term's columns (ValueError unless it is a permutation of them)."""
        m = self.mirror(dims) if callable(self.mirror) else self.mirror
        if len(m[0]) != self.dim(dims) or sorted(m[0]) != list(range(self.dim(dims))):
            raise ValueError(
                f"observation term {self.name!r}: mirror is not a permutation of its {self.dim(dims)} columns"
            )
        return m


def _gait(env, base) -> torch.Tensor:
    """p_t of the running gait; zeros without a nominal gait."""
    n, ng = env.num_envs, env.nominal
    if ng is None:
        return torch.zeros(n, 18, device=env.device)
    phase = wp.to_torch(ng.phase)
    gid = wp.to_torch(ng.active_gait_id).long()
    freq = wp.to_torch(ng.arrays.frequency)[gid]
    df = wp.to_torch(ng.arrays.df_swing)[gid]
    vn = wp.to_torch(ng.wheel_velocity)
    if not env.cfg.action.use_nominal_wheels:
        vn = torch.zeros_like(vn)
    return torch.cat(
        [
            torch.sin(2 * math.pi * phase),
            torch.cos(2 * math.pi * phase),
            wp.to_torch(ng.phase_residual),
            freq[:, None],
            df[:, None],
            vn * env.cfg.obs.wheel_speed_scale,
        ],
        dim=1,
    )


def _gait_one_hot(env, base) -> torch.Tensor:
    gid = torch.nn.functional.one_hot(env.active_gait(), env.num_gaits).float()
    return torch.zeros_like(gid) if env.nominal is None else gid


def _actions(dims: Dims) -> int:
    return dims.num_actions


ESTIMATE = "estimate"
"""The term z_t, written by the estimator from the history of the other actor terms."""

ACTOR_TERMS: tuple[ObservationTerm, ...] = (
    ObservationTerm("base_ang_vel", 3, lambda env, b: b["ang_vel"], same(-1, 1, -1), "noise_ang_vel", "ang_vel_scale"),
    ObservationTerm("gravity", 3, lambda env, b: b["gravity"], same(1, -1, 1), "noise_gravity"),
    ObservationTerm(
        "leg_pos", 12, lambda env, b: env.tv["actuated_q"][:, :12] - env.default_leg_q, LEG_JOINTS, "noise_joint_pos"
    ),
    ObservationTerm(
        "joint_vel",
        16,
        lambda env, b: env.tv["actuated_qd"],
        concat(LEG_JOINTS, WHEELS),
        "noise_joint_vel",
        "joint_vel_scale",
    ),
    ObservationTerm("gait", 18, _gait, concat(WHEELS, WHEELS, WHEELS, same(1, 1), WHEELS)),
    ObservationTerm(ESTIMATE, 3, None, same(1, -1, 1)),
    ObservationTerm("command", 3, lambda env, b: env.commands * env.command_scale, same(1, -1, -1)),
    ObservationTerm("prev_action", _actions, lambda env, b: env.prev_actions, lambda d: action_mirror(d.num_actions)),
    ObservationTerm("prev2_action", _actions, lambda env, b: env.prev2_actions, lambda d: action_mirror(d.num_actions)),
)
"""The actor observation o_t, in column order."""

PRIVILEGED_TERMS: tuple[ObservationTerm, ...] = (
    ObservationTerm("lin_vel", 3, lambda env, b: b["lin_vel"], same(1, -1, 1), scale="lin_vel_scale"),
    ObservationTerm("height", 1, lambda env, b: b["height"][:, None], same(1)),
    ObservationTerm("friction", 1, lambda env, b: env.friction[:, None], same(1)),
    ObservationTerm("restitution", 1, lambda env, b: env.restitution[:, None], same(1)),
    ObservationTerm("added_mass", 1, lambda env, b: env.added_mass[:, None], same(1)),
    ObservationTerm("wheel_force", 4, lambda env, b: env.tv["wheel_force"] / 100.0, WHEELS),
    ObservationTerm("push", 2, lambda env, b: env.push_vel, same(1, -1)),
    ObservationTerm("gait_id", lambda d: d.num_gaits, _gait_one_hot, lambda d: same(*([1] * d.num_gaits))),
)
"""The critic's privileged x_t (appended to o_t by rsl-rl's ``obs_groups``), in column order."""


def layout(terms: tuple[ObservationTerm, ...], dims: Dims) -> list[tuple[str, int]]:
    """(name, size) of each term, in order."""
    return [(t.name, t.dim(dims)) for t in terms]


def observation_layout(num_actions: int, num_gaits: int = 3) -> list[tuple[str, int]]:
    """(name, size) of each part of the actor observation, in order."""
    return layout(ACTOR_TERMS, Dims(num_actions, num_gaits))


def estimate_index(dims: Dims, terms: tuple[ObservationTerm, ...] = ACTOR_TERMS) -> int:
    """Column of o_t where z_t starts (the proprioceptive observation is o_t without these 3 columns)."""
    names = [t.name for t in terms]
    return sum(t.dim(dims) for t in terms[: names.index(ESTIMATE)])


def decode_observation(obs: torch.Tensor, num_actions: int, num_gaits: int = 3) -> dict[str, torch.Tensor]:
    """Split actor observations (..., D) into their named parts (inverse of the layout)."""
    out, i = {}, 0
    for name, n in observation_layout(num_actions, num_gaits):
        out[name] = obs[..., i : i + n]
        i += n
    if i != obs.shape[-1]:
        raise ValueError(f"observation has {obs.shape[-1]} columns, the layout for {num_actions} actions has {i}")
    return out


def compute_terms(env, terms: tuple[ObservationTerm, ...], base: dict) -> list[torch.Tensor]:
    """Each term's columns (noised, then scaled), in order; noise draws from ``env.gen`` in term order."""
    o = env.cfg.obs
    out = []
    for t in terms:
        x = t.compute(env, base)
        if t.noise is not None:
            x = x + env.noise(x.shape, getattr(o, t.noise))
        if t.scale is not None:
            x = x * getattr(o, t.scale)
        out.append(x)
    return out


def mirror_tensors(mirror: Mirror, device: str = "cpu") -> tuple[torch.Tensor, torch.Tensor]:
    """(perm (D,) long, signs (D,) float32) of a mirror, on ``device``."""
    return (
        torch.tensor(mirror[0], dtype=torch.long, device=device),
        torch.tensor(mirror[1], dtype=torch.float32, device=device),
    )


def mirror_matrix(terms: tuple[ObservationTerm, ...], dims: Dims, device: str = "cpu") -> tuple[torch.Tensor, ...]:
    """(perm (D,) long, signs (D,) float32) of the concatenated terms, on ``device``."""
    return mirror_tensors(concat(*(t.mirror_of(dims) for t in terms)), device)


def apply_mirror(x: torch.Tensor, perm: torch.Tensor, signs: torch.Tensor) -> torch.Tensor:
    """``x[..., perm] * signs`` (the mirror moved to ``x``'s device if it is not there: the env keeps its own there)."""
    if x.shape[-1] != len(perm):
        raise ValueError(f"the mirror is over {len(perm)} columns, got {x.shape[-1]}")
    return x[..., perm.to(x.device)] * signs.to(x.device)


def mirror_observations(env, obs: TensorDict) -> TensorDict:
    """The left-right mirror of each observation group (``policy`` o_t, ``privileged`` x_t) of ``obs``."""
    groups = {"policy": env.obs_mirror, "privileged": env.privileged_mirror}
    return TensorDict(
        {k: apply_mirror(v, *groups[k]) for k, v in obs.items()}, batch_size=obs.batch_size, device=obs.device
    )


def mirror_actions(env, actions: torch.Tensor) -> torch.Tensor:
    """The left-right mirror of actions (..., A)."""
    return apply_mirror(actions, *env.action_mirror)


def data_augmentation(env, obs: TensorDict | None = None, actions: torch.Tensor | None = None):
    """rsl-rl's symmetry ``data_augmentation_func``: (obs, actions) each stacked with its mirror along the batch,
    originals first ([2B, ...]); a None input stays None."""
    obs_aug = None if obs is None else torch.cat([obs, mirror_observations(env, obs)], dim=0)
    act_aug = None if actions is None else torch.cat([actions, mirror_actions(env, actions)], dim=0)
    return obs_aug, act_aug
