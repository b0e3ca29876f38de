"""Does a policy's posture hide its exploration noise? How much of the foot-residual noise reaches the leg targets.

A Gaussian policy pays for its exploration noise in the penalties (at std 0.5 about -8.7 reward per second here,
docs/studies/omnidirectional). A mean foot residual held where the residual is clipped (|0.2 a| >= foot_clip) or
where the joint target passes a joint limit makes the noise of that action column do nothing: the policy escapes
the noise's cost by its posture, and a foot held at the clip can no longer step. This probe measures it for a
checkpoint: robots hold four commands (stand, v_x 0.5, v_y 0.3, w 0.5 m/s or rad/s) with the deterministic policy
for ``--seconds``; at the end state it draws ``--samples`` actions a = mu + sigma eps (sigma: the checkpoint's
std) and pushes each through the env's action map (clip, foot IK: ``wqwarp.kernels.actions.residual_targets``).
Reported per command: the std of the 12 leg-joint targets over the samples [rad] (applied noise), the same with
the policy's foot residual mean set to zero (the noise around the nominal foot: the counterfactual without the
posture), their ratio, the share of foot-residual samples at the clip, and of joint targets at a joint range
bound (the foot IK clamps to the ranges, so noise there does not move the joint either); and where the joints
are at the end state: the share of leg joints beyond the soft range of the ``joint_limits`` reward term (0.9 of
each range) and that term's value, the summed excursion per robot [rad].

Usage::

    python tools/studies/noise_escape_probe.py --checkpoint runs/X/model_4882.pt [--json out.json]
"""

from __future__ import annotations

import json
import os
import sys

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.utils.io import output_problem

COMMANDS = {"stand": (0.0, 0.0, 0.0), "vx0.5": (0.5, 0.0, 0.0), "vy0.3": (0.0, 0.3, 0.0), "wz0.5": (0.0, 0.0, 0.5)}
ROBOTS_PER_COMMAND = 4


def probe(checkpoint: str, seconds: float, samples: int, seed: int) -> dict:
    import torch
    import warp as wp

    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.rollout import evaluation_session, start_rollout
    from wqwarp.kernels.actions import residual_targets
    from wqwarp.rl.rewards import soft_joint_limits
    from wqwarp.robot import constants as C

    runner = make_policy_runner(checkpoint, None, len(COMMANDS) * ROBOTS_PER_COMMAND, seed=seed)
    env = runner.env
    if not env.residual_mode:
        raise ValueError(f"{checkpoint}: the probe needs a residual policy (20 actions), not {runner.preset}")
    sigma = torch.load(checkpoint, map_location="cpu", weights_only=False)["actor_state_dict"]["distribution.std_param"]
    cfg, n = env.cfg.action, env.num_envs
    cmd = torch.tensor(list(COMMANDS.values())).repeat_interleave(ROBOTS_PER_COMMAND, 0)
    with evaluation_session(env), torch.no_grad():
        obs = start_rollout(env, cmd, seconds + 1.0)
        for _ in range(int(round(seconds / env.dt))):
            obs, _, _, _ = env.step(runner.policy(obs))
        mu = runner.policy(obs)
        q_now = wp.to_torch(env.sim.actuated_q)[:, :12].cpu()  # where the joints are (the joint_limits term's input)
        ng = env.nominal
        gen = torch.Generator().manual_seed(seed)
        lo, hi = torch.tensor(C.LEG_JOINT_RANGES).T
        soft_lo, soft_hi = (torch.tensor(b, dtype=torch.float32) for b in soft_joint_limits(0.9))
        excursion = (soft_lo - q_now).clamp(min=0) + (q_now - soft_hi).clamp(min=0)

        def targets(mean: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
            """(S, N, 12) leg targets and (S, N, 12) raw foot actions of ``samples`` draws around ``mean``."""
            a = mean[None] + sigma * torch.randn(samples, *mean.shape, generator=gen)
            q = []
            for s in range(samples):
                out = [wp.zeros((n, 4), dtype=wp.vec3), wp.zeros((n, 12), dtype=float), wp.zeros((n, 4), dtype=float)]
                wp.launch(
                    residual_targets,
                    dim=(n, 4),
                    inputs=[
                        wp.from_torch(a[s].contiguous()),
                        ng.foot_target,
                        ng.wheel_velocity,
                        int(cfg.use_nominal_wheels),
                        cfg.foot_scale,
                        cfg.foot_clip,
                        cfg.wheel_scale,
                        cfg.wheel_clip,
                    ],
                    outputs=out,
                )
                q.append(wp.to_torch(out[1]).clone())
            return torch.stack(q), a[:, :, 4:16]

        q, foot = targets(mu)
        bare = mu.clone()
        bare[:, 4:16] = 0.0
        q0, _ = targets(bare)
    rows = {}
    for i, name in enumerate(COMMANDS):
        r = slice(i * ROBOTS_PER_COMMAND, (i + 1) * ROBOTS_PER_COMMAND)
        applied, nominal = float(q[:, r].std(0).mean()), float(q0[:, r].std(0).mean())
        rows[name] = {
            "joint_target_noise_rad": applied,
            "joint_target_noise_without_posture_rad": nominal,
            "ratio": applied / nominal if nominal > 0 else None,
            "foot_at_clip": float((cfg.foot_scale * foot[:, r].abs() >= cfg.foot_clip).float().mean()),
            "joint_target_at_range": float(((q[:, r] <= lo + 1e-4) | (q[:, r] >= hi - 1e-4)).float().mean()),
            "joint_beyond_soft_limit": float((excursion[r] > 0).float().mean()),
            "joint_limits_term_rad": float(excursion[r].sum(1).mean()),
            "foot_residual_abs_mean_m": float(
                (cfg.foot_scale * mu[r, 4:16]).clamp(-cfg.foot_clip, cfg.foot_clip).abs().mean()
            ),
        }
    return {
        "checkpoint": checkpoint,
        "iteration": runner.iteration,
        "seconds": seconds,
        "samples": samples,
        "seed": seed,
        "robots_per_command": ROBOTS_PER_COMMAND,
        "foot_std": sigma[4:16].tolist(),
        "commands": rows,
    }


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--checkpoint", required=True, help="a residual policy's model_<it>.pt")
    ap.add_argument("--seconds", type=float, default=3.0, help="rollout before the probe [s] (default 3)")
    ap.add_argument("--samples", type=int, default=64, help="noise draws per robot (default 64)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the rollout and of the draws (default 0)")
    ap.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    if not os.path.isfile(args.checkpoint):
        raise UsageError(f"no such checkpoint: {args.checkpoint}")
    if args.seconds <= 0 or args.samples < 2:
        raise UsageError("need --seconds > 0 and --samples >= 2")
    if args.json and (problem := output_problem(args.json)):
        raise UsageError(f"--json {args.json!r}: {problem}")
    from wqwarp import quiet_warp

    quiet_warp()
    try:
        out = probe(args.checkpoint, args.seconds, args.samples, args.seed)
    except ValueError as e:
        raise UsageError(str(e)) from None
    print(
        f"noise escape probe of {args.checkpoint} (iteration {out['iteration']}), foot std "
        f"{sum(out['foot_std']) / 12:.3f}"
    )
    print(
        f"{'command':<8} {'noise [rad]':>11} {'w/o posture':>11} {'ratio':>6} {'at clip':>8} {'at q lim':>8} "
        f"{'posture':>8} {'q > soft':>8} {'excursion':>9}"
    )
    for name, r in out["commands"].items():
        print(
            f"{name:<8} {r['joint_target_noise_rad']:>11.4f} {r['joint_target_noise_without_posture_rad']:>11.4f} "
            f"{r['ratio']:>6.2f} {r['foot_at_clip']:>8.1%} {r['joint_target_at_range']:>8.1%} "
            f"{100 * r['foot_residual_abs_mean_m']:>6.1f}cm {r['joint_beyond_soft_limit']:>8.1%} "
            f"{r['joint_limits_term_rad']:>7.3f}rad"
        )
    if args.json:
        from wqwarp.utils.io import write_text_atomic

        write_text_atomic(args.json, json.dumps({"command": " ".join(sys.argv), **out}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
