"""Step response of the wheel velocity PID on the standing robot, used to choose ``SimConfig.wheel_*`` gains.

Usage::

    python tools/wheel_step_response.py [--speed 0.5] [--seconds 2] [--gains "kp,ki,kd;kp,ki,kd;..."]

All four wheels are commanded ``speed / R`` [rad/s] from rest with the legs held at the default pose; for each gain
set it prints the wheel-speed rise time (10-90 %), overshoot, steady-state error over the last 0.5 s, and the base
forward speed reached.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def run(kp: float, ki: float, kd: float, speed: float, seconds: float, i_limit: float) -> dict:
    import warp as wp

    from wqwarp import constants as C
    from wqwarp.sim.backend import SimConfig, Simulator

    wp.config.quiet = True
    sim = Simulator(SimConfig(num_envs=1, wheel_kp=kp, wheel_ki=ki, wheel_kd=kd, wheel_i_limit=i_limit))
    target = C.WHEEL_FORWARD_SIGN * speed / C.WHEEL_RADIUS
    sim.wheel_qd_target.fill_(target)
    wheel_dof = sim.layout.actuated_dof[12:]
    steps = int(round(seconds / sim.policy_dt))
    w, v = [], []
    for _ in range(steps):
        sim.step()
        w.append(sim.joint_qd.numpy()[0, wheel_dof].mean())
        v.append(sim.joint_qd.numpy()[0, 0])
    w = np.asarray(w)
    t = np.arange(1, steps + 1) * sim.policy_dt
    rise = t[np.argmax(w >= 0.9 * target)] - t[np.argmax(w >= 0.1 * target)]
    tail = w[t > seconds - 0.5]
    return {
        "kp": kp, "ki": ki, "kd": kd, "rise_s": float(rise), "overshoot_pct": float(100 * (w.max() / target - 1)),
        "steady_err_pct": float(100 * abs(tail.mean() / target - 1)), "base_vx": float(np.mean(v[-25:])),
    }  # fmt: skip


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--speed", type=float, default=0.5, help="commanded rolling speed [m/s] (default 0.5)")
    ap.add_argument("--seconds", type=float, default=2.0, help="length of each run [s] (default 2)")
    ap.add_argument("--i-limit", type=float, default=0.5, help="integral bound [rad] (default 0.5)")
    ap.add_argument("--gains", default="2,0,0;2,10,0;4,10,0;2,20,0;1,5,0",
                    help='semicolon-separated "kp,ki,kd" sets (default: a small sweep)')  # fmt: skip
    args = ap.parse_args(argv)
    try:
        sets = [tuple(float(x) for x in g.split(",")) for g in args.gains.split(";")]
        if any(len(s) != 3 for s in sets):
            raise ValueError
    except ValueError:
        print(f"error: --gains must look like '2,10,0;4,10,0', got {args.gains!r}", file=sys.stderr)
        return 2
    print(f"{'kp':>5} {'ki':>5} {'kd':>5} {'rise[s]':>8} {'overshoot%':>10} {'steady err%':>11} {'base vx':>8}")
    for kp, ki, kd in sets:
        r = run(kp, ki, kd, args.speed, args.seconds, args.i_limit)
        print(f"{kp:5.2f} {ki:5.2f} {kd:5.2f} {r['rise_s']:8.3f} {r['overshoot_pct']:10.1f} "
              f"{r['steady_err_pct']:11.2f} {r['base_vx']:8.3f}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
