"""Write the nominal gait of one robot standing at the default pose, one CSV row per policy step.

Usage::

    python tools/gait_trace.py --gait {driving,trotting,walking} --vx V --vy V --wz W --seconds S [--dt 0.02]
                               --csv PATH [--plot PNG]

Columns: ``t, phase_0..phase_3, swing_0..swing_3, foot_z_0..foot_z_3, wheel_vel_0..wheel_vel_3,
q_target_0..q_target_11``. Legs in the project order FR, FL, RR, RL (``wqwarp.robot.constants``); ``swing_i`` is 1 while
leg i swings; ``foot_z`` is the nominal foot-point (calf end) height in the hip frame [m]; ``wheel_vel`` the nominal
wheel speed [rad/s] with every wheel assumed on the ground (legs at the default pose for the lateral distances
of Eq. (3)); ``q_target`` the nominal leg joint targets [rad] (hip, thigh, calf per leg). No physics runs.
"""

from __future__ import annotations

import csv
import sys

import numpy as np

from wqwarp.cli.args import doc_parser
from wqwarp.control.gaits import GAIT_NAMES
from wqwarp.utils.io import write_atomic

COLUMNS = (
    ["t"]
    + [f"phase_{i}" for i in range(4)]
    + [f"swing_{i}" for i in range(4)]
    + [f"foot_z_{i}" for i in range(4)]
    + [f"wheel_vel_{i}" for i in range(4)]
    + [f"q_target_{i}" for i in range(12)]
)


def trace(gait: str, vx: float, vy: float, wz: float, seconds: float, dt: float) -> np.ndarray:
    """Rows of ``COLUMNS`` for ``seconds`` of the nominal gait at policy step ``dt``."""
    from wqwarp import quiet_warp
    from wqwarp.control.driver import OpenLoopDriver

    quiet_warp()
    driver = OpenLoopDriver(None, gait, (vx, vy, wz), num_envs=1, device="cpu", dt=dt)  # no physics, wheels down
    ng = driver.nominal
    rows = []
    for k in range(int(round(seconds / dt))):
        driver.step()
        psi = ng.swing_psi.numpy()[0]
        rows.append(
            np.concatenate(
                [
                    [(k + 1) * dt],
                    ng.phase.numpy()[0],
                    (psi >= 0).astype(np.float32),
                    ng.foot_target.numpy()[0][:, 2],
                    ng.wheel_velocity.numpy()[0],
                    ng.leg_joint_target.numpy()[0],
                ]
            )
        )
    return np.asarray(rows)


def plot(rows: np.ndarray, path: str, title: str) -> None:
    """Phases, foot-point heights and nominal wheel speeds of ``rows`` (:func:`trace`) against time, to PNG ``path``
    (written atomically)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = rows[:, 0]
    fig, ax = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    names = ("FR", "FL", "RR", "RL")
    for i in range(4):
        ax[0].plot(t, rows[:, 1 + i], label=names[i])
        ax[1].plot(t, rows[:, 9 + i], label=names[i])
        ax[2].plot(t, rows[:, 13 + i], label=names[i])
    ax[0].set_ylabel("phase [cycles]")
    ax[1].set_ylabel("foot-point z, hip frame [m]")
    ax[2].set_ylabel("nominal wheel speed [rad/s]")
    ax[2].set_xlabel("t [s]")
    ax[0].legend(ncol=4, fontsize=8)
    ax[0].set_title(title)
    fig.tight_layout()
    from wqwarp.utils.provenance import save_figure

    save_figure(fig, path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__, epilog_from=2)
    ap.add_argument("--gait", required=True, choices=GAIT_NAMES, help="nominal gait from the paper's Table I")
    ap.add_argument("--vx", type=float, default=0.0, help="commanded forward speed [m/s] (default 0)")
    ap.add_argument("--vy", type=float, default=0.0, help="commanded lateral speed [m/s] (default 0; not in Eq. 3)")
    ap.add_argument("--wz", type=float, default=0.0, help="commanded yaw rate [rad/s] (default 0)")
    ap.add_argument("--seconds", type=float, default=2.0, help="length of the trace [s] (default 2)")
    ap.add_argument("--dt", type=float, default=0.02, help="policy step [s] (default 0.02, i.e. 50 Hz)")
    ap.add_argument("--csv", required=True, help="output CSV path")
    ap.add_argument("--plot", default=None, help="also draw phases, foot heights and wheel speeds to this PNG")
    args = ap.parse_args(argv)
    ap.check_outputs(args.csv, args.plot)
    if not (args.seconds > 0 and args.dt > 0 and args.seconds >= args.dt):
        ap.error("need --seconds >= --dt > 0")
    rows = trace(args.gait, args.vx, args.vy, args.wz, args.seconds, args.dt)

    def write_csv(tmp):
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(COLUMNS)
            w.writerows([[f"{x:.6g}" for x in r] for r in rows])

    write_atomic(args.csv, write_csv)
    print(f"wrote {args.csv} ({len(rows)} rows)")
    if args.plot:
        title = f"{args.gait}: vx={args.vx} vy={args.vy} wz={args.wz}"
        plot(rows, args.plot, title)
        print(f"wrote {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
