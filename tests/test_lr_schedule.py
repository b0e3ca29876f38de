"""PPO's learning-rate schedules (``TrainConfig.schedule``): rsl-rl's per-minibatch KL rule and ours once per update.

The per-minibatch rule's floor reading (docs/studies/fast_skill): the KL it reads grows over an update's steps, so the
rate it leaves (the one logged) falls to rsl-rl's 1e-5 floor within an update from 1e-3. ``adaptive_update`` applies
the same rule once, to the KL over the whole rollout of the policy that will collect next."""

from __future__ import annotations

import contextlib
import io

import pytest
import torch
from helpers import task_runner

from wqwarp.rl.algorithm import kl_rule
from wqwarp.rl.config import TrainConfig


def _runner(schedule: str, **train):
    return task_runner("ours", 16, 3, steps_per_env=8, overrides={"train.schedule": schedule, **train})


def _rollout_kl(alg) -> float:
    """The KL of the actor now against the one that collected the stored rollout, over all its transitions."""
    st = alg.storage
    obs = st.observations.flatten(0, 1)
    old_mu, old_sigma = (p.flatten(0, 1) for p in st.distribution_params)
    with torch.inference_mode():  # the rollout's tensors are inference tensors (rsl-rl collects in that mode)
        mu = alg.actor(obs)
        sigma = alg.actor.distribution.std_param.expand_as(mu)
        kl = torch.log(sigma / old_sigma) + (old_sigma**2 + (old_mu - mu) ** 2) / (2 * sigma**2) - 0.5
        return float(kl.sum(-1).mean())


def test_kl_rule_hand_values():
    assert kl_rule(1e-3, 0.03, 0.01) == pytest.approx(1e-3 / 1.5)  # above 2x the target
    assert kl_rule(1e-3, 0.004, 0.01) == pytest.approx(1.5e-3)  # below half
    assert kl_rule(1e-3, 0.01, 0.01) == 1e-3  # inside the band
    assert kl_rule(1e-3, 0.0, 0.01) == 1e-3  # no step taken yet: rsl-rl leaves the rate
    assert kl_rule(1.2e-5, 1.0, 0.01) == 1e-5  # the floor
    assert kl_rule(8e-3, 1e-6, 0.01) == 1e-2  # the ceiling


def test_the_rsl_rl_dict_carries_the_schedule():
    assert TrainConfig().rsl_rl_dict()["algorithm"]["schedule"] == "adaptive"
    assert TrainConfig().rsl_rl_dict()["algorithm"]["kl_per_update"] is False
    d = TrainConfig(schedule="adaptive_update").rsl_rl_dict()["algorithm"]
    assert (d["schedule"], d["kl_per_update"]) == ("fixed", True)  # rsl-rl's own rule off, ours on
    d = TrainConfig(schedule="fixed").rsl_rl_dict()["algorithm"]
    assert (d["schedule"], d["kl_per_update"]) == ("fixed", False)


@pytest.mark.parametrize(
    ("desired_kl", "factor"),
    [(1e-6, 1 / 1.5), (1e3, 1.5)],  # the update's KL far above 2x the target / far below half of it
)
def test_adaptive_update_applies_the_rule_once_to_the_rollout_kl(desired_kl, factor):
    runner = _runner("adaptive_update", **{"train.desired_kl": desired_kl})
    alg = runner.alg
    assert alg.kl_per_update and alg.schedule == "fixed"
    lr0 = alg.learning_rate
    with contextlib.redirect_stdout(io.StringIO()):
        runner.learn(1)
    assert alg.update_kl == pytest.approx(_rollout_kl(alg), rel=1e-4)  # the storage still holds the rollout
    assert alg.update_kl > 0
    assert alg.learning_rate == pytest.approx(lr0 * factor)
    assert all(g["lr"] == pytest.approx(lr0 * factor) for g in alg.optimizer.param_groups)


def test_the_per_minibatch_rule_ends_its_first_update_far_below_its_start():
    """rsl-rl's rule from 1e-3 on a fresh policy: the KL read before the later minibatches' steps is above 2x the
    target, so the rate is divided by 1.5 at each of them (20 minibatches: 1e-3 / 1.5^k, at most the 1e-5 floor)."""
    runner = _runner("adaptive")
    with contextlib.redirect_stdout(io.StringIO()):
        runner.learn(1)
    assert runner.alg.learning_rate < 1e-3 / 1.5**5
    assert _rollout_kl(runner.alg) > 2 * TrainConfig().desired_kl
