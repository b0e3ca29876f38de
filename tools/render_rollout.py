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
import copy
import math
import os
import pickle
import subprocess
import sys
import tempfile
import time

import numpy as np

from wqwarp.cli.args import ArgumentParser
from wqwarp.eval.loading import parse_segments  # noqa: E402

EXTENSIONS = (".gif", ".mp4")
GL_BACKENDS = ("egl", "osmesa")
POLICY_HZ = 50
AVERAGE_SECONDS = 0.5  # window of the measured velocity and power shown
TILE = 0.5  # checker tile edge on the ground [m]
SKY = (0.86, 0.89, 0.93, 1.0)
SKY_WALL = 30.0  # distance of the sky wall behind the robot [m]
SUN = np.array([-0.3, 0.2, -1.0]) / np.linalg.norm([-0.3, 0.2, -1.0])  # sunlight direction
# Renders one 8x8 image with MuJoCo's Renderer: whether the MUJOCO_GL backend of the environment works here.
_GL_PROBE = ("import mujoco; m = mujoco.MjModel.from_xml_string('<mujoco/>'); r = mujoco.Renderer(m, 8, 8); "
             "r.update_scene(mujoco.MjData(m)); r.render(); r.close()")  # fmt: skip


class UsageError(Exception):
    """Bad input or missing prerequisite: printed as ``error: ...``, exit status 2."""


def select_gl_backend() -> str:
    """Set ``MUJOCO_GL`` before mujoco is imported: the user's value if set, else the first of :data:`GL_BACKENDS`
    that renders in a subprocess (a backend that cannot load can break ``import mujoco`` itself). UsageError naming
    every backend tried and its error if none works."""
    if "mujoco" in sys.modules:  # too late to choose; whatever mujoco was imported with
        return os.environ.get("MUJOCO_GL", "")
    user = os.environ.get("MUJOCO_GL", "").strip()
    errors = []
    for gl in [user] if user else GL_BACKENDS:
        env = dict(os.environ, MUJOCO_GL=gl)
        try:
            r = subprocess.run([sys.executable, "-c", _GL_PROBE], env=env, capture_output=True, text=True, timeout=120)
            ok, why = r.returncode == 0, (r.stderr.strip().splitlines() or [f"exit status {r.returncode}"])[-1]
        except subprocess.TimeoutExpired:
            ok, why = False, "no answer within 120 s"
        if ok:
            os.environ["MUJOCO_GL"] = gl
            return gl
        errors.append(f"MUJOCO_GL={gl}: {why}")
    hint = "Debian/Ubuntu packages: libegl1 libegl-mesa0 libgl1-mesa-dri for egl, libosmesa6 for osmesa"
    raise UsageError(f"no OpenGL backend can render offscreen ({hint}): " + "; ".join(errors))


def _font(size: int):
    from PIL import ImageFont

    try:  # a monospaced font keeps the numbers still; matplotlib (the train extra) ships DejaVu Sans Mono
        import matplotlib

        path = os.path.join(os.path.dirname(matplotlib.__file__), "mpl-data", "fonts", "ttf", "DejaVuSansMono.ttf")
        return ImageFont.truetype(path, size)
    except Exception:
        try:
            return ImageFont.load_default(size=size)
        except TypeError:  # Pillow < 10.1
            return ImageFont.load_default()


def heading(qpos: np.ndarray) -> np.ndarray:
    """Yaw [rad] of each robot's trunk from MuJoCo ``qpos`` (N, nq) (free joint: position, then quaternion wxyz)."""
    w, x, y, z = qpos[:, 3], qpos[:, 4], qpos[:, 5], qpos[:, 6]
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


class PanelRenderer:
    """Draws one robot of the simulation's single-robot MuJoCo model from its ``qpos`` with a tracking camera."""

    def __init__(self, mj_model, width: int, height: int, distance: float, elevation: float):
        import mujoco

        self.mujoco = mujoco
        m = copy.copy(mj_model)  # a copy: the simulation's model is not touched
        m.vis.global_.offwidth = max(int(m.vis.global_.offwidth), width)
        m.vis.global_.offheight = max(int(m.vis.global_.offheight), height)
        m.vis.headlight.ambient[:] = 0.35
        m.vis.headlight.diffuse[:] = 0.45
        m.vis.headlight.specular[:] = 0.1
        m.vis.quality.shadowsize = 1024  # software GL: the default 4096 costs more than the rest of a frame
        extent = max(float(m.stat.extent), 1e-3)  # MuJoCo scales these distances by the model's extent
        m.vis.map.zfar = max(float(m.vis.map.zfar), 1.5 * SKY_WALL / extent)
        m.vis.map.shadowclip = (3 * distance + 3) / extent  # the sun's shadow map covers what the camera sees
        m.vis.map.fogstart, m.vis.map.fogend = (2 * distance + 1) / extent, (3 * distance + 5) / extent
        m.vis.rgba.fog[:] = SKY  # the colour of the distance and of the dome around the scene
        planes = m.geom_type == mujoco.mjtGeom.mjGEOM_PLANE
        m.geom_rgba[planes] = (0.80, 0.82, 0.84, 1.0)
        m.geom_size[planes, :2] = 0.0  # drawn without edges
        for g in np.flatnonzero(~planes):  # grey links, dark wheels, an orange trunk
            body = m.body(m.geom_bodyid[g]).name
            m.geom_rgba[g] = (0.12, 0.12, 0.13, 1.0) if body.endswith("_wheel") else (
                (0.93, 0.55, 0.16, 1.0) if body.endswith("trunk") else (0.55, 0.58, 0.64, 1.0))  # fmt: skip
        self.model = m
        self.data = mujoco.MjData(m)
        try:
            self.trunk = m.body("_wheeled_go1_trunk").id
        except KeyError:
            self.trunk = 1
        self.renderer = mujoco.Renderer(m, height, width)
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_FOG] = 1
        self.cam = mujoco.MjvCamera()
        self.cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.cam.distance, self.cam.elevation = distance, elevation
        self._tile_geom = (np.array([TILE / 2, TILE / 2, 0.0005]), np.eye(3).reshape(-1),
                           np.array([0.62, 0.64, 0.68, 1.0], np.float32))  # fmt: skip
        self._reach = int(math.ceil((3 * distance + 3) / TILE))

    def render(self, qpos: np.ndarray, azimuth_deg: float) -> np.ndarray:
        """(height, width, 3) uint8 image of the robot at ``qpos`` (nq,), camera azimuth in world degrees."""
        mj = self.mujoco
        d = self.data
        d.qpos[:] = qpos
        d.qvel[:] = 0.0
        mj.mj_forward(self.model, d)
        self.cam.lookat[:] = d.xpos[self.trunk]
        self.cam.azimuth = azimuth_deg
        self.renderer.update_scene(d, camera=self.cam)
        self._decorate(self.renderer.scene, d.xpos[self.trunk])
        return self.renderer.render()

    def _decorate(self, scn, centre: np.ndarray) -> None:
        """Dark checker tiles on the ground around ``centre`` and a sun that casts shadows."""
        mj = self.mujoco
        size, mat, rgba = self._tile_geom
        cx, cy = int(math.floor(centre[0] / TILE)), int(math.floor(centre[1] / TILE))
        for ix in range(cx - self._reach, cx + self._reach + 1):
            for iy in range(cy - self._reach, cy + self._reach + 1):
                if (ix + iy) % 2 or scn.ngeom >= scn.maxgeom:
                    continue
                pos = np.array([(ix + 0.5) * TILE, (iy + 0.5) * TILE, 0.0])
                mj.mjv_initGeom(scn.geoms[scn.ngeom], mj.mjtGeom.mjGEOM_BOX, size, pos, mat, rgba)
                scn.ngeom += 1
        if scn.ngeom < scn.maxgeom:  # a wall beyond the fog's end behind the robot: a sky instead of black
            az = math.radians(self.cam.azimuth)
            c, s = math.cos(az), math.sin(az)
            wall = np.array([[-s, 0.0, -c], [c, 0.0, -s], [0.0, -1.0, 0.0]])  # columns: x, y, normal to the camera
            mj.mjv_initGeom(scn.geoms[scn.ngeom], mj.mjtGeom.mjGEOM_PLANE, np.array([4 * SKY_WALL, 4 * SKY_WALL, 1.0]),
                            centre + SKY_WALL * np.array([c, s, 0.0]), wall.reshape(-1), rgba)  # fmt: skip
            scn.ngeom += 1
        if scn.nlight < len(scn.lights):
            light = scn.lights[scn.nlight]
            light.type = mj.mjtLightType.mjLIGHT_DIRECTIONAL
            light.dir[:] = SUN
            light.pos[:] = centre - 2.0 * SUN  # the shadow map is centred on the light: keep it near the robot
            light.ambient[:] = 0.1
            light.diffuse[:] = 0.5
            light.specular[:] = 0.2
            light.attenuation[:] = (1.0, 0.0, 0.0)
            light.cutoff, light.exponent, light.bulbradius, light.range = 90.0, 0.0, 0.02, 10.0
            light.headlight, light.castshadow, light.id, light.texid = 0, 1, -1, -1
            scn.nlight += 1

    def close(self) -> None:
        self.renderer.close()


def draw_overlay(img: np.ndarray, lines: list[str], font) -> np.ndarray:
    """``lines`` of text on a translucent dark box in the top left corner of ``img``."""
    from PIL import Image, ImageDraw

    base = Image.fromarray(img).convert("RGBA")
    layer = Image.new("RGBA", base.size, (0, 0, 0, 0))
    draw = ImageDraw.Draw(layer)
    pad = 3
    boxes = [draw.textbbox((0, 0), s, font=font) for s in lines]
    step = max(b[3] for b in boxes) + 2
    w = max(b[2] for b in boxes) + 2 * pad
    draw.rectangle([0, 0, w, step * len(lines) + 2 * pad - 2], fill=(0, 0, 0, 140))
    for i, s in enumerate(lines):
        draw.text((pad, pad + i * step), s, font=font, fill=(255, 255, 255, 255))
    out = np.asarray(Image.alpha_composite(base, layer).convert("RGB")).copy()
    out[:, -1] = 40  # a dark line between panels
    return out


class GifWriter:
    """Collects frames (palette images, 1 byte a pixel) and writes them with Pillow at the end."""

    def __init__(self, path: str, fps: int):
        self.path, self.fps, self.frames = path, fps, []

    def append(self, frame: np.ndarray) -> None:
        from PIL import Image

        self.frames.append(Image.fromarray(frame).convert("P", palette=Image.Palette.ADAPTIVE, colors=256))

    def close(self) -> None:
        self.frames[0].save(self.path, format="GIF", save_all=True, append_images=self.frames[1:],
                            duration=1000.0 / self.fps, loop=0, optimize=False)  # fmt: skip


class Mp4Writer:
    """H.264 through imageio-ffmpeg, frame by frame."""

    def __init__(self, path: str, fps: int):
        import imageio.v2 as imageio

        opts = {"codec": "libx264", "quality": 8, "pixelformat": "yuv420p", "macro_block_size": 1}
        self.writer = imageio.get_writer(path, format="FFMPEG", fps=fps, ffmpeg_log_level="error", **opts)

    def append(self, frame: np.ndarray) -> None:
        h, w = frame.shape[:2]  # yuv420p needs even sizes: repeat the last row / column rather than rescale
        self.writer.append_data(np.pad(frame, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge"))

    def close(self) -> None:
        self.writer.close()


def check_mp4_writer() -> None:
    try:
        import imageio  # noqa: F401
        import imageio_ffmpeg  # noqa: F401
    except ImportError as e:
        raise UsageError(f".mp4 needs imageio and imageio-ffmpeg ({e}): `pip install imageio imageio-ffmpeg` "
                         "(or `pip install -e .[render]`), or write a .gif") from None  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    ap = ArgumentParser(description=__doc__.split("\n\n")[0], epilog=__doc__.split("\n\n", 1)[1],
                        formatter_class=argparse.RawDescriptionHelpFormatter)  # fmt: skip
    ap.add_argument("--checkpoint", required=True, help="model_<it>.pt written by train/ppo_newton.py")
    ap.add_argument("--out", required=True, help="video to write: .mp4 (needs imageio-ffmpeg) or .gif")
    ap.add_argument("--preset", default=None, help="preset of the checkpoint (default: from its configuration)")
    ap.add_argument("--robots", type=int, default=3, help="robots, one panel each, tiled left to right (default 3)")
    ap.add_argument("--command", default="0.6,0,0", help="command vx,vy,wz held by all robots (default 0.6,0,0)")
    ap.add_argument("--segments", default=None,
                    help="command sequence 'vx,vy,wz:seconds;...' instead of --command (its length replaces "
                         "--seconds)")  # fmt: skip
    ap.add_argument("--seconds", type=float, default=6.0, help="length with --command [s] (default 6)")
    ap.add_argument("--fps", type=int, default=25, help="frames per second, a divisor of 50 (default 25)")
    ap.add_argument("--width", type=int, default=320, help="panel width [px] (default 320)")
    ap.add_argument("--height", type=int, default=240, help="panel height [px] (default 240)")
    ap.add_argument("--distance", type=float, default=2.0, help="camera distance from the trunk [m] (default 2)")
    ap.add_argument("--elevation", type=float, default=-20.0, help="camera elevation [deg], negative looks down "
                    "(default -20)")  # fmt: skip
    ap.add_argument("--azimuth", type=float, default=-120.0, help="camera azimuth [deg] from the robot's heading at "
                    "its episode start (0 behind, -90 its left side; default -120)")  # fmt: skip
    ap.add_argument("--seed", type=int, default=None, help="env random seed: spawn yaws (default: the checkpoint's)")
    return ap


def check_args(args) -> list[tuple[tuple[float, float, float], float]]:
    """Validate everything that needs no simulation; the command segments, or UsageError."""
    ext = os.path.splitext(args.out)[1].lower()
    if ext not in EXTENSIONS:
        raise UsageError(f"--out {args.out!r}: unknown extension {ext or '(none)'!r}; use .mp4 or .gif")
    folder = os.path.dirname(os.path.abspath(args.out))
    if not os.path.isdir(folder):
        raise UsageError(f"--out {args.out!r}: folder {folder} does not exist")
    if os.path.isdir(args.out):
        raise UsageError(f"--out {args.out!r} is a folder")
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
        check_mp4_writer()
    return segments


def render(args, segments, writer, progress=print) -> dict:
    """Run the rollout and feed ``writer`` one frame (H, K * W, 3) every 50 / fps policy steps. Returns a summary."""
    import torch
    import warp as wp

    wp.config.quiet = True
    from wqwarp.control.gaits import GAIT_NAMES
    from wqwarp.eval.loading import make_policy_runner
    from wqwarp.eval.protocols import start_rollout

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
    progress(f"{runner.preset} checkpoint (iteration {runner.iteration}), {robots}, {sum(steps) * dt:g} s, "
             f"{num_frames} frames of {n * args.width}x{args.height} at {args.fps} fps, "
             f"MUJOCO_GL={os.environ.get('MUJOCO_GL', '')}")  # fmt: skip
    try:
        panel = PanelRenderer(env.sim.mj_model, args.width, args.height, args.distance, args.elevation)
    except Exception as e:  # e.g. mujoco imported by the caller before MUJOCO_GL was chosen
        raise UsageError(f"offscreen rendering failed (MUJOCO_GL={os.environ.get('MUJOCO_GL', '')!r}): {e}; set "
                         "MUJOCO_GL=egl or osmesa before mujoco is imported") from None  # fmt: skip
    font = _font(max(8, round(args.height / 20)))
    window = collections.deque(maxlen=max(1, int(round(AVERAGE_SECONDS / dt))))
    falls = np.zeros(n, dtype=np.int64)
    obs = start_rollout(env, torch.tensor([segments[0][0]] * n, dtype=torch.float32), sum(steps) * dt)
    yaw0 = heading(env.sim.mujoco_qpos())
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
                    window.append(torch.stack([b["lin_vel"][:, 0], b["lin_vel"][:, 1], b["ang_vel"][:, 2],
                                               env.tv["p_cost"]], 1).cpu().numpy())  # fmt: skip
                    done = dones.bool().cpu().numpy()
                    qpos = env.sim.mujoco_qpos()
                    if done.any():
                        falls += done
                        yaw0[done] = heading(qpos[done])
                    if k % stride:
                        continue
                    mean = np.mean(window, axis=0)
                    gait = env.active_gait().cpu().numpy()
                    tiles = []
                    for i in range(n):
                        img = panel.render(qpos[i], math.degrees(yaw0[i]) + args.azimuth)
                        v, p = mean[i], mean[i, 3]
                        lines = [f"robot {i}  t {k * dt:5.2f} s" + (f"  falls {falls[i]}" if falls[i] else ""),
                                 f"cmd  vx {cmd[0]:+.2f} vy {cmd[1]:+.2f} wz {cmd[2]:+.2f}",
                                 f"meas vx {v[0]:+.2f} vy {v[1]:+.2f} wz {v[2]:+.2f}",
                                 f"{GAIT_NAMES[int(gait[i])]}  {p:.0f} W"]  # fmt: skip
                        tiles.append(draw_overlay(img, lines, font))
                    writer.append(np.concatenate(tiles, axis=1))
                    frames += 1
                    pct = 100 * frames // num_frames
                    if pct // 10 > shown:
                        shown = pct // 10
                        progress(f"  {pct:3d}%  {frames}/{num_frames} frames  ({time.time() - t0:.1f} s)")
    finally:
        panel.close()
    return {"frames": frames, "width": n * args.width, "height": args.height, "seconds": k * dt,
            "falls": int(falls.sum()), "wall": time.time() - t0}  # fmt: skip


def write_atomically(path: str, fps: int, produce) -> None:
    """``produce(writer)`` fills a writer for a temporary file beside ``path``; then it replaces ``path``. On any
    failure the temporary file is removed and ``path`` is untouched."""
    folder, name = os.path.split(os.path.abspath(path))
    ext = os.path.splitext(name)[1].lower()
    fd, tmp = tempfile.mkstemp(prefix=f".{name}.", suffix=ext, dir=folder)
    os.close(fd)
    try:
        writer = (GifWriter if ext == ".gif" else Mp4Writer)(tmp, fps)
        produce(writer)
        writer.close()
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; a written file normally is not
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        segments = check_args(args)
        gl = select_gl_backend()
        summary = {}

        def produce(writer):
            summary.update(render(args, segments, writer, progress=lambda s: print(s, flush=True)))

        write_atomically(args.out, args.fps, produce)
    except UsageError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {args.out}: {summary['frames']} frames of {summary['width']}x{summary['height']}, "
          f"{summary['seconds']:g} s at {args.fps} fps, falls {summary['falls']}, MUJOCO_GL={gl}, "
          f"{summary['wall']:.1f} s")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
