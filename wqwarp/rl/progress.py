"""Training progress: one console line per iteration and ``metrics.jsonl`` in the log directory.

:class:`ProgressLogger` is rsl-rl's ``Logger`` (TensorBoard scalars of ``extras["log"]``, the losses of the update,
rewards, timings) with three additions, all inside ``log`` (called once per iteration by rsl-rl's runner):

- the scalars of the whole iteration (``iteration_log``: the gait selector's ``Gait/*`` usage shares, switch and fall
  counts, temperature and ``Predictor/*`` errors, which are counted over the rollout rather than per step) join the
  iteration's ``extras["log"]`` entries, so that rsl-rl writes them like every other extra;
- the iteration's means are appended to ``<log_dir>/metrics.jsonl`` (one JSON object per line, flushed every
  iteration): what summaries and reports read instead of the console;
- the console shows :func:`status_line` (bar, ETA, reward, tracking errors, power, steps/s, gait shares) instead of
  rsl-rl's block (``console="block"`` keeps the block, ``"none"`` prints nothing).
"""

from __future__ import annotations

import contextlib
import datetime
import io
import json
import math
import os
import statistics
import time
from collections.abc import Callable
from typing import Literal

import torch
from rsl_rl.utils.logger import Logger

METRICS_FILE = "metrics.jsonl"
"""Name of the per-iteration metrics file in the log directory."""


def extras_means(ep_extras: list[dict]) -> dict[str, float]:
    """Mean of every ``extras["log"]`` entry over the steps that hold it, as rsl-rl's ``Logger.log`` computes it."""
    out: dict[str, float] = {}
    for key in dict.fromkeys(k for info in ep_extras for k in info):
        parts = [torch.as_tensor(info[key], dtype=torch.float64).reshape(-1).cpu() for info in ep_extras if key in info]
        out[key] = float(torch.cat(parts).mean())
    return out


def group_std(action_std: torch.Tensor) -> dict[str, float]:
    """``Policy/std_<group>``: the policy's mean action std per action group (``observations.action_groups``)."""
    from wqwarp.rl.observations import action_groups

    std = action_std.detach().reshape(-1, action_std.shape[-1]).mean(0)  # (A,) or per sample (..., A)
    return {f"Policy/std_{name}": std[cols].mean().item() for name, cols in action_groups(std.numel()).items()}


def read_metrics(log_dir: str) -> list[dict]:
    """The lines of ``<log_dir>/metrics.jsonl`` in order (a line cut short by a crash is skipped); [] if none."""
    path = os.path.join(log_dir, METRICS_FILE)
    if not os.path.isfile(path):
        return []
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            with contextlib.suppress(json.JSONDecodeError):
                rows.append(json.loads(line))
    return rows


def _num(x: float | None) -> float:
    return float("nan") if x is None else x


def status_line(m: dict, total: int, eta_s: float) -> str:
    """The one-line status of an iteration's metrics ``m`` (a :class:`ProgressLogger` row)."""
    from wqwarp.rl.gait_selection import usage_from_scalars

    it = m["iteration"]
    frac = it / max(total, 1)
    bar = "#" * int(20 * frac) + "-" * (20 - int(20 * frac))
    g = lambda k: _num(m.get(k))  # noqa: E731
    status = (
        f"[{bar}] {it}/{total} ETA {datetime.timedelta(seconds=int(eta_s))} | "
        f"reward {g('mean_reward'):7.2f} | err vx {g('Metrics/vx_error'):.2f} vy {g('Metrics/vy_error'):.2f} "
        f"wz {g('Metrics/wz_error'):.2f} | power {g('Metrics/p_cost'):6.1f} W (legs "
        f"{g('Metrics/p_cost_legs'):5.1f}, wheels {g('Metrics/p_cost_wheels'):5.1f}) | "
        f"elec {g('Metrics/p_elec'):6.1f} W | {g('steps_per_s'):6.0f} steps/s"
    )
    usage = usage_from_scalars(m)
    if usage:
        status += " | gaits " + " ".join(f"{n[:5]} {100 * v:3.0f}%" for n, v in usage.items())
        if "Gait/temperature" in m:
            status += f" tau {m['Gait/temperature']:.2g}"
    return status


class ProgressLogger(Logger):
    """rsl-rl's ``Logger`` with the iteration's own scalars, ``metrics.jsonl`` and a one-line console (module
    docstring). The constructor takes ``Logger``'s arguments plus the two below."""

    def __init__(
        self,
        *args,
        iteration_log: Callable[[], dict[str, float]] | None = None,
        console: Literal["line", "block", "none"] = "line",
        **kwargs,
    ) -> None:
        super().__init__(*args, **kwargs)
        self.iteration_log = iteration_log
        """Called once per iteration (on every rank: it restarts the counters): scalars of the whole iteration."""
        self.console = console
        """``line``: :func:`status_line` (a newline every 10 iterations); ``block``: rsl-rl's; ``none``."""
        self.metrics: dict = {}
        """The last row written to ``metrics.jsonl``."""
        self._t0 = self._t_last = time.time()

    def init_logging_writer(self) -> None:
        super().init_logging_writer()
        self._t0 = self._t_last = time.time()

    def log(
        self,
        it: int,
        start_it: int,
        total_it: int,
        collect_time: float,
        learn_time: float,
        loss_dict: dict,
        learning_rate: float,
        action_std: torch.Tensor,
        rnd_weight: float | None,
        print_minimal: bool = False,
        width: int = 80,
        pad: int = 40,
    ) -> None:
        scalars = self.iteration_log() if self.iteration_log is not None else {}
        if self.writer is not None:
            if scalars:
                self.ep_extras.append(dict(scalars))
            self.metrics = self._row(it, collect_time, learn_time, loss_dict, learning_rate, action_std)
            self._append(self.metrics)
        quiet = self.console != "block"
        with contextlib.redirect_stdout(io.StringIO()) if quiet else contextlib.nullcontext():
            super().log(
                it,
                start_it,
                total_it,
                collect_time,
                learn_time,
                loss_dict,
                learning_rate,
                action_std,
                rnd_weight,
                print_minimal,
                width,
                pad,
            )
        if self.writer is not None:  # rsl-rl logs the mean std; the row holds it per action group
            for key, value in self.metrics.items():
                if key.startswith("Policy/std_"):
                    self.writer.add_scalar(key, value, it)
        if self.writer is not None and self.console == "line":
            done = it + 1 - start_it
            eta = (time.time() - self._t0) / max(done, 1) * (total_it - it - 1)
            print("\r" + status_line(self.metrics, total_it, eta), end="", flush=True)
            if (it + 1) % 10 == 0 or it + 1 == total_it:
                print(flush=True)

    def _row(
        self,
        it: int,
        collect_time: float,
        learn_time: float,
        loss_dict: dict,
        learning_rate: float,
        action_std: torch.Tensor,
    ) -> dict:
        """The iteration's metrics: counters and timings [s], means of the extras, losses (``Loss/<name>``)."""
        now = time.time()
        steps = self.cfg["num_steps_per_env"] * self.num_envs * self.gpu_world_size  # all ranks under torchrun
        row = {
            "iteration": it + 1,
            "mean_reward": statistics.mean(self.rewbuffer) if self.rewbuffer else None,
            "mean_episode_length": statistics.mean(self.lenbuffer) if self.lenbuffer else None,
            "steps_per_s": steps / max(collect_time + learn_time, 1e-9),
            "collect_s": collect_time,
            "learn_s": learn_time,
            "wall_s": now - self._t_last,
            "learning_rate": learning_rate,
            "action_std": action_std.mean().item(),
        }
        row.update(group_std(action_std))
        self._t_last = now
        row.update(extras_means(self.ep_extras))
        row.update({f"Loss/{k}": float(v) for k, v in loss_dict.items()})
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in row.items()}

    def _append(self, row: dict) -> None:
        """One line appended to ``metrics.jsonl`` and flushed (a crash loses at most the line being written)."""
        with open(os.path.join(self.log_dir, METRICS_FILE), "a", encoding="utf-8") as f:
            f.write(json.dumps(row) + "\n")
            f.flush()
