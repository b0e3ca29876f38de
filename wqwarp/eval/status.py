"""The README's status table, built from a reproduction's ``results.json`` (``tools/readme_status.py`` writes it
between two marker lines of the README, and a test holds the README to it): one row per claim of the paper, with
the default tasks' numbers as means and 95 % intervals over the seeds and the claims' verdicts
(:func:`wqwarp.eval.report.paper_claims`). Nothing here is measured; a number absent from the results reads "not
run yet"."""

from __future__ import annotations

from wqwarp.eval.report import MOVING, PLAIN_NAMES, _fmt, _over_tasks, cell_text, seeds_by_method
from wqwarp.rl.presets import PAPER_NAMES

BEGIN = "<!-- status table: built by tools/readme_status.py from docs/results/cpu/results.json; do not edit -->"
END = "<!-- end of the status table -->"
PAGE = "docs/RESULTS.md"
"""Where the rows link (the page the results.json belongs to)."""
NOT_RUN = "not run yet"
CLAIMS_HEADING = "The paper's claims, judged over seeds"
TRACKING_HEADING = "Tracking and energy (the paper's Fig. 5)"
PUSH_HEADING = "Push recovery (the paper's Table III)"
S2S_HEADING = "Sim-to-sim"
"""The page's headings the rows link to (``wqwarp.eval.report.render_markdown`` writes them)."""


UPRIGHT_MSE = (("upright", 1, 100.0), ("mse", 4, 1.0))


def _cells(summary: dict, key: str, labels: tuple[str, ...] | None = None) -> str:
    """``label estimate [interval], verdict`` of a claim's comparisons (all, or those ``labels``)."""
    claim = next((c for c in summary.get("claims") or [] if c["id"] == key), None)
    if claim is None:
        return NOT_RUN
    share = claim["cells"][0]["kind"] == "mean"
    parts = []
    for cell in claim["cells"]:
        if labels is not None and cell["label"] not in labels:
            continue
        est, verdict = cell_text(cell, share)
        parts.append(f"{cell['label']} {est}" + (f": **{verdict}**" if cell["estimate"] is not None else ""))
    return "; ".join(parts) or NOT_RUN


def _anchor(title: str) -> str:
    """GitHub's anchor of a heading."""
    keep = "".join(ch for ch in title.lower() if ch.isalnum() or ch in " -_")
    return keep.replace(" ", "-")


def status_table(summary: dict) -> str:
    """The table (with its marker lines) for a reproduction's ``results.json`` content ``summary``."""
    pres = summary["presets"]
    seeds = summary["seeds"]
    ours = (pres.get("ours") or {}).get("tracking") or {}
    trot = (pres.get("no_predictor") or {}).get("tracking") or {}
    claims_link = f"[claims]({PAGE}#{_anchor(CLAIMS_HEADING)})"
    fig5 = f"[Fig. 5]({PAGE}#{_anchor(TRACKING_HEADING)})"
    table3 = f"[Table III]({PAGE}#{_anchor(PUSH_HEADING)})"
    has_s2s = any(e.get("sim2sim") for e in pres.values())  # the page has the section only then
    s2s_link = f"[sim-to-sim]({PAGE}#{_anchor(S2S_HEADING)})" if has_s2s else f"[{PAGE}]({PAGE})"

    def metric(block: dict, task: str, m: str, digits: int, scale: float = 1.0) -> str:
        return _fmt((block.get(task) or {}).get(m), digits, scale)

    tracking = (
        "; ".join(f"{PLAIN_NAMES[t]} {metric(ours, t, 'mse', 4)}" for t in MOVING) + " (fixed trot "
        + ", ".join(metric(trot, t, "mse", 4) for t in MOVING) + "); upright "
        + ", ".join(f"{PLAIN_NAMES[t]} {metric(ours, t, 'upright', 1, 100.0)} %" for t in ("stand", *MOVING))
        if ours else NOT_RUN
    )  # fmt: skip
    gaits = (
        f"driving {_fmt(_over_tasks(ours, 'legged_share', ('vx',), lambda v: 1.0 - v[0]), 0, 100.0)} % of the v_x "
        f"task; legged gaits {_cells(summary, 'legged_lateral')}"
        if ours else NOT_RUN
    )  # fmt: skip
    push_ours = []
    for lvl in ("0.5", "0.7"):
        block = ((pres.get("ours") or {}).get("push") or {}).get(lvl) or {}
        if block:
            row = {t: {"upright": (block.get(t) or {}).get("upright")} for t in ("stand", *MOVING)}
            cells = ", ".join(f"{PLAIN_NAMES[t]} {metric(row, t, 'upright', 1, 100.0)}" for t in ("stand", *MOVING))
            push_ours.append(f"{lvl} m/s: {cells} %")
    push = (
        "Ours upright " + "; ".join(push_ours) + "; against the others (points over the four settings): "
        + "; ".join(_cells(summary, f"push_{lvl}") for lvl in ("0.5", "0.7"))
        if push_ours else NOT_RUN
    )  # fmt: skip
    if not push_ours and any(e.get("push") for e in pres.values()):  # the others' records, so none is hidden
        push = f"{NOT_RUN} for Ours; seeds with a push record: {seeds_by_method(pres, 'push', 'upright')}"
    s2s = []
    for p, e in pres.items():
        block = e.get("sim2sim") or {}
        if "authors_robot" in block and "train" in block:
            up, mse = (_fmt(_over_tasks(block["authors_robot"], m), d, k) for m, d, k in UPRIGHT_MSE)
            own = _fmt(_over_tasks(block["train"], "mse"), 4)
            s2s.append(f"{PAPER_NAMES[p]} upright {up} %, MSE {mse} (on our robot {own})")
    dt = ((pres.get("ours") or {}).get("sim2sim") or {}).get("dt0.001")
    base = ((pres.get("ours") or {}).get("sim2sim") or {}).get("train")
    dt_text = NOT_RUN
    if dt and base:
        from wqwarp.eval.stats import diff_ci, paired

        _, x, y = paired(_over_tasks(dt, "mean_p_cost"), _over_tasks(base, "mean_p_cost"))
        dt_text = f"{_fmt(diff_ci(x, y) if x else None, 2)} W"
    n = len(seeds)
    rows = [
        BEGIN,
        f"The default tasks (`<method>`) on training seed{'s' * (n != 1)} {', '.join(map(str, seeds))}, none of "
        "which chose a lever; mean ± half the 95 % interval over the seeds evaluated so far; each verdict from its "
        f"interval, with the number of seeds it rests on (holds / does not hold / undecided). Source: [{PAGE}]({PAGE}) "
        "and its `results.json`.",
        "",
        "| the paper's claim | here | record |",
        "|---|---|---|",
        f"| a residual policy on the nominal gaits tracks v_x, v_y and w | `ours` MSE {tracking} | {fig5} |",
        f"| energy-aware selection drives forward and steps sideways (Fig. 6) | `ours` {gaits} | {fig5}, "
        f"{claims_link} |",
        "| up to 35 % less energy than a fixed gait | `ours` / the fixed trot, p_cost: "
        f"{_cells(summary, 'fixed_gait_p_cost', ('v_x task', 'three moving tasks'))}; as the battery pays it "
        f"(p_elec): {_cells(summary, 'fixed_gait_p_elec', ('v_x task', 'three moving tasks'))} | {claims_link} |",
        f"| ... at comparable tracking | `ours` / the fixed trot, MSE: {_cells(summary, 'comparable_tracking')} | "
        f"{claims_link} |",
        f"| lowest power of the methods | `ours` / each other method over the three tasks, p_cost: "
        f"{_cells(summary, 'lowest_power_p_cost')} | {claims_link} |",
        f"| push recovery (Table III) | {push} | {table3}, {claims_link} |",
        "| (energy is the robot's) | "
        + (
            f"`ours`'s p_cost at the paper's dt 0.001 moves by {dt_text} (mean over the three tasks, paired by "
            "seed); legs and wheels apart on the page"
            if dt_text != NOT_RUN
            else NOT_RUN
        )
        + f" | {s2s_link} |",
        f"| sim-to-sim on the authors' robot | {'; '.join(s2s) or NOT_RUN} | {s2s_link} |",
        END,
    ]
    return "\n".join(rows)


def replace_block(text: str, table: str) -> str:
    """``text`` (the README) with its block between :data:`BEGIN` and :data:`END` replaced by ``table``;
    ValueError when the markers are missing."""
    try:
        a, b = text.index(BEGIN), text.index(END) + len(END)
    except ValueError:
        raise ValueError(f"no status block (a line {BEGIN!r} ... {END!r})") from None
    return text[:a] + table + text[b:]
