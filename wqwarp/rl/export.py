"""Export of what the robot runs at 50 Hz: observation history -> estimator z_t -> o_t -> actor (and the power
predictor with its argmin rule, for predictive gait selection).

:func:`export_onboard_policy` writes ``policy.onnx`` (ONNX opset 18, any batch size; checked against onnxruntime in
``tests/test_export_verified.py``), ``policy.pt2`` (``torch.export``: ``torch.export.load(path).module()``) and
``policy.json`` (layout, scales, joint order, the gait selection rule), every file atomically.
"""

from __future__ import annotations

import contextlib
import copy
import json
import logging
import os
import warnings
from collections.abc import Iterator
from typing import TYPE_CHECKING

import torch
from torch import nn

from wqwarp import __version__
from wqwarp.rl.config import to_dict
from wqwarp.robot.constants import ACTUATED_JOINT_NAMES
from wqwarp.utils.io import atomic_path, write_text_atomic

if TYPE_CHECKING:
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner


class OnboardPolicy(nn.Module):
    """Everything the robot runs at 50 Hz: proprioceptive history (B, H, D) -> estimator z_t -> o_t -> actor.

    The newest history row is o_t without z_t (``WheeledGo1Env.obs_layout`` minus ``estimate``), unnormalised and
    scaled exactly as in training; z_t, scaled by ``z_scale``, is inserted at column ``split``.
    """

    def __init__(self, actor: nn.Module, estimator: nn.Module, split: int, z_scale: torch.Tensor):
        super().__init__()
        self.actor = actor
        self.estimator = estimator
        self.split = split
        self.register_buffer("z_scale", z_scale)

    def observation(self, history: torch.Tensor) -> torch.Tensor:
        """o_t (B, D + 3) from the history: the newest row with z_t inserted."""
        z = self.estimator(history.reshape(history.shape[0], -1)) * self.z_scale
        latest = history[:, -1]
        return torch.cat([latest[:, : self.split], z, latest[:, self.split :]], dim=1)

    def forward(self, history: torch.Tensor) -> torch.Tensor:
        return self.actor(self.observation(history))


class OnboardPolicyWithPredictor(OnboardPolicy):
    """:class:`OnboardPolicy` plus the power predictor: history -> (actions (B, A), predicted p_cost per gait (B, G)
    [W]). The robot selects argmin over the predicted powers once per decision interval (see ``policy.json``)."""

    def __init__(self, actor: nn.Module, estimator: nn.Module, split: int, z_scale: torch.Tensor, predictor: nn.Module):
        super().__init__(actor, estimator, split, z_scale)
        self.predictor = predictor

    def forward(self, history: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:  # type: ignore[override]
        obs = self.observation(history)
        return self.actor(obs), self.predictor(obs)


class OnboardPolicyWithFeasibility(OnboardPolicyWithPredictor):
    """:class:`OnboardPolicyWithPredictor` plus the tracking head (``feasible`` criterion): history -> (actions,
    predicted power (B, G) [W], predicted mean squared tracking error (B, G))."""

    def __init__(
        self,
        actor: nn.Module,
        estimator: nn.Module,
        split: int,
        z_scale: torch.Tensor,
        predictor: nn.Module,
        tracker: nn.Module,
    ):
        super().__init__(actor, estimator, split, z_scale, predictor)
        self.tracker = tracker

    def forward(self, history: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:  # type: ignore[override]
        obs = self.observation(history)
        return self.actor(obs), self.predictor(obs), self.tracker(obs)


def onboard_module(runner: WqRunner) -> tuple[OnboardPolicy, list[str]]:
    """The onboard module on the CPU in eval mode (copies: the runner's networks are untouched) and its output
    names."""
    env = runner.env
    actor = runner.alg.get_policy().as_onnx(verbose=False).to("cpu").eval()
    estimator = copy.deepcopy(env.estimator).to("cpu").eval()
    z_scale = env.estimate_scale.detach().to("cpu").clone()  # z_t = (v_x, v_y, h) as the observation scales it
    split = env.estimate_index  # z_t is inserted at this column of o_t
    sel = env.gait_selector
    if sel.name == "predictive":
        predictor = copy.deepcopy(sel.predictor).to("cpu").eval()
        if sel.tracker is not None:
            tracker = copy.deepcopy(sel.tracker).to("cpu").eval()
            module = OnboardPolicyWithFeasibility(actor, estimator, split, z_scale, predictor, tracker).eval()
            return module, ["actions", "predicted_power", "predicted_tracking_error"]
        return OnboardPolicyWithPredictor(actor, estimator, split, z_scale, predictor).eval(), [
            "actions",
            "predicted_power",
        ]
    return OnboardPolicy(actor, estimator, split, z_scale).eval(), ["actions"]


def exported_program(model: nn.Module, dummy: torch.Tensor) -> torch.export.ExportedProgram:
    """``torch.export`` of ``model`` on a history like ``dummy`` (B, H, D), any batch size B >= 1."""
    return torch.export.export(model, (dummy,), dynamic_shapes=({0: torch.export.Dim("batch", min=1)},))


@contextlib.contextmanager
def _quiet_onnx_exporter() -> Iterator[None]:
    """Silence what torch's own ONNX exporter reports about itself (a ``FutureWarning`` raised inside torch.export's
    tree specs, "torchvision is not installed" log lines); our own warnings stay."""
    log = logging.getLogger("torch.onnx._internal.exporter._registration")
    level = log.level
    log.setLevel(logging.ERROR)
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings(
                "ignore", message=r"`isinstance\(treespec, LeafSpec\)` is deprecated", category=FutureWarning
            )
            yield
    finally:
        log.setLevel(level)


def _write_onnx(program: torch.export.ExportedProgram, outputs: list[str], path: str) -> None:
    with atomic_path(path) as tmp, _quiet_onnx_exporter():
        torch.onnx.export(
            program,
            input_names=["history"],
            output_names=outputs,
            f=tmp,
            opset_version=18,
            dynamo=True,
            external_data=False,
            verbose=False,
        )


def _write_pt2(program: torch.export.ExportedProgram, path: str) -> None:
    with atomic_path(path) as tmp:
        torch.export.save(program, tmp)


def policy_metadata(env: WheeledGo1Env, outputs: list[str]) -> dict:
    """``policy.json``: what a robot needs besides the network (layout, scales, timing, joint order, gait rule)."""
    meta = {
        "wqwarp_version": __version__,
        "history_length": env.cfg.obs.history_length,
        "proprio_dim": env.proprio_dim,
        "num_actions": env.num_actions,
        "outputs": outputs,
        "observation_layout_with_estimate": [list(x) for x in env.obs_layout],
        "estimate_inserted_at": env.estimate_index,
        "policy_dt": env.dt,
        "joint_order": list(ACTUATED_JOINT_NAMES),
        "env_cfg": to_dict(env.cfg),
    }
    selector = env.gait_selector
    if selector.name == "predictive":
        p = env.cfg.predictor
        meta["gait_selection"] = {
            "gaits": list(selector.gait_names),
            "predicted_power": "mean p_cost = sum |tau| |qd| over the next horizon_s, per gait in 'gaits' order [W]",
            "horizon_s": p.horizon_s,
            "decision_interval_s": p.decision_interval_s,
            "rule": "every decision_interval_s, counted from the first full policy step run in the selected gait, "
            "request gait = argmin(predicted_power) (the paper's softmax(-p/tau) with tau -> 0). A request takes "
            "effect at the first policy step at which no leg of the running gait is in swing; until then the "
            "running gait continues. The gait part of the observation (phase, frequency, DF_swing, nominal wheel "
            "speeds) always describes the running gait.",
        }
        candidates = []
        if p.kinematic_mask:
            flags = selector.stepless.tolist()
            stepless = [g for g, no_swing in zip(selector.gait_names, flags, strict=True) if no_swing]
            candidates.append(
                f"the gaits other than {', '.join(stepless)} (no swing) if |v_y^cmd| > "
                f"{p.kinematic_lateral_limit} m/s or |w^cmd| > {p.kinematic_yaw_limit} rad/s, else every "
                "gait"
            )
            if selector.reach_limit is not None:
                bounds = zip(selector.gait_names, selector.reach_limit.tolist(), strict=True)
                limits = ", ".join(f"{g} {r:.3f}" for g, r in bounds if r != float("inf"))
                candidates.append(f"of those, no gait whose lateral reach [m/s] is below |v_y^cmd| ({limits})")
        if selector.tracker is not None:
            meta["gait_selection"]["predicted_tracking_error"] = (
                "mean (v_x^cmd - v_x)^2 + (v_y^cmd - v_y)^2 + (w^cmd - w_z)^2 over the next horizon_s, per gait"
            )
            among = " of those" if candidates else ""
            candidates.append(
                f"the gaits{among} with predicted_tracking_error <= the minimum{among} + {p.feasible_margin}"
            )
        if candidates:
            meta["gait_selection"]["rule"] = meta["gait_selection"]["rule"].replace(
                "request gait = argmin(predicted_power)",
                f"candidates = {'; then '.join(candidates)}; request gait = the candidate of least predicted_power",
            )
    return meta


def export_onboard_policy(runner: WqRunner, out_dir: str) -> dict[str, str]:
    """Write ``policy.onnx``, ``policy.pt2`` and ``policy.json`` to ``out_dir`` (module docstring); returns
    kind -> path. With predictive gait selection the module also returns each gait's predicted power."""
    env = runner.env
    os.makedirs(out_dir, exist_ok=True)
    model, outputs = onboard_module(runner)
    dummy = torch.zeros(2, env.cfg.obs.history_length, env.proprio_dim)
    paths = {
        "onnx": os.path.join(out_dir, "policy.onnx"),
        "torch_export": os.path.join(out_dir, "policy.pt2"),
        "json": os.path.join(out_dir, "policy.json"),
    }
    program = exported_program(model, dummy)
    _write_onnx(program, outputs, paths["onnx"])
    _write_pt2(program, paths["torch_export"])
    write_text_atomic(paths["json"], json.dumps(policy_metadata(env, outputs), indent=2))
    return paths
