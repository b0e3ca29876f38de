"""The CUDA code path on Warp's CPU device: the env and a short training run on the ``mujoco_warp`` backend, and no
host copy in a step (resets and pushes included)."""

from __future__ import annotations

import contextlib
import io
import sys

import torch
import warp as wp

from wqwarp.rl.config import TrainConfig
from wqwarp.rl.env import WheeledGo1Env
from wqwarp.rl.presets import make_preset
from wqwarp.rl.runner import WqRunner

N = 4


def _warp_env(preset: str = "ours", **dr) -> WheeledGo1Env:
    cfg = make_preset(preset)
    cfg.sim.num_envs = N
    cfg.sim.device = "cpu"
    cfg.sim.backend = "mujoco_warp"  # the GPU's physics path, run by Warp on the CPU
    for k, v in dr.items():
        setattr(cfg.domain_rand, k, v)
    return WheeledGo1Env(cfg)


class HostCopies:
    """Counts device -> host transfers requested from ``wqwarp`` code: ``wp.array.numpy``, ``wp.array.assign``,
    ``torch.Tensor.cpu / numpy / item / tolist / __float__ / __int__ / __bool__``. On the CPU device these are free,
    on CUDA each is a copy and a synchronisation, so they must not run per step."""

    NAMES = (
        (wp.array, "numpy"),
        (wp.array, "assign"),
        (torch.Tensor, "cpu"),
        (torch.Tensor, "numpy"),
        (torch.Tensor, "item"),
        (torch.Tensor, "tolist"),
        (torch.Tensor, "__float__"),
        (torch.Tensor, "__int__"),
        (torch.Tensor, "__bool__"),
    )

    def __init__(self, monkeypatch):
        self.calls: list[str] = []
        for cls, name in self.NAMES:
            original = getattr(cls, name)
            monkeypatch.setattr(cls, name, self._counting(original, f"{cls.__name__}.{name}"))

    def _counting(self, original, label: str):
        calls = self.calls

        def counted(*a, **kw):
            caller = sys._getframe(1)
            module = caller.f_globals.get("__name__", "")
            if module.startswith("wqwarp"):
                calls.append(f"{label} from {module}:{caller.f_lineno}")
            return original(*a, **kw)

        return counted


def test_env_steps_resets_and_pushes_without_host_copies(monkeypatch):
    env = _warp_env(push_interval=0.1)  # a push every 5 policy steps
    env.collect_training_data = True
    gen = torch.Generator().manual_seed(0)
    for _ in range(3):  # compile and warm up
        env.step(torch.randn(N, env.num_actions, generator=gen) * 0.2)
    events = {"reset": 0, "push": 0}
    for name in ("_reset_envs", "_push_robots"):
        original = getattr(env, name)

        def wrapped(*a, _original=original, _key=name, **kw):
            events["reset" if _key == "_reset_envs" else "push"] += 1
            return _original(*a, **kw)

        monkeypatch.setattr(env, name, wrapped)
    env.episode_length_buf[:2] = env.max_episode_length - 2  # two robots time out inside the window
    copies = HostCopies(monkeypatch)
    actions = torch.randn(12, N, env.num_actions, generator=gen) * 0.2
    for a in actions:
        env.step(a)
    assert events["reset"] >= 1 and events["push"] >= 2, events
    assert copies.calls == [], "host copies in env.step:\n" + "\n".join(copies.calls)


def test_resets_on_the_device_path_match_the_requested_state():
    env = _warp_env("no_predictor")
    sim = env.sim
    ids = torch.tensor([1, 3])
    q = torch.tensor(sim._default_q).repeat(2, 1)
    q[:, 0] = torch.tensor([0.5, -0.25])  # moved base
    q[:, 2] += 0.1
    qd = torch.zeros(2, sim.layout.dofs_per_world)
    qd[:, 0] = 0.3
    before = sim.joint_q.numpy().copy()
    sim.reset(ids, q, qd)
    after = sim.joint_q.numpy()
    torch.testing.assert_close(torch.from_numpy(after[[1, 3]]), q)
    torch.testing.assert_close(torch.from_numpy(sim.joint_qd.numpy()[[1, 3]]), qd)
    assert (after[[0, 2]] == before[[0, 2]]).all()  # the other robots are untouched
    trunk = sim.body_q.numpy()[:, sim.layout.trunk_body, :3]
    assert abs(trunk[1, 0] - 0.5) < 0.05 and abs(trunk[3, 0] + 0.25) < 0.05  # FK ran for the reset robots


def test_two_training_iterations_on_the_mujoco_warp_backend(tmp_path):
    env = _warp_env("ours")
    tcfg = TrainConfig(num_steps_per_env=4, max_iterations=2, save_interval=1)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, tcfg.rsl_rl_dict(), log_dir=str(tmp_path), device="cpu")
        runner.learn(2)
    assert runner.current_learning_iteration == 1
    assert (tmp_path / "model_0.pt").is_file()
    assert torch.isfinite(torch.as_tensor(runner.alg.aux_losses["estimator"]))
    for p in runner.alg.get_policy().parameters():
        assert torch.isfinite(p).all()


def test_cuda_env_steps_without_host_copies(monkeypatch, cuda_device):
    cfg = make_preset("ours")
    cfg.sim.num_envs = N
    cfg.sim.device = cuda_device
    cfg.domain_rand.push_interval = 0.1
    env = WheeledGo1Env(cfg)
    for _ in range(3):
        env.step(torch.zeros(N, env.num_actions, device=env.device))
    copies = HostCopies(monkeypatch)
    for _ in range(10):
        env.step(torch.zeros(N, env.num_actions, device=env.device))
    assert copies.calls == [], "host copies in env.step:\n" + "\n".join(copies.calls)
