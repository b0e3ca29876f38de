"""Where PPO's KL comes from (issue 60): the KL of every minibatch before its gradient step, the learning rate
the adaptive schedule then sets, and the KL split into its mean and std parts, per action group.

    python docs/studies/fast_skill/kl_probe.py --iterations 6 --json docs/studies/fast_skill/kl_probe_ours_s1.json
    python docs/studies/fast_skill/kl_probe.py --iterations 6 --checkpoint RUN/model_500.pt --json ...

Per probed iteration: the learning rate it starts with, the one before each minibatch's step, the one it leaves, and
the KL before each step, split into the mean and the std terms per action group (phase, foot, wheel).

The probe is a subclass of the training algorithm (``KLProbePPO``); the training it runs is the ``ours`` task's.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys

import torch

from wqwarp.rl.algorithm import WqPPO

RECORDS: list[dict] = []


def kl_parts(old_mu, old_sigma, mu, sigma):
    """Per-dimension Gaussian KL(old || new) split into the mean term and the std term (sum = KL)."""
    mean_part = (mu - old_mu).pow(2) / (2 * sigma.pow(2))
    std_part = torch.log(sigma / old_sigma) + old_sigma.pow(2) / (2 * sigma.pow(2)) - 0.5
    return mean_part, std_part


class KLProbePPO(WqPPO):
    def update(self):
        from wqwarp.rl.observations import action_groups

        rec = {"iteration": self.iteration, "lr_in": self.learning_rate, "minibatches": []}
        orig_kl = self.actor.get_kl_divergence
        probe = self

        def recording_kl(old, new):
            kl = orig_kl(old, new)
            (omu, osig), (mu, sig) = old, new
            mpart, spart = kl_parts(omu, osig, mu, sig)
            groups = action_groups(mu.shape[-1])
            rec["minibatches"].append(
                {
                    "kl": float(kl.mean()),
                    "lr_before": probe.learning_rate,
                    "mean_part": {g: float(mpart[:, c].sum(-1).mean()) for g, c in groups.items()},
                    "std_part": {g: float(spart[:, c].sum(-1).mean()) for g, c in groups.items()},
                    "kl_p95": float(kl.quantile(0.95)),
                    "kl_max": float(kl.max()),
                }
            )
            return kl

        self.actor.get_kl_divergence = recording_kl  # this probe's own instance, not the library class
        try:
            out = super().update()
        finally:
            del self.actor.get_kl_divergence
        rec["lr_out"] = self.learning_rate
        rec["std"] = (
            [float(x) for x in self.actor.distribution.std_param.detach()]
            if hasattr(self.actor.distribution, "std_param")
            else None
        )
        RECORDS.append(rec)
        first = rec["minibatches"][0]
        print(
            f"it {rec['iteration']:4d} lr {rec['lr_in']:.2e} -> {rec['lr_out']:.2e}  first-minibatch KL "
            f"{first['kl']:.2e}  second {rec['minibatches'][1]['kl']:.2e}  last {rec['minibatches'][-1]['kl']:.2e}",
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
    train.algorithm_class = "__main__:KLProbePPO" if __name__ == "__main__" else f"{__name__}:KLProbePPO"
    threads = configure_threads(None, None, None, None)
    cfg.sim.nthread = threads["physics"]
    torch.manual_seed(a.seed)
    env = WheeledGo1Env(cfg)
    with contextlib.redirect_stdout(io.StringIO()):
        runner = WqRunner(env, train.rsl_rl_dict(), log_dir=None, device="cpu")
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
