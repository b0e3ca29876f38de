"""The observation registry: layouts, the estimate's insertion point and the left-right mirror (hand cases)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
import torch
from tensordict import TensorDict

from wqwarp.rl import observations as ob
from wqwarp.rl.observations import ACTOR_TERMS, PRIVILEGED_TERMS, Dims


def _mirror(terms, dims, parts: dict[str, list[float]]) -> dict[str, list[float]]:
    """Mirror of an observation given by named parts (zeros elsewhere), returned by name."""
    lay = ob.layout(terms, dims)
    x = torch.zeros(sum(k for _, k in lay))
    offsets, i = {}, 0
    for name, k in lay:
        offsets[name] = (i, k)
        i += k
    for name, values in parts.items():
        a, k = offsets[name]
        x[a : a + k] = torch.tensor(values)
    y = ob.apply_mirror(x, *ob.mirror_matrix(terms, dims))
    return {name: y[a : a + k].tolist() for name, (a, k) in offsets.items()}


def test_layouts_and_the_estimate_index():
    dims = Dims(20, 3)
    assert ob.observation_layout(20) == [
        ("base_ang_vel", 3),
        ("gravity", 3),
        ("leg_pos", 12),
        ("joint_vel", 16),
        ("gait", 18),
        ("estimate", 3),
        ("command", 3),
        ("prev_action", 20),
        ("prev2_action", 20),
    ]
    assert ob.estimate_index(dims) == 3 + 3 + 12 + 16 + 18
    assert ob.layout(PRIVILEGED_TERMS, Dims(16, 4))[-1] == ("gait_id", 4)


@pytest.mark.parametrize("dims", [Dims(20, 3), Dims(16, 3), Dims(20, 4)])
def test_mirroring_twice_is_the_identity(dims):
    x = torch.randn(5, sum(t.dim(dims) for t in ACTOR_TERMS))
    p = torch.randn(5, sum(t.dim(dims) for t in PRIVILEGED_TERMS))
    a = torch.randn(5, dims.num_actions)
    for v, m in (
        (x, ob.mirror_matrix(ACTOR_TERMS, dims)),
        (p, ob.mirror_matrix(PRIVILEGED_TERMS, dims)),
        (a, ob.mirror_tensors(ob.action_mirror(dims.num_actions))),
    ):
        assert not torch.equal(ob.apply_mirror(v, *m), v)
        torch.testing.assert_close(ob.apply_mirror(ob.apply_mirror(v, *m), *m), v, rtol=0, atol=0)


def test_the_mirror_of_each_term_maps_what_it_should():
    legs = [1.0, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12]  # FR (hip, thigh, calf), FL, RR, RL
    y = _mirror(
        ACTOR_TERMS,
        Dims(20, 3),
        {
            "base_ang_vel": [1, 2, 3],
            "gravity": [0.1, 0.2, -0.9],
            "leg_pos": legs,
            "joint_vel": [*legs, 13, 14, 15, 16],
            "gait": [*range(1, 19)],
            "estimate": [0.5, 0.3, 0.27],
            "command": [1, 0.5, 0.7],
            "prev_action": [*range(1, 21)],
        },
    )
    assert y["base_ang_vel"] == [-1, 2, -3]  # roll and yaw rates change sign, pitch rate does not
    assert y["gravity"] == pytest.approx([0.1, -0.2, -0.9])
    assert y["leg_pos"] == [-4, 5, 6, -1, 2, 3, -10, 11, 12, -7, 8, 9]  # FR<->FL, RR<->RL, hips negated
    assert y["joint_vel"][12:] == [14, 13, 16, 15]  # wheel speeds swap legs
    assert y["gait"] == [2, 1, 4, 3, 6, 5, 8, 7, 10, 9, 12, 11, 13, 14, 16, 15, 18, 17]  # f and DF_swing stay
    assert y["estimate"] == pytest.approx([0.5, -0.3, 0.27]) and y["command"] == pytest.approx([1, -0.5, -0.7])
    # residual action: dphi (4) swap; dp per leg (x, y, z) swap with y negated; dv (4) swap
    assert y["prev_action"] == [2, 1, 4, 3, 8, -9, 10, 5, -6, 7, 14, -15, 16, 11, -12, 13, 18, 17, 20, 19]
    assert y["prev2_action"] == [0.0] * 20
    p = _mirror(
        PRIVILEGED_TERMS,
        Dims(20, 3),
        {"lin_vel": [1, 2, 3], "wheel_force": [1, 2, 3, 4], "push": [0.3, 0.4], "gait_id": [0, 1, 0]},
    )
    assert p["lin_vel"] == [1, -2, 3] and p["wheel_force"] == [2, 1, 4, 3] and p["push"] == pytest.approx([0.3, -0.4])
    assert p["gait_id"] == [0, 1, 0]
    base = ob.apply_mirror(torch.arange(1.0, 17.0), *ob.mirror_tensors(ob.action_mirror(16)))
    assert base.tolist() == [-4, 5, 6, -1, 2, 3, -10, 11, 12, -7, 8, 9, 14, 13, 16, 15]  # baseline joint offsets


def test_data_augmentation_has_rsl_rls_shape():
    dims = Dims(20, 3)
    env = SimpleNamespace(
        obs_mirror=ob.mirror_matrix(ACTOR_TERMS, dims),
        privileged_mirror=ob.mirror_matrix(PRIVILEGED_TERMS, dims),
        action_mirror=ob.mirror_tensors(ob.action_mirror(20)),
    )
    obs = TensorDict({"policy": torch.randn(6, 98), "privileged": torch.randn(6, 16)}, batch_size=[6])
    a = torch.randn(6, 20)
    obs2, a2 = ob.data_augmentation(env, obs=obs, actions=a)
    assert obs2.batch_size == torch.Size([12]) and a2.shape == (12, 20)
    torch.testing.assert_close(obs2["policy"][:6], obs["policy"])
    torch.testing.assert_close(a2[6:], ob.mirror_actions(env, a))
    assert ob.data_augmentation(env, obs=None, actions=a)[0] is None
    assert ob.data_augmentation(env, obs=obs, actions=None)[1] is None
    with pytest.raises(ValueError, match="columns"):
        ob.mirror_actions(env, torch.randn(6, 16))
