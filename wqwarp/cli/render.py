"""Render a rollout of a trained checkpoint to a video (.mp4 or .gif) that can be watched without Omniverse.

Usage::

    python tools/render_rollout.py --checkpoint runs/ours_X/model_1499.pt --out run.mp4|run.gif [--robots 3]
        [--command vx,vy,wz | --segments "vx,vy,wz:seconds;..."] [--seconds 6] [--fps 25]
        [--width 320] [--height 240] [--azimuth -120] [--elevation -20] [--distance 2] [--seed N] [--preset NAME]

--robots K robots (no domain randomisation, each with its own random spawn yaw) run the deterministic policy on the
CPU (mujoco_cpu backend) side by side; each is drawn in its own panel by MuJoCo's offscreen renderer, and the K panels
are tiled left to right into one frame (robot 0 on the left), so a frame is K x --width pixels wide and --height
pixels tall. Each panel's camera tracks its robot's trunk at --distance metres and --elevation degrees; --azimuth is
measured from the robot's heading at the start of its episode (0: looking along the heading, from behind; -90:
looking at its left side; -120, the default: from its front left), so every panel starts from the same side of its
robot and turning stays visible. The ground gets a 0.5 m checker pattern so that motion can be seen.

Overlay on each panel: robot index and time [s]; the command (v_x, v_y, w_z) held; the measured base velocity
(v_x, v_y in the base frame [m/s], w_z [rad/s]) and the power p_cost [W], both averaged over the last 0.5 s; the
gait running now; the number of falls (a robot that falls is reset and goes on).

Commands: --command for the whole --seconds, or --segments, a sequence ``v_x,v_y,w_z:seconds`` separated by ';'
(as tools/gait_sequence.py), whose durations give the length (--seconds is then ignored). The policy runs at 50 Hz;
--fps must divide 50 (50, 25, 10, 5, ...): a frame is drawn every 50 / fps policy steps.

Output: .gif through Pillow; .mp4 (H.264) through imageio with imageio-ffmpeg (``pip install imageio imageio-ffmpeg``
or ``pip install -e .[render]``). The file is written to a temporary file in the same folder and moved into place at
the end: a failure leaves no partial file and an existing file stays as it was.

Offscreen OpenGL: MUJOCO_GL as set by the user, otherwise the first of egl and osmesa that can render here (tried in
a subprocess before mujoco is imported). Headless Linux without a GPU needs mesa's EGL and software driver (Debian
packages libegl1 libegl-mesa0 libgl1-mesa-dri) or OSMesa (libosmesa6).

Exit status: 0 on success; 2 on bad input (missing or unusable checkpoint, unknown output extension, missing output
folder, malformed command or segments, --robots < 1, an --fps that does not divide 50, panel size out of range),
when the .mp4 writer is not installed, or when no OpenGL backend can render.
"""

from __future__ import annotations

import argparse
import collections
import math
import os
import pickle
import sys
import time

import numpy as np

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.eval.timeline import parse_segments
from wqwarp.utils.io import atomic_path, output_problem
from wqwarp.viz import video

EXTENSIONS = (".gif", ".mp4")
POLICY_HZ = 50
AVERAGE_SECONDS = 0.5  # window of the measured velocity and power shown


def build_parser() -> argparse.ArgumentParser:
    ap = doc_parser(__doc__)
    ap.add_argument("--checkpoint", required=True, help="model_<it>.pt written by train/ppo_newton.py")
    ap.add_argument("--out", required=True, help="video to write: .mp4 (needs imageio-ffmpeg) or .gif")
    ap.add_argument("--preset", default=None, help="preset of the checkpoint (default: from its configuration)")
    ap.add_argument("--robots", type=int, default=3, help="robots, one panel each, tiled left to right (default 3)")
    ap.add_argument("--command", default="0.6,0,0", help="command vx,vy,wz held by all robots (default 0.6,0,0)")
    ap.add_argument(
        "--segments",
        default=None,
        help="command sequence 'vx,vy,wz:seconds;...' instead of --command (its length replaces --seconds)",
    )
    ap.add_argument("--seconds", type=float, default=6.0, help="length with --command [s] (default 6)")
    ap.add_argument("--fps", type=int, default=25, help="frames per second, a divisor of 50 (default 25)")
    ap.add_argument("--width", type=int, default=320, help="panel width [px] (default 320)")
    ap.add_argument("--height", type=int, default=240, help="panel height [px] (default 240)")
    ap.add_argument("--distance", type=float, default=2.0, help="camera distance from the trunk [m] (default 2)")
    ap.add_argument(
        "--elevation", type=float, default=-20.0, help="camera elevation [deg], negative looks down (default -20)"
    )
    ap.add_argument(
        "--azimuth",
        type=float,
        default=-120.0,
        help="camera azimuth [deg] from the robot's heading at "
        "its episode start (0 behind, -90 its left side; default -120)",
    )
    ap.add_argument("--seed", type=int, default=None, help="env random seed: spawn yaws (default: the checkpoint's)")
    return ap


def check_args(args) -> list[tuple[tuple[float, float, float], float]]:
    """Validate everything that needs no simulation; the command segments, or UsageError."""
    ext = os.path.splitext(args.out)[1].lower()
    if ext not in EXTENSIONS:
        raise UsageError(f"--out {args.out!r}: unknown extension {ext or '(none)'!r}; use .mp4 or .gif")
    if problem := output_problem(args.out):
        raise UsageError(f"--out {args.out!r}: {problem}")
    if not os.path.isfile(args.checkpoint):
        raise UsageError(f"no such checkpoint: {args.checkpoint}")
    if args.robots < 1:
        raise UsageError(f"--robots must be >= 1, got {args.robots}")
    if args.fps < 1 or POLICY_HZ % args.fps:
        raise UsageError(f"--fps must divide the policy rate {POLICY_HZ} Hz (50, 25, 10, 5, ...), got {args.fps}")
    if not (16 <= args.width <= 4096 and 16 <= args.height <= 4096):
        raise UsageError(f"--width and --height must be 16..4096 px, got {args.width}x{args.height}")
    if not (math.isfinite(args.distance) and args.distance > 0):
        raise UsageError(f"--distance must be > 0, got {args.distance}")
    try:
        if args.segments is not None:
            segments = parse_segments(args.segments)
        else:
            if not (math.isfinite(args.seconds) and args.seconds > 0):
                raise UsageError(f"--seconds must be > 0, got {args.seconds}")
            segments = parse_segments(f"{args.command}:{args.seconds}")  # one segment: the command held
    except ValueError as e:
        raise UsageError(f"{'--segments' if args.segments is not None else '--command'}: {e}") from None
    if sum(round(s * POLICY_HZ) for _, s in segments) < POLICY_HZ // args.fps:
        raise UsageError("the rollout is shorter than one frame")
    if ext == ".mp4":
        video.check_mp4_writer()
    return segments


def render(args, segments, writer, progress=print) -> dict:
    """Run the rollout and feed ``writer`` one frame (H, K * W, 3) every 50 / fps policy steps. Returns a summary."""
    import torch

    from wqwarp import quiet_warp

    quiet_warp()
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.rollout import start_rollout

    extra = {} if args.seed is None else {"seed": args.seed}
    try:
        runner = make_policy_runner(args.checkpoint, args.preset, args.robots, "cpu", **extra)
    except (ValueError, RuntimeError, EOFError, pickle.UnpicklingError) as e:  # what a file that is no checkpoint gives
        msg = str(e)
        raise UsageError(msg if args.checkpoint in msg else f"cannot use checkpoint {args.checkpoint}: {msg}") from None
    env, n = runner.env, args.robots
    dt = float(env.dt)
    stride = int(round(1.0 / (args.fps * dt)))
    if stride < 1 or abs(stride * dt * args.fps - 1.0) > 1e-6:
        raise UsageError(f"--fps {args.fps} does not divide the policy rate {1.0 / dt:g} Hz")
    steps = [int(round(s / dt)) for _, s in segments]
    num_frames = sum(steps) // stride
    robots = f"{n} robot{'s' * (n > 1)}"
    progress(
        f"{runner.preset} checkpoint (iteration {runner.iteration}), {robots}, {sum(steps) * dt:g} s, "
        f"{num_frames} frames of {n * args.width}x{args.height} at {args.fps} fps, "
        f"MUJOCO_GL={os.environ.get('MUJOCO_GL', '')}"
    )
    try:
        panel = video.PanelRenderer(env.sim.mj_model, args.width, args.height, args.distance, args.elevation)
    except Exception as e:  # e.g. mujoco imported by the caller before MUJOCO_GL was chosen
        raise UsageError(
            f"offscreen rendering failed (MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r}): {e}; set "
            "MUJOCO_GL=egl or osmesa before mujoco is imported"
        ) from None
    text_font = video.font(max(8, round(args.height / 20)))
    window = collections.deque(maxlen=max(1, int(round(AVERAGE_SECONDS / dt))))
    falls = np.zeros(n, dtype=np.int64)
    obs = start_rollout(env, torch.tensor([segments[0][0]] * n, dtype=torch.float32), sum(steps) * dt)
    yaw0 = video.heading(env.sim.mujoco_qpos())
    k = frames = 0
    shown = -1
    t0 = time.time()
    try:
        with torch.no_grad():
            for (cmd, _), seg_steps in zip(segments, steps, strict=True):
                env.hold_commands(torch.tensor([cmd] * n, dtype=torch.float32))
                for _ in range(seg_steps):
                    obs, _, dones, _ = env.step(runner.policy(obs))
                    k += 1
                    b = env.base_state()
                    window.append(
                        torch.stack([b["lin_vel"][:, 0], b["lin_vel"][:, 1], b["ang_vel"][:, 2], env.tv["p_cost"]], 1)
                        .cpu()
                        .numpy()
                    )
                    done = dones.bool().cpu().numpy()
                    qpos = env.sim.mujoco_qpos()
                    if done.any():
                        falls += done
                        yaw0[done] = video.heading(qpos[done])
                    if k % stride:
                        continue
                    mean = np.mean(window, axis=0)
                    gait = env.active_gait().cpu().numpy()
                    tiles = []
                    for i in range(n):
                        img = panel.render(qpos[i], math.degrees(yaw0[i]) + args.azimuth)
                        v, p = mean[i], mean[i, 3]
                        lines = [
                            f"robot {i}  t {k * dt:5.2f} s" + (f"  falls {falls[i]}" if falls[i] else ""),
                            f"cmd  vx {cmd[0]:+.2f} vy {cmd[1]:+.2f} wz {cmd[2]:+.2f}",
                            f"meas vx {v[0]:+.2f} vy {v[1]:+.2f} wz {v[2]:+.2f}",
                            f"{env.gait_names[int(gait[i])]}  {p:.0f} W",
                        ]
                        tiles.append(video.draw_overlay(img, lines, text_font))
                    writer.append(np.concatenate(tiles, axis=1))
                    frames += 1
                    pct = 100 * frames // num_frames
                    if pct // 10 > shown:
                        shown = pct // 10
                        progress(f"  {pct:3d}%  {frames}/{num_frames} frames  ({time.time() - t0:.1f} s)")
    finally:
        panel.close()
    return {
        "frames": frames,
        "width": n * args.width,
        "height": args.height,
        "seconds": k * dt,
        "falls": int(falls.sum()),
        "wall": time.time() - t0,
    }


def write_atomically(path: str, fps: int, produce) -> None:
    """``produce(writer)`` fills a writer for a temporary file beside ``path``; then it replaces ``path``
    (:func:`wqwarp.utils.io.atomic_path`). On any failure the temporary file is removed and ``path`` is untouched."""
    with atomic_path(path) as tmp:
        writer = (video.GifWriter if os.path.splitext(path)[1].lower() == ".gif" else video.Mp4Writer)(tmp, fps)
        produce(writer)
        writer.close()
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; a written file normally is not


@entry_point
def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        segments = check_args(args)
        gl = video.select_gl_backend()
        summary = {}

        def produce(writer):
            summary.update(render(args, segments, writer, progress=lambda s: print(s, flush=True)))

        write_atomically(args.out, args.fps, produce)
    except video.RenderSetupError as e:  # no OpenGL backend or no .mp4 writer: a missing prerequisite, exit 2
        raise UsageError(str(e)) from None
    print(
        f"wrote {args.out}: {summary['frames']} frames of {summary['width']}x{summary['height']}, "
        f"{summary['seconds']:g} s at {args.fps} fps, falls {summary['falls']}, MUJOCO_GL={gl}, "
        f"{summary['wall']:.1f} s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
