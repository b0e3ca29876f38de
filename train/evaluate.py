"""Evaluate a trained checkpoint as in the paper: tracking error, energy (p_cost) and push recovery.

Examples::

    python train/evaluate.py --checkpoint runs/no_predictor_X/model_1499.pt --tasks vx --seconds 20
    python train/evaluate.py --checkpoint CKPT --tasks vx,vy,wz --push 0.5 --num-envs 256 --json eval.json

Tracking tasks set one command axis, spread evenly over the paper's range (v_x in [-1, 1] m/s, v_y in [-0.7, 0.7]
m/s, w in [-0.7, 0.7] rad/s), the others zero; errors and power are averaged after a 2 s settling time over all
robots (a robot that falls is reset and keeps counting; falls are reported beside). ``--push V`` adds random
pushes up to V m/s every 15 s (Table III). With a predictive preset (ours, no_wheel_vel) each robot runs the argmin
of its predicted gait powers (tau -> 0), reselected every decision interval, unless ``--sample-gaits``; the share of
each running gait is reported per task. Nothing learns: the estimator and the power predictor stay as saved in the
checkpoint.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time

from wqwarp.cli.args import ArgumentParser, output_problem


def main(argv=None) -> int:
    from wqwarp.eval.loading import PHYSICS
    from wqwarp.eval.protocols import TASKS
    from wqwarp.rl.config import PRESETS
    from wqwarp.utils.provenance import write_result_json

    p = ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                       formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    p.add_argument("--checkpoint", required=True, help="model_<it>.pt written by train/ppo_newton.py")
    p.add_argument(
        "--preset",
        default=None,
        choices=sorted(PRESETS),
        help="label of the results; must be the method the checkpoint was trained as (default: the preset in the "
        "run's config.json). The environment is always built from the configuration stored in the checkpoint",
    )
    p.add_argument(
        "--tasks", default="vx,vy,wz", help=f"comma-separated tasks from {', '.join(TASKS)} (default vx,vy,wz)"
    )
    p.add_argument("--num-envs", type=int, default=None, help="robots per task (default 100; the paper uses 1000)")
    p.add_argument("--seconds", type=float, default=None, help="length of each rollout [s] (default 20; 60 push)")
    p.add_argument(
        "--paper-scale",
        action="store_true",
        help="the paper's scale: 1000 robots and 60 s per task (unless --num-envs / --seconds say otherwise); about "
        "30x the default's cost",
    )
    p.add_argument(
        "--push-interval", type=float, default=15.0, help="seconds between pushes (default 15, as the paper)"
    )
    p.add_argument(
        "--physics",
        default="",
        help="sim-to-sim: comma-separated physics to evaluate after the training physics, from "
        f"{', '.join(k for k in PHYSICS if k != 'train')}; deltas against the training physics are printed",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed of the evaluation (spawn yaws, pushes; default 0)")
    p.add_argument("--push", type=float, default=0.0, help="max push velocity [m/s]; 0 disables pushes (default)")
    p.add_argument(
        "--protocol",
        choices=("tracking", "push"),
        default="tracking",
        help="tracking (default): --tasks over the paper's tracking ranges, --push optional. push: Table III - tasks "
        "stand, vx, vy, wz with commands in [-1, 1], random pushes up to each of --push-levels m/s every 15 s along "
        "the trunk's x and y; a robot recovers if its trunk never touches the ground (default 60 s per run)",
    )
    p.add_argument("--push-levels", default="0.5,0.7", help="push protocol: comma-separated max push velocities [m/s]")
    p.add_argument("--device", default="cpu", help="cpu or cuda:N (default cpu)")
    p.add_argument(
        "--dt",
        type=float,
        default=None,
        help="physics step [s] (default: the training value 0.005); the policy keeps its 50 Hz step, e.g. --dt 0.001 "
        "checks that a power figure is not an artefact of the time step (the paper trains at 0.001)",
    )
    p.add_argument(
        "--sample-gaits",
        action="store_true",
        help="predictive presets: sample gaits from softmax(-p/tau) at the checkpoint's tau instead of the argmin "
        "(the default, tau -> 0)",
    )
    p.add_argument(
        "--force-gait",
        default=None,
        choices=("driving", "trotting", "walking"),
        help="predictive presets, diagnostics: run this gait instead of the selected one; the predictor's forecast "
        "for it is reported beside the realised power",
    )
    p.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = p.parse_args(argv)
    push_protocol = args.protocol == "push"
    if args.seconds is None:
        args.seconds = 60.0 if (push_protocol or args.paper_scale) else 20.0
    if args.num_envs is None:
        args.num_envs = 1000 if args.paper_scale else 100
    physics = [x.strip() for x in args.physics.split(",") if x.strip()]
    bad_physics = [x for x in physics if x not in PHYSICS or x == "train"]
    if bad_physics:
        print(f"error: --physics {bad_physics}: choose from {', '.join(k for k in PHYSICS if k != 'train')}",
              file=sys.stderr)  # fmt: skip
        return 2
    if args.push_interval <= 0:
        print(f"error: --push-interval must be > 0 s, got {args.push_interval}", file=sys.stderr)
        return 2
    if args.json and (problem := output_problem(args.json)):
        print(f"error: --json {args.json!r}: {problem}", file=sys.stderr)
        return 2
    if push_protocol:
        try:
            levels = [float(x) for x in args.push_levels.split(",") if x.strip()]
        except ValueError:
            levels = []
        if not levels or min(levels) <= 0:
            print(f"error: --push-levels {args.push_levels!r}: need positive velocities, e.g. 0.5,0.7", file=sys.stderr)
            return 2
        if args.tasks == "vx,vy,wz":  # the tracking default: use Table III's tasks
            args.tasks = "stand,vx,vy,wz"
    tasks = [t.strip() for t in args.tasks.split(",") if t.strip()]
    bad = [t for t in tasks if t not in TASKS]
    if bad or not tasks:
        print(f"error: unknown task(s) {bad}; choose from {', '.join(TASKS)}", file=sys.stderr)
        return 2
    if args.num_envs < 1 or args.seconds <= 2.0:
        print("error: need --num-envs >= 1 and --seconds > 2 (the settling time)", file=sys.stderr)
        return 2
    import warp as wp

    wp.config.quiet = True
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.protocols import PUSH_TASKS, run_task
    from wqwarp.rl.config import to_dict

    t_start = time.time()

    runs = [(lvl, t) for lvl in levels for t in tasks] if push_protocol else [(args.push, t) for t in tasks]
    by_physics = {}
    for phys in ["train", *physics]:
        t_phys = time.time()
        try:
            runner = make_policy_runner(args.checkpoint, args.preset, args.num_envs, args.device, dt=args.dt,
                                        evaluation_selection="sample" if args.sample_gaits else None,
                                        physics=phys, seed=args.seed)  # fmt: skip
        except ValueError as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
        if args.sample_gaits and runner.env.gait_selector.name != "predictive":
            print(f"error: --sample-gaits needs a predictive preset, not {runner.preset}", file=sys.stderr)
            return 2
        if args.force_gait:
            if runner.env.gait_selector.name != "predictive":
                print(f"error: --force-gait needs a predictive preset, not {runner.preset}", file=sys.stderr)
                return 2
            from wqwarp.control.gaits import gait_index

            runner.env.gait_selector.forced_gait = gait_index(args.force_gait)
        cfg = runner.env.cfg
        scale = "" if args.num_envs >= 1000 else " (the paper: 1000 robots; --paper-scale)"
        print(f"\n{runner.preset} checkpoint (iteration {runner.iteration}), {args.num_envs} robots{scale}, "
              f"{args.seconds:g} s, physics {phys}: dt {cfg.sim.dt:g} s x {cfg.sim.decimation}, joints "
              f"{cfg.sim.joint_model}, friction {cfg.domain_rand.nominal_friction:g}, seed {args.seed}")  # fmt: skip
        print(f"{'task':>9} {'MSE':>8} {'|err|':>8} {'p_cost [W]':>11} {'legs':>7} {'wheels':>7} {'CoT':>6} "
              f"{'upright':>8}  gaits")  # fmt: skip
        results = []
        for push, t in runs:

            def show(k, n, t=t):
                if sys.stdout.isatty() and (k == n or k % max(1, n // 20) == 0):
                    print(f"\r  {t}: {100 * k // n:3d} %", end="", flush=True)

            rng = PUSH_TASKS[t][1] if push_protocol else None
            r = run_task(runner, t, args.seconds, max_push=push, push_interval=args.push_interval, progress=show,
                         command_range=rng)  # fmt: skip
            results.append(dataclasses.asdict(r))
            label = f"{t}@{push:g}" if push_protocol else t
            cot = f"{r.cost_of_transport:6.2f}" if r.cost_of_transport is not None else f"{'-':>6}"
            print(
                f"\r{label:>9} {r.mse:8.4f} {r.mean_abs_error:8.3f} {r.mean_p_cost:11.1f} {r.mean_p_cost_legs:7.1f} "
                f"{r.mean_p_cost_wheels:7.1f} {cot} {100 * r.upright:7.1f}%  "
                + " ".join(f"{g} {100 * v:.0f}%" for g, v in (r.gait_usage or {}).items() if v > 0)
                + ("  (commands outside the training range)" if r.outside_training_range else "")
            )
        by_physics[phys] = {"physics": phys, "overrides": PHYSICS[phys], "config": to_dict(cfg),
                            "wall_time_s": time.time() - t_phys, "results": results}  # fmt: skip
        preset, iteration = runner.preset, runner.iteration
        del runner
    results = by_physics["train"]["results"]
    deltas = {}
    for phys in physics:
        deltas[phys] = [physics_delta(a, b) for a, b in zip(results, by_physics[phys]["results"], strict=True)]
        print(f"\nsim-to-sim: {phys} minus train")
        print(f"{'task':>9} {'dMSE':>8} {'dp_cost [W]':>12} {'(%)':>7} {'dlegs':>7} {'dwheels':>8} {'dupright':>9}")
        for d in deltas[phys]:
            print(f"{d['label']:>9} {d['mse']:8.4f} {d['mean_p_cost']:12.1f} {d['mean_p_cost_rel']:7.1%} "
                  f"{d['mean_p_cost_legs']:7.1f} {d['mean_p_cost_wheels']:8.1f} "
                  f"{100 * d['upright']:8.1f}%")  # fmt: skip
    if push_protocol:
        print("\nTable III: share of robots that recovered (trunk never touched the ground) [%]")
        print(f"{'max push':>9} " + " ".join(f"{t:>8}" for t in tasks))
        for lvl in levels:
            row = [r for r in results if r["max_push"] == lvl]
            print(f"{lvl:>7g} m/s " + " ".join(f"{100 * r['upright']:8.1f}" for r in row))
    if args.json:
        train = by_physics["train"]
        write_result_json(args.json, {
            "checkpoint": args.checkpoint, "preset": preset, "iteration": iteration, "protocol": args.protocol,
            "forced_gait": args.force_gait, "seed": args.seed, "num_envs": args.num_envs, "seconds": args.seconds,
            "push_interval": args.push_interval, "dt": train["config"]["sim"]["dt"],
            "decimation": train["config"]["sim"]["decimation"], "wall_time_s": time.time() - t_start,
            "config": train["config"], "results": results,
            "sim2sim": {p: {**by_physics[p], "deltas": deltas[p]} for p in physics},
        })  # fmt: skip
    return 0


def physics_delta(train: dict, other: dict) -> dict:
    """Change of each metric of one task from the training physics (``train``) to another (``other``)."""
    keys = ("mse", "mean_abs_error", "mean_p_cost", "mean_p_cost_legs", "mean_p_cost_wheels", "mean_p_mech",
            "mean_p_joule", "upright", "falls")  # fmt: skip
    out = {"task": train["task"], "max_push": train["max_push"]}
    out["label"] = f"{train['task']}@{train['max_push']:g}" if train["max_push"] else train["task"]
    out.update({k: other[k] - train[k] for k in keys})
    out["mean_p_cost_rel"] = out["mean_p_cost"] / train["mean_p_cost"] if train["mean_p_cost"] else float("nan")
    return out


if __name__ == "__main__":
    sys.exit(main())
