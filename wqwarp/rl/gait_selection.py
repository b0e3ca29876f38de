"""Gait selection: which nominal gait each robot requests (paper, "Predictive Energy-Aware Nominal Gait Selection").

One interface, three selectors (:func:`make_gait_selector` picks one from ``GaitConfig.selection``):
    none        no nominal gait (the baseline); nothing to select
    fixed       every robot requests ``GaitConfig.fixed_gait``
    predictive  a power prediction network estimates, from the actor observation o_t, each gait's mean p_cost over
                the next ``horizon_s`` (1 s); robots sample their gait with probabilities softmax(-p_est / tau),
                tau annealed over the PPO iterations (:class:`TemperatureSchedule`); by default p_est is divided
                by its mean over the gaits first (``PredictorConfig.power_normalization``), which leaves the argmin
                unchanged and makes tau a fraction of the robot's mean predicted power; with
                ``PredictorConfig.criterion = "feasible"`` (beyond the paper) a tracking head predicts each gait's
                mean squared tracking error over the horizon too; a gait not predicted to track within
                ``feasible_margin`` of the best one has its odds cut by e^(feasible_penalty / tau) while training
                and is never the argmin; ``kinematic`` never offers a gait without swing for a lateral command
                (nor, above a limit, a turn); ``kinematic_feasible`` applies that mask first and the margin among
                the gaits it leaves (:meth:`PredictiveGaitSelector.rule_candidates`, the one statement of the rule)

The environment owns a selector and calls it at fixed points of ``step`` (:meth:`GaitSelector.record_step` after the
physics, :meth:`GaitSelector.on_reset` for robots reset, :meth:`GaitSelector.select` once o_t is known). The
requested gait has one home: ``NominalGait.gait_id`` (Warp), which the selector writes through a zero-copy torch
view. The gait that actually runs is ``NominalGait.active_gait_id``: a request takes effect when the library's
continuity rule allows (no leg of the active gait in swing; ``wqwarp.kernels.gait``).

Timing (predictive). A robot's gait is held for ``decision_interval_s`` counted from the first full policy step
run in it, then selected again (it may keep the same gait). A labelled window starts at an observation o_t where
the requested gait is in effect and no window is open; it is labelled with the realised mean p_cost (and mean
squared tracking error) of the next ``horizon`` policy steps, for the gait that ran. A window cut by a reset or by a
gait switch is dropped, never labelled. With decision interval = horizon, every selection that is not cut yields
one window.

Learning happens in the algorithm, not in ``VecEnv.step``: the env only stores labelled windows while its
``collect_training_data`` flag is set (``wqwarp.rl.runner.WqRunner.learn`` sets it), and the algorithm calls
:meth:`GaitSelector.fit` after each PPO update (``wqwarp.rl.algorithm.GaitSelectorLearner``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from wqwarp.rl.config import TEMPERATURE_SHAPES
from wqwarp.rl.estimator import mlp

COMMAND_TYPES: tuple[str, ...] = ("forward", "lateral", "yaw", "mixed", "zero")
"""Command types of the usage logs: only v_x, only v_y, only w_z non-zero; several; none."""

COMMAND_ZERO: float = 0.05
"""|command| below which an axis counts as zero for the usage logs [m/s or rad/s]."""

SHAPES: tuple[str, ...] = TEMPERATURE_SHAPES


def usage_from_scalars(scalars: dict[str, float]) -> dict[str, float]:
    """gait -> share of robot-steps from the ``Gait/usage_<gait>`` entries of :meth:`GaitSelector.log_scalars`
    (the per-command-type entries ``Gait/usage_<gait>_<type>`` are left out)."""
    return {k[len("Gait/usage_") :]: v for k, v in scalars.items() if k.startswith("Gait/usage_") and k.count("_") == 1}


def command_type(commands: torch.Tensor) -> torch.Tensor:
    """Index into :data:`COMMAND_TYPES` of each command (N, 3) (v_x, v_y, w_z)."""
    nz = commands.abs() > COMMAND_ZERO
    count = nz.sum(dim=1)
    single = torch.argmax(nz.to(torch.int8), dim=1)  # the one non-zero axis when count == 1
    out = torch.where(count == 1, single, torch.full_like(count, 3))
    return torch.where(count == 0, torch.full_like(count, 4), out)


# --- temperature -----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class TemperatureSchedule:
    """tau(iteration): from ``start`` at iteration 0 to ``end`` at ``iterations``, constant afterwards (a fraction
    of the mean predicted power, or W, by ``PredictorConfig.power_normalization``)."""

    start: float
    end: float
    iterations: int
    shape: str = "exponential"

    def __post_init__(self) -> None:
        if not (self.start > 0.0 and self.end > 0.0):
            raise ValueError(f"temperatures must be > 0, got start {self.start} and end {self.end}")
        if self.iterations < 0:
            raise ValueError(f"temperature iterations must be >= 0, got {self.iterations}")
        if self.shape not in SHAPES:
            raise ValueError(f"unknown temperature shape {self.shape!r}; choose one of {', '.join(SHAPES)}")

    def __call__(self, iteration: int) -> float:
        s = 1.0 if self.iterations == 0 else min(max(iteration / self.iterations, 0.0), 1.0)
        if self.shape == "exponential":
            return self.start * (self.end / self.start) ** s
        if self.shape == "cosine":
            s = 0.5 * (1.0 - math.cos(math.pi * s))
        return self.start + (self.end - self.start) * s


def tracking_error(commands: torch.Tensor, lin_vel: torch.Tensor, ang_vel: torch.Tensor) -> torch.Tensor:
    """Squared tracking error of each robot (N,): (v_x^cmd - v_x)^2 + (v_y^cmd - v_y)^2 + (w^cmd - w_z)^2, base frame
    (the quantities of Table II's three tracking terms)."""
    return ((commands[:, :2] - lin_vel[:, :2]) ** 2).sum(dim=1) + (commands[:, 2] - ang_vel[:, 2]) ** 2


def feasible_gaits(error: torch.Tensor, margin: float, allowed: torch.Tensor | None = None) -> torch.Tensor:
    """(B, G) bool: the gaits whose predicted tracking error is within ``margin`` of the row's best (never empty).
    ``allowed`` (same shape, bool; at least one per row): only those gaits count, for the best and as candidates."""
    if allowed is None:
        return error <= error.min(dim=-1, keepdim=True).values + margin
    error = error.masked_fill(~allowed, float("inf"))
    return allowed & (error <= error.min(dim=-1, keepdim=True).values + margin)


def both_candidates(a: torch.Tensor | None, b: torch.Tensor | None) -> torch.Tensor | None:
    """The gaits in both candidate masks (None: every gait)."""
    return b if a is None else a if b is None else a & b


def gait_probabilities(power: torch.Tensor, temperature: float, candidates: torch.Tensor | None = None) -> torch.Tensor:
    """softmax(-power / tau) over the last axis (paper's selection probabilities); tau <= 0 gives the argmin.
    ``candidates`` (same shape, bool; at least one per row) restricts both to those gaits."""
    if candidates is not None:
        power = power.masked_fill(~candidates, float("inf"))
    if temperature <= 0.0:
        return torch.nn.functional.one_hot(torch.argmin(power, dim=-1), power.shape[-1]).to(power.dtype)
    return torch.softmax(-power / temperature, dim=-1)


# --- power prediction network ----------------------------------------------------------------------------------------
class PowerPredictor(nn.Module):
    """MLP from the actor observation o_t (B, D) to each gait's predicted mean p_cost over the horizon (B, G) [W]
    (the same module, with other targets, is the ``feasible`` criterion's tracking head [(m/s)^2]).

    Inputs and targets are normalised inside the module (buffers ``obs_mean``, ``obs_std``, ``target_mean``,
    ``target_std``, set from the replay buffer at each fit), so the exported module takes raw o_t and returns watts.
    """

    def __init__(self, obs_dim: int, num_gaits: int, hidden_dims: tuple[int, ...] = (128, 64)):
        super().__init__()
        self.net = mlp(obs_dim, hidden_dims, num_gaits)
        self.register_buffer("obs_mean", torch.zeros(obs_dim))
        self.register_buffer("obs_std", torch.ones(obs_dim))
        self.register_buffer("target_mean", torch.zeros(num_gaits))
        self.register_buffer("target_std", torch.ones(num_gaits))

    def normalized(self, obs: torch.Tensor) -> torch.Tensor:
        """Network output in normalised target units (B, G)."""
        return self.net((obs - self.obs_mean) / self.obs_std)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.normalized(obs) * self.target_std + self.target_mean


class WindowLabeler:
    """Per-robot windows of ``horizon`` policy steps -> labelled samples (o_t at the window start, gait, mean p_cost,
    mean squared tracking error).

    :meth:`start` opens a window at o_t for robots whose requested gait is in effect and that have none open;
    :meth:`step` adds one policy step's p_cost and returns the windows that completed. A reset or a change of the
    running gait inside a window drops it, and with ``command_cut`` a change of the robot's command too.
    """

    def __init__(self, num_envs: int, obs_dim: int, horizon: int, device: str = "cpu", command_cut: bool = False):
        if horizon < 1:
            raise ValueError(f"window horizon must be >= 1 policy step, got {horizon}")
        self.horizon = horizon
        self.command_cut = command_cut
        self.command = torch.zeros(num_envs, 3, device=device)
        """The command at each open window's o_t (read only with ``command_cut``)."""
        self.open = torch.zeros(num_envs, dtype=torch.bool, device=device)
        self.gait = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.obs = torch.zeros(num_envs, obs_dim, device=device)
        self.sum = torch.zeros(num_envs, device=device)
        self.err_sum = torch.zeros(num_envs, device=device)
        self.length = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.dropped = torch.zeros((), dtype=torch.long, device=device)
        """Windows dropped since construction (reset or gait switch inside; a tensor: no host sync per step)."""

    def start(
        self,
        obs: torch.Tensor,
        active: torch.Tensor,
        requested: torch.Tensor,
        allowed: torch.Tensor | None = None,
        commands: torch.Tensor | None = None,
    ) -> None:
        """Open windows at o_t; ``allowed`` (N,) bool restricts them to those robots (None: every robot);
        ``commands`` (N, 3) are o_t's (needed with ``command_cut``)."""
        new = ~self.open & (active == requested)
        if allowed is not None:
            new &= allowed
        if self.command_cut:
            if commands is None:
                raise ValueError("a labeler with command_cut needs the commands at o_t")
            self.command[new] = commands[new].to(self.command)
        self.obs[new] = obs[new]
        self.gait[new] = active[new]
        self.sum[new] = 0.0
        self.err_sum[new] = 0.0
        self.length[new] = 0
        self.open |= new

    def step(
        self,
        p_cost: torch.Tensor,
        error: torch.Tensor,
        active: torch.Tensor,
        reset: torch.Tensor,
        commands: torch.Tensor | None = None,
    ):
        """Account one policy step that ran gait ``active`` under ``commands`` (N, 3; needed with ``command_cut``),
        cost ``p_cost`` [W] and tracked with squared error ``error``; ``reset`` marks robots reset after it. Returns
        (obs (K, D), gait (K,), mean p_cost (K,), mean error (K,)) of the windows completed by this step."""
        cut = self.open & ((active != self.gait) | reset)
        if self.command_cut:
            if commands is None:
                raise ValueError("a labeler with command_cut needs each step's commands")
            cut |= self.open & (commands.to(self.command) != self.command).any(dim=1)
        self.dropped += cut.sum()
        self.open &= ~cut
        zero = torch.zeros_like(p_cost)
        self.sum += torch.where(self.open, p_cost, zero)
        self.err_sum += torch.where(self.open, error, zero)
        self.length += self.open.long()
        done = self.open & (self.length >= self.horizon)
        self.open &= ~done
        return (
            self.obs[done].clone(),
            self.gait[done].clone(),
            self.sum[done] / self.horizon,
            self.err_sum[done] / self.horizon,
        )


class WindowRing:
    """Ring buffer of the most recent labelled windows: o_t (cap, D), gait (cap,), mean p_cost (cap,) [W], mean
    squared tracking error (cap,)."""

    def __init__(self, capacity: int, obs_dim: int, device):
        self.obs = torch.zeros(capacity, obs_dim, device=device)
        self.gait = torch.zeros(capacity, dtype=torch.long, device=device)
        self.y = torch.zeros(capacity, device=device)
        self.e = torch.zeros(capacity, device=device)
        self.n = 0
        """Windows held (at most the capacity)."""
        self.i = 0
        """Next slot to write."""

    def put(self, obs: torch.Tensor, gait: torch.Tensor, y: torch.Tensor, e: torch.Tensor) -> None:
        cap, m = len(self.y), len(y)
        if m > cap:
            obs, gait, y, e, m = obs[-cap:], gait[-cap:], y[-cap:], e[-cap:], cap
        pos = (self.i + torch.arange(m, device=self.y.device)) % cap
        self.obs[pos], self.gait[pos], self.y[pos], self.e[pos] = obs, gait, y, e
        self.i = (self.i + m) % cap
        self.n = min(self.n + m, cap)


# --- selectors -------------------------------------------------------------------------------------------------------
class GaitSelector:
    """Interface of the gait selectors; the base class is the ``none`` selector (no nominal gait)."""

    name = "none"
    num_gaits = 0
    gen: torch.Generator | None = None
    """The selector's own random stream (the predictive selector's softmax sampling); None when it draws nothing."""
    label_robots: torch.Tensor | None = None
    """(N,) bool: the robots that act with the policy's mean action while training and alone label the predictor
    (``PredictorConfig.label_source = "mean"``; ``wqwarp.rl.algorithm.WqPPO`` reads it); None: every robot samples
    its actions (and labels, where there is a predictor)."""

    def record_step(self, p_cost, error, active, commands, reset, died) -> None:
        """After the physics of a policy step (before resets): p_cost (N,) [W], squared tracking error (N,)
        (:func:`tracking_error`), running gait (N,), commands (N, 3), reset (N,) bool (died or timed out), died (N,)
        bool."""

    def on_reset(self, ids: torch.Tensor) -> None:
        """Robots ``ids`` were reset (their gait restarts in the requested gait)."""

    def select(self, obs: torch.Tensor, active: torch.Tensor, commands: torch.Tensor | None = None) -> None:
        """Once o_t (N, D) is known: choose the gait of the robots that are due (``commands`` (N, 3): the
        ``kinematic`` criterion reads v_y)."""

    def request_selection(self) -> None:
        """Make every robot due for a selection at the next observation (after networks were loaded)."""

    def snapshot(self) -> dict:
        """What an evaluation protocol may change in this selector, to give back with :meth:`restore`."""
        return {}

    def restore(self, saved: dict) -> None:
        """Give back the state :meth:`snapshot` took."""

    def fit(self) -> dict[str, float]:
        """Learn from the data recorded since the last call (the algorithm, after each PPO update); returns losses."""
        return {}

    def set_training(self, training: bool) -> None:
        """Training (the runner collects): record windows and sample at the schedule's tau; else evaluation."""

    def set_iteration(self, iteration: int) -> None:
        """The PPO iteration the coming rollout belongs to (moves the temperature schedule)."""

    def log_scalars(self) -> dict[str, float]:
        """TensorBoard scalars of the iteration, then the counters restart."""
        return {}

    def state_dict(self) -> dict:
        return {"name": self.name}

    def load_state_dict(self, state: dict) -> None:
        if state.get("name", self.name) != self.name:
            raise ValueError(f"checkpoint holds a {state.get('name')!r} gait selector, this preset uses {self.name!r}")


class FixedGaitSelector(GaitSelector):
    """Every robot requests one gait; logs the usage of the running gaits like the predictive selector."""

    name = "fixed"

    def __init__(self, requested: torch.Tensor, gait_names: tuple[str, ...], gait: int, policy_dt: float):
        self.requested = requested
        """Torch view of ``NominalGait.gait_id`` (int32): the one home of the requested gait."""
        self.gait_names = gait_names
        self.num_gaits = len(gait_names)
        self.dt = policy_dt
        self.requested[:] = gait
        dev = requested.device
        self.usage = torch.zeros(self.num_gaits, len(COMMAND_TYPES), device=dev)
        self.events = torch.zeros(3, device=dev)
        """Switches, falls, falls within 1 s of a switch since the last log (a tensor: no host sync per step)."""
        self.one_second = max(1, int(round(1.0 / policy_dt)))
        self.since_switch = torch.full((len(requested),), 10**9, dtype=torch.long, device=dev)
        self.last_active: torch.Tensor | None = None

    def record_step(self, p_cost, error, active, commands, reset, died) -> None:
        active = active.long()
        ctype = command_type(commands)
        self.usage.index_put_((active, ctype), torch.ones_like(p_cost), accumulate=True)
        if self.last_active is not None:
            switched = active != self.last_active
            self.events[0] += switched.sum()
            self.since_switch = torch.where(switched, torch.zeros_like(self.since_switch), self.since_switch + 1)
        self.events[1] += died.sum()
        self.events[2] += (died & (self.since_switch < self.one_second)).sum()
        self.last_active = active.clone()

    def on_reset(self, ids: torch.Tensor) -> None:
        self.since_switch[ids] = 10**9
        if self.last_active is not None:
            self.last_active[ids] = self.requested[ids].long()

    def snapshot(self) -> dict:
        # the switch counter's memory of the running gait: a fresh selector does not compare its first step
        last = None if self.last_active is None else self.last_active.clone()
        return {"last_active": last, "since_switch": self.since_switch.clone()}

    def restore(self, saved: dict) -> None:
        self.last_active, self.since_switch = saved["last_active"], saved["since_switch"]

    def log_scalars(self) -> dict[str, float]:
        total = float(self.usage.sum())
        if total == 0.0:
            return {}
        out = {}
        robot_seconds = total * self.dt
        switches, falls, falls_after_switch = self.events.tolist()
        out["Gait/switches_per_robot_minute"] = 60.0 * switches / robot_seconds
        out["Gait/falls_within_1s_of_switch"] = falls_after_switch
        out["Gait/falls"] = falls
        for g, name in enumerate(self.gait_names):
            out[f"Gait/usage_{name}"] = float(self.usage[g].sum()) / total
            for c, ctype in enumerate(COMMAND_TYPES):
                col = float(self.usage[:, c].sum())
                if col > 0.0:
                    out[f"Gait/usage_{name}_{ctype}"] = float(self.usage[g, c]) / col
        self.usage.zero_()
        self.events.zero_()
        return out


class PredictiveGaitSelector(FixedGaitSelector):
    """The paper's predictive selector: softmax(-p_est / tau) sampling over the library, tau annealed."""

    name = "predictive"

    def __init__(
        self,
        requested: torch.Tensor,
        gait_names: tuple[str, ...],
        start_gait: int,
        policy_dt: float,
        obs_dim: int,
        cfg,
        seed: int = 0,
        stepless: tuple[bool, ...] | None = None,
        reach_limit: tuple[float, ...] | None = None,
    ):
        super().__init__(requested, gait_names, start_gait, policy_dt)
        self.cfg = cfg
        dev = requested.device
        n = len(requested)
        self.horizon = max(1, int(round(cfg.horizon_s / policy_dt)))
        self.decision_steps = max(1, int(round(cfg.decision_interval_s / policy_dt)))
        self.schedule = TemperatureSchedule(
            cfg.temperature_start, cfg.temperature_end, cfg.temperature_iterations, cfg.temperature_shape
        )
        self.iteration = 0
        self.training = False
        """True while the runner collects training data: sample at the schedule's tau and record windows."""
        self.predictor = PowerPredictor(obs_dim, self.num_gaits, tuple(cfg.hidden_dims)).to(dev)
        self.optimizer = torch.optim.Adam(self.predictor.parameters(), lr=cfg.learning_rate)
        self.tracker: PowerPredictor | None = None
        """The ``feasible`` criterion's tracking head: each gait's mean squared tracking error over the horizon
        (built only for that criterion: the paper's rule draws no extra initialisation from torch's RNG)."""
        self.tracker_fitted = False
        """True once the tracking head was fitted: before, every gait is a candidate."""
        if cfg.tracking_head:
            self.tracker = PowerPredictor(obs_dim, self.num_gaits, tuple(cfg.hidden_dims)).to(dev)
            self.tracker_optimizer = torch.optim.Adam(self.tracker.parameters(), lr=cfg.learning_rate)
        self.stepless = torch.tensor(stepless or (False,) * self.num_gaits, dtype=torch.bool, device=dev)
        """Gaits without swing (``make_gait_selector`` reads them from the library): the ``kinematic`` criterion's
        gaits that cannot move the trunk sideways."""
        if cfg.kinematic_mask and bool(self.stepless.all()):
            raise ValueError("the kinematic criterion needs a gait with swing in gait.library")
        self.reach_limit = (
            torch.tensor(reach_limit, dtype=torch.float32, device=dev) if reach_limit is not None else None
        )
        """The ``kinematic_reach`` mask's |v_y^cmd| bound per gait [m/s] (:func:`reach_limits`; inf where it keeps
        none off); None without the mask."""
        self.explored = torch.zeros(2, device=dev)
        """Selections replaced by exploration (``explore_fraction``) and selections made since the last log."""
        self.candidates = torch.zeros(2, device=dev)
        """Candidate gaits offered and selections made since the last log (a tensor: no host sync per step)."""
        self.labeler = WindowLabeler(n, obs_dim, self.horizon, dev, command_cut=cfg.label_command_cut)
        if cfg.label_source == "mean":
            every = max(1, int(round(1.0 / cfg.label_fraction)))
            self.label_robots = torch.arange(n, device=dev) % every == 0
        self.gen = torch.Generator(device=dev)
        self.gen.manual_seed(seed + 7919)
        self.in_gait = torch.zeros(n, dtype=torch.long, device=dev)
        """Full policy steps run in the requested gait since it took effect (or since the last selection)."""
        self.due = torch.ones(n, dtype=torch.bool, device=dev)
        self.prev_active = requested.long().clone()
        cap = max(1, cfg.buffer_size)
        self.replay = WindowRing(cap, obs_dim, dev)
        """Training windows (replay buffer)."""
        self.holdout = WindowRing(max(1, int(cap * cfg.holdout_fraction)), obs_dim, dev)
        """Held-out windows: never trained on, they give the relative error per gait."""
        self.windows = 0
        self.used_temperature = self.temperature
        """tau of the latest selection (logged for the rollout it belongs to)."""
        self.forced_gait: int | torch.Tensor | None = None
        """Diagnostics only: request this gait (an index, or one per robot as an (N,) tensor) instead of selecting
        (the predictor still predicts; evaluation compares its prediction for the forced gait with the realised
        power)."""
        self.last_losses: dict[str, float] = {}

    @property
    def temperature(self) -> float:
        """tau of the coming selections [W]; 0 means the argmin (evaluation default)."""
        if self.training or self.cfg.evaluation_selection == "sample":
            return self.schedule(self.iteration)
        return 0.0

    def set_iteration(self, iteration: int) -> None:
        self.iteration = int(iteration)

    def set_training(self, training: bool) -> None:
        if training and not self.training:
            self.due[:] = True  # selections made outside training are redone at the next step
        self.training = training

    # --- env hooks ---------------------------------------------------------------------------------------------------
    def record_step(self, p_cost, error, active, commands, reset, died) -> None:
        super().record_step(p_cost, error, active, commands, reset, died)
        active = active.long()
        req = self.requested.long()
        ran = (active == req) & (self.prev_active == req)
        self.in_gait = torch.where(ran, self.in_gait + 1, torch.zeros_like(self.in_gait))
        self.due |= self.in_gait >= self.decision_steps
        self.prev_active = active.clone()
        if self.training:
            obs, gait, y, e = self.labeler.step(p_cost, error, active, reset, commands)
            if len(y):
                self._store(obs, gait, y, e)

    def on_reset(self, ids: torch.Tensor) -> None:
        super().on_reset(ids)
        self.due[ids] = True
        self.in_gait[ids] = 0

    def snapshot(self) -> dict:
        return {**super().snapshot(), "forced_gait": self.forced_gait, "gen": self.gen.get_state()}

    def restore(self, saved: dict) -> None:
        super().restore(saved)
        self.forced_gait = saved["forced_gait"]
        self.gen.set_state(saved["gen"])

    def request_selection(self) -> None:
        self.due[:] = True

    def force(self, gait: int | torch.Tensor) -> None:
        """Diagnostics: request ``gait`` (an index, or one per robot as an (N,) tensor) instead of selecting, from
        now on: the request is written at once, so a reset starts the robots in it (not in the gait the rule chose
        before, which would run until the continuity rule let the forced one in)."""
        self.forced_gait = gait
        self.requested[:] = gait.to(self.requested) if torch.is_tensor(gait) else gait

    @torch.no_grad()
    def select(self, obs: torch.Tensor, active: torch.Tensor, commands: torch.Tensor | None = None) -> None:
        active = active.long()
        self.prev_active = active.clone()  # resets restart robots in their requested gait
        self.used_temperature = self.temperature
        ids = self.due.nonzero(as_tuple=False).flatten()
        if len(ids) and self.forced_gait is not None:
            forced = self.forced_gait
            self.requested[ids] = forced.to(self.requested)[ids] if torch.is_tensor(forced) else forced
            self.in_gait[ids] = 0
            self.due[ids] = False
        elif len(ids):
            cfg, tau = self.cfg, self.temperature
            power = self.predictor(obs[ids])
            unit = power.mean(dim=1, keepdim=True).clamp(min=1.0)  # the robot's mean predicted power
            if cfg.power_normalization == "mean":
                power, unit = power / unit, 1.0
            hard, soft = self.rule_candidates(obs[ids], None if commands is None else commands[ids])
            candidates = both_candidates(hard, soft)
            if candidates is not None:
                self.candidates[0] += candidates.sum()
                self.candidates[1] += len(ids)
                if soft is not None and tau > 0.0:  # softened: odds x e^(-feasible_penalty / tau)
                    power = power + cfg.feasible_penalty * unit * (~soft).to(power.dtype)
                    candidates = hard
            probs = gait_probabilities(power, tau, candidates)
            choice = torch.multinomial(probs, 1, generator=self.gen).flatten()
            if self.training and cfg.explore_fraction > 0.0:
                choice = self.explore(choice, hard)
            self.requested[ids] = choice.to(self.requested.dtype)
            self.in_gait[ids] = 0
            self.due[ids] = False
        if self.training:
            self.labeler.start(obs, active, self.requested.long(), self.label_robots, commands)

    def explore(self, choice: torch.Tensor, allowed: torch.Tensor | None) -> torch.Tensor:
        """``choice`` (B,) with each entry replaced, with probability ``explore_fraction``, by a gait drawn uniformly
        among ``allowed`` (B, G) (every gait if None); counts the replaced selections for the log."""
        b = len(choice)
        if allowed is None:
            allowed = torch.ones(b, self.num_gaits, dtype=torch.bool, device=choice.device)
        explore = torch.rand(b, generator=self.gen, device=choice.device) < self.cfg.explore_fraction
        uniform = torch.multinomial(allowed.float(), 1, generator=self.gen).flatten()
        self.explored[0] += explore.sum()
        self.explored[1] += b
        return torch.where(explore, uniform, choice)

    def predict(self, obs: torch.Tensor) -> torch.Tensor:
        """Predicted mean p_cost of each gait over the horizon (N, G) [W]."""
        with torch.no_grad():
            return self.predictor(obs)

    def predict_error(self, obs: torch.Tensor) -> torch.Tensor | None:
        """Predicted mean squared tracking error of each gait over the horizon (N, G); None without a tracking head."""
        if self.tracker is None:
            return None
        with torch.no_grad():
            return self.tracker(obs)

    def kinematic_candidates(self, commands: torch.Tensor) -> torch.Tensor:
        """(N, G) bool: the gaits the ``kinematic`` criterion offers for commands (N, 3): no gait without swing for
        |v_y| above ``kinematic_lateral_limit`` or |w| above ``kinematic_yaw_limit`` (never empty: the library has a
        stepping gait, checked at build)."""
        cfg = self.cfg
        legged = (commands[:, 1].abs() > cfg.kinematic_lateral_limit) | (commands[:, 2].abs() > cfg.kinematic_yaw_limit)
        allowed = ~(legged[:, None] & self.stepless[None, :])
        if self.reach_limit is not None:  # stepping gaits: |v_y| within their reach
            allowed &= commands[:, 1:2].abs() <= self.reach_limit[None, :]
        return allowed

    def candidate_gaits(self, obs: torch.Tensor, allowed: torch.Tensor | None = None) -> torch.Tensor | None:
        """(N, G) bool: the gaits the ``feasible`` margin offers for o_t among ``allowed`` (every gait if None);
        None (every gait) without a tracking head or before it was fitted."""
        if self.tracker is None or not self.tracker_fitted:
            return None
        return feasible_gaits(self.predict_error(obs), self.cfg.feasible_margin, allowed)

    def rule_candidates(
        self, obs: torch.Tensor | None, commands: torch.Tensor | None, error: torch.Tensor | None = None
    ) -> tuple[torch.Tensor | None, ...]:
        """The criterion's candidates for o_t (N, D) and its commands (N, 3), as two (N, G) bool masks or None
        (every gait): ``hard``, the kinematic mask, never crossed; ``soft``, the feasible margin (within ``hard``),
        softened by ``feasible_penalty`` while training at tau > 0 and a mask at the argmin. ``error`` (N, G): the
        tracking head's prediction to use instead of its output for ``obs`` (the energy map's cell means)."""
        hard = None
        if self.cfg.kinematic_mask:
            if commands is None:
                raise ValueError(f"the {self.cfg.criterion} criterion needs the robots' commands")
            hard = self.kinematic_candidates(commands)
        if error is not None and self.tracker_fitted:
            return hard, feasible_gaits(error, self.cfg.feasible_margin, hard)
        return hard, self.candidate_gaits(obs, hard)

    # --- learning ----------------------------------------------------------------------------------------------------
    def _store(self, obs: torch.Tensor, gait: torch.Tensor, y: torch.Tensor, e: torch.Tensor) -> None:
        """Add completed windows: every ``1/holdout_fraction``-th window goes to the held-out set."""
        every = int(round(1.0 / self.cfg.holdout_fraction)) if self.cfg.holdout_fraction > 0 else 0
        number = self.windows + 1 + torch.arange(len(y), device=y.device)
        self.windows += len(y)
        held = (number % every == 0) if every else torch.zeros_like(number, dtype=torch.bool)
        self.holdout.put(obs[held], gait[held], y[held], e[held])
        self.replay.put(obs[~held], gait[~held], y[~held], e[~held])

    def add_windows(
        self, obs: torch.Tensor, gait: torch.Tensor, y: torch.Tensor, e: torch.Tensor | None = None
    ) -> None:
        """Add labelled windows directly (tests, offline data); ``e`` (tracking error) defaults to zeros."""
        self._store(obs, gait.long(), y, torch.zeros_like(y) if e is None else e)

    def _update_normalization(
        self, p: PowerPredictor, y: torch.Tensor, min_std: float, obs_mean: torch.Tensor, obs_std: torch.Tensor
    ) -> None:
        """Input (given) and per-gait target normalisation of network ``p`` from the replay buffer's targets ``y``."""
        r = self.replay
        n = r.n
        g, y = r.gait[:n], y[:n]
        p.obs_mean.copy_(obs_mean)
        p.obs_std.copy_(obs_std)
        for k in range(self.num_gaits):
            yk = y[g == k]
            if len(yk) >= 2:
                p.target_mean[k] = yk.mean()
                p.target_std[k] = yk.std(unbiased=False).clamp(min=min_std)

    def fit(self) -> dict[str, float]:
        """Masked regression on the replay buffer: only the output of the gait that ran is trained (the power
        predictor, and the tracking head on the same batches when there is one)."""
        r = self.replay
        if r.n < self.cfg.batch_size // 4:
            return {}
        cfg, p, t = self.cfg, self.predictor, self.tracker
        with torch.inference_mode(False), torch.enable_grad():
            x = r.obs[: r.n]
            stats = (x.mean(0), x.std(0, unbiased=False).clamp(min=1e-3) if r.n > 1 else torch.ones_like(x[0]))
            self._update_normalization(p, r.y, 0.1, *stats)
            if t is not None:
                self._update_normalization(t, r.e, 1e-3, *stats)
            total = torch.zeros(2, device=r.y.device)
            for _ in range(cfg.updates_per_iteration):
                idx = torch.randint(0, r.n, (min(cfg.batch_size, r.n),), generator=self.gen, device=r.y.device)
                x, g = r.obs[idx].clone(), r.gait[idx].clone()
                heads = [(p, self.optimizer, r.y[idx].clone())]
                if t is not None:
                    heads.append((t, self.tracker_optimizer, r.e[idx].clone()))
                for k, (net, opt, y) in enumerate(heads):
                    pred = net.normalized(x).gather(1, g[:, None]).squeeze(1)
                    target = (y - net.target_mean[g]) / net.target_std[g]
                    loss = torch.mean((pred - target) ** 2)
                    opt.zero_grad()
                    loss.backward()
                    opt.step()
                    total[k] += loss.detach()
        losses = (total / cfg.updates_per_iteration).tolist()  # one device -> host copy per fit
        out = {"loss": losses[0]}
        if t is not None:
            out["tracking_loss"] = losses[1]
            self.tracker_fitted = True
        out.update(self.holdout_errors())
        self.last_losses = out
        return out

    @torch.no_grad()
    def holdout_errors(self) -> dict[str, float]:
        """Relative error per gait on held-out windows: mean |p_est - p| / mean p (never trained on)."""
        out = {}
        h = self.holdout
        n = h.n
        if n == 0:
            return out
        pred = self.predictor(h.obs[:n]).gather(1, h.gait[:n, None]).squeeze(1)
        track = None if self.tracker is None else self.tracker(h.obs[:n]).gather(1, h.gait[:n, None]).squeeze(1)
        for k, name in enumerate(self.gait_names):
            m = h.gait[:n] == k
            if m.any():
                y = h.y[:n][m]
                out[f"rel_error_{name}"] = float((pred[m] - y).abs().mean() / y.abs().mean().clamp(min=1e-6))
                if track is not None:  # absolute: the error itself is near 0 where a gait tracks
                    out[f"tracking_abs_error_{name}"] = float((track[m] - h.e[:n][m]).abs().mean())
                    out[f"tracking_error_{name}"] = float(h.e[:n][m].mean())
        return out

    def log_scalars(self) -> dict[str, float]:
        out = super().log_scalars()
        out["Gait/temperature"] = self.used_temperature
        for k, v in self.last_losses.items():
            out[f"Predictor/{k}"] = v
        offered, selections = self.candidates.tolist()
        if selections > 0:
            out["Gait/candidates_per_selection"] = offered / selections
        self.candidates.zero_()
        explored, made = self.explored.tolist()
        if self.cfg.explore_fraction > 0.0 and made > 0:
            out["Gait/explored_share"] = explored / made
        self.explored.zero_()
        out["Predictor/windows"] = float(self.windows)
        out["Predictor/windows_dropped"] = float(self.labeler.dropped)
        return out

    # --- checkpoints -------------------------------------------------------------------------------------------------
    def state_dict(self) -> dict:
        state = {
            "name": self.name,
            "predictor": self.predictor.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "iteration": self.iteration,
            "rng": self.gen.get_state(),
        }
        if self.tracker is not None:
            state.update(
                tracker=self.tracker.state_dict(),
                tracker_optimizer=self.tracker_optimizer.state_dict(),
                tracker_fitted=self.tracker_fitted,
            )
        return state

    def load_state_dict(self, state: dict) -> None:
        super().load_state_dict(state)
        self.predictor.load_state_dict(state["predictor"])
        if "optimizer" in state:
            self.optimizer.load_state_dict(state["optimizer"])
        self.iteration = int(state.get("iteration", 0))
        if "rng" in state:  # sampling and replay draws continue where the checkpoint left them
            self.gen.set_state(state["rng"].cpu())
        if self.tracker is not None and "tracker" in state:  # a power-criterion checkpoint has none: fitted afresh
            self.tracker.load_state_dict(state["tracker"])
            self.tracker_optimizer.load_state_dict(state["tracker_optimizer"])
            self.tracker_fitted = bool(state.get("tracker_fitted", True))


def lateral_reach(gait, lateral_limit: float) -> float:
    """The nominal lateral reach of ``gait`` [m/s]: the trunk speed at which the stance feet sweep the lateral
    feed-forward's full stroke 2 ``lateral_limit`` [m] in one stance phase of (1 - DF_swing) / f [s]; 0 for a gait
    without swing (``wqwarp.kernels.gait.lateral_stroke``)."""
    if gait.df_swing == 0.0 or gait.frequency == 0.0:
        return 0.0
    return 2.0 * lateral_limit * gait.frequency / (1.0 - gait.df_swing)


def reach_limits(library, lateral_limit: float) -> tuple[float, ...]:
    """The ``kinematic_reach`` mask's |v_y^cmd| bound per gait of ``library`` [m/s]: each stepping gait's
    :func:`lateral_reach`, inf for the widest-reaching one (always a candidate) and for the gaits without swing
    (``kinematic_lateral_limit`` bounds those)."""
    reach = [lateral_reach(g, lateral_limit) if g.df_swing > 0.0 else -1.0 for g in library]
    widest = max(range(len(reach)), key=reach.__getitem__)
    return tuple(math.inf if r < 0.0 or i == widest else r for i, r in enumerate(reach))


def make_gait_selector(
    cfg, requested: torch.Tensor | None, gait_names: tuple[str, ...], start_gait: int, policy_dt: float, obs_dim: int
) -> GaitSelector:
    """The selector of ``cfg.gait.selection`` (``cfg``: ``wqwarp.rl.config.EnvConfig``)."""
    sel = cfg.gait.selection
    if sel == "none":
        return GaitSelector()
    if sel == "fixed":
        return FixedGaitSelector(requested, gait_names, start_gait, policy_dt)
    if sel == "predictive":
        stepless = tuple(g.df_swing == 0.0 for g in cfg.gait.library)
        reach = None
        if cfg.predictor.kinematic_reach:
            if not cfg.predictor.kinematic_mask:
                raise ValueError(
                    "predictor.kinematic_reach needs a kinematic criterion (kinematic, kinematic_feasible)"
                )
            if cfg.gait.lateral_gain <= 0.0:
                raise ValueError("predictor.kinematic_reach needs gait.lateral_gain > 0 (the lateral feed-forward)")
            reach = reach_limits(cfg.gait.library, cfg.gait.lateral_limit)
        return PredictiveGaitSelector(
            requested, gait_names, start_gait, policy_dt, obs_dim, cfg.predictor, cfg.seed, stepless, reach
        )
    raise ValueError(f"unknown gait.selection {sel!r}; choose none, fixed or predictive")
