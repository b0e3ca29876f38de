"""The exported onboard policy (the ``torch.export`` program, and ONNX run with onnxruntime) computes what the
runner's inference policy, estimator and power predictor compute, on real observation histories of a
trained-for-2-iterations run."""

from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
import torch

from wqwarp.rl.config import TrainConfig
from wqwarp.rl.env import WheeledGo1Env
from wqwarp.rl.export import export_onboard_policy
from wqwarp.rl.presets import make_preset
from wqwarp.rl.runner import WqRunner

ort = pytest.importorskip("onnxruntime")


@pytest.mark.parametrize("preset", ["ours", "no_predictor"])
def test_exported_policy_matches_the_runner_on_real_histories(preset, tmp_path):
    cfg = make_preset(preset)
    cfg.sim.num_envs = 8
    env = WheeledGo1Env(cfg)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, TrainConfig(num_steps_per_env=8).rsl_rl_dict(), log_dir=None, device="cpu")
        runner.learn(2)  # normalisers, estimator and predictor move away from their initialisation
    paths = export_onboard_policy(runner, str(tmp_path))
    policy = runner.get_inference_policy("cpu")
    program = torch.export.load(paths["torch_export"]).module()
    session = ort.InferenceSession(paths["onnx"], providers=["CPUExecutionProvider"])
    obs = env.get_observations()
    checked = 0
    for step in range(30):
        with torch.inference_mode():
            actions = policy(obs)
        if step >= 6:  # a full history of real observations
            history = env.history.clone()
            assert history.abs().sum(dim=(1, 2)).min() > 0  # no robot has an empty (zero) history
            with torch.inference_mode():
                ts = program(history)
            ox = session.run(None, {"history": history.numpy()})
            ts_actions = ts[0] if isinstance(ts, tuple) else ts
            torch.testing.assert_close(ts_actions, actions, atol=1e-5, rtol=0)
            np.testing.assert_allclose(ox[0], actions.numpy(), atol=1e-5, rtol=0)
            if preset == "ours":
                predicted = env.gait_selector.predict(obs["policy"])
                torch.testing.assert_close(ts[1], predicted, atol=1e-4, rtol=1e-5)
                np.testing.assert_allclose(ox[1], predicted.numpy(), atol=1e-4, rtol=1e-5)
            checked += 1
        obs, _, _, _ = env.step(actions)  # env.history is now the history that produced obs
    assert checked == 24
