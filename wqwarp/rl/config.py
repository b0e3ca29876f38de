"""One config tree for the residual-RL environment and training (the paper's methods are presets of it:
``wqwarp.rl.presets``).

Every field carries its unit and source, in the docstring under it (which is also its ``--help`` on the command
line through tyro, ``wqwarp.cli.train_args``). Code reads behaviour fields (``action.use_nominal_legs``,
``gait.selection``, ...), never a preset's name. Choices are ``Literal`` types, checked when set; each section checks
its numbers when built (``wqwarp.utils.checked_config``). No physics engine and no torch are imported here.
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass, field
from typing import Annotated, Literal

from typing_extensions import Doc

from wqwarp.control.gaits import TABLE_I, Gait, load_tuned_gait, with_gait
from wqwarp.rl.rewards import REWARD_TERMS, TERMS, RewardTerm  # noqa: F401  (REWARD_TERMS: re-exported)
from wqwarp.sim.config import SimConfig
from wqwarp.utils.checked_config import CheckedConfig, check_positive, check_ranges, require
from wqwarp.utils.migration import fill_missing, migrate, since_default

PowerMeasure = Literal["mechanical", "electrical"]
"""The power the energy-aware selection and the power reward read (:attr:`EnvConfig.power_measure`)."""
POWER_OUTPUT = {"mechanical": "p_cost", "electrical": "p_elec"}
"""The simulator's output each measure reads (``wqwarp.kernels.power``)."""
RewardPowerMeasure = Literal["same", "mechanical", "electrical"]
"""What the reward's power term reads (:attr:`RewardConfig.power_measure`): ``same`` follows
:attr:`EnvConfig.power_measure`."""

GaitSelection = Literal["none", "fixed", "predictive"]
"""How each robot's nominal gait is chosen (:attr:`GaitConfig.selection`)."""
PowerNormalization = Literal["mean", "watts"]
"""What the softmax temperature divides (:attr:`PredictorConfig.power_normalization`)."""
TemperatureShape = Literal["exponential", "linear", "cosine"]
"""Interpolation of tau between its ends (:attr:`PredictorConfig.temperature_shape`)."""
EvaluationSelection = Literal["argmin", "sample"]
"""Gait selection outside training (:attr:`PredictorConfig.evaluation_selection`)."""
SelectionCriterion = Literal["power", "feasible", "kinematic", "kinematic_feasible"]
"""What the predictive selector ranks (:attr:`PredictorConfig.criterion`)."""
SELECTION_CRITERIA: tuple[str, ...] = typing.get_args(SelectionCriterion)
LabelSource = Literal["policy", "mean"]
"""Which actions the predictor's labelled windows come from (:attr:`PredictorConfig.label_source`)."""
PhaseResidualMode = Literal["offset", "increment"]
"""How the phase residual enters the gait phase (:attr:`ActionConfig.phase_residual_mode`)."""
TEMPERATURE_SHAPES: tuple[str, ...] = typing.get_args(TemperatureShape)
Symmetry = Literal["none", "augmentation", "mirror_loss", "both"]
"""Use of the left-right mirror in PPO (:attr:`TrainConfig.symmetry`, rsl-rl's ``symmetry_cfg``)."""
LrSchedule = Literal["adaptive", "adaptive_update", "fixed"]
"""How PPO's learning rate moves (:attr:`TrainConfig.schedule`)."""


def _term_field(t: RewardTerm) -> tuple[str, object, dataclasses.Field]:
    """The weight field of reward term ``t``: its docstring as a PEP 727 ``Doc`` (the option's help on the command
    line), its migration for checkpoints written before the term existed."""
    meta = migrate(t.migration.value, t.migration.why) if t.migration else {}
    return t.name, Annotated[float, Doc(t.doc)], field(default=t.weight, metadata={**meta, "doc": t.doc})


RewardWeights = dataclasses.make_dataclass(
    "RewardWeights", [_term_field(t) for t in TERMS], namespace={"__module__": __name__}
)
RewardWeights.__doc__ = """One weight per term of the reward registry ``wqwarp.rl.rewards`` (the fields are derived
from it): the base of :class:`RewardConfig`."""


@dataclass
class RewardConfig(RewardWeights):
    """Weights of the paper's Table II (and of the terms beyond it, 0 by default), one field per term of the registry
    ``wqwarp.rl.rewards`` (:class:`RewardWeights`, derived from it), and the reward's other settings. Each term is
    multiplied by its weight and by the policy step dt (legged_gym convention), summed per step; a zero weight skips
    the term. Definitions in ``wqwarp.kernels.rewards``."""

    tracking_sigma: float = 4.0
    """The 4 in exp(-4 err^2) [1/(m/s)^2]."""
    only_positive: bool = field(
        default=False, metadata=migrate(False, "the plain sum, the only reward before the setting existed")
    )
    """Clip each step's summed reward at zero (legged_gym's only_positive_rewards, on by default there): the penalties
    cannot make a step worse than doing nothing rewarded. The paper does not say; off keeps the plain sum."""
    soft_joint_limit: float = field(
        default=0.9, metadata=since_default("the default; read only by the joint-limit term, off before it existed")
    )
    """Width of the soft joint range of the joint_limits term as a fraction of each leg joint's range, about its
    centre (legged_gym's soft_dof_pos_limit)."""
    ramp_terms: tuple[str, ...] = field(default=(), metadata=migrate([], "no reward ramp before the setting existed"))
    """Terms whose weights are annealed in during training (a curriculum beyond the paper, which does not say; e.g.
    p_cost, so that tracking is learned before the energy term counts): weight 0 before PPO iteration ramp_start,
    then linear to the full weight over ramp_iterations. Evaluation and a policy outside training see the full
    weights. Empty: no ramp."""
    ramp_start: int = field(default=0, metadata=since_default("its default (unused without ramp terms)"))
    """PPO iteration at which the ramp_terms start counting."""
    ramp_iterations: int = field(default=0, metadata=since_default("its default (unused without ramp terms)"))
    """PPO iterations from ramp_start to the full weight of the ramp_terms (0: a step at ramp_start)."""
    ramp_gate_vy_error: float = field(
        default=0.0, metadata=migrate(0.0, "the ramp started at ramp_start before the gate existed")
    )
    """Beyond the paper: with a value > 0 the ramp waits for the lateral skill. It starts at the first PPO iteration
    >= ramp_start at which the training's mean |v_y error| (Metrics/vy_error, every robot) over the last
    ramp_gate_window iterations is below this value [m/s] (0.15: the studies' skill threshold); the opening iteration
    is saved in the checkpoint. 0: the ramp starts at ramp_start. Under torchrun each rank gates on its own robots."""
    ramp_gate_window: int = field(default=100, metadata=since_default("its default (unused without the gate)"))
    """PPO iterations averaged by the ramp_gate_vy_error gate."""
    power_measure: RewardPowerMeasure = field(
        default="same", metadata=migrate("same", "the power term read env.power_measure before the setting existed")
    )
    """What the power term (``p_cost``) reads, apart from the selection (beyond the paper): ``same`` (default) the
    env's ``power_measure``, else ``mechanical`` (p_cost) or ``electrical`` (p_elec), e.g. gaits ranked by the
    paper's measure while the residual pays for its posture by the battery's."""

    def weights(self, terms: tuple[RewardTerm, ...] = TERMS) -> list[float]:
        """w_k of each of ``terms`` in order: the field of that name, or the term's default weight for a term defined
        outside the package (not a field)."""
        return [float(getattr(self, t.name, t.weight)) for t in terms]

    def ramp_scale(self, iteration: int, start: int | None = None) -> float:
        """Factor on the weights of ``ramp_terms`` at PPO ``iteration``: 0 before ``start`` (default ``ramp_start``;
        with ``ramp_gate_vy_error`` the iteration the gate opened), then (iteration - start) / ramp_iterations up to 1
        (a step to 1 at ``start`` when ramp_iterations is 0)."""
        done = int(iteration) - (self.ramp_start if start is None else int(start))
        if self.ramp_iterations <= 0:
            return 1.0 if done >= 0 else 0.0
        return min(1.0, max(0.0, done / self.ramp_iterations))


@dataclass
class CommandConfig(CheckedConfig):
    """Velocity commands (v_x, v_y, w_z) in the base frame, resampled during an episode."""

    vx_range: tuple[float, float] = (-1.5, 1.5)
    """[m/s] the authors' training range (xu-yang16/wheeled-quadruped-sim2sim,
    sim/policy_manager/policy_config/my_legged_robot_config.py lines 37-39: lin_vel_x [-1.5, 1.5]); it covers the
    paper's evaluation ranges v_x in [-1, 1] (tracking) and [-1, 1] (pushes, Table III)."""
    vy_range: tuple[float, float] = (-0.7, 0.7)
    """[m/s] authors' config: lin_vel_y [-0.7, 0.7]; the paper's tracking range. Table III's [-1, 1] lies outside."""
    wz_range: tuple[float, float] = (-1.0, 1.0)
    """[rad/s] authors' config: ang_vel_yaw [-1, 1]; covers the paper's [-0.7, 0.7] (tracking) and [-1, 1]
    (pushes)."""
    resampling_time: float = 10.0
    """Seconds between command resamples within an episode [s]."""
    single_axis_prob: float = 0.5
    """Probability that a sample has only one non-zero axis (the paper evaluates single-axis commands)."""
    zero_prob: float = 0.1
    """Probability of a zero command (standing still)."""
    single_axis_weights: tuple[float, float, float] = field(
        default=(1.0, 1.0, 1.0),
        metadata=migrate([1.0, 1.0, 1.0], "equal odds, the only sampler before the setting existed"),
    )
    """Relative odds that a single-axis sample keeps v_x, v_y or w_z (default: equal). (1, 2, 1) makes pure lateral
    commands a quarter of all samples at ``single_axis_prob`` 0.5 instead of a sixth."""

    def check(self) -> None:
        check_ranges(self, "vx_range", "vy_range", "wz_range")
        check_positive(self, "resampling_time")
        w = self.single_axis_weights
        require(
            len(w) == 3 and min(w) >= 0.0 and sum(w) > 0.0,
            "CommandConfig.single_axis_weights",
            f"needs three non-negative odds with a positive sum, got {w}",
        )
        for n in ("single_axis_prob", "zero_prob"):
            require(0.0 <= getattr(self, n) <= 1.0, f"CommandConfig.{n}", f"must be in [0, 1], got {getattr(self, n)}")


TABLE_I_BEFORE_LIBRARY_SETTING: tuple[dict, ...] = (
    {"name": "driving", "phase_offsets": [0.0, 0.0, 0.0, 0.0], "df_swing": 0.0, "frequency": 0.0, "stance_x": -0.05},
    {"name": "trotting", "phase_offsets": [0.0, 0.5, 0.5, 0.0], "df_swing": 0.4, "frequency": 1.2, "stance_x": 0.0},
    {"name": "walking", "phase_offsets": [0.0, 0.25, 0.5, 0.75], "df_swing": 0.225, "frequency": 0.8, "stance_x": 0.0},
)
"""The gait library of every configuration written before ``GaitConfig.library`` was a setting: the paper's Table I
as ``wqwarp.control.gaits.TABLE_I`` held it then, written out. It must never follow ``TABLE_I`` (an edit of the
default library does not change what those checkpoints were trained with)."""


@dataclass
class GaitConfig(CheckedConfig):
    """Nominal gait and its selection."""

    selection: GaitSelection = "fixed"
    """``fixed``: always ``fixed_gait``; ``none``: no nominal gait (baseline); ``predictive``: the power predictor
    picks each robot's gait by softmax sampling (``wqwarp.rl.gait_selection``)."""
    fixed_gait: str = "trotting"
    """Gait of ``library`` used when ``selection == 'fixed'`` (and at start-up with ``predictive``)."""
    body_height: float = 0.2
    """h_b: foot point (calf end) below the hip in stance [m] (authors' generator: body_height 0.2 m)."""
    swing_height: float = 0.1
    """h_s [m] (authors' generator: max_clearance 0.1 m)."""
    swing_x_amplitude: float = 0.05
    """Horizontal swing amplitude of the foot point [m] (authors' generator: max_horizontal_offset 0.05 m)."""
    lateral_gain: float = field(
        default=0.0, metadata=migrate(0.0, "no lateral feed-forward before the setting existed")
    )
    """Lateral feed-forward, NOT in the paper (0 = off, the paper's nominal gait): every stepping leg's nominal foot
    y gets a sawtooth locked to its phase, -A -> +A over swing and back over stance, with A = clip(lateral_gain x
    v_y command, +-lateral_limit) [s]; the stance legs push the body toward +A. The driving gait (no swing) gets
    none. ``wqwarp.kernels.gait.lateral_stroke``."""
    lateral_limit: float = field(default=0.12, metadata=since_default("its default (unused at gain 0)"))
    """|A| bound of the lateral feed-forward [m] (the nominal trot rolls over near 0.15 m open loop)."""
    library: tuple[Gait, ...] = field(
        default=TABLE_I,
        metadata=migrate(TABLE_I_BEFORE_LIBRARY_SETTING, "Table I, the only library before it was a setting"),
    )
    """The nominal gait library, index = gait id (default: the paper's Table I, ``wqwarp.control.gaits``). It sets
    the privileged one-hot size and the predictor's outputs, and is stored in checkpoints."""

    def __post_init__(self) -> None:
        self.library = tuple(g if isinstance(g, Gait) else Gait.from_dict(g) for g in self.library)  # from a dict
        super().__post_init__()

    def check(self) -> None:
        check_positive(self, "lateral_gain", "lateral_limit", strict=False)
        names = [g.name for g in self.library]
        require(
            bool(names) and len(set(names)) == len(names),
            "GaitConfig.library",
            f"needs at least one gait and unique names, got {names}",
        )
        require(
            self.fixed_gait in names,
            "GaitConfig.fixed_gait",
            f"{self.fixed_gait!r} is not in the library ({', '.join(names)})",
        )

    def with_tuned(self, path: str, name: str | None = None) -> GaitConfig:
        """A copy whose library holds the gait tuned on the differentiable path (``tools/optimize_gait.py`` JSON,
        ``wqwarp.control.gaits.load_tuned_gait``), replacing the library gait of its name or added as ``name``."""
        gait = load_tuned_gait(path, self.library, name)
        return dataclasses.replace(self, library=with_gait(self.library, gait))


@dataclass
class PredictorConfig(CheckedConfig):
    """Predictive gait selection (paper, "Predictive Energy-Aware Nominal Gait Selection"): an MLP predicts each
    gait's mean p_cost over the next ``horizon_s`` from o_t; gaits are sampled with probabilities softmax(-p/tau).
    The paper gives no values for the temperature, the network or its training; ours are stated here."""

    horizon_s: float = 1.0
    """Prediction horizon [s] (paper: 1 s, "roughly a single gait cycle"); 50 policy steps at 50 Hz."""
    decision_interval_s: float = 1.0
    """Time a robot runs its selected gait before the next selection [s], counted from when the gait took effect
    (a switch waits for the library's continuity rule). Equal to the horizon, so each selection yields one window."""
    power_normalization: PowerNormalization = field(
        default="mean", metadata=migrate("watts", "the literal formula, the only one before the setting existed")
    )
    """What tau divides: ``mean`` (default) p_est / mean over gaits of p_est, per robot, so tau is a fraction of
    the robot's mean predicted power; ``watts`` p_est itself, the paper's formula taken literally. The argmin, and
    so evaluation and export, is the same for both. Measured (docs/method.md): with ``watts`` and tau from
    100 W, p_cost falls from about 1200 W to 30 W during training, so any fixed tau is too cold early or too hot
    late; the run converged on driving for 98 % of robot-steps by iteration 130 (tau 54 W) and stopped exploring
    the legged gaits."""
    temperature_start: float = 2.0
    """tau at iteration 0 (with ``mean`` normalisation: gaits at 0.5x and 1.3x the mean power are picked with
    probabilities 0.47 and 0.31 against each other)."""
    temperature_end: float = 0.05
    """tau at the end of the annealing: a gait 10 % of the mean power dearer is picked e^-2 = 0.14 times as often."""
    temperature_iterations: int = 2000
    """PPO iterations over which tau goes from start to end; constant afterwards."""
    temperature_shape: TemperatureShape = "exponential"
    """``exponential`` (geometric), ``linear`` or ``cosine`` interpolation between the ends."""
    evaluation_selection: EvaluationSelection = "argmin"
    """Selection outside training (evaluation, playback, export): ``argmin`` (tau -> 0) or ``sample`` (tau at the
    checkpoint's schedule position)."""
    hidden_dims: tuple[int, ...] = (128, 64)
    learning_rate: float = 1e-3
    batch_size: int = 256
    updates_per_iteration: int = 8
    """Gradient steps on the replay buffer after each PPO update."""
    buffer_size: int = 20000
    """Replay buffer of the most recent labelled windows."""
    holdout_fraction: float = 0.1
    """Share of windows kept out of training to measure the relative error per gait."""
    criterion: SelectionCriterion = field(
        default="power",
        metadata=migrate("power", "the paper's power-only rule, the only one before the setting existed"),
    )
    """What the selection ranks: ``power`` (default, the paper's rule) softmax(-p_est / tau) over every gait;
    ``feasible`` (beyond the paper) the same softmax over the gaits predicted to track the command: a second MLP
    (the tracking head) predicts each gait's mean squared tracking error over the horizon, e = (v_x^cmd - v_x)^2 +
    (v_y^cmd - v_y)^2 + (w^cmd - w)^2, and a gait is a candidate when its e_est is within ``feasible_margin`` of the
    best gait's; ``kinematic`` (beyond the paper) the same softmax over the gaits whose nominal pattern can produce
    the command: a gait without swing (driving: wheels that roll along x) is no candidate for |v_y^cmd| above
    ``kinematic_lateral_limit``; ``kinematic_feasible`` (beyond the paper) both, in that order: the kinematic mask,
    then the ``feasible`` margin among the gaits it leaves (the best of those sets the margin), so that a lateral
    command goes to the cheapest *stepping* gait predicted to track it, not to the cheapest stepping gait.
    Measured (docs/studies/omnidirectional): with ``power`` a lateral command is cheapest standing still in the
    driving gait, so ``ours`` stops stepping sideways as tau anneals; with ``feasible`` the legged gaits, which
    cannot yet step sideways, track every command worse than driving early in training, so the head rules them out
    before they learn; with ``kinematic`` the power rule sends 80-86 % of the lateral commands to walking, the
    cheaper and slower sideways gait (docs/studies/residual_energy)."""
    feasible_margin: float = field(
        default=0.02, metadata=since_default("its default (unused with the power criterion)")
    )
    """Candidates of the ``feasible`` criterion: e_est <= min over gaits of e_est + this [(m/s)^2, (rad/s)^2 for w].
    0.02 is an RMS shortfall of 0.14 m/s: a lateral command of 0.15 m/s or more rules out a gait that stands."""
    kinematic_lateral_limit: float = field(
        default=0.1, metadata=since_default("its default (unused with the power criterion)")
    )
    """|v_y^cmd| [m/s] above which the ``kinematic`` criterion excludes the gaits without swing, in training and in
    evaluation alike (a property of the gait, not a learned estimate)."""
    kinematic_yaw_limit: float = field(
        default=10.0, metadata=migrate(10.0, "driving a candidate for every yaw command before the setting existed")
    )
    """|w^cmd| [rad/s] above which the ``kinematic`` criterion also excludes the gaits without swing (default 10:
    above every command, so driving stays a candidate for any turn). Not a kinematic impossibility: unsteerable
    wheels turn by skidding, and measured (docs/studies/omnidirectional), the policy learns to turn in the driving
    gait only with a posture (front feet crossed under the trunk) that also stops its lateral stepping."""
    feasible_penalty: float = field(
        default=2.0, metadata=since_default("its default (unused with the power criterion)")
    )
    """How the ``feasible`` criterion treats a gait that is not a candidate while training: its normalised p_est is
    raised by this (in units of the robot's mean p_est over the gaits) before the softmax, so its odds fall by
    e^(penalty / tau): by 2.7x at tau 2, e^40 at 0.05. The mask tightens as tau anneals and early exploration stays
    close to the paper's. A penalty below the spread of the normalised powers lets a cheap non-candidate win at low
    tau (driving at 0.23 of the mean against trotting at 1.28 needs more than 1.05); the number of gaits (3) is
    always enough. Measured (docs/studies/omnidirectional): a hard mask from the first iteration (penalty infinite)
    made the selection an argmin of the predicted error (1.0-1.1 candidates per selection) and sent 90-100 % of the
    lateral commands to driving by iteration 600. The argmin (evaluation) never picks a non-candidate."""

    kinematic_reach: bool = field(
        default=False, metadata=migrate(False, "no gait was kept off commands beyond its reach before the setting")
    )
    """Beyond the paper, with the ``kinematic`` criteria: also keep a lateral command off each stepping gait whose
    nominal pattern cannot reach it, |v_y^cmd| above r = 2 ``gait.lateral_limit`` f / (1 - DF_swing), the speed at
    which the stance foot sweeps the lateral feed-forward's full stroke (+-lateral_limit) in one stance phase
    (Table I at 0.12 m: trotting 0.48, walking 0.25 m/s). The stepping gait of the widest reach always stays a
    candidate. Measured open loop (docs/studies/skill_levers, every action 0): trotting reaches 0.38 m/s, walking
    0.22 m/s, at the 0.12 m stroke. A property of the gait, not a learned estimate; it needs ``gait.lateral_gain``
    > 0 (without the feed-forward the nominal gaits have no lateral stroke). On in the ``ours`` and ``no_wheel_vel``
    tasks: at 7.38 M samples v_y MSE 0.019-0.030 on four seeds against 0.035-0.110 without (the walking seeds' lateral
    commands go to trotting), at more power where the control walked sideways."""
    explore_fraction: float = field(
        default=0.0, metadata=migrate(0.0, "selections were never overridden by exploration before the setting")
    )
    """Beyond the paper: while training, this share of the selections (drawn per robot and selection) ignores the
    softmax and picks uniformly among the gaits the kinematic mask allows (every gait without it), so that each gait
    keeps practising the commands it can produce and the tracking head keeps labelled windows of each. Measured
    (docs/studies/skill_every_seed): with ``kinematic_feasible`` the head offers 1.0-1.2 candidates per selection, so
    the gait that first tracks lateral commands best gets all of them and stays best (trotting on seeds 1 and 2,
    walking on 3 and 4); at 0.25 both of those seeds track v_y below MSE 0.05 at 7.38 M samples (0.042 / 0.050
    against 0.065 / 0.090), but so did another perturbation of those runs (two PPO epochs: 0.034 / 0.068), and fresh
    seeds 5 / 6 with it miss the bound (0.067 / 0.091; docs/studies/skill_levers): not in any task until an A/B on
    unselected seeds shows it. Evaluation and export (argmin) never explore. 0 (default, the paper's): the
    criterion's softmax alone."""

    label_source: LabelSource = field(
        default="policy",
        metadata=migrate("policy", "every robot's sampled actions, the only labels before the setting existed"),
    )
    """Which robots' windows label the predictor: ``policy`` (default, the paper's) every robot's, acting with the
    training policy's sampled actions; ``mean`` (beyond the paper) only the ``label_fraction`` of robots that act
    with the policy's mean action (what evaluation and deployment run), whose transitions PPO then leaves out of
    the policy loss (advantage 0, return = value: the mean is not a sample of the distribution). Measured
    (docs/studies/omnidirectional): with ``policy`` the predictor overestimates the legged gaits 2-3x against
    evaluation (the exploration noise costs power in the leg joints) and predicts driving in every turning cell
    where walking is cheaper."""
    label_fraction: float = field(default=0.125, metadata=since_default("its default (unused with policy labels)"))
    """Share of robots that act with the mean action and label the predictor with ``label_source = mean`` (every
    round(1 / fraction)-th robot; at most 0.5: the others' samples train the policy)."""
    label_command_cut: bool = field(
        default=False, metadata=migrate(False, "windows were cut only by resets and gait switches before the setting")
    )
    """Beyond the paper: also drop a window in which the robot's command changes (a resample every
    ``commands.resampling_time``), as one cut by a reset or a gait switch is. The forecast at o_t is for o_t's
    command, and evaluation holds its commands; a window that straddles a resample labels o_t with part of another
    command's power (a standing robot's window that ends in a 1 m/s command costs it several watts). Off: the
    paper's windows."""

    @property
    def kinematic_mask(self) -> bool:
        """Whether the criterion keeps commands off the gaits whose nominal pattern cannot produce them."""
        return self.criterion in ("kinematic", "kinematic_feasible")

    @property
    def tracking_head(self) -> bool:
        """Whether the criterion needs the tracking head (each gait's predicted squared tracking error)."""
        return self.criterion in ("feasible", "kinematic_feasible")

    def check(self) -> None:
        require(
            0.0 < self.label_fraction <= 0.5,
            "PredictorConfig.label_fraction",
            f"must be in (0, 0.5] (the other robots train the policy), got {self.label_fraction}",
        )
        check_positive(
            self,
            "horizon_s",
            "decision_interval_s",
            "temperature_start",
            "temperature_end",
            "learning_rate",
            "batch_size",
            "buffer_size",
        )
        check_positive(
            self,
            "temperature_iterations",
            "updates_per_iteration",
            "feasible_margin",
            "feasible_penalty",
            "kinematic_lateral_limit",
            "kinematic_yaw_limit",
            strict=False,
        )
        require(
            0.0 <= self.explore_fraction < 1.0,
            "PredictorConfig.explore_fraction",
            f"must be in [0, 1), got {self.explore_fraction}",
        )
        require(
            0.0 <= self.holdout_fraction < 1.0,
            "PredictorConfig.holdout_fraction",
            f"must be in [0, 1), got {self.holdout_fraction}",
        )
        require(
            len(self.hidden_dims) > 0 and min(self.hidden_dims) >= 1,
            "PredictorConfig.hidden_dims",
            f"must be positive layer sizes, got {self.hidden_dims}",
        )


@dataclass
class ActionConfig(CheckedConfig):
    """How the policy's action maps to leg and wheel targets (authors' public harness scales)."""

    use_nominal_legs: bool = True
    """Legs: p_des = p_n + dp -> IK -> PD (False: baseline joint-offset actions around the default pose)."""
    use_nominal_wheels: bool = True
    """Wheels: v_des = v_n + dv (False: v_des = dv, as PMTG and 'w/o nominal wheel velocity')."""
    phase_residual_mode: PhaseResidualMode = field(
        default="offset", metadata=migrate("increment", "the only reading before the setting existed")
    )
    """How dphi enters the phase: ``offset`` (an offset from the gait clock, phi = (phi0 + f t + dphi) mod 1, as the
    authors' generator PMTG.py does; the default) or ``increment`` (added to the clock every policy step, a phase
    rate). Measured (docs/method.md): with ``increment`` the policy learns dphi = -f dt, which stops the
    gait clock; the legs stand still, the "fixed trot" becomes a driving gait (cheap: 7.6 W standing) and lateral
    motion becomes impossible. ``offset`` keeps the gait the preset names."""
    phase_scale: float = 0.2
    """Phase residual per unit action [cycles] (harness x0.2)."""
    phase_clip: float = 0.2
    """|dphi| bound [cycles]."""
    foot_scale: float = 0.2
    """Foot-point residual per unit action [m] (harness x0.2)."""
    foot_clip: float = 0.3
    """|dp| bound per axis [m] (harness clip 0.3)."""
    wheel_scale: float = 5.0
    """Wheel-speed residual per unit action [rad/s] (harness x5)."""
    wheel_clip: float = 40.0
    """|v_des| bound [rad/s] (harness clip 40; AK80-6 top speed 38.2)."""
    joint_scale: float = 0.25
    """Baseline only: joint offset per unit action [rad] (legged_gym Go1 action_scale 0.25)."""
    clip_actions: float = 10.0
    """Raw actions are clipped to +-this before scaling."""

    def check(self) -> None:
        check_positive(self, "phase_clip", "foot_clip", "wheel_clip", "clip_actions")


@dataclass
class ObservationConfig(CheckedConfig):
    """Observation scales and noise (legged_gym-style; the terms that read them: ``wqwarp.rl.observations``)."""

    lin_vel_scale: float = 2.0
    """Scale of linear velocities: the v_x, v_y commands, the estimate z_t and the critic's true velocity [s/m]."""
    ang_vel_scale: float = 0.25
    """Scale of angular velocities: the base angular velocity and the w_z command [s/rad]."""
    joint_vel_scale: float = 0.05
    """Scale of the 16 joint velocities [s/rad]."""
    wheel_speed_scale: float = 0.05
    """Scale of nominal wheel velocities in p_t [s/rad]."""
    noise: bool = True
    """Add uniform noise to the sensor part of the actor observation."""
    noise_ang_vel: float = 0.2
    """Noise amplitude of the base angular velocity [rad/s]."""
    noise_gravity: float = 0.05
    """Noise amplitude of the projected gravity [-]."""
    noise_joint_pos: float = 0.01
    """Noise amplitude of the leg joint positions [rad]."""
    noise_joint_vel: float = 1.5
    """Noise amplitude of the joint velocities [rad/s]."""
    history_length: int = 6
    """H, the estimator's observation history (paper: H = 6)."""

    def check(self) -> None:
        check_positive(self, "history_length")
        check_positive(self, "noise_ang_vel", "noise_gravity", "noise_joint_pos", "noise_joint_vel", strict=False)


@dataclass
class EstimatorConfig(CheckedConfig):
    """MLP state estimator z_t = (v_x, v_y, h) from the last H proprioceptive observations."""

    hidden_dims: tuple[int, ...] = (128, 64)
    learning_rate: float = 1e-3
    epochs: int = 2
    """Passes over each iteration's samples."""
    batch_size: int = 512
    use_true_state: bool = False
    """Debug switch: feed the true (v_x, v_y, h) to the policy instead of the estimate."""

    def check(self) -> None:
        check_positive(self, "learning_rate", "epochs", "batch_size")


@dataclass
class DomainRandConfig(CheckedConfig):
    """Randomised per robot at start-up (friction, restitution, mass) and pushes during episodes."""

    friction_range: tuple[float, float] = (0.5, 1.25)
    """Sliding friction coefficient [-] of all contacts."""
    restitution_range: tuple[float, float] = (0.0, 0.4)
    """Coefficient of restitution [-], mapped to MuJoCo's contact damping ratio (MuJoCo has no restitution)."""
    added_mass_range: tuple[float, float] = (-1.0, 2.0)
    """Mass added to the trunk [kg]."""
    motor_strength_range: tuple[float, float] = (0.9, 1.1)
    """Torque scale of every motor [-]."""
    push_interval: float = 15.0
    """Seconds between random pushes [s] (paper: every 15 s); <= 0 disables pushes."""
    push_max_vel: float = 0.5
    """Largest velocity impulse along x and along y [m/s] (paper evaluates 0.5 and 0.7)."""
    enabled: bool = True
    nominal_friction: float = field(
        default=1.0, metadata=migrate(1.0, "the friction without randomisation before the setting existed")
    )
    """Sliding friction of every contact when ``enabled`` is off (evaluation) [-]; the authors' MuJoCo model uses
    0.6 (``constants.AUTHORS_GROUND_FRICTION``)."""

    def check(self) -> None:
        check_ranges(self, "friction_range", "restitution_range", "added_mass_range", "motor_strength_range")
        check_positive(self, "push_max_vel", "nominal_friction", strict=False)


@dataclass
class EnvConfig(CheckedConfig):
    """The residual-RL environment."""

    sim: SimConfig = field(default_factory=SimConfig)
    episode_length_s: float = 20.0
    """Episode length [s] (paper: 20 s)."""
    reward: RewardConfig = field(default_factory=RewardConfig)
    commands: CommandConfig = field(default_factory=CommandConfig)
    gait: GaitConfig = field(default_factory=GaitConfig)
    action: ActionConfig = field(default_factory=ActionConfig)
    obs: ObservationConfig = field(default_factory=ObservationConfig)
    estimator: EstimatorConfig = field(default_factory=EstimatorConfig)
    predictor: PredictorConfig = field(default_factory=PredictorConfig)
    domain_rand: DomainRandConfig = field(default_factory=DomainRandConfig)
    power_measure: PowerMeasure = field(
        default="mechanical", metadata=migrate("mechanical", "the paper's p_cost, the only measure before the setting")
    )
    """What the energy-aware parts read (beyond the paper): ``mechanical`` (default, the paper's p_cost = sum |tau|
    |qd|) or ``electrical`` (``p_elec``, what the battery pays under the motor model of ``wqwarp.robot.motors``).
    It sets the power predictor's labels, so the selection ranks the gaits by that measure, and the reward's power
    term (``reward.p_cost``, weight 0 in every task) unless ``reward.power_measure`` names another. Both measures
    are reported whatever is chosen."""

    seed: int = 1
    """Seed of the env's random streams (spawn yaws, commands, pushes, sampled gaits); offset by the rank under
    torchrun."""

    @property
    def reward_power_output(self) -> str:
        """The simulator output the reward's power term reads (``p_cost`` or ``p_elec``)."""
        measure = self.power_measure if self.reward.power_measure == "same" else self.reward.power_measure
        return POWER_OUTPUT[measure]

    def check(self) -> None:
        check_positive(self, "episode_length_s")
        f = self.reward.soft_joint_limit
        require(0.0 < f <= 1.0, "RewardConfig.soft_joint_limit", f"must be in (0, 1], got {f}")
        check_positive(self.reward, "ramp_start", "ramp_iterations", "ramp_gate_vy_error", strict=False)
        check_positive(self.reward, "ramp_gate_window")
        require(
            self.gait.selection != "none" or not self.action.use_nominal_legs,
            "ActionConfig.use_nominal_legs",
            "needs a nominal gait (gait.selection != 'none')",
        )


@dataclass
class TrainConfig(CheckedConfig):
    """rsl-rl PPO settings (legged_gym defaults unless noted)."""

    num_steps_per_env: int = 24
    max_iterations: int = 4000
    """PPO iterations (paper: 4000 epochs)."""
    save_interval: int = 50
    """Iterations between checkpoints."""
    actor_hidden_dims: tuple[int, ...] = (256, 128, 64)
    critic_hidden_dims: tuple[int, ...] = (256, 128, 64)
    init_noise_std: float = 0.5
    """Initial action standard deviation of the Gaussian policy (legged_gym: 1.0)."""
    init_noise_std_groups: tuple[float, ...] = ()
    """Per-group initial std overriding ``init_noise_std`` (empty: one std for all): (phase, foot, wheel) for the 20
    residual actions, (joints, wheels) for the baseline's 16; ``wqwarp.rl.algorithm.action_groups``."""
    symmetry: Symmetry = "none"
    """Left-right symmetry through rsl-rl's ``symmetry_cfg`` (``wqwarp.rl.observations.data_augmentation``, the
    mirror derived from the observation and action registries): ``augmentation`` adds every minibatch's mirror to
    PPO's losses, ``mirror_loss`` adds ``mirror_loss_coeff`` x ||pi(mirror o) - mirror pi(o)||^2, ``both`` does both,
    ``none`` neither."""
    mirror_loss_coeff: float = 1.0
    """Weight of the mirror loss (``symmetry`` ``mirror_loss`` or ``both``)."""
    learning_rate: float = 1e-3
    num_learning_epochs: int = 5
    num_mini_batches: int = 4
    entropy_coef: float = 0.005
    gamma: float = 0.99
    lam: float = 0.95
    desired_kl: float = 0.01
    schedule: LrSchedule = field(
        default="adaptive", metadata=migrate("adaptive", "rsl-rl's per-minibatch rule, the only one before the setting")
    )
    """How the learning rate follows ``desired_kl``. ``adaptive`` (rsl-rl's, legged_gym's): before every minibatch's
    step, the KL of the policy so far in this update against the one that collected the rollout; above 2x the target
    the rate is divided by 1.5, below half multiplied by 1.5. The KL accumulates over an update's steps, so the rate
    climbs from its floor during the first minibatches and falls back to it by the last, and the rate logged (the
    last one) sits at 1e-5 (docs/studies/fast_skill). ``adaptive_update``: the same rule once per update, on the KL
    of the policy that collects the next rollout against the one that collected this one, over the whole rollout;
    every step of an update runs at one rate. ``fixed``: ``learning_rate`` throughout."""
    clip_param: float = 0.2
    algorithm_class: str = "wqwarp.rl.algorithm:WqPPO"
    """The PPO class rsl-rl's runner builds (``"module:Class"``, importable): :class:`wqwarp.rl.algorithm.WqPPO` or a
    subclass, e.g. ``wqwarp.rl.algorithm:KeptMeanActorsPPO``, the control of ``--env.predictor.label-source mean``.
    :meth:`check` reads only the format; ``wqwarp.rl.algorithm.resolve_algorithm_class`` imports and checks the
    class (the config imports no torch)."""

    def check(self) -> None:
        module, sep, attr = self.algorithm_class.partition(":")
        require(
            bool(sep and module and attr),
            "TrainConfig.algorithm_class",
            f"must be 'module:Class', got {self.algorithm_class!r}",
        )
        check_positive(
            self,
            "num_steps_per_env",
            "max_iterations",
            "save_interval",
            "num_learning_epochs",
            "num_mini_batches",
            "learning_rate",
            "init_noise_std",
        )
        check_positive(self, "mirror_loss_coeff", strict=False)
        g = self.init_noise_std_groups
        require(
            len(g) in (0, 2, 3) and all(x > 0 for x in g),
            "TrainConfig.init_noise_std_groups",
            f"needs 3 positive values (phase, foot, wheel) or 2 (joints, wheels), got {g}",
        )

    def symmetry_cfg(self) -> dict | None:
        """rsl-rl's ``symmetry_cfg`` for :attr:`symmetry` (None when off)."""
        if self.symmetry == "none":
            return None
        return {
            "use_data_augmentation": self.symmetry in ("augmentation", "both"),
            "use_mirror_loss": self.symmetry in ("mirror_loss", "both"),
            "mirror_loss_coeff": self.mirror_loss_coeff,
            "data_augmentation_func": "wqwarp.rl.observations:data_augmentation",
        }

    def rsl_rl_dict(self) -> dict:
        """The runner configuration rsl-rl 5.5.1 expects (asymmetric critic through ``obs_groups``)."""
        dist = {"class_name": "GaussianDistribution", "init_std": self.init_noise_std, "std_type": "scalar"}
        return {
            "num_steps_per_env": self.num_steps_per_env,
            "save_interval": self.save_interval,
            "obs_groups": {"actor": ["policy"], "critic": ["policy", "privileged"]},
            "actor": {
                "class_name": "MLPModel",
                "hidden_dims": list(self.actor_hidden_dims),
                "activation": "elu",
                "obs_normalization": True,
                "distribution_cfg": dist,
            },
            "critic": {
                "class_name": "MLPModel",
                "hidden_dims": list(self.critic_hidden_dims),
                "activation": "elu",
                "obs_normalization": True,
            },
            "algorithm": {
                "class_name": self.algorithm_class,
                "learning_rate": self.learning_rate,
                "num_learning_epochs": self.num_learning_epochs,
                "num_mini_batches": self.num_mini_batches,
                "clip_param": self.clip_param,
                "gamma": self.gamma,
                "lam": self.lam,
                "entropy_coef": self.entropy_coef,
                "desired_kl": self.desired_kl,
                "schedule": "adaptive" if self.schedule == "adaptive" else "fixed",
                "kl_per_update": self.schedule == "adaptive_update",
                "value_loss_coef": 1.0,
                "max_grad_norm": 1.0,
                "use_clipped_value_loss": True,
                "symmetry_cfg": self.symmetry_cfg(),
                "init_std_groups": list(self.init_noise_std_groups) or None,
            },
            "logger": "tensorboard",
            "check_for_nan": True,
        }


def to_dict(cfg) -> dict:
    """A plain, JSON-serialisable dict of a config (for logs and checkpoints); :func:`from_dict` reads it back."""
    return dataclasses.asdict(cfg)


_MISSING_HINT = (
    " A setting added after configurations were written declares how they behave without it on its own field: "
    "metadata=migrate(value, why) or since_default(why) (wqwarp.utils.migration)."
)


def from_dict(cls, data, where: str = "", migrated: list[str] | None = None):
    """The config dataclass ``cls`` from the dict :func:`to_dict` wrote (nested configs recursively, lists back to
    tuples). A key that ``cls`` does not have, or a field the dict lacks, is a ValueError naming it and its path:
    a configuration is read whole or not at all, never completed with today's defaults. With a ``migrated`` list, a
    missing field that declares how the code behaved before it (``wqwarp.utils.migration``, its field metadata) is
    filled with that, and each fill appended to ``migrated`` as ``"path = value (why)"``."""
    import typing

    where = where or cls.__name__
    if not isinstance(data, dict):
        raise ValueError(f"config {where}: expected a mapping, got {type(data).__name__}")
    if migrated is not None:
        data = fill_missing(cls, data, where.partition(".")[2], migrated)
    names = [f.name for f in dataclasses.fields(cls)]
    unknown = sorted(set(data) - set(names))
    missing = [n for n in names if n not in data]
    if unknown or missing:
        parts = ([f"unknown keys {unknown}"] if unknown else []) + ([f"missing keys {missing}"] if missing else [])
        hint = _MISSING_HINT if missing else ""
        raise ValueError(f"config {where}: {'; '.join(parts)} (written by another version of wqwarp?){hint}")
    hints = typing.get_type_hints(cls)
    kw = {}
    for n in names:
        t, v = hints[n], data[n]
        if dataclasses.is_dataclass(t):
            kw[n] = from_dict(t, v, f"{where}.{n}", migrated)
        elif typing.get_origin(t) is tuple and isinstance(v, list | tuple):
            kw[n] = tuple(v)
        else:
            kw[n] = v
    return cls(**kw)


def env_config_from_dict(data: dict, migrated: list[str] | None = None) -> EnvConfig:
    """:class:`EnvConfig` from a checkpoint's ``infos['env_cfg']`` or ``config.json``'s ``env``.

    A setting added after the checkpoint was written is filled with the behaviour of the code that wrote it, as its
    field declares (``wqwarp.utils.migration``; :func:`wqwarp.utils.migration.migrations` lists them); a checkpoint
    of a non-predictive preset written before the predictor existed gets the (never read) predictor defaults. Each
    fill is appended to ``migrated`` as ``"path = value (why)"``. Any other missing setting is a ValueError naming
    it."""
    import copy

    data = copy.deepcopy(data)
    notes = migrated if migrated is not None else []
    if "predictor" not in data and data.get("gait", {}).get("selection") != "predictive":
        data["predictor"] = dataclasses.asdict(PredictorConfig())
        notes.append("predictor = defaults (this preset never reads them; written before the predictor existed)")
    return from_dict(EnvConfig, data, migrated=notes)
