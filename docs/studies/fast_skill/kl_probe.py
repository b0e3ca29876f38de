"""Where PPO's KL comes from (issue 60): the KL of every minibatch before its gradient step, the learning rate
the adaptive schedule then sets, and the KL split into its mean and std parts, per action group.

    python docs/studies/fast_skill/kl_probe.py --iterations 6 --json docs/studies/fast_skill/kl_probe_ours_s1.json
    python docs/studies/fast_skill/kl_probe.py --iterations 6 --checkpoint RUN/model_500.pt --json ...

Per probed iteration: the learning rate it starts with, the one before each minibatch's step, the one it leaves, and
the KL before each step, split into the mean and the std terms per action group (phase, foot, wheel).

The probe is the task's actor and algorithm subclassed through rsl-rl's ``class_name`` entries (``KLRecordingMLPModel``
records the KL readings, ``KLProbePPO`` the rates); the training it runs is the task's.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys

import torch
from rsl_rl.models import MLPModel

from wqwarp.rl.algorithm import WqPPO, kl_rule

RECORDS: list[dict] = []
"""One entry per probed update."""


def kl_parts(old_mu, old_sigma, mu, sigma):
    """Per-dimension Gaussian KL(old || new) split into the mean term and the std term (sum = KL)."""
    mean_part = (mu - old_mu).pow(2) / (2 * sigma.pow(2))
    std_part = torch.log(sigma / old_sigma) + old_sigma.pow(2) / (2 * sigma.pow(2)) - 0.5
    return mean_part, std_part


class KLRecordingMLPModel(MLPModel):
    """rsl-rl's actor (named by the actor config's ``class_name``) that records every KL its PPO reads: the mean
    over the minibatch and the mean and std terms per action group."""

    readings: list[dict] = []

    def get_kl_divergence(self, old_params, new_params):
        from wqwarp.rl.observations import action_groups

        kl = super().get_kl_divergence(old_params, new_params)
        (omu, osig), (mu, sig) = old_params, new_params
        mpart, spart = kl_parts(omu, osig, mu, sig)
        groups = action_groups(mu.shape[-1])
        self.readings.append(
            {
                "kl": float(kl.mean()),
                "mean_part": {g: float(mpart[:, c].sum(-1).mean()) for g, c in groups.items()},
                "std_part": {g: float(spart[:, c].sum(-1).mean()) for g, c in groups.items()},
                "kl_p95": float(kl.quantile(0.95)),
                "kl_max": float(kl.max()),
            }
        )
        return kl


class KLProbePPO(WqPPO):
    """The task's algorithm; after each update, the record of its KL readings with the rate before each step
    (derived from the rule, checked against the rate the update left)."""

    def update(self):
        lr_in, iteration = self.learning_rate, self.iteration
        KLRecordingMLPModel.readings.clear()
        out = super().update()
        minibatches, lr = [], lr_in
        for reading in KLRecordingMLPModel.readings:
            minibatches.append({**reading, "lr_before": lr})
            lr = kl_rule(lr, reading["kl"], self.desired_kl)
        if lr != self.learning_rate:
            raise RuntimeError(f"the rule replayed gives {lr}, the update left {self.learning_rate}")
        rec = {
            "iteration": iteration,
            "lr_in": lr_in,
            "lr_out": self.learning_rate,
            "minibatches": minibatches,
            "std": [float(x) for x in self.actor.distribution.std_param.detach()],
        }
        RECORDS.append(rec)
        kls = [m["kl"] for m in minibatches]
        print(
            f"it {rec['iteration']:4d} lr {lr_in:.2e} -> {rec['lr_out']:.2e}  first-minibatch KL {kls[0]:.2e}  "
            f"second {kls[1]:.2e}  last {kls[-1]:.2e}",
            flush=True,
        )
        return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--task", default="ours")
    p.add_argument("--iterations", type=int, default=30)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--num-envs", type=int, default=128)
    p.add_argument("--set", action="append", default=[], help="PATH=VALUE (python literal) over the task")
    p.add_argument("--checkpoint", default=None, help="start from this checkpoint (networks, optimizer, rate)")
    p.add_argument("--json", default=None)
    a = p.parse_args(argv)
    import ast

    from wqwarp.rl.env import WheeledGo1Env
    from wqwarp.rl.runner import WqRunner
    from wqwarp.rl.tasks import TASKS, set_path
    from wqwarp.utils.threads import configure_threads

    cfg, train = TASKS[a.task].make()
    cfg.sim.num_envs = a.num_envs
    cfg.seed = a.seed
    for s in a.set:
        k, v = s.split("=", 1)
        try:
            v = ast.literal_eval(v)
        except Exception:
            pass
        set_path({"env": cfg, "train": train}, k, v)
    here = "__main__" if __name__ == "__main__" else __name__
    train.algorithm_class = f"{here}:KLProbePPO"
    threads = configure_threads(None, None, None, None)
    cfg.sim.nthread = threads["physics"]
    torch.manual_seed(a.seed)
    env = WheeledGo1Env(cfg)
    with contextlib.redirect_stdout(io.StringIO()):
        rsl = train.rsl_rl_dict()
        rsl["actor"]["class_name"] = f"{here}:KLRecordingMLPModel"  # rsl-rl's extension point for the actor
        runner = WqRunner(env, rsl, log_dir=None, device="cpu")
    runner.alg.update_threads = threads["update"]
    if a.checkpoint:
        runner.load(a.checkpoint, restore_rng=True)
        runner.current_learning_iteration += 1
    runner.learn(a.iterations, init_at_random_ep_len=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"command": " ".join(sys.argv), "records": RECORDS}, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
