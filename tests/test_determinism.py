"""Determinism on the CPU: the same seed gives the same first training iteration (rollout statistics and updated
networks) and the same evaluation numbers; another seed gives others."""

from __future__ import annotations

import dataclasses

import torch
from helpers import first_iteration

from wqwarp.eval.loading import make_policy_runner
from wqwarp.eval.tracking import run_task
from wqwarp.rl.presets import make_preset


def _first_iteration(seed: int) -> dict:
    runner = first_iteration("ours-paper", num_envs=8, seed=seed, steps_per_env=8)
    env = runner.env
    st = runner.alg.storage
    return {
        "rewards": st.rewards.clone(),
        "obs": st.observations["policy"].clone(),
        "actions": st.actions.clone(),
        "actor": {k: v.clone() for k, v in runner.alg.actor.state_dict().items()},
        "estimator": {k: v.clone() for k, v in env.estimator.state_dict().items()},
    }


def test_the_same_seed_gives_the_same_first_iteration():
    a, b, c = _first_iteration(5), _first_iteration(5), _first_iteration(6)
    for k in ("rewards", "obs", "actions"):
        assert torch.equal(a[k], b[k]), k
        assert not torch.equal(a[k], c[k]), k
    for net in ("actor", "estimator"):
        assert all(torch.equal(a[net][k], b[net][k]) for k in a[net]), net


def test_the_same_seed_gives_the_same_evaluation(tmp_path, save_checkpoint):
    cfg = make_preset("ours")
    cfg.sim.num_envs = 8
    path = save_checkpoint(tmp_path / "m.pt", cfg)

    def evaluate(seed: int):
        runner = make_policy_runner(path, "ours", num_envs=6, seed=seed)
        return dataclasses.asdict(run_task(runner, "vx", seconds=2.0, settle=0.5, max_push=0.5, push_interval=1.0))

    first, again, other = evaluate(3), evaluate(3), evaluate(4)
    assert first == again
    assert first != other
