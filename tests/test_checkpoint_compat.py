"""Checkpoints against the env that loads them: another gait set is refused with one line naming both, and a
checkpoint of the earlier format (the extensions' state in ``infos``) still loads whole."""

from __future__ import annotations

import pytest
import torch
from helpers import preset_runner


def _runner(seed: int):
    return preset_runner("ours", num_envs=4, seed=seed)


def test_another_gait_set_and_the_earlier_format(tmp_path):
    a, b = _runner(1), _runner(2)
    path = str(tmp_path / "m.pt")
    a.save(path)
    ckpt = torch.load(path, weights_only=False)

    other = dict(ckpt, infos=dict(ckpt["infos"]))
    gait = dict(other["infos"]["env_cfg"]["gait"])
    gait["library"] = [dict(g, name=f"{g['name']}_tuned") for g in gait["library"]]
    other["infos"]["env_cfg"] = dict(other["infos"]["env_cfg"], gait=gait)
    torch.save(other, tmp_path / "other.pt")
    with pytest.raises(ValueError, match=r"trained with the gaits \[.*_tuned.*\], this env runs \[") as e:
        b.load(str(tmp_path / "other.pt"))
    assert "\n" not in str(e.value)

    # the same names, other parameters (a tuned trot keeps its name): refused too, naming what differs
    gait = dict(ckpt["infos"]["env_cfg"]["gait"])
    gait["library"] = [dict(g, frequency=1.11) if g["name"] == "trotting" else g for g in gait["library"]]
    tuned = dict(ckpt, infos=dict(ckpt["infos"], env_cfg=dict(ckpt["infos"]["env_cfg"], gait=gait)))
    torch.save(tuned, tmp_path / "tuned.pt")
    with pytest.raises(ValueError, match=r"another 'trotting' gait \(frequency 1.11 in the checkpoint, 1.2 here\)"):
        b.load(str(tmp_path / "tuned.pt"))

    old = {k: v for k, v in ckpt.items() if not k.startswith(("estimator_", "gait_selector_"))}
    old["infos"] = dict(ckpt["infos"], format=1, estimator=ckpt["estimator_state_dict"],
                        estimator_optimizer=ckpt["estimator_optimizer_state_dict"],
                        gait_selector=ckpt["gait_selector_state_dict"])  # fmt: skip
    torch.save(old, tmp_path / "old.pt")
    b.load(str(tmp_path / "old.pt"))
    for x, y in ((a.env.estimator, b.env.estimator), (a.env.gait_selector.predictor, b.env.gait_selector.predictor)):
        assert all(torch.equal(p, q) for p, q in zip(x.state_dict().values(), y.state_dict().values(), strict=True))
