"""Drive this project's wheeled Go1 and the authors' public MuJoCo model with the same controller, side by side.

Usage::

    python tools/studies/compare_authors_model.py --mjcf PATH/wheeled_go1.xml [--dt 0.005] [--decimation 4]
        [--scenarios standing,drive_0.5,trot_0] [--json docs/studies/authors_model/authors_model_dt0.005.json]

``--mjcf`` is ``resources/wheeled_go1/xml/wheeled_go1.xml`` of the paper's first author's MIT-licensed harness
(github.com/xu-yang16/wheeled-quadruped-sim2sim); it is not shipped here. Its mesh geoms are visual only
(contype 0, explicit inertials) and are dropped on load, so the STL files are not needed.

Both robots run the same loop at the same physics step: this project's nominal gait (``wqwarp.control.nominal``) gives
leg joint targets and nominal wheel speeds (every wheel taken as touching the ground); legs track them with PD (Kp 40,
Kd 1, the harness's gains), wheels with this project's wheel PID (``SimConfig`` gains), torques clipped to the same
limits. The authors' model keeps everything of its own: masses (14.26 kg), joint damping 0.01, armature 0.01, friction
loss 0.2 N m, ground friction 0.6, box collision shapes; their wheel axes point -y on the right legs, which is
accounted for. Printed per scenario and robot: trunk height, forward speed, p_cost of legs and wheels, averaged over
``--seconds`` after ``--warmup``.
"""

from __future__ import annotations

import os
import sys
import xml.etree.ElementTree as ET

import numpy as np

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.utils.io import output_problem

SCENARIOS = {
    "standing": ("driving", (0.0, 0.0, 0.0)),
    "drive_0.5": ("driving", (0.5, 0.0, 0.0)),
    "drive_1.0": ("driving", (1.0, 0.0, 0.0)),
    "trot_0": ("trotting", (0.0, 0.0, 0.0)),
    "trot_0.3": ("trotting", (0.3, 0.0, 0.0)),
}
LEGS = ("FR", "FL", "RR", "RL")


def load_authors_model(path: str, dt: float):
    """The authors' MJCF without its visual meshes, at physics step ``dt``."""
    import mujoco

    root = ET.parse(path).getroot()
    for parent in root.iter():
        for child in list(parent):
            if child.tag == "geom" and child.get("type") == "mesh":
                parent.remove(child)
            elif child.tag in ("mesh", "texture", "material") or (child.tag == "sensor" and parent is root):
                parent.remove(child)
    for g in root.iter("geom"):
        g.attrib.pop("material", None)
    compiler = root.find("compiler")
    if compiler is not None:
        compiler.attrib.pop("meshdir", None)
    m = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    m.opt.timestep = dt
    return m


class AuthorsRobot:
    """The authors' model driven like ``wqwarp.sim.simulator.Simulator`` (explicit PD / PID torques every substep)."""

    def __init__(self, model, sim_cfg):
        import mujoco

        from wqwarp.robot import constants as C

        self.m, self.cfg, self.mj = model, sim_cfg, mujoco
        self.d = mujoco.MjData(model)
        jid = [model.joint(f"{leg}_{k}_joint").id for leg in LEGS for k in ("hip", "thigh", "calf")]
        wid = [model.joint(f"{leg}_wheel_joint").id for leg in LEGS]
        self.qadr = np.array([model.jnt_qposadr[j] for j in jid + wid])
        self.vadr = np.array([model.jnt_dofadr[j] for j in jid + wid])
        self.act = np.array(
            [model.actuator(f"{leg}_{k}").id for leg in LEGS for k in ("hip", "thigh", "calf")]
            + [model.actuator(f"{leg}_wheel").id for leg in LEGS]
        )
        self.limit = np.asarray(C.TORQUE_LIMITS)
        self.d.qpos[self.qadr[:12]] = C.DEFAULT_JOINT_POS[:12]
        mujoco.mj_forward(model, self.d)
        # wheel axis in the world frame: +y rolls forward (as this project's wheels); theirs point -y on the right
        self.sign = np.sign([self.d.xaxis[j][1] for j in wid])
        lowest = min(
            self.d.geom_xpos[g][2] - model.geom_size[g][0]
            for g in range(model.ngeom)
            if model.geom_bodyid[g] in [model.jnt_bodyid[j] for j in wid]
        )
        self.d.qpos[2] -= lowest  # wheels just touching the ground
        mujoco.mj_forward(model, self.d)
        self.integral = np.zeros(4)

    def step(self, leg_target, wheel_target, decimation) -> tuple[float, float]:
        c, p_legs, p_wheels = self.cfg, 0.0, 0.0
        for _ in range(decimation):
            q, qd = self.d.qpos[self.qadr], self.d.qvel[self.vadr]
            tau = np.zeros(16)
            tau[:12] = c.leg_kp * (leg_target - q[:12]) - c.leg_kd * qd[:12]
            w = self.sign * qd[12:]  # wheel speed in this project's convention
            e = wheel_target - w
            step = e * c.dt
            u = c.wheel_kp * e + c.wheel_ki * self.integral
            grow = (np.abs(u) > self.limit[12:]) & (u * step > 0)
            self.integral = np.where(
                grow, self.integral, np.clip(self.integral + step, -c.wheel_i_limit, c.wheel_i_limit)
            )
            tau[12:] = self.sign * (c.wheel_kp * e + c.wheel_ki * self.integral)
            tau = np.clip(tau, -self.limit, self.limit)
            self.d.ctrl[self.act] = tau
            self.mj.mj_step(self.m, self.d)
            p = np.abs(tau) * np.abs(self.d.qvel[self.vadr])
            p_legs += p[:12].sum() / decimation
            p_wheels += p[12:].sum() / decimation
        return p_legs, p_wheels

    def base(self) -> tuple[float, float]:
        """Trunk height [m] and forward speed in the trunk frame [m/s] (MuJoCo's free-joint qvel[0:3] is world)."""
        rot = self.d.xmat[1].reshape(3, 3)
        return float(self.d.qpos[2]), float((rot.T @ self.d.qvel[0:3])[0])

    def leg_q(self) -> np.ndarray:
        return self.d.qpos[self.qadr[:12]].astype(np.float32)


def run(scenario: str, mjcf: str, dt: float, decimation: int, warmup: float, seconds: float) -> dict:
    import warp as wp

    from wqwarp import quiet_warp
    from wqwarp.control.driver import OpenLoopDriver
    from wqwarp.control.nominal import NominalGait
    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    quiet_warp()
    gait, cmd = SCENARIOS[scenario]
    cfg = SimConfig(num_envs=1, dt=dt, decimation=decimation)
    ours = Simulator(cfg)
    theirs = AuthorsRobot(load_authors_model(mjcf, dt), cfg)
    driver = OpenLoopDriver(ours, gait, cmd, contact="ground")  # this robot: the one open-loop driver
    ng = NominalGait(1, "cpu")  # the authors' robot is no Simulator: the same gait, driven by hand below
    ng.reset([0], ng.gait_ids(gait))
    ng.command.assign(np.array([cmd], np.float32))
    contact = wp.ones((1, 4), dtype=wp.int32)  # all wheels on the ground, as the driver's contact="ground"
    steps, start = int(round((warmup + seconds) / ours.policy_dt)), int(round(warmup / ours.policy_dt))
    rows = {"ours": [], "theirs": []}
    for k in range(steps):
        driver.step()
        ng.step(wp.array(theirs.leg_q()[None], dtype=wp.float32), contact, ours.policy_dt)
        p_legs, p_wheels = theirs.step(ng.leg_joint_target.numpy()[0], ng.wheel_velocity.numpy()[0], decimation)
        if k >= start:
            q = ours.joint_q.numpy()
            vx = float(ours.base_lin_vel.numpy()[0, 0])  # base frame
            rows["ours"].append([q[0, 2], vx, ours.p_cost_legs.numpy()[0], ours.p_cost_wheels.numpy()[0]])
            rows["theirs"].append([*theirs.base(), p_legs, p_wheels])
    out = {}
    for who, r in rows.items():
        h, vx, legs, wheels = np.asarray(r, np.float64).mean(0)
        out[who] = {"height": h, "v_x": vx, "p_cost_legs": legs, "p_cost_wheels": wheels, "p_cost": legs + wheels}
    return out


@entry_point
def main(argv=None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--mjcf", required=True, help="the authors' resources/wheeled_go1/xml/wheeled_go1.xml")
    ap.add_argument(
        "--scenarios",
        default="standing,drive_0.5,drive_1.0,trot_0,trot_0.3",
        help=f"comma-separated, from {', '.join(SCENARIOS)} (default: all)",
    )
    ap.add_argument("--dt", type=float, default=0.005, help="physics step [s] (default 0.005)")
    ap.add_argument("--decimation", type=int, default=4, help="physics steps per 50 Hz policy step (default 4)")
    ap.add_argument("--warmup", type=float, default=1.0, help="seconds before averaging (default 1)")
    ap.add_argument("--seconds", type=float, default=3.0, help="seconds averaged (default 3)")
    ap.add_argument("--json", default=None, help="also write the results to this JSON file")
    args = ap.parse_args(argv)
    names = args.scenarios.split(",")
    bad = [n for n in names if n not in SCENARIOS]
    if bad or args.dt <= 0 or args.decimation < 1 or args.seconds <= 0 or args.warmup < 0:
        raise UsageError(f"unknown scenario {bad} or non-positive dt / decimation / seconds")
    if not os.path.isfile(args.mjcf):
        raise UsageError(f"no such MJCF file: {args.mjcf}")
    if args.json and (problem := output_problem(args.json)):
        raise UsageError(f"--json {args.json!r}: {problem}")
    print("| scenario | robot | height [m] | v_x [m/s] | p_cost [W] | legs [W] | wheels [W] |")
    print("|---|---|---|---|---|---|---|")
    results = {}
    for name in names:
        r = results[name] = run(name, args.mjcf, args.dt, args.decimation, args.warmup, args.seconds)
        for who in ("ours", "theirs"):
            x = r[who]
            print(
                f"| {name} | {who} | {x['height']:.3f} | {x['v_x']:.2f} | {x['p_cost']:.1f} | "
                f"{x['p_cost_legs']:.1f} | {x['p_cost_wheels']:.1f} |",
                flush=True,
            )
    if args.json:
        from wqwarp.utils.provenance import write_result_json

        write_result_json(args.json, {"dt": args.dt, "decimation": args.decimation, "results": results}, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
