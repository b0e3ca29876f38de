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
"""

from __future__ import annotations

import sys

from wqwarp.cli.args import doc_parser


def learned_std(policy, obs):
    """The policy's action std (rsl-rl's Gaussian: a learned parameter, the same for every observation), shaped as
    its actions on ``obs``; ValueError for a policy without an action distribution."""
    import torch

    dist = getattr(policy, "distribution", None)
    if dist is None:
        raise ValueError("the policy has no action distribution to sample")
    with torch.no_grad():
        dist.update(policy(obs))
        return dist.std.detach().clone()


ARMS = {"policy": ((), False), "zero_wheel_residuals": (("wheel",), False),
        "zero_leg_residuals": (("phase", "foot"), False), "nominal": (("phase", "foot", "wheel"), False)}
"""Rollout name -> (action groups set to zero, sampled): the policy; its wheel residuals zeroed (wheels on the
nominal velocities, legs the policy's); its leg residuals zeroed (phase and feet nominal, wheels the policy's);
every residual zeroed (the nominal gait alone, as ``train/evaluate.py --zero-residual``)."""
NOISE_ARMS = {"policy_sampled": ((), True), "zero_wheel_mean_sampled": (("wheel",), True)}
"""The ``--noise`` rollouts, compared with each other."""


def rollout(runner, vx: float, seconds: float, settle: float, zero: tuple[str, ...] = (), sample: bool = False,
            seed: int = 0) -> dict:
    """One rollout at the held command ``vx``; the action groups ``zero`` (``wqwarp.rl.observations.action_groups``)
    set to 0 (with ``sample`` the Gaussian noise around them stays); ``sample`` draws the actions from the
    policy's distribution (torch seeded with ``seed``, so two rollouts draw the same noise while their states
    agree)."""
    import numpy as np
    import torch
    import warp as wp

    from wqwarp.eval.rollout import start_rollout
    from wqwarp.rl.observations import action_groups

    env = runner.env
    groups = action_groups(env.num_actions)
    wheels = groups["wheel"]
    n = env.num_envs
    cmd = torch.tensor([[vx, 0.0, 0.0]] * n)
    obs = start_rollout(env, cmd, seconds)
    keys = ("p_cost_legs", "p_cost_wheels", "p_mech_legs", "p_mech_wheels", "p_joule_legs", "p_joule_wheels")
    acc: dict = {k: [] for k in (*keys, "wheel_qd", "wheel_target", "wheel_torque", "vx")}
    per_robot: list[torch.Tensor] = []  # (n, 4) wheel actions of each step after settling
    usage = torch.zeros(env.num_gaits)
    terms = torch.zeros(len(env.reward_names))
    fell = torch.zeros(n, dtype=torch.bool)
    gen = torch.Generator(device="cpu").manual_seed(seed)
    std = learned_std(runner.policy, obs) if sample else None
    with torch.no_grad():
        for k in range(int(round(seconds / env.dt))):
            a = runner.policy(obs).clone()  # the deterministic output: the mean action
            for g in zero:
                a[:, groups[g]] = 0.0
            if std is not None:
                a = a + std * torch.randn(a.shape, generator=gen).to(a.device)
            obs, _, dones, _ = env.step(a)
            fell |= dones.bool().cpu()
            if k * env.dt < settle:
                continue
            for key in keys:
                acc[key].append(float(env.tv[key].mean()))
            acc["wheel_qd"].append(env.tv["actuated_qd"][:, 12:].mean(0).tolist())
            acc["wheel_target"].append(wp.to_torch(env.sim.wheel_qd_target).mean(0).tolist())
            acc["wheel_torque"].append(env.tv["joint_torque"][:, 12:].mean(0).tolist())
            per_robot.append(a[:, wheels].detach().cpu().clone())
            acc["vx"].append(float(env.base_state()["lin_vel"][:, 0].mean()))
            usage += torch.bincount(env.active_gait().cpu(), minlength=env.num_gaits).float()
            terms += wp.to_torch(env.reward_terms_wp).mean(0).cpu()
    out = {k: np.round(np.mean(np.asarray(v), axis=0), 4).tolist() for k, v in acc.items()}
    per_s = terms / max(1, len(acc["vx"])) / env.dt  # w_k r_k dt per step -> per second
    out["reward_per_s"] = {name: round(float(per_s[k]), 4) for k, name in enumerate(env.reward_names)}
    out["reward_per_s"]["total"] = round(float(per_s.sum()), 4)
    out["gait_usage"] = {g: float(usage[i] / usage.sum()) for i, g in enumerate(env.gait_names)}
    out["fell"] = int(fell.sum())
    out["p_cost"] = out["p_cost_legs"] + out["p_cost_wheels"]
    w = torch.stack(per_robot)  # (T, n, 4)

    def per_wheel(x: torch.Tensor) -> np.ndarray:  # (T, n, 4) -> the mean over steps and robots, per wheel
        return x.mean((0, 1)).double().numpy()

    out["wheel_action"] = per_wheel(w).round(4).tolist()
    out["wheel_action_rms_about_mean"] = np.sqrt(per_wheel((w - w.mean(0)).pow(2))).round(4).tolist()
    out["wheel_action_step_rms"] = np.sqrt(per_wheel((w[1:] - w[:-1]).pow(2))).round(4).tolist()
    out["wheel_scale_rad_s"] = float(env.cfg.action.wheel_scale)  # x the action RMS: rad/s
    if std is not None:
        out["action_std"] = [round(float(x), 4) for x in std[0]]
    return out


def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--checkpoint", required=True, help="model_<it>.pt written by train/ppo_newton.py")
    ap.add_argument("--preset", default=None, help="preset of the checkpoint (default: from its run's config.json)")
    ap.add_argument("--vx", type=float, default=0.8, help="held forward command [m/s] (default 0.8)")
    ap.add_argument("--robots", type=int, default=8, help="robots (default 8; no domain randomisation)")
    ap.add_argument("--seconds", type=float, default=6.0, help="rollout length [s] (default 6, the first 2 settle)")
    ap.add_argument("--noise", action="store_true",
                    help="also roll out with sampled actions (the policy's learned std, as in training), with and "
                         "without the mean wheel actions")  # fmt: skip
    ap.add_argument("--seed", type=int, default=0, help="seed of the sampled actions (default 0)")
    ap.add_argument("--json", default=None, help="write every rollout's numbers here")
    args = ap.parse_args(argv)
    if args.robots < 1 or args.seconds <= 2.0:
        print("error: need --robots >= 1 and --seconds > 2 (the settling time)", file=sys.stderr)
        return 2
    ap.check_outputs(args.json)

    from wqwarp import quiet_warp

    quiet_warp()
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.utils.provenance import write_result_json

    try:
        runner = make_policy_runner(args.checkpoint, args.preset, args.robots)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    if runner.env.num_actions != 20:
        print(f"error: {runner.preset} has no wheel residuals (16 joint actions)", file=sys.stderr)
        return 2
    res = {}
    arms = ARMS | (NOISE_ARMS if args.noise else {})
    for name, (zero, sample) in arms.items():
        try:
            res[name] = rollout(runner, args.vx, args.seconds, 2.0, zero, sample, args.seed)
        except ValueError as e:  # --noise on a policy without an action distribution
            print(f"error: {e}", file=sys.stderr)
            return 2
        r = res[name]
        print(f"{name:>21}: v_x {r['vx']:.3f} m/s | p_cost {r['p_cost']:6.1f} W (legs {r['p_cost_legs']:5.1f}, "
              f"wheels {r['p_cost_wheels']:5.1f}; wheels mech {r['p_mech_wheels']:5.1f}, Joule "
              f"{r['p_joule_wheels']:5.1f}) | wheel qd {r['wheel_qd']} | torque {r['wheel_torque']}")  # fmt: skip
    pairs = [("policy", b) for b in list(ARMS)[1:]] + ([tuple(NOISE_ARMS)] if args.noise else [])
    for a, b in pairs:
        rp, rz = res[a]["reward_per_s"], res[b]["reward_per_s"]
        print(f"reward per second, {a} -> {b}: "
              + ", ".join(f"{k} {rp[k]:+.3f} -> {rz[k]:+.3f}" for k in rp if rp[k] or rz[k]))  # fmt: skip
    out = {"checkpoint": args.checkpoint, "preset": runner.preset, "iteration": runner.iteration, "vx": args.vx,
           "robots": args.robots, "seconds": args.seconds, "settle": 2.0,
           "noise_seed": args.seed if args.noise else None, "wheel_order": ["FR", "FL", "RR", "RL"],
           "results": res}  # fmt: skip
    if args.json:
        write_result_json(args.json, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
