"""Write ``assets/usd/wheeled_go1.usda``: the Unitree Go1 with a driven wheel on each calf, in UsdPhysics schemas.

Usage::

    python tools/build_wheeled_go1.py [--out assets/usd/wheeled_go1.usda] [--check]

``--check`` regenerates the asset in memory and exits 1 if the committed file differs (used by tests and CI).

Every number carries its source:
    [MJCF]  MuJoCo Menagerie ``unitree_go1/go1.xml`` (BSD-3, commit 1f39894), see ../shared/reference/go1/FACTS.md
    [URDF]  Unitree ``go1_description`` (BSD-3), same FACTS.md
    [HARN]  the paper's first author's public wheeled-Go1 sim-to-sim harness (MIT), xu-yang16/wheeled-quadruped-sim2sim
            ``resources/wheeled_go1/xml/wheeled_go1.xml`` and ``.../meshes/wheeled_go1.urdf``, via SIMULATION_FACTS.md
    [AK80]  T-Motor AK80-6 data (rated 6 N m, 38.2 rad/s, 0.485 kg, rotor 6.07e-5 kg m^2, 6:1), FACTS.md
    [CYL]   uniform solid cylinder inertia, I_axis = m r^2 / 2, I_perp = m (3 r^2 + w^2) / 12 (derived here)

The asset is built in the zero joint pose (legs straight down) with the trunk origin at ``TRUNK_SPAWN_Z``; bodies
are siblings under the articulation root prim, each at its world pose, joined by revolute / fixed joints.
"""

from __future__ import annotations

import math
import os
import sys

from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

from wqwarp.cli.args import UsageError, doc_parser, entry_point
from wqwarp.robot import constants as C
from wqwarp.utils.io import directory_problem, write_text_atomic

ROOT = "/wheeled_go1"
TRUNK_SPAWN_Z = 0.5
"""Trunk origin height in the asset's zero pose [m]; the simulator resets robots to their default pose anyway."""

# ---------------------------------------------------------------------------------------------------------------
# Mass properties [MJCF]: (mass [kg], COM [m], principal inertia [kg m^2], principal axes quat (w, x, y, z)).
# The MJCF mirrors the hip's COM per leg and the thigh's per side; the calf (with the 0.06 kg foot merged) is shared.
TRUNK_INERTIAL = (
    5.204,
    (0.0223, 0.002, -0.0005),
    (0.0716565, 0.0630105, 0.0168101),
    (-0.00342088, 0.705204, 0.000106698, 0.708996),
)
HIP_INERTIAL = {
    "FR": (
        0.68,
        (-0.0049166, 0.00762615, -8.865e-05),
        (0.000734064, 0.000468438, 0.000398719),
        (0.507341, 0.514169, 0.495027, 0.482891),
    ),
    "FL": (
        0.68,
        (-0.0049166, -0.00762615, -8.865e-05),
        (0.000734064, 0.000468438, 0.000398719),
        (0.482891, 0.495027, 0.514169, 0.507341),
    ),
    "RR": (
        0.68,
        (0.0049166, 0.00762615, -8.865e-05),
        (0.000734064, 0.000468438, 0.000398719),
        (0.495027, 0.482891, 0.507341, 0.514169),
    ),
    "RL": (
        0.68,
        (0.0049166, -0.00762615, -8.865e-05),
        (0.000734064, 0.000468438, 0.000398719),
        (0.514169, 0.507341, 0.482891, 0.495027),
    ),
}
THIGH_RIGHT = (
    1.009,
    (-0.00304722, 0.019315, -0.0305004),
    (0.00478717, 0.00460903, 0.000709268),
    (0.65243, -0.0272313, 0.0775126, 0.753383),
)
THIGH_LEFT = (
    1.009,
    (-0.00304722, -0.019315, -0.0305004),
    (0.00478717, 0.00460903, 0.000709268),
    (0.753383, 0.0775126, -0.0272313, 0.65243),
)
CALF_INERTIAL = (
    0.195862,
    (0.00429862, 0.000976676, -0.146197),
    (0.00149767, 0.00148468, 3.58427e-05),
    (0.691246, 0.00357467, 0.00511118, 0.722592),
)


def _cylinder_inertia(mass: float, radius: float, width: float) -> tuple[float, float, float]:
    """[CYL] principal inertia of a solid cylinder whose axis is y: (I_perp, I_axis, I_perp) [kg m^2]."""
    i_axis = 0.5 * mass * radius**2
    i_perp = mass * (3.0 * radius**2 + width**2) / 12.0
    return (i_perp, i_axis, i_perp)


# Wheel [HARN]: radius 0.075 m, width 0.03 m, 0.2023 kg, centre INBOARD of the calf at (-0.015, -+0.0245, -0.233)
# in the calf frame (left legs -0.0245, right legs +0.0245; constants.WHEEL_CENTER_IN_CALF).
WHEEL_INERTIA = _cylinder_inertia(C.WHEEL_MASS, C.WHEEL_RADIUS, C.WHEEL_WIDTH)
# Wheel motor [HARN] 0.514 kg, coaxial with the wheel at (-0.015, +-0.0025, -0.233) in the calf frame, where the
# authors' MJCF puts its collision cylinder (constants.WHEEL_MOTOR_IN_CALF); its inertia is that of a cylinder of the
# AK80-6's size, 98 mm diameter x 38.5 mm [AK80], axis along y. It has no collision shape here (see below).
WHEEL_MOTOR_INERTIA = _cylinder_inertia(C.WHEEL_MOTOR_MASS, 0.049, 0.0385)

# Joint dynamics. Armature: 0.01 kg m^2 on every leg joint [MJCF]; the wheel carries the AK80-6 rotor reflected
# through its 6:1 gearbox, 6.07e-5 * 36 = 2.19e-3 kg m^2 [AK80]. Joint damping and dry friction are left at 0 as in
# the URDF [URDF]: the leg PD and wheel PID supply all damping.
# The authors' MJCF [HARN] sets, as class defaults for every joint, damping 0.01 N m s/rad, armature 0.01 kg m^2 and
# frictionloss 0.2 N m, and ground friction 0.6. Not adopted here, each for a stated reason: the leg armature is the
# same 0.01; a wheel armature of 0.01 would be 4.6x the AK80-6 rotor reflected through its gearbox (the data sheet
# value above), and a larger armature hides the explicit-feedback limit of the wheel loop rather than respecting it
# (SimConfig.wheel_kp); damping 0.01 is 1 % of the leg PD's Kd; the 0.2 N m dry friction on all 16 joints is a
# motor loss model of its own (it costs ~0.2 N m x 20 rad/s = 4 W per wheel at 1.5 m/s) that the paper does not
# state, so it belongs to a second physics configuration for sim-to-sim evaluation, not to the training model;
# friction is randomised per robot in training (EnvConfig.domain_rand.friction_range 0.5-1.25 spans 0.6).
LEG_ARMATURE = 0.01
WHEEL_ARMATURE = C.WHEEL_ARMATURE
LEG_VELOCITY_LIMITS = (C.HIP_VELOCITY_LIMIT, C.THIGH_VELOCITY_LIMIT, C.CALF_VELOCITY_LIMIT)  # [URDF] rad/s

# Collision shapes, simplified from the MJCF `collision` classes to axis-aligned primitives [MJCF]:
# trunk box half-sizes (0.125, 0.04, 0.057) plus two cylinders r 0.058, half-length 0.125 along x at y = +-0.04;
# thigh: one capsule r 0.02 around thigh1..3 (z from 0 to -0.2, x about -0.01); calf: one capsule r 0.012 around
# calf1..2 (z from 0 to -0.2, x about +0.01). The wheel is a cylinder (axis y) [HARN]. The hip has none (as its
# MJCF cylinders only touch the ground when the trunk does).
# The authors' MJCF [HARN] uses boxes instead: trunk half-sizes (0.13, 0.04675, 0.057), thigh (0.1065, 0.01225, 0.017)
# and calf (0.1065, 0.008, 0.008) centred 0.1065 below each joint, plus a colliding wheel-motor cylinder (r 0.049)
# coaxial with the wheel. Ours stay within ~1 cm of theirs in every extent; the motor cylinder lies inside the wheel's
# 0.075 m radius, so it can touch flat ground only after the wheel does, and is left out.
TRUNK_BOX_HALF = (0.125, 0.04, 0.057)
TRUNK_CYL = (0.058, 0.25)  # radius, full length [m]
THIGH_CAPSULE = ((-0.01, 0.0, -0.1), 0.02, 0.16)  # centre, radius, cylindrical-part length [m]
CALF_CAPSULE = ((0.01, 0.0, -0.1), 0.012, 0.176)


def _vec(v) -> Gf.Vec3f:
    return Gf.Vec3f(*[float(x) for x in v])


def _add_body(stage: Usd.Stage, name: str, pos, inertial) -> Usd.Prim:
    """A rigid body prim at world position `pos` (zero pose, identity orientation) with explicit mass properties."""
    xf = UsdGeom.Xform.Define(stage, f"{ROOT}/{name}")
    xf.AddTranslateOp().Set(Gf.Vec3d(*[float(x) for x in pos]))
    prim = xf.GetPrim()
    UsdPhysics.RigidBodyAPI.Apply(prim)
    mass, com, inertia, quat = inertial
    m = UsdPhysics.MassAPI.Apply(prim)
    m.CreateMassAttr(float(mass))
    m.CreateCenterOfMassAttr(Gf.Vec3f(*[float(x) for x in com]))
    m.CreateDiagonalInertiaAttr(_vec(inertia))
    w, x, y, z = quat
    q = Gf.Quatf(float(w), float(x), float(y), float(z)).GetNormalized()
    m.CreatePrincipalAxesAttr(q)
    return prim


def _add_shape(stage: Usd.Stage, body: str, name: str, kind: str, **kw) -> None:
    path = f"{ROOT}/{body}/{name}"
    if kind == "box":
        g = UsdGeom.Cube.Define(stage, path)
        g.CreateSizeAttr(2.0)
        g.AddTranslateOp().Set(Gf.Vec3d(*kw.get("pos", (0.0, 0.0, 0.0))))
        g.AddScaleOp().Set(Gf.Vec3f(*kw["half"]))
    elif kind == "cylinder":
        g = UsdGeom.Cylinder.Define(stage, path)
        g.CreateRadiusAttr(float(kw["radius"]))
        g.CreateHeightAttr(float(kw["height"]))
        g.CreateAxisAttr(kw["axis"])
        g.AddTranslateOp().Set(Gf.Vec3d(*kw.get("pos", (0.0, 0.0, 0.0))))
    elif kind == "capsule":
        g = UsdGeom.Capsule.Define(stage, path)
        g.CreateRadiusAttr(float(kw["radius"]))
        g.CreateHeightAttr(float(kw["height"]))
        g.CreateAxisAttr("Z")
        g.AddTranslateOp().Set(Gf.Vec3d(*kw["pos"]))
    else:
        raise ValueError(kind)
    UsdPhysics.CollisionAPI.Apply(g.GetPrim())


def _add_revolute(stage, name, parent, child, local_pos, axis, limits, armature, vel_limit, effort) -> None:
    j = UsdPhysics.RevoluteJoint.Define(stage, f"{ROOT}/joints/{name}")
    j.CreateBody0Rel().SetTargets([Sdf.Path(f"{ROOT}/{parent}")])
    j.CreateBody1Rel().SetTargets([Sdf.Path(f"{ROOT}/{child}")])
    j.CreateLocalPos0Attr(Gf.Vec3f(*[float(x) for x in local_pos]))
    j.CreateLocalRot0Attr(Gf.Quatf(1.0))
    j.CreateLocalPos1Attr(Gf.Vec3f(0.0))
    j.CreateLocalRot1Attr(Gf.Quatf(1.0))
    j.CreateAxisAttr(axis)
    if limits is not None:  # UsdPhysics revolute limits are in degrees
        j.CreateLowerLimitAttr(math.degrees(limits[0]))
        j.CreateUpperLimitAttr(math.degrees(limits[1]))
    p = j.GetPrim()
    p.CreateAttribute("newton:armature", Sdf.ValueTypeNames.Float).Set(float(armature))
    p.CreateAttribute("newton:velocityLimit", Sdf.ValueTypeNames.Float).Set(float(vel_limit))
    # Torque limit [N m]; enforced by the actuation kernels (wqwarp.kernels.actuation), kept here for reference.
    p.CreateAttribute("wqwarp:effortLimit", Sdf.ValueTypeNames.Float).Set(float(effort))


def build_stage() -> Usd.Stage:
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    root = UsdGeom.Xform.Define(stage, ROOT).GetPrim()
    stage.SetDefaultPrim(root)
    UsdPhysics.ArticulationRootAPI.Apply(root)
    root.SetDocumentation("Wheeled Unitree Go1; generated by tools/build_wheeled_go1.py - do not edit by hand.")
    UsdGeom.Scope.Define(stage, f"{ROOT}/joints")

    trunk = (0.0, 0.0, TRUNK_SPAWN_Z)
    _add_body(stage, "trunk", trunk, TRUNK_INERTIAL)
    _add_shape(stage, "trunk", "collision_box", "box", half=TRUNK_BOX_HALF)
    for k, y in (("left", 0.04), ("right", -0.04)):
        _add_shape(
            stage,
            "trunk",
            f"collision_cyl_{k}",
            "cylinder",
            radius=TRUNK_CYL[0],
            height=TRUNK_CYL[1],
            axis="X",
            pos=(0.0, y, 0.0),
        )

    for i, leg in enumerate(C.LEG_NAMES):
        sx, sy = C.LEG_FRONT_SIGN[i], C.LEG_SIDE_SIGN[i]
        hip = (trunk[0] + sx * C.HIP_OFFSET_X, trunk[1] + sy * C.HIP_OFFSET_Y, trunk[2])  # [MJCF]
        thigh = (hip[0], hip[1] + sy * C.THIGH_OFFSET_Y, hip[2])  # [MJCF]
        calf = (thigh[0], thigh[1], thigh[2] - C.THIGH_LENGTH)  # [MJCF]
        wx, wy, wz = C.WHEEL_CENTER_IN_CALF  # [HARN], y mirrored on right legs
        wheel_local = (wx, sy * wy, wz)
        wheel = (calf[0] + wheel_local[0], calf[1] + wheel_local[1], calf[2] + wheel_local[2])
        mx, my, mz = C.WHEEL_MOTOR_IN_CALF  # [HARN], y mirrored on right legs
        motor_local = (mx, sy * my, mz)
        motor = (calf[0] + motor_local[0], calf[1] + motor_local[1], calf[2] + motor_local[2])

        _add_body(stage, f"{leg}_hip", hip, HIP_INERTIAL[leg])
        _add_body(stage, f"{leg}_thigh", thigh, THIGH_LEFT if sy > 0 else THIGH_RIGHT)
        _add_body(stage, f"{leg}_calf", calf, CALF_INERTIAL)
        _add_body(
            stage, f"{leg}_wheel_motor", motor, (C.WHEEL_MOTOR_MASS, (0, 0, 0), WHEEL_MOTOR_INERTIA, (1, 0, 0, 0))
        )
        _add_body(stage, f"{leg}_wheel", wheel, (C.WHEEL_MASS, (0, 0, 0), WHEEL_INERTIA, (1, 0, 0, 0)))

        c, r, h = THIGH_CAPSULE
        _add_shape(stage, f"{leg}_thigh", "collision", "capsule", pos=c, radius=r, height=h)
        c, r, h = CALF_CAPSULE
        _add_shape(stage, f"{leg}_calf", "collision", "capsule", pos=c, radius=r, height=h)
        _add_shape(
            stage, f"{leg}_wheel", "collision", "cylinder", radius=C.WHEEL_RADIUS, height=C.WHEEL_WIDTH, axis="Y"
        )

        names = [f"{leg}_{k}_joint" for k in C.LEG_JOINT_KINDS]
        ranges = (C.HIP_RANGE, C.THIGH_RANGE, C.CALF_RANGE)
        efforts = (C.HIP_TORQUE_LIMIT, C.THIGH_TORQUE_LIMIT, C.CALF_TORQUE_LIMIT)
        chain = (
            ("trunk", f"{leg}_hip", (hip[0] - trunk[0], hip[1] - trunk[1], 0.0), "X"),
            (f"{leg}_hip", f"{leg}_thigh", (0.0, sy * C.THIGH_OFFSET_Y, 0.0), "Y"),
            (f"{leg}_thigh", f"{leg}_calf", (0.0, 0.0, -C.THIGH_LENGTH), "Y"),
        )
        for (parent, child, pos, axis), name, rng, eff, vl in zip(
            chain, names, ranges, efforts, LEG_VELOCITY_LIMITS, strict=True
        ):
            _add_revolute(stage, name, parent, child, pos, axis, rng, LEG_ARMATURE, vl, eff)
        # Continuous wheel joint parallel to the knee (axis y) [HARN]; AK80-6 torque and speed limits [AK80].
        _add_revolute(
            stage,
            f"{leg}_wheel_joint",
            f"{leg}_calf",
            f"{leg}_wheel",
            wheel_local,
            "Y",
            None,
            WHEEL_ARMATURE,
            C.WHEEL_VELOCITY_LIMIT,
            C.WHEEL_TORQUE_LIMIT,
        )
        fj = UsdPhysics.FixedJoint.Define(stage, f"{ROOT}/joints/{leg}_wheel_motor_fixed")
        fj.CreateBody0Rel().SetTargets([Sdf.Path(f"{ROOT}/{leg}_calf")])
        fj.CreateBody1Rel().SetTargets([Sdf.Path(f"{ROOT}/{leg}_wheel_motor")])
        fj.CreateLocalPos0Attr(Gf.Vec3f(*motor_local))
        fj.CreateLocalRot0Attr(Gf.Quatf(1.0))
        fj.CreateLocalPos1Attr(Gf.Vec3f(0.0))
        fj.CreateLocalRot1Attr(Gf.Quatf(1.0))
    return stage


def render() -> str:
    """The asset as text (deterministic: no timestamps, fixed authoring order)."""
    stage = build_stage()  # keep the stage alive while its layer is exported
    return stage.GetRootLayer().ExportToString()


@entry_point
def main(argv: list[str] | None = None) -> int:
    ap = doc_parser(__doc__)
    ap.add_argument("--out", default=C.WHEELED_GO1_USD, help="output .usda path (default: the committed asset)")
    ap.add_argument("--check", action="store_true", help="exit 1 if the file at --out differs from a fresh build")
    args = ap.parse_args(argv)
    text = render()
    if args.check:
        try:
            with open(args.out, encoding="utf-8") as f:
                same = f.read() == text
        except OSError as e:
            raise UsageError(f"cannot read {args.out}: {e}") from None
        print("asset up to date" if same else f"asset differs from a fresh build: {args.out}")
        return 0 if same else 1
    out_dir = os.path.dirname(os.path.abspath(args.out))
    if os.path.isdir(args.out) or (problem := directory_problem(out_dir)):
        ap.error(f"cannot write {args.out}: {problem or 'is a directory'}")
    os.makedirs(out_dir, exist_ok=True)
    write_text_atomic(args.out, text)  # write then rename: no half-written asset
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
