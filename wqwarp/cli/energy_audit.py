"""Audit the simulator's power metrics: open-loop nominal gaits at two physics settings, legs and wheels apart.

Usage::

    python tools/energy_audit.py [--scenarios standing,drive_1.0,...] [--settings 0.005x4,0.001x20]
                                 [--warmup 1.0] [--seconds 3.0] [--num-envs 2] [--json PATH]
                                 [--quiet]

What runs: for every scenario and every physics setting ``DTxDECIMATION`` (physics substep dt [s] x substeps per
policy step; both defaults give a 50 Hz policy rate), ``--num-envs`` robots start at the default pose and follow
the nominal gait open loop, with no policy: once per policy step ``wqwarp.control.nominal.NominalGait`` turns the
command (v_x, v_y, w_z in the base frame) into leg joint targets (leg PD) and wheel speed targets (wheel PID), as in
``tests/sim/test_nominal_open_loop.py``. ``air_wheels`` instead holds the legs at the default joint pose and all four
wheels at a constant 5 rad/s with the robot in free fall (no ground load): it starts at rest at a height
max(50 m, g T^2 / 2 + 10 m), T = warmup + seconds, so it never reaches the ground inside the run.

What is measured: after ``--warmup`` seconds, the mean over ``--seconds`` seconds of policy steps and over the robots of
the simulator's own power outputs, each already averaged over the physics substeps of a policy step: ``p_cost`` = sum
|tau| |qd| (the paper's cost), ``p_mech`` = sum max(tau qd, 0), ``p_elec`` = the electrical power the battery pays
(``wqwarp.robot.motors``: tau qd plus each motor's copper loss, settled over the robot's bus), in total and for the 12
leg joints and the 4 wheels apart [W], and the copper loss of the legs and of the wheels; the base forward speed v_x in
the base frame [m/s], the yaw rate w_z [rad/s] and the trunk height [m]; and whether the trunk touched the ground at any
policy step of the run (warm-up included). ``ratio`` is p_cost at the first setting over p_cost at the last one.

For ``air_wheels`` also, seen at every physics substep (the simulator is built with decimation 1 and stepped
``decimation`` times per policy step, the same physics since the targets are constant; a once-per-policy-step sample
would alias a wheel that chatters at the substep rate): p_cost per wheel, |tau| |qd| averaged like ``p_cost``
(their sum is ``p_cost_wheels``); the wheel speed (window mean and largest |qd - target|); and the number of
wheel-torque sign flips: a flip is a sign change of one wheel's ``sim.joint_torque`` between two consecutive physics
substeps, both at simulated time >= 0.1 s and inside the window, with |tau| > 0.01 N m on both sides (smaller torques
are rounding noise around a settled wheel), summed over wheels and robots.

Output: progress lines on stderr (one per scenario and setting, with the elapsed time) unless ``--quiet``; a markdown
table on stdout; a JSON file with the command line, the git commit (and whether the tree was dirty), the settings,
the simulator configuration, every scenario's results per setting and the ratios, written atomically. Bad input
prints one ``error: ...`` line on stderr, writes nothing and exits with code 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import shlex
import sys
import time

import numpy as np

from wqwarp import quiet_warp
from wqwarp.cli.args import UsageError, doc_parser, entry_point, repo_path
from wqwarp.utils.io import output_problem

quiet_warp()

DEFAULT_JSON = "docs/studies/energy_audit/energy_audit.json"
DEFAULT_SETTINGS = "0.005x4,0.001x20"
GRAVITY = 9.81
"""[m/s^2], for the free-fall start height of ``air_wheels``."""
AIR_WHEEL_SPEED = 5.0
"""Wheel speed target of ``air_wheels`` [rad/s]."""
FLIP_SETTLE_TIME = 0.1
"""Wheel-torque sign flips are counted only from this simulated time on [s]."""
FLIP_DEADBAND = 0.01
"""A wheel torque counts towards a sign flip only if larger than this in magnitude [N m]."""

SCENARIOS: dict[str, tuple[str | None, tuple[float, float, float]]] = {
    "standing": ("driving", (0.0, 0.0, 0.0)),
    "drive_0.5": ("driving", (0.5, 0.0, 0.0)),
    "drive_1.0": ("driving", (1.0, 0.0, 0.0)),
    "turn_0.5": ("driving", (0.0, 0.0, 0.5)),
    "trot_0": ("trotting", (0.0, 0.0, 0.0)),
    "trot_0.3": ("trotting", (0.3, 0.0, 0.0)),
    "walk_0": ("walking", (0.0, 0.0, 0.0)),
    "walk_0.3": ("walking", (0.3, 0.0, 0.0)),
    "air_wheels": (None, (0.0, 0.0, 0.0)),
}
"""Scenario name -> (nominal gait, or None for the airborne wheel test; command (v_x [m/s], v_y [m/s], w_z [rad/s]))."""

POWERS = ("p_cost", "p_mech", "p_elec")
GROUPS = ("", "_legs", "_wheels")


def parse_settings(text: str) -> list[tuple[float, int]]:
    """``"0.005x4,0.001x20"`` -> [(0.005, 4), (0.001, 20)]: physics dt [s] and decimation of each setting."""
    settings = []
    for item in text.split(","):
        dt_text, sep, dec_text = item.strip().partition("x")
        try:
            dt, decimation = float(dt_text), int(dec_text)
        except ValueError:
            raise UsageError(f"malformed setting {item.strip()!r}; expected DTxDECIMATION, e.g. 0.005x4") from None
        if not sep or not (dt > 0 and np.isfinite(dt) and decimation >= 1):
            raise UsageError(f"malformed setting {item.strip()!r}; need dt > 0 and an integer decimation >= 1")
        settings.append((dt, decimation))
    return settings


def setting_name(dt: float, decimation: int) -> str:
    return f"{dt:g}x{decimation}"


def run_scenario(
    name: str,
    dt: float,
    decimation: int,
    warmup: float,
    seconds: float,
    num_envs: int,
    backend: str = "auto",
    trace: list | None = None,
) -> dict:
    """Run one scenario at one physics setting and return its window means (see the module docstring). With
    ``trace`` (a list), append per policy step, warm-up included, the robot means of time [s], trunk height [m],
    base v_x [m/s], yaw rate [rad/s] and p_cost (legs, wheels) [W] as a dict."""
    from wqwarp.control.driver import OpenLoopDriver
    from wqwarp.robot import asset as robot
    from wqwarp.robot import constants as C
    from wqwarp.sim.config import SimConfig
    from wqwarp.sim.simulator import Simulator

    gait, command = SCENARIOS[name]
    n = num_envs
    airborne = gait is None
    # air_wheels: a decimation-1 simulator stepped `decimation` times per policy step (same physics, the targets
    # being constant) so that every substep's torque is seen; the gaits use the setting as the policy would.
    sim_steps = decimation if airborne else 1
    sim = Simulator(
        SimConfig(num_envs=n, device="cpu", dt=dt, decimation=1 if airborne else decimation, backend=backend)
    )
    policy_dt = dt * decimation
    warmup_steps = int(round(warmup / policy_dt))
    window_steps = int(round(seconds / policy_dt))
    driver = None
    start_height = None
    if airborne:  # free fall from rest, legs at the default pose, wheels at a constant target
        total = (warmup_steps + window_steps) * policy_dt
        start_height = max(50.0, 0.5 * GRAVITY * total**2 + 10.0)
        q = np.tile(robot.default_joint_q(sim.layout, base_height=start_height), (n, 1))
        sim.reset(np.arange(n), q, np.zeros((n, sim.layout.dofs_per_world), np.float32))
        sim.leg_q_target.assign(np.tile(np.asarray(C.DEFAULT_JOINT_POS[:12], np.float32), (n, 1)))
        sim.wheel_qd_target.fill_(AIR_WHEEL_SPEED)
    else:  # the nominal gait open loop on the measured wheel contact
        driver = OpenLoopDriver(sim, gait, command, contact="sim")

    power_names = [p + g for p in POWERS for g in GROUPS] + ["p_copper_legs", "p_copper_wheels"]
    sums = dict.fromkeys(power_names, 0.0)
    vx = wz = height = 0.0
    tau_sq = np.zeros(16)  # per joint, last substep of each window step, mean over the robots
    trunk_steps = 0  # steps (x robots) with the trunk touching the ground, whole run
    wheel_p = np.zeros(4)  # |tau| |qd| per wheel and substep, summed over the window, averaged over the robots
    wheel_qd, wheel_err = np.zeros(4), 0.0
    flips, flip_pairs, prev_tau = 0, 0, None
    for k in range(warmup_steps + window_steps):
        in_window = k >= warmup_steps
        for j in range(sim_steps):
            qd_before = sim.actuated_qd.numpy()[:, 12:16].copy()  # the velocity the torque is computed from
            if driver is not None:
                driver.step()  # nominal gait -> targets -> one policy step (sim_steps is 1)
            else:
                sim.step()
            trunk_steps += int(sim.body_collision.numpy()[:, 0].sum())
            if in_window:
                for p in power_names:
                    sums[p] += float(getattr(sim, p).numpy().mean()) / sim_steps
            if not (airborne and in_window):
                continue
            t = k * policy_dt + (j + 1) * dt  # simulated time at the end of this substep
            tau, qd = sim.joint_torque.numpy()[:, 12:16].copy(), sim.actuated_qd.numpy()[:, 12:16]
            wheel_p += (np.abs(tau) * np.abs(qd_before)).mean(0) / sim_steps
            wheel_qd += qd.mean(0) / sim_steps
            wheel_err = max(wheel_err, float(np.abs(qd - AIR_WHEEL_SPEED).max()))
            if prev_tau is not None and t - dt >= FLIP_SETTLE_TIME - 1e-9:
                big = (np.abs(tau) > FLIP_DEADBAND) & (np.abs(prev_tau) > FLIP_DEADBAND)
                flips += int((big & (np.sign(tau) != np.sign(prev_tau))).sum())
                flip_pairs += 1
            prev_tau = tau
        if not (in_window or trace is not None):
            continue
        jq, jqd = sim.joint_q.numpy(), sim.joint_qd.numpy()
        step_vx = float(sim.base_lin_vel.numpy()[:, 0].mean())  # base frame
        step_wz = float(jqd[:, 5].mean())  # yaw rate: world-frame angular velocity about z
        step_z = float(jq[:, 2].mean())
        if trace is not None:
            trace.append(
                {
                    "t": (k + 1) * policy_dt,
                    "height": step_z,
                    "v_x": step_vx,
                    "w_z": step_wz,
                    **{p: float(getattr(sim, p).numpy().mean()) for p in ("p_cost", "p_cost_legs", "p_cost_wheels")},
                }
            )
        if not in_window:
            continue
        tau_sq += (sim.joint_torque.numpy().astype(np.float64) ** 2).mean(0)
        vx += step_vx
        wz += step_wz
        height += step_z

    m = 1.0 / window_steps
    out = {
        "dt": dt,
        "decimation": decimation,
        "policy_dt": policy_dt,
        "warmup_steps": warmup_steps,
        "window_steps": window_steps,
        **{p: sums[p] * m for p in power_names},
        "v_x": vx * m,
        "w_z": wz * m,
        "height": height * m,
        "copper_by_joint_kind": copper_by_kind(sim.motor_model, tau_sq * m),
        "trunk_touched": trunk_steps > 0,
        "trunk_contact_steps": trunk_steps,
    }
    if airborne:
        out.update(
            {
                "start_height": start_height,
                "wheel_speed_target": AIR_WHEEL_SPEED,
                "p_cost_per_wheel": (wheel_p * m).tolist(),
                "wheel_speed": (wheel_qd * m).tolist(),
                "wheel_speed_max_error": wheel_err,
                "wheel_torque_sign_flips": flips,
                "wheel_torque_substep_pairs": flip_pairs,
            }
        )
    return out


def copper_by_kind(model, tau_sq) -> dict:
    """Per joint kind (hip, thigh, knee over the four legs; the four wheels): the RMS output torque [N m] and the
    copper loss it costs [W] under ``model`` (``wqwarp.robot.motors.MotorModel``), from the window mean of each
    joint's squared torque ``tau_sq`` (16,) sampled at the last substep of each policy step: the term-by-term
    reading of ``p_copper_legs`` / ``p_copper_wheels``, which average every substep."""
    from wqwarp.robot.constants import JOINT_KIND_INDICES

    coeff = model.per_joint()["copper"]
    return {
        k: {
            "torque_rms": float(np.sqrt(np.mean([tau_sq[j] for j in js]))),
            "copper_w": float(sum(coeff[j] * tau_sq[j] for j in js)),
        }
        for k, js in JOINT_KIND_INDICES.items()
    }


def _ratio(a: float, b: float) -> float | None:
    return a / b if b > 0 else None


def audit(
    scenarios: list[str],
    settings: list[tuple[float, int]],
    warmup: float,
    seconds: float,
    num_envs: int,
    quiet: bool = False,
    backend: str = "auto",
) -> dict:
    """Every scenario at every setting: {scenario: {"gait", "command", "results": {setting: {...}}, "ratio"}}."""
    out = {}
    t0 = time.perf_counter()
    for name in scenarios:
        gait, command = SCENARIOS[name]
        results = {}
        for dt, decimation in settings:
            s = setting_name(dt, decimation)
            results[s] = run_scenario(name, dt, decimation, warmup, seconds, num_envs, backend)
            if not quiet:
                r = results[s]
                print(
                    f"[{time.perf_counter() - t0:7.1f} s] {name:<10} dt {s:<8} p_cost {r['p_cost']:7.2f} W "
                    f"(legs {r['p_cost_legs']:.2f}, wheels {r['p_cost_wheels']:.2f}) | p_elec {r['p_elec']:7.2f} W "
                    f"(legs {r['p_elec_legs']:.2f}, copper {r['p_copper_legs']:.2f}; wheels {r['p_elec_wheels']:.2f}, "
                    f"copper {r['p_copper_wheels']:.2f})",
                    file=sys.stderr,
                )
        entry = {
            "gait": gait or "none (free fall, legs held, wheels at 5 rad/s)",
            "command": list(command),
            "results": results,
        }
        if len(settings) > 1:
            first, last = results[setting_name(*settings[0])], results[setting_name(*settings[-1])]
            entry["ratio"] = {
                p: _ratio(first[p], last[p])
                for p in ("p_cost", "p_cost_legs", "p_cost_wheels", "p_elec", "p_elec_legs", "p_elec_wheels")
            }
        out[name] = entry
    return out


def _fmt(x: float | None, spec: str = ".2f") -> str:
    return "-" if x is None else format(x, spec)


def table(report: dict) -> str:
    """Markdown table of the audit: p_cost per setting (legs / wheels), ratio, v_x and trunk height per setting."""
    names = [s["name"] for s in report["settings"]]
    head = ["scenario"] + [f"p_cost dt{s['dt']:g} [W] (legs / wheels)" for s in report["settings"]]
    head += ["ratio (legs / wheels)", "v_x [m/s]", "height [m]"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    notes = []
    for name, entry in report["scenarios"].items():
        res = [entry["results"][s] for s in names]
        row = [name] + [f"{r['p_cost']:.2f} ({r['p_cost_legs']:.2f} / {r['p_cost_wheels']:.2f})" for r in res]
        ratio = entry.get("ratio")
        row.append(
            "-"
            if ratio is None
            else f"{_fmt(ratio['p_cost'])} ({_fmt(ratio['p_cost_legs'])} / {_fmt(ratio['p_cost_wheels'])})"
        )
        row.append(" / ".join(f"{r['v_x']:.2f}" for r in res))
        if entry["results"][names[0]].get("start_height") is not None:
            row.append("free fall")
            for s, r in zip(names, res, strict=True):
                per_wheel = ", ".join(f"{p:.3f}" for p in r["p_cost_per_wheel"])
                speed = ", ".join(f"{v:.3f}" for v in r["wheel_speed"])
                notes.append(
                    f"- air_wheels at dt {s}: p_cost per wheel (FR, FL, RR, RL) {per_wheel} W; wheel speed "
                    f"{speed} rad/s (target {r['wheel_speed_target']:g}, largest error "
                    f"{r['wheel_speed_max_error']:.3f}); {r['wheel_torque_sign_flips']} wheel-torque sign "
                    f"flips over {r['wheel_torque_substep_pairs']} consecutive-substep pairs x 4 wheels x "
                    f"{report['num_envs']} robot(s)"
                )
        else:
            row.append(" / ".join(f"{r['height']:.3f}" for r in res))
        for s, r in zip(names, res, strict=True):
            if r["trunk_touched"]:
                hits = r["trunk_contact_steps"]
                notes.append(f"- {name} at dt {s}: the trunk touched the ground ({hits} steps x robots)")
        lines.append("| " + " | ".join(row) + " |")
    settings = ", ".join(f"dt {s['dt']:g} s x {s['decimation']}" for s in report["settings"])
    lines.append("")
    lines.append(
        f"Settings: {settings}; ratio = first / last setting; v_x and height listed per setting. "
        f"Mean over {report['seconds']:g} s after {report['warmup']:g} s warm-up, "
        f"{report['num_envs']} robot(s)."
    )
    if notes:
        lines += [""] + notes
    return "\n".join(lines)


def _parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = doc_parser(__doc__)
    ap.add_argument(
        "--scenarios",
        default=",".join(SCENARIOS),
        help=f"comma-separated scenarios (default: all: {', '.join(SCENARIOS)})",
    )
    ap.add_argument(
        "--settings",
        default=DEFAULT_SETTINGS,
        help=f"comma-separated physics settings DTxDECIMATION: substep dt [s] x substeps per policy step "
        f"(default {DEFAULT_SETTINGS}; the ratio is first / last)",
    )
    ap.add_argument("--warmup", type=float, default=1.0, help="simulated time before the window [s] (default 1.0)")
    ap.add_argument("--seconds", type=float, default=3.0, help="length of the averaging window [s] (default 3.0)")
    ap.add_argument("--num-envs", type=int, default=2, help="robots per scenario and setting (default 2)")
    ap.add_argument("--json", default=None, help=f"output JSON path (default {DEFAULT_JSON} in the repository root)")
    ap.add_argument(
        "--backend",
        default="auto",
        choices=("auto", "mujoco_cpu", "featherstone"),
        help="physics: auto (MuJoCo on the CPU), mujoco_cpu, or featherstone (the differentiable path's "
        "solver with spring-damper contact, SimConfig.contact_*)",
    )
    ap.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    return ap.parse_args(argv)


def _validate(args: argparse.Namespace) -> tuple[list[str], list[tuple[float, int]], str]:
    scenarios = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    unknown = [s for s in scenarios if s not in SCENARIOS]
    if unknown or not scenarios:
        raise UsageError(f"unknown scenario {', '.join(unknown) or '(none given)'}; choose from {', '.join(SCENARIOS)}")
    settings = parse_settings(args.settings)
    if not (args.seconds > 0 and np.isfinite(args.seconds)):
        raise UsageError(f"--seconds must be > 0, got {args.seconds}")
    if not (args.warmup >= 0 and np.isfinite(args.warmup)):
        raise UsageError(f"--warmup must be >= 0, got {args.warmup}")
    if args.num_envs < 1:
        raise UsageError(f"--num-envs must be >= 1, got {args.num_envs}")
    for dt, decimation in settings:
        if round(args.seconds / (dt * decimation)) < 1:
            raise UsageError(f"--seconds {args.seconds} is shorter than one policy step at dt {dt} x {decimation}")
    path = repo_path(DEFAULT_JSON) if args.json is None else args.json
    if problem := output_problem(path):
        raise UsageError(f"cannot write --json {path!r}: {problem}")
    return scenarios, list(dict.fromkeys(settings)), path


@entry_point
def main(argv: list[str] | None = None) -> int:
    args = _parse_args(argv)
    scenarios, settings, path = _validate(args)
    from wqwarp.sim.config import SimConfig
    from wqwarp.utils.provenance import git_state, write_result_json

    sim_config = {
        k: v
        for k, v in dataclasses.asdict(SimConfig(backend=args.backend)).items()
        if k not in ("num_envs", "dt", "decimation")
    }
    report = {
        "command": shlex.join(["python", "tools/energy_audit.py", *(sys.argv[1:] if argv is None else argv)]),
        "git": git_state(),
        "created": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "warmup": args.warmup,
        "seconds": args.seconds,
        "num_envs": args.num_envs,
        "settings": [
            {"name": setting_name(dt, dec), "dt": dt, "decimation": dec, "policy_dt": dt * dec} for dt, dec in settings
        ],
        "sim_config": sim_config,
        "scenarios": audit(scenarios, settings, args.warmup, args.seconds, args.num_envs, args.quiet, args.backend),
    }
    write_result_json(path, report)
    print(table(report))
    if not args.quiet:
        print(f"wrote {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
