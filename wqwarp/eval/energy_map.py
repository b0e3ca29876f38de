"""Gait energy map of a predictive checkpoint: over a grid of commands, the measured power of each gait, the power
predictor's estimate of it, and the gait that wins.

Two command planes: (v_x, v_y) at w = 0 and (v_x, w) at v_y = 0, ``grid`` values per axis over the paper's
evaluation ranges (v_x [-1, 1] m/s, v_y [-0.7, 0.7] m/s, w [-0.7, 0.7] rad/s). Every cell runs one robot per gait
of the checkpoint's library (Table I: driving, trotting, walking), the gait forced for the whole rollout, all robots
in one batch, commands held, no randomisation. Measured per robot over the second half of ``seconds``: mean p_cost
(legs and wheels), the squared velocity error, and whether the trunk touched the ground. Predicted: the mean over
the same steps of the predictor's output for that gait, from the observations of the cell's robots. The measured
winner is the cheapest gait whose robot stayed up, the tracking winner the cheapest whose robot also tracked its
command (squared velocity error at most :data:`TRACKING_LIMIT`); the predicted winner is the argmin of the
predictions over every gait (what the paper's rule selects), ``selected`` the gait the checkpoint's own criterion
selects from the cell's mean predictions and its command (``PredictiveGaitSelector.rule_candidates``, both masks: the
same as the predicted winner with the paper's ``power`` rule; with ``kinematic`` never driving for a lateral
command; with a tracking head, ``feasible`` or ``kinematic_feasible``, the cheapest gait predicted to track, whose
predicted squared error per gait is reported too).
Energy alone can favour a gait that does not do the task (driving under a lateral command stands still, cheaply):
the figure marks such cells.

The policy was trained with the gaits its selector chose; a forced gait it rarely ran during training measures
that gait under this policy, not the gait's best possible power. Nothing learns.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TextIO

import numpy as np
import torch

from wqwarp.eval.options import SelectionOptions, option
from wqwarp.eval.rollout import evaluation_session, start_rollout
from wqwarp.rl.gait_selection import both_candidates, tracking_error

RANGES = {"vx": (-1.0, 1.0), "vy": (-0.7, 0.7), "wz": (-0.7, 0.7)}
AXES = {"vx": 0, "vy": 1, "wz": 2}
TRACKING_LIMIT = 0.05
"""Squared velocity error [(m/s)^2, (rad/s)^2 summed over v_x, v_y, w] up to which a gait counts as tracking its
command (0.05: an error of about 0.22 m/s)."""
PLANES = (("vx", "vy"), ("vx", "wz"))


def grid_commands(grid: int) -> list[tuple[str, tuple[float, float, float]]]:
    """``[(plane, (vx, vy, wz)), ...]``: ``grid`` x ``grid`` cells per plane of :data:`PLANES`."""
    cells = []
    for a, b in PLANES:
        for u in np.linspace(*RANGES[a], grid):
            for v in np.linspace(*RANGES[b], grid):
                c = [0.0, 0.0, 0.0]
                c[AXES[a]], c[AXES[b]] = round(float(u), 4), round(float(v), 4)
                cells.append((f"{a}-{b}", tuple(c)))
    return cells


@torch.no_grad()
def measure_forced_gaits(runner, commands: torch.Tensor, gaits: torch.Tensor, seconds: float, progress=None) -> dict:
    """Robot i holds ``commands[i]`` in gait ``gaits[i]`` for ``seconds`` [s]; per robot over the second half: mean
    p_cost (``p``, ``legs``, ``wheels``) [W], squared velocity error ``err``, the predictor's mean output per gait
    ``pred`` (N, G) [W] (and, with a tracking head, its mean output ``pred_err`` (N, G)), the share of steps not in
    the forced gait ``wrong_gait``, and ``fell`` (N,) bool. Needs the predictive selection; the env is left as it
    was found."""
    env = runner.env
    sel = env.gait_selector
    if sel.name != "predictive":
        raise ValueError(f"the energy map needs a predictive preset (ours, no_wheel_vel), not {runner.preset}")
    with evaluation_session(env):
        sel.force(gaits)
        obs = start_rollout(env, commands, seconds)
        steps = max(2, int(round(seconds / env.dt)))
        n, dev = env.num_envs, env.device
        acc = {k: torch.zeros(n, device=dev) for k in ("p", "legs", "wheels", "elec", "err", "wrong_gait", "count")}
        acc["pred"] = torch.zeros(n, sel.num_gaits, device=dev)
        if sel.tracker is not None:
            acc["pred_err"] = torch.zeros(n, sel.num_gaits, device=dev)
        fell = torch.zeros(n, dtype=torch.bool, device=dev)
        for k in range(steps):
            p_now = sel.predict(obs["policy"])
            e_now = sel.predict_error(obs["policy"])
            obs, _, dones, _ = env.step(runner.policy(obs))
            fell |= dones.bool()
            if k >= steps // 2:
                b = env.base_state()
                acc["err"] += tracking_error(commands, b["lin_vel"], b["ang_vel"])
                acc["p"] += env.tv["p_cost"]
                acc["legs"] += env.tv["p_cost_legs"]
                acc["wheels"] += env.tv["p_cost_wheels"]
                acc["elec"] += env.tv["p_elec"]
                acc["pred"] += p_now
                if e_now is not None:
                    acc["pred_err"] += e_now
                acc["wrong_gait"] += (env.active_gait() != gaits).float()
                acc["count"] += 1
            if progress is not None:
                progress(k + 1, steps)
    c = acc.pop("count").clamp(min=1)
    out = {k: v / (c[:, None] if v.dim() == 2 else c) for k, v in acc.items()}
    out["fell"] = fell
    return out


def tracks_command(sq_error: float, fell: bool) -> bool:
    """Whether a robot counts as tracking its command: upright, squared velocity error at most TRACKING_LIMIT."""
    return not fell and sq_error <= TRACKING_LIMIT


def _cheapest(gaits: list[str], power: torch.Tensor, candidates: list[int]) -> str | None:
    """The gait of ``candidates`` (indices) with the lowest ``power``, or None if there are none."""
    return gaits[min(candidates, key=lambda k: float(power[k]))] if candidates else None


def summarise_cells(cells: list, gaits: list[str], m: dict, allowed: torch.Tensor | None = None) -> list[dict]:
    """One result entry per cell from :func:`measure_forced_gaits` of robots ordered cell * G + gait; ``allowed``
    (cells, G) bool: the gaits the checkpoint's criterion may select in each cell (None: every gait)."""
    g = len(gaits)
    out = []
    for i, (plane, command) in enumerate(cells):
        cell = {k: v[i * g : (i + 1) * g] for k, v in m.items()}
        per = {
            key: {gaits[k]: float(cell[key][k]) for k in range(g)}
            for key in ("p", "legs", "wheels", "elec", "err", "wrong_gait")
        }
        predicted = {gaits[k]: float(cell["pred"].mean(0)[k]) for k in range(g)}  # from all the cell's robots' obs
        fell = [bool(cell["fell"][k]) for k in range(g)]
        up = [k for k in range(g) if not fell[k]]
        ok = [k for k in range(g) if tracks_command(float(cell["err"][k]), fell[k])]
        out.append(
            {
                "plane": plane,
                "command": list(command),
                "measured_p_cost": per["p"],
                "measured_p_cost_legs": per["legs"],
                "measured_p_cost_wheels": per["wheels"],
                "measured_p_elec": per["elec"],
                "sq_velocity_error": per["err"],
                "fell": dict(zip(gaits, fell, strict=True)),
                "share_not_in_forced_gait": per["wrong_gait"],
                "predicted_p_cost": predicted,
                "measured_winner": _cheapest(gaits, cell["p"], up),
                "measured_winner_tracking": _cheapest(gaits, cell["p"], ok),
                "measured_winner_elec": _cheapest(gaits, cell["elec"], up),
                "measured_winner_elec_tracking": _cheapest(gaits, cell["elec"], ok),
                "predicted_winner": min(predicted, key=predicted.get),
                "selected": _cheapest(
                    gaits,
                    cell["pred"].mean(0),
                    list(range(g)) if allowed is None else allowed[i].nonzero().flatten().tolist(),
                ),
            }
        )
        if "pred_err" in cell:
            err = cell["pred_err"].mean(0)
            out[-1]["predicted_sq_velocity_error"] = {gaits[k]: float(err[k]) for k in range(g)}
    return out


def cell_means(m: dict, key: str, cells: int) -> torch.Tensor | None:
    """(cells, G) mean over each cell's robots of a per-robot (N, G) measurement ``m[key]``; None if absent."""
    if key not in m:
        return None
    return m[key].reshape(cells, -1, m[key].shape[-1]).mean(1)


@dataclass(kw_only=True)
class EnergyMapOptions(SelectionOptions):
    """Options of the energy-map protocol (``tools/gait_energy_map.py``)."""

    grid: int = option(5, help="values per command axis (default 5: 2 x 25 cells)")
    seconds: float = option(4.0, help="rollout length [s]; the second half is measured")
    png: str | None = option(None, help="draw the map here (matplotlib)", output=True)

    def validate(self) -> None:
        if self.grid < 2 or self.seconds < 0.2:
            raise ValueError("need --grid >= 2 and --seconds >= 0.2")


def energy_map(opts: EnergyMapOptions, log: TextIO) -> dict:
    """Per command cell of :func:`grid_commands`: each gait's measured and predicted power and the winners."""
    from wqwarp.eval.loading import checkpoint_gait_names, make_policy_runner
    from wqwarp.rl.config import to_dict

    opts.validate()
    t0 = time.time()
    cells = grid_commands(opts.grid)
    gaits = list(checkpoint_gait_names(opts.checkpoint))  # one robot per gait of the run's library and cell
    g = len(gaits)
    runner = make_policy_runner(
        opts.checkpoint, None, len(cells) * g, opts.device, seed=opts.seed, criterion=opts.criterion
    )
    dev = runner.env.device
    cmd = torch.tensor([c for _, c in cells for _ in range(g)], dtype=torch.float32, device=dev)  # robot = cell*g+k

    def progress(k: int, n: int) -> None:
        if log.isatty() and k % max(1, n // 20) == 0:
            print(f"\r  {100 * k // n:3d} %", end="", flush=True, file=log)

    m = measure_forced_gaits(runner, cmd, torch.arange(g, device=dev).repeat(len(cells)), opts.seconds, progress)
    cell_cmd = torch.tensor([c for _, c in cells], dtype=torch.float32, device=dev)
    sel = runner.env.gait_selector
    kinematic, feasible = sel.rule_candidates(None, cell_cmd, cell_means(m, "pred_err", len(cells)))
    out_cells = summarise_cells(cells, gaits, m, both_candidates(kinematic, feasible))
    measure = runner.env.cfg.power_measure  # what the predictor was trained to forecast
    key = "measured_winner" if measure == "mechanical" else "measured_winner_elec"
    agree = [cl[key] == cl["predicted_winner"] for cl in out_cells if cl[key]]
    print(
        f"\r{runner.preset} checkpoint (iteration {runner.iteration}): {len(cells)} cells x {g} gaits, "
        f"{opts.seconds:g} s; predicted winner = measured winner ({measure} power) in {sum(agree)}/{len(agree)} cells",
        file=log,
    )
    for label, k in (("mechanical", "measured_winner"), ("electrical", "measured_winner_elec")):
        wins = {gt: sum(cl[k] == gt for cl in out_cells) for gt in gaits}
        print(f"measured winners, {label} power: " + ", ".join(f"{gt} {w}" for gt, w in wins.items()), file=log)
    untracked = sum(cl["measured_winner"] != cl["measured_winner_tracking"] for cl in out_cells)
    print(
        f"cells where the cheapest gait does not track its command (squared error > {TRACKING_LIMIT}): {untracked}",
        file=log,
    )
    rule = rule_summary(out_cells, kinematic)
    print(
        f"{runner.env.cfg.predictor.criterion} criterion: selects the cheapest gait that tracks in "
        f"{rule['selects_cheapest_tracking']}/{rule['cells_with_a_tracking_gait']} cells, a gait that tracks in "
        f"{rule['selects_a_tracking_gait']}/{len(out_cells)}",
        file=log,
    )
    if "tracking_head" in rule:
        head = rule["tracking_head"]
        print(
            f"tracking head: its argmin among the candidates is the measured best tracker in "
            f"{head['argmin_is_best_tracker']}/{len(out_cells)} cells; where a gait tracks, it predicts "
            f"{head['median_predicted_where_tracking']:.3f} (median; measured <= {TRACKING_LIMIT})",
            file=log,
        )
    return {
        "checkpoint": opts.checkpoint,
        "preset": runner.preset,
        "iteration": runner.iteration,
        "seed": opts.seed,
        "grid": opts.grid,
        "seconds": opts.seconds,
        "wall_time_s": time.time() - t0,
        "power_measure": measure,
        "winner_agreement": sum(agree) / max(len(agree), 1),
        "tracking_limit": TRACKING_LIMIT,
        "cheapest_does_not_track": untracked,
        "criterion": runner.env.cfg.predictor.criterion,
        "rule": rule,
        "cells": out_cells,
        "config": to_dict(runner.env.cfg),
    }


def rule_summary(cells: list[dict], kinematic: torch.Tensor | None) -> dict:
    """How the rule's per-cell ``selected`` gait fares on the measured map: in how many cells it is the cheapest gait
    that tracks (of the cells where one does), in how many it tracks at all (upright, squared error at most
    :data:`TRACKING_LIMIT`); with a tracking head, in how many cells the head's argmin among the rule's kinematic
    candidates (``kinematic`` (cells, G) rows; every gait where None) is the measured best tracker among them, and
    the head's median prediction over the robot-cells whose gait tracks."""

    def tracks(cell: dict, gait: str) -> bool:
        return tracks_command(cell["sq_velocity_error"][gait], cell["fell"][gait])

    out = {
        "selects_cheapest_tracking": sum(
            c["selected"] == c["measured_winner_tracking"] for c in cells if c["measured_winner_tracking"]
        ),
        "cells_with_a_tracking_gait": sum(1 for c in cells if c["measured_winner_tracking"]),
        "selects_a_tracking_gait": sum(tracks(c, c["selected"]) for c in cells),
    }
    if "predicted_sq_velocity_error" not in cells[0]:
        return out
    best = 0
    where_tracking = []
    for i, c in enumerate(cells):
        pred, meas = c["predicted_sq_velocity_error"], c["sq_velocity_error"]
        gaits = list(meas)
        kin = gaits if kinematic is None else [g for k, g in enumerate(gaits) if bool(kinematic[i, k])]
        best += min(kin, key=pred.get) == min(kin, key=meas.get)
        where_tracking += [pred[g] for g in gaits if tracks(c, g)]
    out["tracking_head"] = {
        "argmin_is_best_tracker": best,
        "median_predicted_where_tracking": float(np.median(where_tracking)) if where_tracking else float("nan"),
        "robot_cells_tracking": len(where_tracking),
    }
    return out


def draw_energy_map(result: dict, path: str, command: str | None = None) -> None:
    """Per plane: the measured p_cost of each gait (the prediction printed under it) and the winners."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap

    cells = result["cells"]
    gaits = list(cells[0]["measured_p_cost"])
    axes_idx = AXES
    labels = {"vx": "$v_x$ [m/s]", "vy": "$v_y$ [m/s]", "wz": "$\\omega$ [rad/s]"}
    fig, ax = plt.subplots(len(PLANES), len(gaits) + 1, figsize=(4.2 * (len(gaits) + 1), 3.8 * len(PLANES)))
    vmax = max(max(c["measured_p_cost"].values()) for c in cells)
    for row, (a, b) in enumerate(PLANES):
        sub = [c for c in cells if c["plane"] == f"{a}-{b}"]
        us = sorted({c["command"][axes_idx[a]] for c in sub})
        vs = sorted({c["command"][axes_idx[b]] for c in sub})
        at = {(c["command"][axes_idx[a]], c["command"][axes_idx[b]]): c for c in sub}
        for col, gait in enumerate(gaits):
            m = np.array([[at[(u, v)]["measured_p_cost"][gait] for u in us] for v in vs])
            im = ax[row, col].imshow(m, origin="lower", cmap="viridis", vmin=0, vmax=vmax, aspect="auto")
            for i, v in enumerate(vs):
                for j, u in enumerate(us):
                    c = at[(u, v)]
                    mark = " x" if c["fell"][gait] else ""
                    text = f"{c['measured_p_cost'][gait]:.0f}{mark}\n({c['predicted_p_cost'][gait]:.0f})"
                    ax[row, col].text(j, i, text, ha="center", va="center", fontsize=6, color="w")
            ax[row, col].set_title(f"{gait}: measured (predicted) W", fontsize=9)
            fig.colorbar(im, ax=ax[row, col], fraction=0.046)
        win = np.array(
            [
                [gaits.index(at[(u, v)]["measured_winner"]) if at[(u, v)]["measured_winner"] else -1 for u in us]
                for v in vs
            ]
        )
        cmap = ListedColormap(["#dddddd", *plt.get_cmap("tab10").colors[: len(gaits)]])  # grey: no gait stayed up
        ax[row, -1].imshow(win + 1, origin="lower", cmap=cmap, vmin=0, vmax=len(gaits), aspect="auto")
        for i, v in enumerate(vs):
            for j, u in enumerate(us):
                c = at[(u, v)]
                text = f"{(c['measured_winner'] or '-')[:5]}\nsel {c.get('selected', c['predicted_winner'])[:5]}"
                if c["measured_winner_tracking"] != c["measured_winner"]:
                    text += f"\ntrack {(c['measured_winner_tracking'] or 'none')[:5]}"
                ax[row, -1].text(j, i, text, ha="center", va="center", fontsize=6)
        ax[row, -1].set_title(
            "cheapest: measured (colour); 'sel': the rule's choice;\n'track': cheapest that tracks", fontsize=8
        )
        for axx in ax[row]:
            axx.set_xticks(range(len(us)), [f"{u:g}" for u in us], fontsize=7)
            axx.set_yticks(range(len(vs)), [f"{v:g}" for v in vs], fontsize=7)
            axx.set_xlabel(labels[a])
        ax[row, 0].set_ylabel(labels[b])
    fig.suptitle(
        f"gait energy map: {result['preset']} (iteration {result['iteration']}), x = the trunk touched the ground",
        fontsize=10,
    )
    fig.tight_layout()
    from wqwarp.utils.provenance import save_figure

    save_figure(fig, path, dpi=90, command=command)
