"""The refactoring guard: the first training iteration of fixed seeds equals the one recorded before the package was
restructured (main at bc08f71): rollout rewards, observations and actions, and the networks after the update
(actor, critic, estimator, power predictor). The third case is the default main job's configuration (``ours`` with
the ``omni`` levers of ``wqwarp.rl.profiles``), recorded when it became the default.

``python tests/test_behaviour_reference.py --record`` rewrites ``tests/data/first_iteration.npz``; do that only for a
change that is meant to change behaviour, and say so in the commit."""

from __future__ import annotations

import os
import sys

import helpers
import numpy as np
import pytest

REFERENCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "first_iteration.npz")
CASES = (("ours", 5, "paper"), ("baseline", 7, "paper"), ("ours", 5, "omni"))


def label(preset: str, profile: str) -> str:
    """The case's key prefix in the reference file (the paper's cases keep the names recorded at bc08f71)."""
    return preset if profile == "paper" else f"{preset}+{profile}"


def first_iteration(preset: str, seed: int, profile: str = "paper") -> dict[str, np.ndarray]:
    runner = helpers.first_iteration(preset, num_envs=8, seed=seed, steps_per_env=8, profile=profile)
    env = runner.env
    st = runner.alg.storage
    out = {"rewards": st.rewards, "obs": st.observations["policy"], "privileged": st.observations["privileged"],
           "actions": st.actions}  # fmt: skip
    nets = {"actor": runner.alg.actor, "critic": runner.alg.critic, "estimator": env.estimator}
    if env.gait_selector.name == "predictive":
        nets["predictor"] = env.gait_selector.predictor
    for name, net in nets.items():
        for k, v in net.state_dict().items():
            if v.is_floating_point():
                out[f"{name}/{k}"] = v
    head = label(preset, profile)
    return {f"{head}/{k}": _fingerprint(k, v.detach().cpu().numpy().astype(np.float64)) for k, v in out.items()}


def _fingerprint(name: str, x: np.ndarray) -> np.ndarray:
    """Rollout tensors whole; a network tensor as its sum, its sum of squares and 16 fixed random projections (any
    change of a weight changes them; the file stays small)."""
    if "/" not in name:
        return x
    flat = x.reshape(-1)
    proj = np.random.default_rng(flat.size).standard_normal((16, flat.size))
    return np.concatenate([[flat.sum(), (flat**2).sum()], proj @ flat])


@pytest.mark.parametrize("preset,seed,profile", CASES)
def test_first_iteration_equals_the_recorded_one(preset, seed, profile):
    ref = np.load(REFERENCE)
    now = first_iteration(preset, seed, profile)
    keys = sorted(k for k in ref.files if k.startswith(f"{label(preset, profile)}/"))
    assert keys == sorted(now), "the recorded and current runs hold different tensors"
    for k in keys:
        # float32 sums may round differently once a computation moves between torch and Warp; anything else differs
        np.testing.assert_allclose(now[k], ref[k], rtol=1e-4, atol=1e-5, err_msg=k)


if __name__ == "__main__":
    if "--record" not in sys.argv:
        sys.exit("usage: python tests/test_behaviour_reference.py --record")
    data = {}
    for preset, seed, profile in CASES:
        data.update(first_iteration(preset, seed, profile))
    np.savez_compressed(REFERENCE, **data)
    print(f"wrote {REFERENCE} ({len(data)} arrays)")
