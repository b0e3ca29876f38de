"""Where a trained policy's wheel power goes: the same rollout with the policy's residuals, with its wheel residuals
set to zero (wheels on the nominal velocities of Eq. 3), with its leg residuals set to zero (phase and feet on the
nominal gait, the wheels the policy's) and with every residual zero (the nominal gait alone), at a held forward
command. The wheels' power is not the wheel residuals' alone: the feet the policy places set where each wheel
touches the ground.

Usage::

    python tools/studies/wheel_residual_probe.py --checkpoint runs/ours_X/model_1499.pt --vx 0.8
        --json docs/studies/wheel_probe/probe.json

Per wheel (FR, FL, RR, RL): mean velocity [rad/s], target [rad/s], torque [N m] and the policy's wheel action; per
joint group: mean p_cost, mechanical and Joule power [W]; the base velocity achieved [m/s] and the share of each
running gait; how the wheel actions vary (RMS about each robot's own time mean, and RMS of the step-to-step change;
x the wheel scale in rad/s); each reward term per second (w_k r_k, the policy's own objective: does it pay the
policy to keep its wheel residuals?). A front pair driving (positive torque) while the rear pair brakes (negative
torque) at the same forward speed is power spent on wheel slip: the robot pays it and gains no speed. Nothing
learns.

``--noise`` adds the same pair with the actions PPO trains on: sampled from the policy's Gaussian (its learned std,
seeded alike in both rollouts), once as sampled and once with the policy's wheel output (the mean of its wheel
actions) removed, the noise kept. That tests whether the wheel residuals pay for the stochastic policy that PPO
optimises though not for its mean: if the sampled reward is higher with them, exploration noise holds them there.

``--held-wheels`` adds the policy's legs and the nominal gait with the wheel actions held constant at the policy's
mean wheel action: is a constant mismatch of the wheel speeds the waste? (``wheel_mismatch.py`` measures what a
mismatch costs by pattern and size.)
"""

from __future__ import annotations

import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.eval.wheel_probe import rollout

ARMS = {
    "policy": ((), False),
    "zero_wheel_residuals": (("wheel",), False),
    "zero_leg_residuals": (("phase", "foot"), False),
    "nominal": (("phase", "foot", "wheel"), False),
}
"""Rollout name -> (action groups set to zero, sampled): the policy; its wheel residuals zeroed (wheels on the
nominal velocities, legs the policy's); its leg residuals zeroed (phase and feet nominal, wheels the policy's);
every residual zeroed (the nominal gait alone, as ``train/evaluate.py --zero-residual``)."""
NOISE_ARMS = {"policy_sampled": ((), True), "zero_wheel_mean_sampled": (("wheel",), True)}
"""The ``--noise`` rollouts, compared with each other."""
HELD_ARMS = {"policy_held_wheels": (), "nominal_held_wheels": ("phase", "foot", "wheel")}
"""The ``--held-wheels`` rollouts: the policy's legs, or the nominal gait, with the wheel actions held at the
policy rollout's mean wheel action (per wheel, over robots and steps). If the nominal gait with the held wheels
spends what the policy's wheels spend, a constant mismatch between the wheels' speeds is the waste, not how the
wheel actions vary or where the feet are."""


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--checkpoint", required=True, help="model_<it>.pt written by train/ppo_newton.py")
    ap.add_argument("--preset", default=None, help="preset of the checkpoint (default: from its run's config.json)")
    ap.add_argument("--vx", type=float, default=0.8, help="held forward command [m/s] (default 0.8)")
    ap.add_argument("--robots", type=int, default=8, help="robots (default 8; no domain randomisation)")
    ap.add_argument("--seconds", type=float, default=6.0, help="rollout length [s] (default 6, the first 2 settle)")
    ap.add_argument(
        "--noise",
        action="store_true",
        help="also roll out with sampled actions (the policy's learned std, as in training), with and "
        "without the mean wheel actions",
    )
    ap.add_argument(
        "--held-wheels",
        action="store_true",
        help="also roll out the policy's legs and the nominal gait with the wheel actions held at the "
        "policy's mean wheel action",
    )
    ap.add_argument("--seed", type=int, default=0, help="seed of the sampled actions (default 0)")
    ap.add_argument("--json", default=None, help="write every rollout's numbers here")
    args = ap.parse_args(argv)
    if args.robots < 1 or args.seconds <= 2.0:
        raise UsageError("need --robots >= 1 and --seconds > 2 (the settling time)")
    ap.check_outputs(args.json)

    from wqwarp import quiet_warp

    quiet_warp()
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.utils.provenance import write_result_json

    try:
        runner = make_policy_runner(args.checkpoint, args.preset, args.robots)
    except ValueError as e:
        raise UsageError(str(e)) from None
    if runner.env.num_actions != 20:
        raise UsageError(f"{runner.preset} has no wheel residuals (16 joint actions)")
    res = {}
    arms = {name: (zero, sample, False) for name, (zero, sample) in (ARMS | (NOISE_ARMS if args.noise else {})).items()}
    if args.held_wheels:
        arms |= {name: (zero, False, True) for name, zero in HELD_ARMS.items()}
    for name, (zero, sample, held) in arms.items():
        fixed = res["policy"]["wheel_action"] if held else None
        try:
            res[name] = rollout(runner, args.vx, args.seconds, 2.0, zero, sample, args.seed, fixed)
        except ValueError as e:  # --noise on a policy without an action distribution
            raise UsageError(str(e)) from None
        r = res[name]
        print(
            f"{name:>21}: v_x {r['vx']:.3f} m/s | p_cost {r['p_cost']:6.1f} W (legs {r['p_cost_legs']:5.1f}, "
            f"wheels {r['p_cost_wheels']:5.1f}; wheels mech {r['p_mech_wheels']:5.1f}, electrical "
            f"{r['p_elec_wheels']:5.1f}) | wheel qd {r['wheel_qd']} | torque {r['wheel_torque']}"
        )
    pairs = [("policy", b) for b in list(ARMS)[1:] + (list(HELD_ARMS) if args.held_wheels else [])]
    pairs += [tuple(NOISE_ARMS)] if args.noise else []
    for a, b in pairs:
        rp, rz = res[a]["reward_per_s"], res[b]["reward_per_s"]
        print(
            f"reward per second, {a} -> {b}: "
            + ", ".join(f"{k} {rp[k]:+.3f} -> {rz[k]:+.3f}" for k in rp if rp[k] or rz[k])
        )
    out = {
        "checkpoint": args.checkpoint,
        "preset": runner.preset,
        "iteration": runner.iteration,
        "vx": args.vx,
        "robots": args.robots,
        "seconds": args.seconds,
        "settle": 2.0,
        "noise_seed": args.seed if args.noise else None,
        "wheel_order": ["FR", "FL", "RR", "RL"],
        "results": res,
    }
    if args.json:
        write_result_json(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
