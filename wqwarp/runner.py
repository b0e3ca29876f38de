"""rsl-rl's OnPolicyRunner, with the estimator and the environment's layout saved in every checkpoint, and export
of the onboard policy (estimator + actor) to TorchScript and ONNX."""

from __future__ import annotations

import copy
import json
import os

import torch
from rsl_rl.runners import OnPolicyRunner
from torch import nn

from wqwarp import __version__
from wqwarp.config import to_dict
from wqwarp.constants import ACTUATED_JOINT_NAMES
from wqwarp.env import WheeledGo1Env, observation_layout

CHECKPOINT_FORMAT = 1


class WqRunner(OnPolicyRunner):
    """OnPolicyRunner whose checkpoints also hold the state estimator, the observation layout and the env config."""

    env: WheeledGo1Env

    def _env_infos(self) -> dict:
        env = self.env
        return {
            "format": CHECKPOINT_FORMAT,
            "wqwarp_version": __version__,
            "estimator": env.estimator.state_dict(),
            "estimator_optimizer": env.estimator_trainer.optimizer.state_dict(),
            "obs_layout": env.obs_layout,
            "num_actions": env.num_actions,
            "env_cfg": to_dict(env.cfg),
        }

    def save(self, path: str, infos: dict | None = None) -> None:
        """Save atomically (temporary file, then rename): a crash never leaves a truncated checkpoint."""
        merged = self._env_infos()
        merged.update(infos or {})
        tmp = path + ".tmp"
        super().save(tmp, merged)
        os.replace(tmp, path)

    def load(self, path: str, load_cfg: dict | None = None, strict: bool = True, map_location: str | None = None):
        infos = torch.load(path, weights_only=False, map_location=map_location or self.device).get("infos") or {}
        check_compatible(infos, self.env, path)
        infos = super().load(path, load_cfg, strict, map_location or self.device)
        self.env.estimator.load_state_dict(infos["estimator"])
        if "estimator_optimizer" in infos:
            self.env.estimator_trainer.optimizer.load_state_dict(infos["estimator_optimizer"])
        return infos


def check_compatible(infos: dict, env: WheeledGo1Env, path: str) -> None:
    """Raise ValueError if a checkpoint was trained with another observation or action layout."""
    layout = [tuple(x) for x in infos.get("obs_layout", [])]
    if not layout or infos.get("format") != CHECKPOINT_FORMAT:
        raise ValueError(f"{path} is not a wqwarp checkpoint (no observation layout recorded)")
    if layout != [tuple(x) for x in env.obs_layout] or infos.get("num_actions") != env.num_actions:
        raise ValueError(f"{path} was trained with another observation/action layout ({infos.get('num_actions')} "
                         f"actions, {sum(k for _, k in layout)} observations) than this preset "
                         f"({env.num_actions} actions, {env.num_obs} observations)")  # fmt: skip


class OnboardPolicy(nn.Module):
    """Everything the robot runs at 50 Hz: proprioceptive history (B, H, D) -> estimator z_t -> actor -> action.

    The newest history row is o_t without z_t (``wqwarp.env.observation_layout`` minus ``estimate``), unnormalised
    and scaled exactly as in training; z_t is inserted before the command.
    """

    def __init__(self, actor: nn.Module, estimator: nn.Module, split: int, z_scale: torch.Tensor):
        super().__init__()
        self.actor = actor
        self.estimator = estimator
        self.split = split
        self.register_buffer("z_scale", z_scale)

    def forward(self, history: torch.Tensor) -> torch.Tensor:
        z = self.estimator(history.reshape(history.shape[0], -1)) * self.z_scale
        latest = history[:, -1]
        obs = torch.cat([latest[:, : self.split], z, latest[:, self.split :]], dim=1)
        return self.actor(obs)


def export_onboard_policy(runner: WqRunner, out_dir: str) -> dict[str, str]:
    """Write ``policy.pt`` (TorchScript), ``policy.onnx`` and ``policy.json`` (layout, scales) to ``out_dir``."""
    env = runner.env
    os.makedirs(out_dir, exist_ok=True)
    actor = runner.alg.get_policy().as_jit().to("cpu").eval()
    estimator = copy.deepcopy(env.estimator).to("cpu").eval()
    split = 3 + 3 + 12 + 16 + 18
    s = env.cfg.obs.lin_vel_scale
    model = OnboardPolicy(actor, estimator, split, torch.tensor([s, s, 1.0])).eval()
    H, D = env.cfg.obs.history_length, env.proprio_dim
    dummy = torch.zeros(1, H, D)
    paths = {}
    scripted = torch.jit.script(model)
    paths["torchscript"] = os.path.join(out_dir, "policy.pt")
    scripted.save(paths["torchscript"] + ".tmp")
    os.replace(paths["torchscript"] + ".tmp", paths["torchscript"])
    paths["onnx"] = os.path.join(out_dir, "policy.onnx")
    torch.onnx.export(model, (dummy,), paths["onnx"], input_names=["history"], output_names=["actions"],
                      opset_version=18, dynamo=False)  # fmt: skip
    paths["json"] = os.path.join(out_dir, "policy.json")
    meta = {
        "wqwarp_version": __version__,
        "history_length": H,
        "proprio_dim": D,
        "num_actions": env.num_actions,
        "observation_layout_with_estimate": observation_layout(env.num_actions),
        "estimate_inserted_at": split,
        "policy_dt": env.dt,
        "joint_order": list(ACTUATED_JOINT_NAMES),
        "env_cfg": to_dict(env.cfg),
    }
    with open(paths["json"], "w", encoding="utf-8") as f:
        json.dump(meta, f, indent=2)
    return paths
