"""Rollouts at a held forward command with parts of a residual policy's actions replaced (action groups zeroed,
the wheel actions held, the actions sampled from the policy's Gaussian), with the numbers that say where its wheel
power goes: per-wheel speed, target, torque and action, p_cost / mechanical / Joule power of legs and wheels, each
reward term per second. Used by ``tools/studies/wheel_residual_probe.py`` and ``tools/studies/wheel_mismatch.py``.
Nothing learns."""

from __future__ import annotations


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


def rollout(
    runner,
    vx: float,
    seconds: float,
    settle: float,
    zero: tuple[str, ...] = (),
    sample: bool = False,
    seed: int = 0,
    wheels_fixed: list[float] | None = None,
) -> dict:
    """One rollout at the held command ``vx``; the action groups ``zero`` (``wqwarp.rl.observations.action_groups``)
    set to 0 (with ``sample`` the Gaussian noise around them stays); ``sample`` draws the actions from the
    policy's distribution (torch seeded with ``seed``, so two rollouts draw the same noise while their states
    agree); ``wheels_fixed`` (FR, FL, RR, RL) holds the wheel actions at these values on every robot and step."""
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
    keys = ("p_cost_legs", "p_cost_wheels", "p_mech_legs", "p_mech_wheels", "p_elec_legs", "p_elec_wheels")
    acc: dict = {k: [] for k in (*keys, "wheel_qd", "wheel_target", "wheel_torque", "vx")}
    per_robot: list[torch.Tensor] = []  # (n, 4) wheel actions of each step after settling
    usage = torch.zeros(env.num_gaits)
    terms = torch.zeros(len(env.reward_names))
    fell = torch.zeros(n, dtype=torch.bool)
    gen = torch.Generator(device="cpu").manual_seed(seed)
    std = learned_std(runner.policy, obs) if sample else None
    held = None if wheels_fixed is None else torch.tensor(wheels_fixed, dtype=torch.float32, device=obs.device)
    with torch.no_grad():
        for k in range(int(round(seconds / env.dt))):
            a = runner.policy(obs).clone()  # the deterministic output: the mean action
            for g in zero:
                a[:, groups[g]] = 0.0
            if held is not None:
                a[:, wheels] = held
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
    per_second = max(1, int(round(1.0 / env.dt)))  # the wheels' p_cost in 1 s windows after settling
    wheels_p = np.asarray(acc["p_cost_wheels"])
    out["p_cost_wheels_by_second"] = [
        round(float(wheels_p[i : i + per_second].mean()), 3) for i in range(0, len(wheels_p), per_second)
    ]
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
