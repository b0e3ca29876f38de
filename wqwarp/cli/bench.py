"""Benchmark the simulation core against raw ``mujoco.rollout`` on the same MjModel, in the same process.

Usage::

    python tools/bench.py [--sizes 1,64,256,1024] [--device cpu|cuda:0] [--backend auto|mujoco_cpu|mujoco_warp]
                          [--seconds 2] [--json PATH]

For each robot count N it reports:
    setup_s              building the Newton model and the backend (Simulator construction) [s]
    backend_steps_per_s  robot physics steps per second of the backend, actuation kernels off (torques held) and
                         robots reset every 25 policy steps [robot-steps/s]
    raw_steps_per_s      ``mujoco.rollout`` on all cores, N independent states, ``decimation`` steps per call,
                         constant holding torques [robot-steps/s]
    ratio                backend_steps_per_s / raw_steps_per_s
    policy_steps_per_s   full policy steps (actuation + power kernels every substep, physics, FK, contacts)
                         [robot-policy-steps/s]; compare with raw_steps_per_s / decimation
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from wqwarp.cli.args import UsageError, doc_parser, entry_point, parse_counts
from wqwarp.utils.io import output_problem


def add_bench_options(ap: argparse.ArgumentParser, sizes: str) -> None:
    """The options every benchmark shares (``tools/bench.py``, ``tools/bench_train.py``): ``--sizes`` (robot counts,
    default ``sizes``), ``--device`` and ``--json``."""
    ap.add_argument("--sizes", default=sizes, help=f"comma-separated robot counts (default {sizes})")
    ap.add_argument("--device", default="cpu", help="Warp (and torch) device: cpu or cuda:N (default cpu)")
    ap.add_argument("--json", default=None, help="also write the results as JSON to this path (atomically)")


def parse_bench_args(ap: argparse.ArgumentParser, argv: list[str] | None) -> tuple[argparse.Namespace, list[int]]:
    """Parse ``argv``; with the robot counts of ``--sizes``. :class:`UsageError` for a bad ``--sizes`` or an
    unwritable ``--json`` (the command's :func:`entry_point` prints it and exits 2)."""
    args = ap.parse_args(argv)
    try:
        return args, bench_sizes(args)
    except ValueError as e:
        raise UsageError(str(e)) from None


def bench_sizes(args: argparse.Namespace) -> list[int]:
    """The robot counts of ``--sizes``; ValueError naming the option for bad ``--sizes`` or an unwritable ``--json``."""
    try:
        sizes = parse_counts(args.sizes)
    except ValueError as e:
        raise ValueError(f"--sizes: {e}") from None
    if args.json and (problem := output_problem(args.json)):
        raise ValueError(f"--json {args.json!r}: {problem}")
    return sizes


def device_description(device) -> str:
    """``cuda:0`` style name of a Warp CUDA device, else ``cpu (K cores)``."""
    return device.name if device.is_cuda else f"cpu ({os.cpu_count()} cores)"


def _time(fn, seconds: float) -> tuple[float, int]:
    fn()  # warm-up (compiles, captures)
    n, t0 = 0, time.perf_counter()
    while True:
        fn()
        n += 1
        dt = time.perf_counter() - t0
        if dt >= seconds and n >= 3:
            return dt, n


def bench_size(n: int, device: str, backend: str, seconds: float, cuda_graph: bool = True) -> dict:
    import mujoco
    from mujoco import rollout

    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    t0 = time.perf_counter()
    sim = Simulator(SimConfig(num_envs=n, device=device, backend=backend, cuda_graph=cuda_graph))
    setup = time.perf_counter() - t0
    dec = sim.cfg.decimation
    for _ in range(25):  # settle into the standing pose
        sim.step()

    chunk = 25  # policy steps per timed call; robots are reset after each so none drifts or falls for long

    def run(actuate: bool):
        for _ in range(chunk):
            sim.step(actuate=actuate)
        sim.reset(all_ids)

    all_ids = np.arange(n)
    dt, k = _time(lambda: run(False), seconds)
    backend_sps = n * dec * chunk * k / dt
    dt, k = _time(lambda: run(True), seconds)
    policy_sps = n * chunk * k / dt

    # Raw baseline on the CPU MjModel of this robot (the CPU backend's, or a fresh conversion for mujoco_warp).
    if sim.backend == "mujoco_cpu":
        m, spec_state = sim.mj_model, sim.physics.state_spec
        state0 = sim.physics.current_state().copy()
    else:
        cpu = Simulator(SimConfig(num_envs=1, device="cpu", backend="mujoco_cpu"))
        for _ in range(25):
            cpu.step()
        m, spec_state = cpu.mj_model, cpu.physics.state_spec
        state0 = np.repeat(cpu.physics.current_state(), n, axis=0)
    hold = np.repeat(sim.joint_f.numpy()[:1], n, axis=0)  # constant holding torques (standing robot)
    nthread = os.cpu_count() or 1
    control = np.repeat(hold[:, None, :], dec, axis=1).astype(np.float64)
    out = np.zeros((n, dec, state0.shape[1]))
    datas = [mujoco.MjData(m) for _ in range(min(nthread, n))]
    qfrc = mujoco.mjtState.mjSTATE_QFRC_APPLIED.value
    with rollout.Rollout(nthread=len(datas) if len(datas) > 1 else 0) as r:
        models = [m] * n

        def raw():
            r.rollout(models, datas, state0, control, control_spec=qfrc, nstep=dec, state=out, skip_checks=True)

        dt, k = _time(raw, seconds)
    del spec_state
    raw_sps = n * dec * k / dt
    return {
        "n": n,
        "backend": sim.backend,
        "setup_s": round(setup, 3),
        "backend_steps_per_s": round(backend_sps, 1),
        "raw_steps_per_s": round(raw_sps, 1),
        "ratio": round(backend_sps / raw_sps, 3),
        "policy_steps_per_s": round(policy_sps, 1),
        "policy_vs_raw": round(policy_sps * dec / raw_sps, 3),
    }


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__, epilog_from=2)
    add_bench_options(ap, "1,64,256,1024")
    ap.add_argument("--backend", default="auto", help="auto | mujoco_cpu | mujoco_warp (default auto)")
    ap.add_argument("--seconds", type=float, default=2.0, help="minimum timed wall time per measurement (default 2)")
    ap.add_argument(
        "--no-cuda-graph",
        action="store_true",
        help="mujoco_warp on CUDA: launch the decimation loop's kernels one by one instead of replaying "
        "a captured CUDA graph (to measure what the graph saves)",
    )
    args, sizes = parse_bench_args(ap, argv)
    import warp as wp

    from wqwarp import quiet_warp

    quiet_warp()
    desc = device_description(wp.get_device(args.device))
    results = []
    header = (
        f"{'N':>6} {'backend':>12} {'setup[s]':>9} {'backend st/s':>13} {'raw st/s':>11} {'ratio':>6} "
        f"{'policy st/s':>12} {'policy/raw':>10}"
    )
    print(f"device: {desc}\n{header}", flush=True)
    for n in sizes:
        r = bench_size(n, args.device, args.backend, args.seconds, cuda_graph=not args.no_cuda_graph)
        r["cuda_graph"] = not args.no_cuda_graph
        results.append(r)
        print(
            f"{r['n']:>6} {r['backend']:>12} {r['setup_s']:>9.2f} {r['backend_steps_per_s']:>13.0f} "
            f"{r['raw_steps_per_s']:>11.0f} {r['ratio']:>6.2f} {r['policy_steps_per_s']:>12.0f} "
            f"{r['policy_vs_raw']:>10.2f}",
            flush=True,
        )
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, {"device": desc, "results": results})
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
