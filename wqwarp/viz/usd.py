"""Record a rollout of N robots and write it as a time-sampled USD stage for usdview / Omniverse.

Stage layout (Z up, metres, one time code per frame, ``timeCodesPerSecond = framesPerSecond = fps``)::

    /World                          Xform (default prim)
    /World/ground                   Cube, top face at z = 0, covers every recorded position with a margin
    /World/robot_{i}                Xform translated by (0, i * spacing, 0) (1 m, more if the robots' paths would
                                    overlap sideways); per-frame custom attributes wqwarp:*
    /World/robot_{i}/{body}         Xform per rigid body (trunk, FR_hip, FR_thigh, FR_calf, FR_wheel, ...):
                                    xformOp:translate (float3) + xformOp:orient (quatf), sampled every frame,
                                    the body's world pose from ``Simulator.body_q``
    /World/robot_{i}/{body}/{shape} the asset's Cube / Cylinder / Capsule shapes with their local transforms,
                                    authored once (not time-sampled)

Per-robot attributes on ``/World/robot_{i}``, one sample per frame:

* ``wqwarp:gait`` (string): the requested (selected) gait; ``wqwarp:activeGait`` (string): the gait running after
  the switching rule of ``wqwarp.kernels.gait``.
* ``wqwarp:phase`` (float[4]): gait phases of FR, FL, RR, RL [cycles].
* ``wqwarp:command`` (float3): (v_x, v_y, w_z) command, base frame [m/s, m/s, rad/s].
* ``wqwarp:baseVelocity`` (float3): measured (v_x, v_y, w_z) of the trunk COM in the trunk frame, the command's
  layout [m/s, m/s, rad/s].
* ``wqwarp:pCost`` (float): p_cost = sum |tau| |qd| averaged over the policy step [W].
* ``wqwarp:wheelContact`` (int[4]): wheel contact flags FR, FL, RR, RL.

The stage is built in memory and exported to a temporary file beside the destination, then renamed onto it, so a
failed export never leaves a partial file.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence

import numpy as np

from wqwarp.robot import constants as C
from wqwarp.utils.io import atomic_path, output_problem

USD_EXTENSIONS: tuple[str, ...] = (".usda", ".usdc", ".usd")
"""Output formats: text, binary crate, and ``.usd`` (written as crate)."""

ATTR_GAIT = "wqwarp:gait"
ATTR_ACTIVE_GAIT = "wqwarp:activeGait"
ATTR_PHASE = "wqwarp:phase"
ATTR_COMMAND = "wqwarp:command"
ATTR_BASE_VELOCITY = "wqwarp:baseVelocity"
ATTR_P_COST = "wqwarp:pCost"
ATTR_WHEEL_CONTACT = "wqwarp:wheelContact"

MIN_SPACING = 1.0
"""Smallest distance between neighbouring robots along y [m]."""
GROUND_THICKNESS = 0.02
"""Thickness of the ground slab below z = 0 [m]."""
GROUND_MARGIN = 1.5
"""Ground extends this far beyond every recorded body position [m]."""

_SHAPE_TYPES = ("Cube", "Cylinder", "Capsule", "Sphere", "Cone")
_LEG_COLOURS = {
    "FR": (0.85, 0.25, 0.2),
    "FL": (0.2, 0.65, 0.3),
    "RR": (0.25, 0.4, 0.85),
    "RL": (0.85, 0.7, 0.2),
}
"""Wheel colours per leg, so legs can be told apart from any angle."""


def check_output_path(path: str) -> str | None:
    """The problem with writing a USD file to ``path`` (an extension USD does not write, or
    :func:`wqwarp.cli.args.output_problem`), or None when it can be written."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in USD_EXTENSIONS:
        return f"unknown extension {ext or '(none)'!r} of {path!r}; use one of {', '.join(USD_EXTENSIONS)}"
    problem = output_problem(path)
    return f"cannot write {path!r}: {problem}" if problem else None


def frame_steps(seconds: float, fps: float, policy_dt: float) -> np.ndarray:
    """Policy step recorded by each frame: frame k (time k / fps) shows the state after the nearest policy step.

    Frames cover [0, seconds] inclusive (frame 0 = the state after reset, step 0), so there are
    ``round(seconds * fps) + 1`` of them; at ``fps == 1 / policy_dt`` frame k is step k."""
    if not (seconds > 0 and fps > 0 and policy_dt > 0):
        raise ValueError(f"need seconds, fps and policy_dt > 0, got {seconds}, {fps}, {policy_dt}")
    n_steps = int(round(seconds / policy_dt))
    n_frames = int(round(seconds * fps)) + 1
    t = np.arange(n_frames) / fps
    return np.clip(np.rint(t / policy_dt), 0, n_steps).astype(np.int64)


def asset_shapes(asset_path: str = C.WHEELED_GO1_USD) -> dict[str, list[tuple[str, str, list[tuple]]]]:
    """The shapes of each body of the asset: ``{body: [(shape, prim type, [(attr, type name, value, variability)])]}``.

    Physics attributes and API schemas are left out: the output is for looking at, not simulating."""
    from pxr import Usd

    stage = Usd.Stage.Open(asset_path, load=Usd.Stage.LoadAll)
    if not stage:
        raise ValueError(f"cannot open robot asset {asset_path!r}")
    root = stage.GetDefaultPrim() or stage.GetPseudoRoot()
    out: dict[str, list] = {}
    for body in root.GetChildren():
        if body.GetTypeName() != "Xform":
            continue
        shapes = []
        for shape in body.GetChildren():
            if shape.GetTypeName() not in _SHAPE_TYPES:
                continue
            attrs = []
            for a in shape.GetAttributes():
                name = a.GetName()
                if name.startswith("physics:") or name.startswith("physx") or not a.HasAuthoredValue():
                    continue
                attrs.append((name, str(a.GetTypeName()), a.Get(), a.GetVariability()))
            shapes.append((shape.GetName(), shape.GetTypeName(), attrs))
        out[body.GetName()] = shapes
    return out


class RolloutRecorder:
    """Collect the frames of a rollout of ``num_envs`` robots, then write them as one USD stage.

    Usage: ``rec = RolloutRecorder.for_simulator(sim, seconds, fps)``; call :meth:`capture` with step 0 after reset
    and with step k after the k-th ``sim.step()`` (it stores only the steps some frame needs); then
    :meth:`write`. ``nominal`` (a :class:`wqwarp.control.nominal.NominalGait`) adds the gait, phase and command
    attributes, the gaits named as in its library unless ``gait_names`` says otherwise."""

    def __init__(
        self,
        body_names: Sequence[str],
        num_envs: int,
        seconds: float,
        fps: float,
        policy_dt: float,
        gait_names: Sequence[str] | None = None,
        spacing: float | None = None,
        asset_path: str = C.WHEELED_GO1_USD,
    ):
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.body_names = [n.rsplit("/", 1)[-1] for n in body_names]
        self.num_envs = int(num_envs)
        self.fps = float(fps)
        self.seconds = float(seconds)
        self.policy_dt = float(policy_dt)
        self.gait_names = None if gait_names is None else tuple(gait_names)
        """Gait names by gait id; None: those of the library of the first nominal gait :meth:`capture` is given."""
        self.spacing = None if spacing is None else float(spacing)
        self.asset_path = asset_path
        self.steps = frame_steps(seconds, fps, policy_dt)
        self.num_steps = int(round(seconds / policy_dt))
        n, b, f = self.num_envs, len(self.body_names), self.num_frames
        self.body_q = np.zeros((f, n, b, 7), np.float32)
        self.phase = np.zeros((f, n, 4), np.float32)
        self.command = np.zeros((f, n, 3), np.float32)
        self.base_velocity = np.zeros((f, n, 3), np.float32)
        self.p_cost = np.zeros((f, n), np.float32)
        self.gait = np.zeros((f, n), np.int32)
        self.active_gait = np.zeros((f, n), np.int32)
        self.wheel_contact = np.zeros((f, n, 4), np.int32)
        self.has_gait = False
        self._captured = np.zeros(f, bool)

    @classmethod
    def for_simulator(cls, sim, seconds: float, fps: float, **kwargs) -> RolloutRecorder:
        """A recorder matching ``sim`` (a :class:`wqwarp.sim.simulator.Simulator`)."""
        lay = sim.layout
        names = list(sim.model.body_label[: lay.bodies_per_world])
        return cls(names, sim.num_envs, seconds, fps, sim.policy_dt, **kwargs)

    @property
    def num_frames(self) -> int:
        return int(self.steps.size)

    @property
    def complete(self) -> bool:
        """Every frame has been captured."""
        return bool(self._captured.all())

    def capture(self, step: int, sim, nominal=None) -> int:
        """Store the state of ``sim`` (and ``nominal``) after policy step ``step`` into every frame showing that
        step; returns how many frames it filled (0 for steps no frame needs: nothing is copied then)."""
        frames = np.nonzero(self.steps == step)[0]
        if frames.size == 0:
            return 0
        body_q = sim.body_q.numpy()
        v_base, w_base = sim.base_lin_vel.numpy(), sim.base_ang_vel.numpy()  # the simulator's base frame
        base_vel = np.stack([v_base[:, 0], v_base[:, 1], w_base[:, 2]], axis=1)
        p_cost = sim.p_cost.numpy()
        contact = sim.wheel_contact.numpy()
        if nominal is not None:
            self.has_gait = True
            if self.gait_names is None:
                self.gait_names = tuple(g.name for g in nominal.library)
            phase, command = nominal.phase.numpy(), nominal.command.numpy()
            gait, active = nominal.gait_id.numpy(), nominal.active_gait_id.numpy()
        for k in frames:
            self.body_q[k] = body_q
            self.base_velocity[k] = base_vel
            self.p_cost[k] = p_cost
            self.wheel_contact[k] = contact
            if nominal is not None:
                self.phase[k], self.command[k] = phase, command
                self.gait[k], self.active_gait[k] = gait, active
        self._captured[frames] = True
        return int(frames.size)

    def robot_spacing(self) -> float:
        """Distance between neighbouring robots along y [m]: the given ``spacing``, or (None) 1 m, widened in 0.5 m
        steps until no two robots' recorded paths overlap sideways."""
        if self.spacing is not None:
            return self.spacing
        y = self.body_q[self._captured][..., 1]
        if y.size == 0:
            return MIN_SPACING
        width = float((y.max(axis=(0, 2)) - y.min(axis=(0, 2))).max()) + 0.3  # swept y range of a robot + margin
        return max(MIN_SPACING, math.ceil(width / 0.5) * 0.5)

    # --- stage authoring ----------------------------------------------------------------------------------------
    def _gait_name(self, gait_id: int) -> str:
        names = self.gait_names or ()
        return names[gait_id] if 0 <= gait_id < len(names) else f"gait_{gait_id}"

    def build_stage(self, metadata: dict | None = None):
        """The stage in memory (``pxr.Usd.Stage``). ``metadata`` goes into ``customLayerData['wqwarp']``."""
        from pxr import Gf, Sdf, Usd, UsdGeom, Vt

        import wqwarp

        if not self.complete:
            missing = np.nonzero(~self._captured)[0]
            raise RuntimeError(f"{missing.size} of {self.num_frames} frames were never captured (first: {missing[0]})")
        f, n = self.num_frames, self.num_envs
        stage = Usd.Stage.CreateInMemory()
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        stage.SetStartTimeCode(0)
        stage.SetEndTimeCode(f - 1)
        stage.SetTimeCodesPerSecond(self.fps)
        stage.SetFramesPerSecond(self.fps)
        layer = stage.GetRootLayer()
        info = {
            "version": wqwarp.__version__,
            "numEnvs": n,
            "numFrames": f,
            "seconds": self.seconds,
            "fps": self.fps,
            "policyDt": self.policy_dt,
            "robotSpacing": self.robot_spacing(),
            "legOrder": "FR, FL, RR, RL",
        }
        info.update(metadata or {})
        layer.customLayerData = {"wqwarp": info}
        layer.documentation = "wqwarp rollout; written by wqwarp.viz.usd"

        world = UsdGeom.Xform.Define(stage, "/World")
        stage.SetDefaultPrim(world.GetPrim())

        # Ground: a slab with its top face at z = 0 under everything that was recorded.
        pos = self.body_q[..., 0:3].astype(np.float64)
        offsets = np.arange(n) * self.robot_spacing()
        y = pos[..., 1] + offsets[None, :, None]
        lo = np.array([pos[..., 0].min(), y.min()]) - GROUND_MARGIN
        hi = np.array([pos[..., 0].max(), y.max()]) + GROUND_MARGIN
        ground = UsdGeom.Cube.Define(stage, "/World/ground")
        ground.CreateSizeAttr(1.0)
        gx = UsdGeom.XformCommonAPI(ground)
        centre = (lo + hi) / 2
        gx.SetTranslate(Gf.Vec3d(centre[0], centre[1], -GROUND_THICKNESS / 2))
        gx.SetScale(Gf.Vec3f(float(hi[0] - lo[0]), float(hi[1] - lo[1]), GROUND_THICKNESS))
        ground.CreateDisplayColorAttr([Gf.Vec3f(0.55, 0.55, 0.52)])

        shapes = asset_shapes(self.asset_path)
        body_paths: list[list[Sdf.Path]] = []
        robot_paths: list[Sdf.Path] = []
        for i in range(n):
            rpath = Sdf.Path(f"/World/robot_{i}")
            robot = UsdGeom.Xform.Define(stage, rpath)
            UsdGeom.XformCommonAPI(robot).SetTranslate(Gf.Vec3d(0.0, float(offsets[i]), 0.0))
            prim = robot.GetPrim()
            prim.SetDocumentation(f"robot {i} of the rollout; wqwarp:* attributes are sampled every frame")
            self._define_robot_attributes(prim)
            robot_paths.append(rpath)
            paths = []
            for name in self.body_names:
                bpath = rpath.AppendChild(name)
                body = UsdGeom.Xform.Define(stage, bpath)
                body.AddTranslateOp(UsdGeom.XformOp.PrecisionFloat)
                body.AddOrientOp(UsdGeom.XformOp.PrecisionFloat)
                self._define_shapes(stage, bpath, name, shapes.get(name, []))
                paths.append(bpath)
            body_paths.append(paths)

        # Time samples through the Sdf layer in one change block: no per-sample notices or recomposition.
        translate = Sdf.Path.JoinIdentifier("xformOp", "translate")
        orient = Sdf.Path.JoinIdentifier("xformOp", "orient")
        q = self.body_q.copy()
        for k in range(1, f):  # keep consecutive quaternions in one hemisphere: interpolation takes the short way
            flip = np.sum(q[k, ..., 3:7] * q[k - 1, ..., 3:7], axis=-1) < 0
            q[k, ..., 3:7][flip] *= -1
        with Sdf.ChangeBlock():
            for i in range(n):
                for j, bpath in enumerate(body_paths[i]):
                    tp, op = bpath.AppendProperty(translate), bpath.AppendProperty(orient)
                    p, r = q[:, i, j, 0:3].tolist(), q[:, i, j, 3:7].tolist()
                    for k in range(f):
                        layer.SetTimeSample(tp, k, Gf.Vec3f(*p[k]))
                        x, yy, z, w = r[k]
                        layer.SetTimeSample(op, k, Gf.Quatf(w, x, yy, z))
                rp = robot_paths[i]
                cmd = self.command[:, i].tolist()
                vel = self.base_velocity[:, i].tolist()
                pc = self.p_cost[:, i].tolist()
                contact = self.wheel_contact[:, i]
                for k in range(f):
                    layer.SetTimeSample(rp.AppendProperty(ATTR_BASE_VELOCITY), k, Gf.Vec3f(*vel[k]))
                    layer.SetTimeSample(rp.AppendProperty(ATTR_P_COST), k, float(pc[k]))
                    layer.SetTimeSample(rp.AppendProperty(ATTR_WHEEL_CONTACT), k, Vt.IntArray(contact[k].tolist()))
                    if self.has_gait:
                        layer.SetTimeSample(rp.AppendProperty(ATTR_GAIT), k, self._gait_name(int(self.gait[k, i])))
                        layer.SetTimeSample(
                            rp.AppendProperty(ATTR_ACTIVE_GAIT), k, self._gait_name(int(self.active_gait[k, i]))
                        )
                        layer.SetTimeSample(rp.AppendProperty(ATTR_PHASE), k, Vt.FloatArray(self.phase[k, i].tolist()))
                        layer.SetTimeSample(rp.AppendProperty(ATTR_COMMAND), k, Gf.Vec3f(*cmd[k]))
        return stage

    def _define_robot_attributes(self, prim) -> None:
        from pxr import Sdf

        T = Sdf.ValueTypeNames
        specs = [
            (ATTR_BASE_VELOCITY, T.Float3, "measured (v_x, v_y, w_z) of the trunk, trunk frame [m/s, m/s, rad/s]"),
            (ATTR_P_COST, T.Float, "p_cost = sum |tau| |qd| over the 16 joints, policy-step average [W]"),
            (ATTR_WHEEL_CONTACT, T.IntArray, "wheel contact flags, legs FR, FL, RR, RL"),
        ]
        if self.has_gait:
            specs += [
                (ATTR_GAIT, T.String, "requested (selected) gait"),
                (ATTR_ACTIVE_GAIT, T.String, "gait running after the switching rule"),
                (ATTR_PHASE, T.FloatArray, "gait phases of legs FR, FL, RR, RL [cycles]"),
                (ATTR_COMMAND, T.Float3, "velocity command (v_x, v_y, w_z), base frame [m/s, m/s, rad/s]"),
            ]
        for name, type_name, doc in specs:
            attr = prim.CreateAttribute(name, type_name, custom=True)
            attr.SetDocumentation(doc)

    @staticmethod
    def _define_shapes(stage, body_path, body_name: str, shapes) -> None:
        from pxr import Gf, Sdf, UsdGeom

        leg = body_name.split("_", 1)[0]
        if body_name.endswith("_wheel"):
            colour = _LEG_COLOURS.get(leg, (0.1, 0.1, 0.1))
        elif body_name == C.TRUNK_BODY:
            colour = (0.75, 0.75, 0.78)
        else:
            colour = (0.35, 0.35, 0.38)
        for shape_name, type_name, attrs in shapes:
            prim = stage.DefinePrim(body_path.AppendChild(shape_name), type_name)
            for name, attr_type, value, variability in attrs:
                prim.CreateAttribute(name, Sdf.ValueTypeNames.Find(attr_type), False, variability).Set(value)
            UsdGeom.Gprim(prim).CreateDisplayColorAttr([Gf.Vec3f(*colour)])
        if body_name.endswith("_wheel") and shapes:
            # A dark bar across the wheel's outer face so its spin is visible (the cylinder alone looks static).
            radius = next((a[2] for s in shapes for a in s[2] if a[0] == "radius"), 0.075)
            width = next((a[2] for s in shapes for a in s[2] if a[0] == "height"), 0.03)
            side = -1.0 if leg.endswith("R") else 1.0  # outer face: -y for right legs, +y for left legs
            bar = UsdGeom.Cube.Define(stage, body_path.AppendChild("spin_marker"))
            bar.CreateSizeAttr(1.0)
            api = UsdGeom.XformCommonAPI(bar)
            api.SetTranslate(Gf.Vec3d(0.0, side * (width / 2 + 0.002), 0.0))
            api.SetScale(Gf.Vec3f(2 * radius * 0.9, 0.004, 0.012))
            bar.CreateDisplayColorAttr([Gf.Vec3f(0.05, 0.05, 0.05)])

    def write(self, path: str, metadata: dict | None = None) -> int:
        """Write the stage to ``path`` (.usda text, .usdc or .usd crate) atomically; returns the file size [B].

        Raises ValueError for an unknown extension or an unwritable directory; on any failure nothing is left at
        ``path`` (an existing file there is kept as it was)."""
        problem = check_output_path(path)
        if problem:
            raise ValueError(problem)
        stage = self.build_stage(metadata)
        return export_atomic(stage.GetRootLayer(), path)


def export_atomic(layer, path: str) -> int:
    """Export Sdf ``layer`` to ``path`` through a temporary file in the same directory
    (:func:`wqwarp.utils.io.atomic_path`; its extension sets the format); returns the size [B]."""
    path = os.path.abspath(path)
    with atomic_path(path) as tmp:
        if not layer.Export(tmp):  # .usd is written as crate (binary), USD's default
            raise OSError(f"USD could not write {path!r}")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp creates 0600; give the file the usual permissions
    return os.path.getsize(path)
