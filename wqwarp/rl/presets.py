"""The paper's five methods (Sec. IV) as presets of the config tree, and the registry that names them once.

    ours          predictive gait selection with nominal wheel velocities (the default of ``train/ppo_newton.py``)
    no_predictor  fixed augmented trotting gait with nominal wheel velocities ("Ours w/o predictive module")
    no_wheel_vel  predictive gait selection, no nominal wheel velocities
    pmtg          fixed trotting gait, wheel velocities from the policy only (no nominal wheel velocities)
    baseline      no nominal gait; actions are joint position offsets and wheel velocities; no residual penalty

Each preset is a factory of a fresh :class:`~wqwarp.rl.config.EnvConfig` (nothing shared is mutated) and one
:class:`Preset` entry in :data:`PRESETS`; the command lines, the report's labels and order, which reproduction
stages run and the check that a checkpoint was trained as a named preset all read the registry. Adding a preset:
one factory and one entry. No physics is imported here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from wqwarp.rl.config import ActionConfig, EnvConfig, GaitConfig, RewardConfig


def _ours() -> EnvConfig:
    cfg = EnvConfig()
    cfg.gait = GaitConfig(selection="predictive")
    return cfg


def _no_predictor() -> EnvConfig:
    cfg = EnvConfig()
    cfg.gait = GaitConfig(selection="fixed", fixed_gait="trotting")
    return cfg


def _no_wheel_vel() -> EnvConfig:
    cfg = EnvConfig()
    cfg.gait = GaitConfig(selection="predictive")
    cfg.action = ActionConfig(use_nominal_wheels=False)
    return cfg


def _pmtg() -> EnvConfig:
    cfg = EnvConfig()
    cfg.gait = GaitConfig(selection="fixed", fixed_gait="trotting")
    cfg.action = ActionConfig(use_nominal_wheels=False)
    return cfg


def _baseline() -> EnvConfig:
    cfg = EnvConfig()
    cfg.gait = GaitConfig(selection="none")
    cfg.action = ActionConfig(use_nominal_legs=False, use_nominal_wheels=False)
    cfg.reward = RewardConfig(residual=0.0)  # the paper omits the residual penalty for the baseline
    return cfg


IDENTITY_FIELDS: tuple[str, ...] = (
    "gait.selection",
    "gait.fixed_gait",
    "action.use_nominal_legs",
    "action.use_nominal_wheels",
)
"""The behaviour settings that tell the paper's methods apart (dotted paths in :class:`EnvConfig`): a checkpoint
whose values differ from a preset's was not trained as that preset."""


@dataclass(frozen=True)
class Preset:
    """One method of the paper."""

    name: str
    """Name on the command line (``--preset``) and in result file names."""
    make: Callable[[], EnvConfig]
    """Factory of a fresh config of this method."""
    paper_label: str
    """The method's name in the paper's tables (Table III's column)."""
    summary: str
    """One line for ``--help``."""
    selection_studies: bool = False
    """Reproduction also runs the sim-to-sim check and the gait-selection figures (Fig. 6 timeline, energy map)."""

    @property
    def selector(self) -> str:
        """The gait selector kind of this method (``GaitConfig.selection``: none, fixed or predictive)."""
        return self.make().gait.selection

    @property
    def predictive(self) -> bool:
        """True when the power predictor selects the gaits (the temperature schedule applies)."""
        return self.selector == "predictive"


PRESETS: dict[str, Preset] = {
    p.name: p
    for p in (
        Preset(
            "ours", _ours, "Ours", "predictive gait selection with nominal wheel velocities", selection_studies=True
        ),
        Preset("no_predictor", _no_predictor, "Ours w/o switching", "fixed augmented trotting gait"),
        Preset(
            "no_wheel_vel",
            _no_wheel_vel,
            "Ours w/o nominal wheel velocity",
            "predictive selection without nominal wheel velocities",
        ),
        Preset("pmtg", _pmtg, "PMTG", "trotting without nominal wheel velocities"),
        Preset("baseline", _baseline, "Baseline", "no nominal gait: joint offsets and wheel velocities"),
    )
}
"""Preset name -> :class:`Preset`, in report and training order (the paper's method first, so a partial reproduction
has the rows that matter most)."""
PRESET_ORDER: tuple[str, ...] = tuple(PRESETS)
"""Preset names in report and training order."""
PAPER_NAMES: dict[str, str] = {name: p.paper_label for name, p in PRESETS.items()}
"""Preset name -> the method's name in the paper's tables."""


def make_preset(name: str) -> EnvConfig:
    """A fresh config of preset ``name`` (ValueError naming the known presets otherwise)."""
    if name not in PRESETS:
        raise ValueError(f"unknown preset {name!r}; known presets: {', '.join(PRESETS)}")
    return PRESETS[name].make()


def preset_help() -> str:
    """``ours = ...; no_predictor = ...`` for a ``--preset`` help text."""
    return "; ".join(f"{p.name} = {p.summary}" for p in PRESETS.values())


def config_value(cfg: EnvConfig, path: str) -> object:
    """The field at dotted ``path`` of an env config (``gait.selection``)."""
    node: object = cfg
    for part in path.split("."):
        node = getattr(node, part)
    return node


def preset_differences(name: str, cfg: EnvConfig) -> list[str]:
    """Where ``cfg`` differs from preset ``name`` in :data:`IDENTITY_FIELDS`, as ``"path value (preset x: value)"``."""
    ref = make_preset(name)
    return [
        f"{k} {config_value(cfg, k)!r} (preset {name}: {config_value(ref, k)!r})"
        for k in IDENTITY_FIELDS
        if config_value(ref, k) != config_value(cfg, k)
    ]


def infer_preset(cfg: EnvConfig) -> str | None:
    """The method (preset name) a configuration was trained as, from :data:`IDENTITY_FIELDS`; None if none fits."""
    hits = [name for name in PRESETS if not preset_differences(name, cfg)]
    return hits[0] if len(hits) == 1 else None


def check_preset(name: str, cfg: EnvConfig, path: str) -> None:
    """ValueError unless the configuration of checkpoint ``path`` was trained as preset ``name``."""
    diff = preset_differences(name, cfg)
    if diff:
        raise ValueError(f"{path} was not trained as preset {name!r}: {', '.join(diff)}")
