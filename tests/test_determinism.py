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


def test_the_physics_thread_count_does_not_change_a_rollout():
    """``mujoco.rollout`` splits the robots over its threads; each robot's physics is its own, so 1 and 2 threads give
    the same rollout bit for bit (a training and its evaluation may use different thread counts: issue 47 asked
    whether that is why a policy that trained without falls fell in evaluation; it is not)."""
    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.tasks import TASKS

    rewards, states = {}, {}
    for threads in (1, 2):
        cfg, _ = TASKS["ours"].make()
        cfg.sim.num_envs, cfg.sim.nthread, cfg.seed = 16, threads, 3
        torch.manual_seed(3)
        env = WheeledGo1Env(cfg)
        gen = torch.Generator().manual_seed(0)
        rewards[threads] = torch.stack(
            [env.step(0.3 * torch.randn(16, env.num_actions, generator=gen))[1].clone() for _ in range(60)]
        )
        states[threads] = env.get_observations()["privileged"].clone()
    assert torch.equal(rewards[1], rewards[2]) and torch.equal(states[1], states[2])
    assert rewards[1].abs().sum() > 0
