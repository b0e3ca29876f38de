"""Gradient-based tuning of a nominal gait's parameters for energy per metre, on the differentiable path.

The paper sets its gait library by hand (Table I). :func:`optimize` tunes one gait's parameters theta = (h_b, h_s,
f, DF_swing, stance x) (``wqwarp.diff.rollout.PARAM_NAMES``) at a commanded forward speed v_c with Adam on the
gradients of :class:`wqwarp.diff.rollout.DiffRollout`, minimising

    J(theta) = P_smooth / v_c + w_v (v_x - v_c)^2 + w_h (z - z_0)^2        [J/m]

averaged over ``windows`` robots whose gait clocks start evenly spread over one cycle: P_smooth the smooth p_cost
[W] and v_x the base forward speed [m/s], both means over a short taped window after an untaped warm-up, z the trunk
height [m] and z_0 its value with the initial parameters. At v_x = v_c, P / v_c is the energy per metre. The taped
window is kept short (``TuneConfig.horizon_s``, 0.1 s) because longer windows through contact give gradients that
no longer match finite differences (``tools/studies/gradient_study.py``, ``docs/studies/diffsim/``); spreading the
windows over the gait cycle averages the gradient over the phases, which a single short window would not see.

:func:`evaluate` measures a parameter set with the project's closed-loop nominal gait (``wqwarp.control.driver.
OpenLoopDriver``, Eq. (1)-(3) with contact-dependent wheel speeds) on any ``Simulator`` backend, with the exact p_cost,
so that a gain found on the differentiable solver can be checked on MuJoCo.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field

import numpy as np

from wqwarp.control.gaits import GAIT_LIBRARY, Gait, gait_index

PARAM_SCALE = np.array([0.2, 0.1, 1.0, 0.4, 0.05])
"""Typical size of each parameter [m, m, Hz, -, m]: Adam works on theta / scale."""


def param_bounds(gait: str) -> np.ndarray:
    """(5, 2) lower and upper bounds of the parameters of ``gait``: h_b 0.15-0.28 m (the legs' workspace), h_s
    0.04-0.14 m, f 0.5-2.5 Hz, DF_swing from 0.15 to 0.02 below the smallest gap between two legs' phase offsets (so
    the legs that the gait keeps apart never swing together), stance x +-0.08 m. A gait without swing (driving)
    keeps f and DF_swing at 0."""
    g = GAIT_LIBRARY[gait_index(gait)]
    offs = np.unique(np.asarray(g.phase_offsets) % 1.0)
    gaps = np.diff(np.concatenate([offs, offs[:1] + 1.0]))
    df_hi = float(gaps.min()) - 0.02 if offs.size > 1 else 0.9
    b = np.array([[0.15, 0.28], [0.04, 0.14], [0.5, 2.5], [0.15, df_hi], [-0.08, 0.08]])
    if g.df_swing == 0.0:
        b[2] = b[3] = 0.0
    return b


@dataclass
class TuneConfig:
    """Settings of :func:`optimize`."""

    gait: str = "trotting"
    vx: float = 0.3
    """Commanded forward speed v_c [m/s]."""
    dt: float = 0.002
    """Physics step of the differentiable rollout [s] (decimation 0.02 / dt: 50 Hz targets)."""
    horizon_s: float = 0.1
    """Taped window [s]."""
    warmup_s: float = 1.5
    """Untaped warm-up before each window [s]: the drop from the start pose and the first strides take ~1 s
    (``docs/studies/diffsim/compare_physics_dt0.001.png``); a 0.5 s warm-up samples that transient
    (``docs/differentiable.md``)."""
    windows: int = 8
    """Robots per iteration, their gait clocks spread evenly over one cycle."""
    iterations: int = 30
    lr: float = 0.03
    """Adam step in units of ``PARAM_SCALE``."""
    accept_seconds: float = 1.0
    """Each iterate is also measured untaped for this long after the warm-up (``DiffRollout.measure``, same windows
    and physics): that J, far less noisy than the taped windows', picks the best iterate and triggers the restarts.
    0: use the taped windows' J."""
    patience: int = 3
    """Iterations without a new best J after which the parameters return to the best iterate, Adam's moments are
    reset and the step is halved (the window-averaged J is noisy and its truncated gradient biased, so Adam's
    momentum can carry the parameters away from a good iterate)."""
    w_speed: float = 2.0e4
    """w_v [J s^2 / m^3]: 0.05 m/s of speed error costs 50 J/m."""
    w_height: float = 5.0e5
    """w_h [J / m^3]: 1 cm of trunk-height change costs 50 J/m."""
    free: tuple[str, ...] = ("h_b", "h_s", "frequency", "df_swing", "stance_x")
    """Parameters that are tuned; the others stay at the gait's values."""
    seed: int = 0
    """Reserved for stochastic variants; the rollouts are deterministic."""
    start: list[float] | None = field(default=None)
    """Initial parameters (default: Table I with h_b, h_s from ``constants``)."""


def objective_weights(cfg: TuneConfig, res, z0: float, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """Seeds of dJ/d(P_smooth, v, z) per robot for :meth:`DiffRollout.gradients`, and J (the mean over robots)."""
    vx, z = res.base_velocity[:, 0], res.base_height
    j = res.p_cost_smooth / cfg.vx + cfg.w_speed * (vx - cfg.vx) ** 2 + cfg.w_height * (z - z0) ** 2
    wp_ = np.full(n, 1.0 / (cfg.vx * n))
    wv = np.zeros((n, 3))
    wv[:, 0] = 2.0 * cfg.w_speed * (vx - cfg.vx) / n
    wz = 2.0 * cfg.w_height * (z - z0) / n
    return wp_, wv, wz, float(j.mean())


def optimize(cfg: TuneConfig, progress=None) -> dict:
    """Adam on J (module docstring), returning to the best iterate with a halved step after ``cfg.patience``
    iterations without improvement. Returns {"config", "start", "best", "history": [{"iteration", "J", "p_cost",
    "vx", "height", "params", "grad", "J_accept", ...}]}; "best" is the iterate with the lowest acceptance J
    (``cfg.accept_seconds``) among those whose robots all stayed up."""
    import warp as wp

    from wqwarp.diff.rollout import PARAM_NAMES, DiffRollout, gait_params
    from wqwarp.sim.config import SimConfig

    unknown = [p for p in cfg.free if p not in PARAM_NAMES]
    if unknown:
        raise ValueError(f"unknown parameter {', '.join(unknown)}; choose from {', '.join(PARAM_NAMES)}")
    n = cfg.windows
    decimation = max(1, round(0.02 / cfg.dt))
    policy_dt = cfg.dt * decimation
    sim_cfg = SimConfig(num_envs=n, dt=cfg.dt, decimation=decimation, backend="featherstone")
    roll = DiffRollout(
        sim_cfg,
        cfg.gait,
        (cfg.vx, 0.0, 0.0),
        horizon=max(1, round(cfg.horizon_s / policy_dt)),
        warmup=round(cfg.warmup_s / policy_dt),
    )
    g = GAIT_LIBRARY[gait_index(cfg.gait)]
    shift = (np.arange(n) / n)[:, None]
    roll.phase_offsets.assign((np.asarray(g.phase_offsets, np.float32)[None, :] + shift).astype(np.float32) % 1.0)
    theta0 = np.asarray(cfg.start, np.float64) if cfg.start is not None else gait_params(cfg.gait).astype(np.float64)
    bounds = param_bounds(cfg.gait)
    mask = np.array([p in cfg.free for p in PARAM_NAMES]) & (bounds[:, 1] > bounds[:, 0])
    theta = np.clip(theta0, bounds[:, 0], bounds[:, 1])
    m = np.zeros(5)
    v = np.zeros(5)
    b1, b2 = 0.9, 0.999
    history, z0, z0_long = [], None, None
    lr, best_j, best_theta, since_best, k = cfg.lr, np.inf, theta.copy(), 0, 0
    for it in range(cfg.iterations + 1):
        t0 = time.time()
        roll.set_inputs(theta.astype(np.float32))
        res = roll.run()
        if z0 is None:
            z0 = float(res.base_height.mean())
        wpc, wv, wz, j = objective_weights(cfg, res, z0, n)
        grad = roll.gradients(p_cost_weight=wpc, velocity_weight=wv, height_weight=wz)["params"].sum(0)
        grad = np.where(mask, grad, 0.0).astype(np.float64)
        j_accept = j
        if cfg.accept_seconds > 0:
            long = roll.measure(cfg.accept_seconds, warm_start=False)  # continues from the warm-up of run()
            if z0_long is None:
                z0_long = float(long.base_height.mean())
            j_accept = objective_weights(cfg, long, z0_long, n)[3]
            fell = res.fell | long.fell
        else:
            long, fell = None, res.fell
        entry = {
            "iteration": it,
            "J": j,
            "J_accept": j_accept,
            "lr": lr,
            "p_cost": float(res.p_cost.mean()),
            "p_cost_smooth": float(res.p_cost_smooth.mean()),
            "vx": float(res.base_velocity[:, 0].mean()),
            "height": float(res.base_height.mean()),
            "fell": int(fell.sum()),
            "params": theta.tolist(),
            "grad": grad.tolist(),
            "seconds": time.time() - t0,
        }
        if long is not None:
            entry.update(
                p_cost_long=float(long.p_cost.mean()),
                vx_long=float(long.base_velocity[:, 0].mean()),
                height_long=float(long.base_height.mean()),
            )
        history.append(entry)
        if progress:
            progress(entry)
        if it == cfg.iterations or not np.isfinite(grad).all():
            break
        if j_accept < best_j and not fell.any():
            best_j, best_theta, since_best = j_accept, theta.copy(), 0
        else:
            since_best += 1
        if since_best >= cfg.patience:  # back to the best iterate with a smaller step
            theta, lr, since_best, k = best_theta.copy(), lr * 0.5, 0, 0
            m[:] = 0.0
            v[:] = 0.0
            continue
        gs = grad * PARAM_SCALE  # gradient w.r.t. theta / scale
        m = b1 * m + (1 - b1) * gs
        v = b2 * v + (1 - b2) * gs * gs
        k += 1
        step = lr * (m / (1 - b1**k)) / (np.sqrt(v / (1 - b2**k)) + 1e-8)
        theta = np.clip(theta - np.where(mask, step * PARAM_SCALE, 0.0), bounds[:, 0], bounds[:, 1])
    wp.synchronize()
    ok = [h for h in history if h["fell"] == 0] or history
    best = min(ok, key=lambda h: h["J_accept"])
    return {
        "config": asdict(cfg),
        "param_names": list(PARAM_NAMES),
        "bounds": bounds.tolist(),
        "z0": z0,
        "start": history[0],
        "best": best,
        "history": history,
    }


def evaluate(
    params,
    gait: str,
    vx: float,
    backend: str = "mujoco_cpu",
    dt: float = 0.005,
    decimation: int = 4,
    warmup_s: float = 1.0,
    seconds: float = 3.0,
    num_envs: int = 2,
) -> dict:
    """Run the closed-loop nominal gait with ``params`` (h_b, h_s, f, DF_swing, stance x) at command (vx, 0, 0) on
    ``backend`` and return the window means: p_cost (and legs / wheels) [W], v_x [m/s], trunk height [m], energy per
    metre p_cost / v_x [J/m] (None below 0.02 m/s), and whether the trunk touched the ground."""
    from wqwarp.control.driver import OpenLoopDriver
    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    p = [float(x) for x in params]
    base = GAIT_LIBRARY[gait_index(gait)]
    library = (Gait(base.name, base.phase_offsets, df_swing=p[3], frequency=p[2], stance_x=p[4]),)
    n = num_envs
    sim = Simulator(SimConfig(num_envs=n, device="cpu", dt=dt, decimation=decimation, backend=backend))
    drv = OpenLoopDriver(sim, base.name, (vx, 0.0, 0.0), library=library, body_height=p[0], swing_height=p[1])
    acc = dict.fromkeys(("p_cost", "p_cost_legs", "p_cost_wheels", "vx", "height"), 0.0)
    window = drv.steps(seconds)
    touched = False

    def record(k: int, in_window: bool) -> None:
        nonlocal touched
        touched |= bool(sim.body_collision.numpy()[:, 0].any())
        if not in_window:
            return
        for name in ("p_cost", "p_cost_legs", "p_cost_wheels"):
            acc[name] += float(getattr(sim, name).numpy().mean()) / window
        acc["vx"] += float(sim.base_lin_vel.numpy()[:, 0].mean()) / window
        acc["height"] += float(sim.base_height.numpy().mean()) / window

    drv.run(seconds, warmup_s, on_step=record)
    acc["energy_per_m"] = acc["p_cost"] / acc["vx"] if acc["vx"] > 0.02 else None
    acc["trunk_touched"] = touched
    acc.update(
        backend=sim.backend, dt=dt, decimation=decimation, warmup_s=warmup_s, seconds=seconds, num_envs=n, params=p
    )
    return acc


__all__ = ["PARAM_SCALE", "TuneConfig", "evaluate", "objective_weights", "optimize", "param_bounds"]
