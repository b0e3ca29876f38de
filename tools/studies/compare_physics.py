"""Open-loop trajectories of the energy-audit scenarios on two physics backends, side by side.

Usage::

    python tools/studies/compare_physics.py [--scenarios standing,drive_0.5,drive_1.0,turn_0.5,trot_0.3,walk_0.3]
                                    [--backends mujoco_cpu,featherstone] [--dt 0.001] [--decimation 20]
                                    [--seconds 4] [--json PATH] [--plot PATH]

Each scenario of ``tools/energy_audit.py`` (the nominal gait open loop from the default pose, no policy) runs on every
backend for ``--seconds`` (1 robot), recording per policy step the trunk height [m], base v_x [m/s], yaw rate [rad/s]
and p_cost (legs, wheels) [W]. Reported per scenario and quantity: each backend's mean after the first second, and
the RMS difference of the two trajectories over the same time (the first backend is the reference). ``--plot``
draws height, v_x and p_cost over time for every scenario.

Output: a markdown table on stdout, a progress line per run on stderr, and the JSON (command, git commit, settings,
the trajectories and the summary) written atomically. Bad input: one ``error:`` line, exit code 2, nothing written.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from wqwarp.cli import energy_audit as audit
from wqwarp.cli.args import add_result_options, doc_parser

QUANTITIES = ("height", "v_x", "w_z", "p_cost", "p_cost_legs", "p_cost_wheels")
SETTLE_S = 1.0
"""Start of the compared window [s]: the first second holds the drop from the start pose."""


def compare(traces: dict, backends: list[str]) -> dict:
    """Means after ``SETTLE_S`` per backend and the RMS difference to the first backend, per quantity."""
    ref = traces[backends[0]]
    t = np.array([r["t"] for r in ref])
    keep = t > SETTLE_S
    out = {}
    for q in QUANTITIES:
        series = {b: np.array([r[q] for r in traces[b]])[keep] for b in backends}
        entry = {f"mean_{b}": float(series[b].mean()) for b in backends}
        for b in backends[1:]:
            entry[f"rms_{b}_vs_{backends[0]}"] = float(np.sqrt(np.mean((series[b] - series[backends[0]]) ** 2)))
        out[q] = entry
    return out


def plot(report: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(report["scenarios"])
    fig, axes = plt.subplots(len(names), 3, figsize=(12, 2.2 * len(names)), squeeze=False)
    for i, name in enumerate(names):
        for b, tr in report["scenarios"][name]["traces"].items():
            t = [r["t"] for r in tr]
            for j, q in enumerate(("height", "v_x", "p_cost")):
                axes[i, j].plot(t, [r[q] for r in tr], label=b, lw=1)
                axes[i, j].set_ylabel(f"{name}\n{q}" if j == 0 else q, fontsize=8)
    axes[0, 0].legend(fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    fig.tight_layout()
    from wqwarp.utils.provenance import save_figure

    save_figure(fig, path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    gaits = [s for s, (g, _) in audit.SCENARIOS.items() if g is not None]
    ap = doc_parser(__doc__)
    ap.add_argument(
        "--scenarios",
        default="standing,drive_0.5,drive_1.0,turn_0.5,trot_0.3,walk_0.3",
        help=f"comma-separated scenarios of tools/energy_audit.py (gaits only: {', '.join(gaits)})",
    )
    ap.add_argument(
        "--backends",
        default="mujoco_cpu,featherstone",
        help="two or more backends; the first is the reference (default mujoco_cpu,featherstone)",
    )
    ap.add_argument("--dt", type=float, default=0.001, help="physics step [s] (default 0.001, the paper's)")
    ap.add_argument("--decimation", type=int, default=20, help="substeps per policy step (default 20: 50 Hz)")
    ap.add_argument("--seconds", type=float, default=4.0, help="length of each run [s] (default 4)")
    add_result_options(ap)
    args = ap.parse_args(argv)
    scenarios = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    bad = [s for s in scenarios if s not in gaits]
    if bad or not scenarios:
        ap.error(f"unknown scenario {', '.join(bad) or '(none)'}; choose from {', '.join(gaits)}")
    backends = [b.strip() for b in args.backends.split(",") if b.strip()]
    from wqwarp.sim.config import BACKENDS

    if len(backends) < 2 or any(b not in BACKENDS or b == "auto" for b in backends):
        ap.error(f"--backends needs two or more of {', '.join(b for b in BACKENDS if b != 'auto')}")
    if not (0 < args.dt <= 0.02) or args.decimation < 1 or args.seconds <= SETTLE_S:
        ap.error(f"need 0 < --dt <= 0.02, --decimation >= 1 and --seconds > {SETTLE_S}")
    ap.check_outputs(args.json, args.plot)

    from wqwarp import quiet_warp

    quiet_warp()
    report = {
        "dt": args.dt,
        "decimation": args.decimation,
        "seconds": args.seconds,
        "settle_s": SETTLE_S,
        "backends": backends,
        "scenarios": {},
    }
    t0 = time.time()
    for name in scenarios:
        traces = {}
        for b in backends:
            traces[b] = []
            audit.run_scenario(name, args.dt, args.decimation, 0.0, args.seconds, 1, backend=b, trace=traces[b])
            print(f"[{time.time() - t0:6.1f} s] {name} on {b}", file=sys.stderr, flush=True)
        report["scenarios"][name] = {"summary": compare(traces, backends), "traces": traces}
    rows = [
        f"| scenario | quantity | {' | '.join(backends)} | RMS difference |",
        "|---|---|" + "---|" * len(backends) + "---|",
    ]
    for name, entry in report["scenarios"].items():
        for q in ("height", "v_x", "p_cost", "p_cost_legs", "p_cost_wheels"):
            e = entry["summary"][q]
            rms = ", ".join(f"{v:.3g}" for k, v in e.items() if k.startswith("rms_"))
            rows.append(f"| {name} | {q} | " + " | ".join(f"{e[f'mean_{b}']:.3g}" for b in backends) + f" | {rms} |")
    print("\n".join(rows))
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, report)
    if args.plot:
        plot(report, args.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
