"""What a wheel-speed mismatch costs: the nominal driving gait (every residual 0, the gait forced to ``driving``;
``--gait`` forces another) at a held forward command, with constant wheel-speed offsets added to Eq. 3's nominal
wheel velocities through the wheel actions (offset / wheel scale), by pattern and size. Four wheels on one rigid
body that roll on flat ground can only agree on one speed; wheel-speed targets that disagree make the PID wheels
push against each other through the ground (slip), and that power buys no motion. This measures how many watts
each rad/s of disagreement costs, so a policy's mean wheel actions (``wheel_residual_probe.py``) can be read as
watts.

Usage::

    python tools/studies/wheel_mismatch.py --checkpoint runs/ours_s1_config/model_0.pt --vx 0.8 \\
        --offsets 0.1,0.25,0.5,1 --json docs/studies/residual_energy/wheel_mismatch.json

Patterns (wheel order FR, FL, RR, RL; each wheel's offset is the pattern's sign times the size, rad/s):
``common`` all four +d (the wheels agree: the robot rolls faster, nothing fights), ``one`` RL only +d,
``fore_aft`` front +d and rear -d, ``left_right`` left +d and right -d (a skid turn). Per rollout: p_cost of legs
and wheels, per-wheel torque, base v_x and yaw rate, and the share of robots upright. The offset 0 (the nominal
gait) is always run. The policy's weights do not enter; the checkpoint gives the configuration (wheel scale, PID
gains, physics). Nothing learns.
"""

from __future__ import annotations

import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point

PATTERNS = {
    "common": (1.0, 1.0, 1.0, 1.0),
    "one": (0.0, 0.0, 0.0, 1.0),
    "fore_aft": (1.0, 1.0, -1.0, -1.0),
    "left_right": (-1.0, 1.0, -1.0, 1.0),
}
"""Pattern -> sign of each wheel's offset (FR, FL, RR, RL)."""


def parse_offsets(text: str) -> list[float]:
    """``"0.1,0.5"`` -> [0.1, 0.5]; ValueError naming the bad entry (offsets are positive rad/s)."""
    out = []
    for item in text.split(","):
        try:
            d = float(item)
        except ValueError:
            raise ValueError(f"--offsets: {item!r} is not a number") from None
        if not d > 0.0:
            raise ValueError(f"--offsets: {item!r} must be > 0 rad/s (the offset 0 is always run)")
        out.append(d)
    return out


def sweep(
    runner,
    vx: float,
    offsets: list[float],
    patterns: list[str],
    gait_id: int,
    seconds: float = 6.0,
    settle: float = 2.0,
    progress=print,
) -> list[dict]:
    """One rollout of the forced gait ``gait_id`` per (pattern, offset), and the nominal gait (offset 0) first."""
    from wqwarp.eval.wheel_probe import rollout

    env = runner.env
    env.gait_selector.force(gait_id)
    scale = float(env.cfg.action.wheel_scale)
    everything = ("phase", "foot", "wheel")
    runs = [("nominal", 0.0)] + [(p, d) for p in patterns for d in offsets]
    out = []
    for pattern, d in runs:
        signs = PATTERNS.get(pattern, (0.0,) * 4)
        offset = [s * d for s in signs]
        r = rollout(runner, vx, seconds, settle, everything, wheels_fixed=[o / scale for o in offset])
        row = {"pattern": pattern, "offset_rad_s": d, "wheel_offsets_rad_s": offset, **r}
        out.append(row)
        progress(
            f"{pattern:>10} {d:5.2f} rad/s: p_cost {r['p_cost']:6.1f} W (legs {r['p_cost_legs']:5.1f}, wheels "
            f"{r['p_cost_wheels']:5.1f}) | v_x {r['vx']:.3f} m/s | torque {r['wheel_torque']} | "
            f"fell {r['fell']}"
        )
    return out


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--checkpoint", required=True, help="model_<it>.pt of an ours run (its configuration is used)")
    ap.add_argument("--preset", default=None, help="preset of the checkpoint (default: from its run's config.json)")
    ap.add_argument("--vx", type=float, default=0.8, help="held forward command [m/s] (default 0.8)")
    ap.add_argument(
        "--offsets", default="0.1,0.25,0.5,1", help="offset sizes [rad/s], comma-separated (default 0.1,0.25,0.5,1)"
    )
    ap.add_argument(
        "--patterns",
        default=",".join(PATTERNS),
        help=f"patterns, comma-separated, of {', '.join(PATTERNS)} (default all)",
    )
    ap.add_argument(
        "--gait",
        default="driving",
        help="gait of the library to force (default driving; a legged gait shows what the wheel gains do "
        "to its stance wheels)",
    )
    ap.add_argument("--robots", type=int, default=8, help="robots (default 8; no domain randomisation)")
    ap.add_argument("--seconds", type=float, default=6.0, help="rollout length [s] (default 6, the first 2 settle)")
    ap.add_argument(
        "--wheel-ki",
        type=float,
        default=None,
        help="diagnostic: replace the checkpoint's wheel PID integral gain [N m/rad] (e.g. 0: P-only "
        "wheels, no integral to wind up against the other wheels)",
    )
    ap.add_argument("--json", default=None, help="write every rollout's numbers here")
    args = ap.parse_args(argv)
    try:
        offsets = parse_offsets(args.offsets)
        patterns = [p for p in args.patterns.split(",") if p]
        bad = [p for p in patterns if p not in PATTERNS]
        if bad or not patterns:
            raise ValueError(f"--patterns: unknown {', '.join(bad) or '(none given)'}; choose of {', '.join(PATTERNS)}")
        if args.robots < 1 or args.seconds <= 2.0:
            raise ValueError("need --robots >= 1 and --seconds > 2 (the settling time)")
        if args.wheel_ki is not None and args.wheel_ki < 0.0:
            raise ValueError(f"--wheel-ki {args.wheel_ki:g}: want >= 0")
    except ValueError as e:
        raise UsageError(str(e)) from None
    ap.check_outputs(args.json)

    from wqwarp import quiet_warp

    quiet_warp()
    from wqwarp.control.gaits import gait_index
    from wqwarp.eval.loading import checkpoint_env_config, make_policy_runner
    from wqwarp.eval.physics import evaluation_config
    from wqwarp.rl.presets import check_preset
    from wqwarp.utils.provenance import write_result_json

    try:
        cfg = None
        if args.wheel_ki is not None:  # the gains are built into the simulator: replace them before it exists
            trained = checkpoint_env_config(args.checkpoint)
            if args.preset is not None:
                check_preset(args.preset, trained, args.checkpoint)
            cfg = evaluation_config(trained, args.robots, "cpu")
            cfg.sim.wheel_ki = args.wheel_ki
        runner = make_policy_runner(args.checkpoint, args.preset, args.robots, cfg=cfg)
        gait_id = gait_index(args.gait, runner.env.cfg.gait.library)
    except ValueError as e:
        raise UsageError(str(e)) from None
    if runner.env.num_actions != 20 or runner.env.gait_selector.name != "predictive":
        raise UsageError(
            f"{runner.preset} has no gait to force with wheel residuals (want a predictive preset with "
            f"20 actions, e.g. ours)"
        )
    rows = sweep(runner, args.vx, offsets, patterns, gait_id, args.seconds)
    if args.json:
        write_result_json(
            args.json,
            {
                "checkpoint": args.checkpoint,
                "preset": runner.preset,
                "gait": args.gait,
                "vx": args.vx,
                "robots": args.robots,
                "seconds": args.seconds,
                "settle": 2.0,
                "wheel_scale_rad_s": float(runner.env.cfg.action.wheel_scale),
                "wheel_pid": {
                    k: getattr(runner.env.cfg.sim, k) for k in ("wheel_kp", "wheel_ki", "wheel_kd", "wheel_i_limit")
                },
                "wheel_order": ["FR", "FL", "RR", "RL"],
                "rollouts": rows,
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
