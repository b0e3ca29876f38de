"""How a policy stands (or drives), and what its posture costs the battery: a checkpoint's robots held at one
command (the zero command by default), the trunk height, each leg joint kind's mean angle and RMS torque and the
wheels' RMS torque, and the copper loss those torques cost under the motor model (``wqwarp.robot.motors``), with
p_elec and p_cost, beside the nominal gait alone (every action 0) on the same robots: driving for a predictive preset
(ours, no_wheel_vel), the preset's own gait for a fixed one (no_predictor: trotting in place).

Usage::

    python tools/studies/standing_posture.py --checkpoint runs/i47/reach_s5/model_2999.pt [--robots 8]
        [--seconds 6] [--command 0.5,0,0] [--json PATH]

Measured over the last ``--seconds`` minus 2 s (the first 2 s settle); nothing learns. The gait is the one the
checkpoint's selection picks for the policy (its share is reported) and, for the nominal gait, driving forced (a
predictive preset) or the preset's fixed gait. A preset without a nominal gait (baseline, pmtg) is refused.
"""

from __future__ import annotations

import sys

from wqwarp.cli.args import UsageError, add_result_options, doc_parser, entry_point, parse_command
from wqwarp.robot.constants import JOINT_KIND_INDICES

KINDS = {k: list(v) for k, v in JOINT_KIND_INDICES.items() if k != "wheel"}
"""The leg joints of each kind (indices into the 16 actuated joints)."""
WHEELS = list(JOINT_KIND_INDICES["wheel"])
"""The wheel joints (their angle grows without bound: torque and copper only)."""
SETTLE_S = 2.0
"""Seconds before the measurement starts."""


def measure(runner, zero_residual: bool, seconds: float, command=(0.0, 0.0, 0.0)) -> dict:
    """Trunk height [m], per joint kind the mean angle [rad] and RMS torque [N m] and their copper loss [W] (four
    legs), the wheels' RMS torque and copper, the four hip angles, the running gait's shares, p_elec and p_cost [W],
    over robots and the measured steps, every robot held at ``command`` (v_x, v_y, w)."""
    import numpy as np
    import torch

    from wqwarp.eval.rollout import evaluation_session, start_rollout

    env = runner.env
    n = env.num_envs
    coeff = np.asarray(env.sim.motor_model.per_joint()["copper"])
    with evaluation_session(env), torch.no_grad():
        if zero_residual and env.gait_selector.name == "predictive":
            env.gait_selector.force(torch.zeros(n, dtype=torch.long, device=env.device))  # gait 0: driving
        commands = torch.tensor(command, dtype=torch.float32, device=env.device).expand(n, 3)
        obs = start_rollout(env, commands, seconds)
        height, q, tau_sq, usage, count = 0.0, np.zeros(16), np.zeros(16), torch.zeros(env.num_gaits), 0
        p_elec = p_cost = 0.0
        for k in range(int(round(seconds / env.dt))):
            action = torch.zeros(n, env.num_actions, device=env.device) if zero_residual else runner.policy(obs)
            obs, _, _, _ = env.step(action)
            if k * env.dt < SETTLE_S:
                continue
            tv = env.tv
            height += float(tv["base_height"].mean())
            q += tv["actuated_q"].mean(0).cpu().numpy()
            tau_sq += (tv["joint_torque"].cpu().numpy().astype(np.float64) ** 2).mean(0)
            p_elec += float(tv["p_elec"].mean())
            p_cost += float(tv["p_cost"].mean())
            usage += torch.bincount(env.active_gait().cpu(), minlength=env.num_gaits).float()
            count += 1
    if count == 0:
        raise UsageError(f"--seconds must exceed the {SETTLE_S:g} s of settling")
    q, tau_sq = q / count, tau_sq / count
    names = env.gait_selector.gait_names
    return {
        "height": height / count,
        "p_elec": p_elec / count,
        "p_cost": p_cost / count,
        "wheels": {
            "torque_rms": float(np.sqrt(tau_sq[WHEELS].mean())),
            "copper_w": float((coeff[WHEELS] * tau_sq[WHEELS]).sum()),
        },
        "kinds": {
            k: {
                "mean_angle": float(q[s].mean()),
                "torque_rms": float(np.sqrt(tau_sq[s].mean())),
                "copper_w": float((coeff[s] * tau_sq[s]).sum()),
            }
            for k, s in KINDS.items()
        },
        "hip_angles": [float(x) for x in q[KINDS["hip"]]],
        "gait_usage": {g: float(usage[i] / usage.sum()) for i, g in enumerate(names)},
    }


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument(
        "--checkpoint",
        required=True,
        help="model_<it>.pt of a task with a nominal gait (ours, no_wheel_vel, no_predictor)",
    )
    ap.add_argument("--robots", type=int, default=8, help="robots (default 8)")
    ap.add_argument("--seconds", type=float, default=6.0, help="rollout length [s], the first 2 s settle (default 6)")
    ap.add_argument(
        "--command",
        default="0,0,0",
        help="the command every robot holds, vx,vy,wz [m/s, m/s, rad/s] (default 0,0,0: standing)",
    )
    add_result_options(ap, plot=None)
    args = ap.parse_args(argv)
    if args.robots < 1 or args.seconds <= SETTLE_S:
        raise UsageError(f"need --robots >= 1 and --seconds > {SETTLE_S:g}")
    command = parse_command(args.command)
    ap.check_outputs(args.json)
    from wqwarp.eval.loading import make_policy_runner

    runner = make_policy_runner(args.checkpoint, None, num_envs=args.robots)
    env = runner.env
    if not env.residual_mode:
        raise UsageError(
            f"{args.checkpoint}: needs a preset with a nominal gait (ours, no_predictor), not {runner.preset}"
        )
    if env.gait_selector.name == "predictive":
        nominal = "nominal_driving"
    else:  # a fixed gait: the one every robot runs
        nominal = f"nominal_{env.gait_selector.gait_names[int(env.active_gait()[0])]}"
    out = {}
    for label, zero in (("policy", False), (nominal, True)):
        r = out[label] = measure(runner, zero, args.seconds, command)
        kinds = ", ".join(
            f"{k} {v['mean_angle']:+.2f} rad {v['torque_rms']:.2f} N m {v['copper_w']:.1f} W"
            for k, v in r["kinds"].items()
        )
        hips = " ".join(f"{a:+.2f}" for a in r["hip_angles"])
        wheels = f"wheels {r['wheels']['torque_rms']:.2f} N m {r['wheels']['copper_w']:.1f} W"
        print(
            f"{label:>15}: height {r['height']:.3f} m | p_elec {r['p_elec']:.1f} W p_cost {r['p_cost']:.1f} W | "
            f"{kinds}, {wheels} | hips {hips}"
        )
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(
            args.json,
            {
                "checkpoint": args.checkpoint,
                "robots": args.robots,
                "seconds": args.seconds,
                "command": list(command),
                **out,
            },
            command=" ".join(["tools/studies/standing_posture.py", *(argv or sys.argv[1:])]),
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
