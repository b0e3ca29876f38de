"""Offscreen video of wheeled Go1 rollouts with MuJoCo's renderer: one tracking-camera panel per robot, a text
overlay, and GIF / MP4 writers (used by ``tools/render_rollout.py``, :mod:`wqwarp.cli.render`).

Offscreen OpenGL: MUJOCO_GL as set by the user, otherwise the first of egl and osmesa that can render here (tried in
a subprocess before mujoco is imported, :func:`select_gl_backend`).
"""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys

import numpy as np

GL_BACKENDS = ("egl", "osmesa")
TILE = 0.5  # checker tile edge on the ground [m]
SKY = (0.86, 0.89, 0.93, 1.0)
SKY_WALL = 30.0  # distance of the sky wall behind the robot [m]
SUN = np.array([-0.3, 0.2, -1.0]) / np.linalg.norm([-0.3, 0.2, -1.0])  # sunlight direction
# Renders one 8x8 image with MuJoCo's Renderer: whether the MUJOCO_GL backend of the environment works here.
_GL_PROBE = (
    "import mujoco; m = mujoco.MjModel.from_xml_string('<mujoco/>'); r = mujoco.Renderer(m, 8, 8); "
    "r.update_scene(mujoco.MjData(m)); r.render(); r.close()"
)


class RenderSetupError(RuntimeError):
    """A missing prerequisite of rendering (no OpenGL backend, no MP4 writer), named with how to get it."""


def select_gl_backend() -> str:
    """Set ``MUJOCO_GL`` before mujoco is imported: the user's value if set, else the first of :data:`GL_BACKENDS`
    that renders in a subprocess (a backend that cannot load can break ``import mujoco`` itself).
    RenderSetupError naming every backend tried and its error if none works."""
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
    raise RenderSetupError(f"no OpenGL backend can render offscreen ({hint}): " + "; ".join(errors))


def font(size: int):
    """A monospaced Pillow font of ``size`` [px] (DejaVu Sans Mono from matplotlib, else Pillow's default)."""
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
            m.geom_rgba[g] = (
                (0.12, 0.12, 0.13, 1.0)
                if body.endswith("_wheel")
                else ((0.93, 0.55, 0.16, 1.0) if body.endswith("trunk") else (0.55, 0.58, 0.64, 1.0))
            )
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
        self._tile_geom = (
            np.array([TILE / 2, TILE / 2, 0.0005]),
            np.eye(3).reshape(-1),
            np.array([0.62, 0.64, 0.68, 1.0], np.float32),
        )
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
            mj.mjv_initGeom(
                scn.geoms[scn.ngeom],
                mj.mjtGeom.mjGEOM_PLANE,
                np.array([4 * SKY_WALL, 4 * SKY_WALL, 1.0]),
                centre + SKY_WALL * np.array([c, s, 0.0]),
                wall.reshape(-1),
                rgba,
            )
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
        self.frames[0].save(
            self.path,
            format="GIF",
            save_all=True,
            append_images=self.frames[1:],
            duration=1000.0 / self.fps,
            loop=0,
            optimize=False,
        )


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
        raise RenderSetupError(
            f".mp4 needs imageio and imageio-ffmpeg ({e}): `pip install imageio imageio-ffmpeg` "
            "(or `pip install -e .[render]`), or write a .gif"
        ) from None
