"""Lever profiles: the settings beyond the paper that a method is trained with, named once and applied on top of
its preset (``train/ppo_newton.py --profile``, ``train/reproduce.py --profile``).

    omni   the levers that made the default main job track v_x, v_y and w within 15 M samples on this laptop (issue 21,
           docs/studies/omnidirectional/README.md): the lateral feed-forward, the kinematic gait criterion with
           mean-action labels, and a lower initial foot std. The training command's default.
    energy omni plus the levers of issue 22 (docs/studies/residual_energy/README.md): the paper's p_cost as a reward
           term at a weight that matters (-0.01 per W), held at 0 until the lateral skill is learned and ramped in
           over iterations 2000-3000, and P-only wheels (the authors' harness's law: no integral winding the wheels
           up against each other). The same levers for every method, so the methods stay comparable. An option:
           on three seeds of ours the v_x headline holds (0.28-0.46x the equally trained trot's power) but v_y is
           tracked 2-3x worse than under omni (MSE 0.07-0.11 against 0.040).
    wheels omni plus only the P-only wheels of ``energy`` (no p_cost term): on two seeds each, ``ours`` spends 27-34 %
           less than the fixed trot trained alike over the three tasks (v_x 0.27x its power at 0.08x its MSE), its
           predictor is within 20 % on all four tasks, and it tracks v_y 1.5-2x better than under ``energy`` (MSE
           0.049 / 0.070), though 5-7x worse than that trot (0.009 / 0.011). docs/studies/residual_energy/README.md.
    select wheels with selection among the gaits predicted to track (criterion ``kinematic_feasible``: the kinematic
           mask, then the tracking head's margin) and predictor windows cut at command changes (labels of held
           commands, as evaluation holds them). On two seeds ``ours`` tracks v_y at 1.1 / 1.8x the fixed trot's
           MSE (``wheels``: 5-7x), in legged gaits 86 % of the task, drives standing and v_x 96-99 % (v_x 0.37 /
           0.29x the trot's power), and spends 25 / 10 % less than that trot over the three moving tasks
           (``wheels``: 34 / 27 %). docs/studies/feasible_selection/README.md. The cpu reproduction runs under it
           (docs/RESULTS.md: v_x 0.44x the trot's power at 0.27x its MSE, v_y MSE 0.0078 against its 0.0096, 12 %
           less over the three moving tasks; seed 1).
    paper  none: the paper's method as written (the presets alone).

A profile is a list of :class:`Lever` (a dotted config path, its value, and which methods it applies to: a lever
that a method cannot use, e.g. the gait's lateral feed-forward for the baseline without a nominal gait, is not set,
so the method's config keeps the paper's value). The presets (``wqwarp.rl.presets``) stay the paper's methods; the
checkpoint stores the resolved config, so evaluation needs no profile. No physics is imported here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from wqwarp.rl.config import EnvConfig


def _nominal_legs(cfg: EnvConfig) -> bool:
    return cfg.action.use_nominal_legs


def _predictive(cfg: EnvConfig) -> bool:
    return cfg.gait.selection == "predictive"


def _every(cfg: EnvConfig) -> bool:
    return True


@dataclass(frozen=True)
class Lever:
    """One setting of a profile."""

    path: str
    """Dotted path in the run's config roots (``env.gait.lateral_gain``, ``train.init_noise_std_groups``)."""
    value: object
    applies: Callable[[EnvConfig], bool]
    """Whether the method (its preset's config) can use this setting."""
    why: str
    """Where its value was measured (one line for the reader; docs/training.md and the study have the tables)."""


@dataclass(frozen=True)
class Profile:
    name: str
    summary: str
    levers: tuple[Lever, ...] = ()

    def overrides(self, env: EnvConfig) -> dict[str, object]:
        """Dotted path -> value of the levers that apply to the method of ``env`` (its preset's config); of two
        levers on one path, the later wins (``select`` replaces omni's criterion)."""
        return {lever.path: lever.value for lever in self.levers if lever.applies(env)}


OMNI_LEVERS: tuple[Lever, ...] = (
    Lever("env.gait.lateral_gain", 0.35, _nominal_legs,
          "lateral foot-y stroke A = 0.35 s x v_y command (clip 0.12 m): v_y MSE 0.168 -> 0.062 (fixed trot, 12.3 M)"),
    Lever("env.predictor.criterion", "kinematic", _predictive,
          "gaits without swing are no candidates for lateral commands: the predictor stops picking driving for v_y"),
    Lever("env.predictor.label_source", "mean", _predictive,
          "labels from robots acting with the mean action: forecasts 0.8-1.2x the realised p_cost (paper's: 1.9-2.8x)"),
    Lever("env.predictor.label_fraction", 0.03125, _predictive,
          "4 of 128 robots label (1/8: both seeds took the noise-escape posture, v_y lost)"),
    Lever("env.predictor.kinematic_yaw_limit", 0.2, _predictive,
          "driving is no candidate for |w| > 0.2 rad/s: w tracked on both seeds, in legged gaits"),
    Lever("train.init_noise_std_groups", (0.5, 0.25, 0.5), _nominal_legs,
          "initial foot std 0.25 (phase, wheels 0.5): 0 of 6 runs took the noise-escape posture, 2 of 4 without"),
)  # fmt: skip
"""The levers of ``omni``, measured in docs/studies/omnidirectional/README.md (two seeds at 15 M samples: MSE v_x
0.0014 / 0.0004, v_y 0.0405 / 0.0402, w 0.0249 / 0.0206, all upright)."""

P_ONLY_WHEELS = Lever("env.sim.wheel_ki", 0.0, _every,
                      "P-only wheels: the wheel integrals wound up against each other (front push, rear brake); -59 "
                      "to -65 % power on v_x, two seeds")  # fmt: skip
"""The wheel law of the authors' harness, the lever of ``wheels`` and one of ``energy``."""

WHEELS_LEVERS: tuple[Lever, ...] = (*OMNI_LEVERS, P_ONLY_WHEELS)
"""The levers of ``wheels``, on which ``select`` builds."""

ENERGY_LEVERS: tuple[Lever, ...] = (
    Lever("env.reward.p_cost", -0.01, _every,
          "-0.01 per W of sum |tau qd|: 22-48 % less power per task than omni alone (two seeds, 15 M); Table II's "
          "energy term is ~0.2 % of the tracking rewards"),
    P_ONLY_WHEELS,
    Lever("env.reward.ramp_terms", ("p_cost",), _every,
          "p_cost counts only after the lateral skill is learned (with it from iteration 0 stepping is a coin toss)"),
    Lever("env.reward.ramp_start", 2000, _every,
          "without the term the windowed v_y error goes below 0.15 at iterations 1413-2081 (four runs)"),
    Lever("env.reward.ramp_iterations", 1000, _every, "linear to the full weight at iteration 3000 of 4883"),
)  # fmt: skip
"""The levers ``energy`` adds to ``omni`` (docs/studies/residual_energy/README.md, the ramp sections)."""

SELECT_LEVERS: tuple[Lever, ...] = (
    Lever("env.predictor.criterion", "kinematic_feasible", _predictive,
          "among the gaits the kinematic mask leaves, those predicted to track: v_y MSE 0.020 / 0.012 against "
          "0.049 / 0.070 with the kinematic rule (two seeds, 15 M)"),
    Lever("env.predictor.label_command_cut", True, _predictive,
          "windows that straddle a command resample are dropped: the tracking head's argmin is the best tracker in "
          "49 / 46 of 50 energy-map cells (uncut 40 / 21); standing and v_x driven 96-99 % (uncut 15-97 %)"),
)  # fmt: skip
"""The levers ``select`` puts over ``wheels`` (docs/studies/feasible_selection/README.md; the criterion replaces
omni's ``kinematic``)."""

PROFILES: dict[str, Profile] = {p.name: p for p in (
    Profile("omni", "the levers that met the omnidirectional target at 15 M samples (lateral feed-forward, kinematic "
            "gait criterion with mean-action labels, foot std 0.25)", OMNI_LEVERS),
    Profile("wheels", "omni plus P-only wheels (no p_cost term): the energy profile's wheel law alone, which tracks "
            "v_y 1.5-2x better than energy and still spends 27-34 % less than the fixed trot trained alike",
            WHEELS_LEVERS),
    Profile("select", "wheels with selection among the gaits predicted to track (kinematic_feasible) and predictor "
            "windows cut at command changes: legged v_y at 1.1-1.8x the fixed trot's MSE, driving for v_x",
            WHEELS_LEVERS + SELECT_LEVERS),
    Profile("energy", "omni plus p_cost at -0.01 per W ramped in over iterations 2000-3000 and P-only wheels (the "
            "energy levers of issue 22)", OMNI_LEVERS + ENERGY_LEVERS),
    Profile("paper", "the paper's method as written: no lever beyond the preset"),
)}  # fmt: skip
"""Profile name -> :class:`Profile`."""
DEFAULT_PROFILE = "omni"
"""The training command's profile: the one whose default main job met issue 21's target."""


def profile_help() -> str:
    """``omni = ...; paper = ...`` for a ``--profile`` help text (argparse formats help with ``%``: escaped)."""
    return "; ".join(f"{p.name} = {p.summary}" for p in PROFILES.values()).replace("%", "%%")


def profile_overrides(name: str, env: EnvConfig) -> dict[str, object]:
    """The overrides of profile ``name`` for the method of ``env`` (ValueError naming the known profiles)."""
    if name not in PROFILES:
        raise ValueError(f"unknown profile {name!r}; known profiles: {', '.join(PROFILES)}")
    return PROFILES[name].overrides(env)


def lever_differences(saved_env: dict, env: EnvConfig) -> list[str]:
    """``"path saved (here: value)"`` for each env lever of any profile where a checkpoint's config (its
    ``infos['env_cfg']``, filled by the migrations) and ``env`` differ: a resumed run must keep its levers. Empty when
    the checkpoint is another method (``wqwarp.rl.presets.IDENTITY_FIELDS`` differ): the runner's checks report that."""
    from wqwarp.rl.config import env_config_from_dict
    from wqwarp.rl.presets import IDENTITY_FIELDS, config_value

    saved = env_config_from_dict(saved_env)
    if any(config_value(saved, f) != config_value(env, f) for f in IDENTITY_FIELDS):
        return []
    paths = dict.fromkeys(lv.path.removeprefix("env.") for p in PROFILES.values() for lv in p.levers
                          if lv.path.startswith("env."))  # fmt: skip
    return [f"env.{path} {config_value(saved, path)!r} (here: {config_value(env, path)!r})" for path in paths
            if config_value(saved, path) != config_value(env, path)]  # fmt: skip
