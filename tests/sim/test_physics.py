"""Physics outcomes of the simulation core on the CPU path: standing, driving, turning, power, contacts, reset."""

from __future__ import annotations

import numpy as np
import pytest

from wqwarp.robot import constants as C
from wqwarp.sim.config import SimConfig
from wqwarp.sim.simulator import Simulator


@pytest.fixture(scope="module")
def sim(device):
    return Simulator(SimConfig(num_envs=3, device=device))


def _run(sim, seconds, record=lambda s: None):
    out = []
    for _ in range(int(round(seconds / sim.policy_dt))):
        sim.step()
        out.append(record(sim))
    return out


def _base_vel_body(sim, v=None):
    """Base linear velocity in the base frame (from Newton's world-frame COM velocity; COM offset is tiny), or the
    world vectors ``v`` (N, 3) rotated into the base frame."""
    q = sim.joint_q.numpy()[:, 3:7]
    v = sim.joint_qd.numpy()[:, 0:3] if v is None else v
    x, y, z, w = q.T
    rot = np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        1,
    )
    return np.einsum("nji,nj->ni", rot, v)


def test_stands_five_seconds_in_default_pose(sim):
    sim.reset(np.arange(sim.num_envs))
    sim.wheel_qd_target.zero_()
    z = np.array(_run(sim, 5.0, lambda s: s.joint_q.numpy()[:, 2].copy()))
    assert np.all(np.isfinite(z))
    settled = z[int(0.5 / sim.policy_dt) :]
    assert np.all(np.abs(settled - settled.mean(0)) < 0.02), (settled.min(0), settled.max(0))
    assert np.all(settled > 0.18)  # standing on its wheels, not lying on the trunk
    assert not sim.body_collision.numpy().any()
    assert np.all(sim.wheel_contact.numpy() == 1)
    # All four wheels carry the weight: sum of normal forces ~ m g.
    total = sim.wheel_force.numpy().sum(1)
    assert total == pytest.approx(np.full(sim.num_envs, sim.layout.total_mass * 9.81), rel=0.15)


def test_still_robot_has_near_zero_p_cost(sim):
    sim.reset(np.arange(sim.num_envs))
    sim.wheel_qd_target.zero_()
    p = np.array(_run(sim, 3.0, lambda s: s.p_cost.numpy().copy()))
    assert np.all(p >= 0.0)
    # The legs settle within ~2 s (Kp 40, Kd 1); afterwards only sub-watt holding jitter remains.
    assert np.all(p[-25:].mean(0) < 1.0), p[-25:].mean(0)  # [W]


def test_wheels_drive_the_base_at_the_commanded_speed(sim):
    sim.reset(np.arange(sim.num_envs))
    speed = 0.5
    sim.wheel_qd_target.fill_(C.WHEEL_FORWARD_SIGN * speed / C.WHEEL_RADIUS)
    p_cost = _run(sim, 2.0, lambda s: s.p_cost.numpy().copy())
    vx = _base_vel_body(sim)[:, 0]
    assert vx == pytest.approx(np.full(sim.num_envs, speed), rel=0.10)
    # Driving costs power (accelerating the wheels and holding the legs): clearly above the still robot's.
    assert np.all(np.mean(p_cost[:25], axis=0) > 10.0)  # ~25 W measured in the first 0.5 s
    x = sim.joint_q.numpy()[:, 0]
    assert np.all(x > 0.6)  # moved forward ~0.8 m in 2 s


def test_opposite_wheel_speeds_turn_with_the_expected_sign(sim):
    sim.reset(np.arange(sim.num_envs))
    w = 4.0  # [rad/s]
    side = np.asarray(C.LEG_SIDE_SIGN, np.float32)  # +1 left
    # Left wheels forward, right wheels backward -> yaw to the right (negative yaw rate about +z).
    sim.wheel_qd_target.assign(np.tile(C.WHEEL_FORWARD_SIGN * w * side, (sim.num_envs, 1)))
    _run(sim, 1.5)
    yaw_rate = sim.joint_qd.numpy()[:, 5]
    assert np.all(yaw_rate < -0.1), yaw_rate  # skid steering: the wheels scrub sideways (~2 N m each)
    sim.wheel_qd_target.assign(np.tile(-C.WHEEL_FORWARD_SIGN * w * side, (sim.num_envs, 1)))
    _run(sim, 1.5)
    assert np.all(sim.joint_qd.numpy()[:, 5] > 0.1)


def test_trunk_on_the_ground_is_flagged_as_collision(sim):
    lay = sim.layout
    q = np.tile(sim._default_q, (sim.num_envs, 1))
    q[:, 2] = 0.06  # trunk box half-height is 0.057: lying on the ground, upside down so the legs point up
    q[:, 3:7] = (1.0, 0.0, 0.0, 0.0)  # 180 deg about x (xyzw)
    sim.reset(np.arange(sim.num_envs), q, np.zeros((sim.num_envs, lay.dofs_per_world), np.float32))
    sim.wheel_qd_target.zero_()
    _run(sim, 0.2)
    assert np.all(sim.body_collision.numpy()[:, 0] == 1)
    assert not sim.wheel_contact.numpy().any()


def test_reset_sets_the_given_state_of_only_those_robots(sim):
    sim.reset(np.arange(sim.num_envs))
    _run(sim, 0.1)
    before = sim.joint_q.numpy().copy()
    q = sim._default_q.copy()
    q[0:3] = (1.0, -2.0, 0.4)
    qd = np.zeros(sim.layout.dofs_per_world, np.float32)
    qd[0] = 0.3
    sim.reset([1], q[None], qd[None])
    np.testing.assert_allclose(sim.joint_q.numpy()[1], q, atol=1e-6)
    np.testing.assert_allclose(sim.joint_q.numpy()[[0, 2]], before[[0, 2]])
    np.testing.assert_allclose(sim.body_q.numpy()[1, sim.layout.trunk_body][:3], (1.0, -2.0, 0.4), atol=1e-6)
    sim.step()  # the physics continues from the reset state (falling from 0.4 m, moving +x)
    assert sim.joint_q.numpy()[1, 0] > 1.0 and sim.joint_q.numpy()[1, 2] < 0.4
    with pytest.raises(IndexError):
        sim.reset([sim.num_envs])


def test_torch_views_share_memory(sim):
    views = sim.torch_views()
    assert views["joint_q"].shape == (sim.num_envs, 23)
    assert views["body_q"].shape == (sim.num_envs, sim.layout.bodies_per_world, 7)
    views["wheel_qd_target"][:] = 1.25
    assert np.all(sim.wheel_qd_target.numpy() == 1.25)


def test_base_frame_buffers_follow_steps_resets_and_writes(sim):
    """``base_lin_vel`` ... ``base_yaw`` equal the rotation of Newton's world-frame rows after a step, a reset and an
    in-place write announced by ``state_written`` (a push)."""

    def check():
        q, qd = sim.joint_q.numpy(), sim.joint_qd.numpy()
        x, y, z, w = q[:, 3:7].T
        np.testing.assert_allclose(sim.base_lin_vel.numpy(), _base_vel_body(sim), atol=1e-5)
        np.testing.assert_allclose(sim.base_height.numpy(), q[:, 2])
        np.testing.assert_allclose(
            sim.base_yaw.numpy(), np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)), atol=1e-5
        )
        g = np.tile([0.0, 0.0, -1.0], (sim.num_envs, 1))
        np.testing.assert_allclose(sim.projected_gravity.numpy(), _base_vel_body(sim, g), atol=1e-5)
        np.testing.assert_allclose(sim.base_ang_vel.numpy(), _base_vel_body(sim, qd[:, 3:6]), atol=1e-5)

    sim.reset(np.arange(sim.num_envs))
    check()
    sim.wheel_qd_target.fill_(3.0)
    _run(sim, 0.2)
    check()
    views = sim.torch_views()
    assert views["base_lin_vel"].shape == (sim.num_envs, 3) and views["base_yaw"].shape == (sim.num_envs,)
    views["joint_qd"][:, 0] += 0.7  # a push, as the env writes it
    sim.state_written()
    check()
    sim.wheel_qd_target.zero_()


def test_paper_timestep_runs():
    sim = Simulator(SimConfig(num_envs=2, dt=0.001, decimation=20))
    assert sim.policy_dt == pytest.approx(0.02)
    z = np.array(_run(sim, 1.0, lambda s: s.joint_q.numpy()[:, 2].copy()))
    assert np.all(np.isfinite(z)) and np.all(z[-1] > 0.18)


def test_bad_config_is_rejected():
    with pytest.raises(ValueError, match="backend"):
        SimConfig(backend="physx").validate()
    with pytest.raises(ValueError, match="num_envs"):
        SimConfig(num_envs=0).validate()


def test_every_configurable_backend_has_one_registered_class():
    """A backend is one class in ``wqwarp.sim.backends`` and one registry entry; its name is a ``SimConfig.backend``
    choice. The simulator holds its buffers as attributes, with no attribute delegation."""
    from wqwarp.sim import config
    from wqwarp.sim.backends import BACKENDS, PhysicsBackend
    from wqwarp.sim.buffers import BUFFER_NAMES

    assert set(BACKENDS) == set(config.BACKENDS) - {"auto"}
    assert all(issubclass(cls, PhysicsBackend) and cls.name == name for name, cls in BACKENDS.items())
    assert "__getattr__" not in vars(Simulator)
    assert {"p_cost", "leg_q_target", "actuated_qd", "torque_sq", "base_lin_vel", "base_yaw"} <= set(BUFFER_NAMES)


@pytest.mark.parametrize("backend", ["mujoco_cpu", "mujoco_warp"])
def test_added_trunk_mass_loads_the_wheels(backend):
    sim = Simulator(SimConfig(num_envs=2, backend=backend))
    sim.set_dynamics(friction=np.ones(2), restitution=np.zeros(2), added_mass=np.array([0.0, 2.0]))
    _run(sim, 1.0)
    load = sim.wheel_force.numpy().sum(1)
    assert load[1] - load[0] == pytest.approx(2.0 * 9.81, rel=0.3)


def test_low_friction_makes_the_wheels_slip():
    sim = Simulator(SimConfig(num_envs=2))
    sim.set_dynamics(friction=np.array([1.0, 0.05]), restitution=np.zeros(2), added_mass=np.zeros(2))
    sim.wheel_qd_target.fill_(C.WHEEL_FORWARD_SIGN * 0.5 / C.WHEEL_RADIUS)
    vx = np.array(_run(sim, 2.0, lambda s: _base_vel_body(s)[:, 0]))
    assert vx[-1, 0] == pytest.approx(0.5, rel=0.1)
    assert vx[:25, 1].mean() < 0.6 * vx[:25, 0].mean()  # on ice the base lags the spinning wheels


# --- energy-faithful actuation (wheel loop stable loaded and airborne, at the default and the paper's dt) ------------
def _airborne_wheels(backend: str, dt: float, decimation: int, seconds: float = 0.5):
    """Robot in free fall (no ground load), wheels commanded 5 rad/s from rest; per-substep wheel torques and speeds."""
    from wqwarp.robot import asset as robot

    sim = Simulator(SimConfig(num_envs=1, backend=backend, device="cpu", dt=dt, decimation=1))
    q = robot.default_joint_q(sim.layout, base_height=50.0)[None]
    sim.reset([0], q, np.zeros((1, sim.layout.dofs_per_world), np.float32))
    sim.wheel_qd_target.fill_(5.0)
    dof = sim.layout.actuated_dof[12:]
    tau, speed, power = [], [], []
    for _ in range(int(round(seconds / dt))):
        sim.step()
        tau.append(sim.joint_torque.numpy()[0, 12:].copy())
        speed.append(sim.joint_qd.numpy()[0, dof].copy())
        power.append(sim.p_cost_wheels.numpy()[0])
    return np.asarray(tau), np.asarray(speed), np.asarray(power)


@pytest.mark.parametrize("backend", ["mujoco_cpu", "mujoco_warp"])
@pytest.mark.parametrize(("dt", "decimation"), [(0.005, 4), (0.001, 20)])
def test_airborne_wheel_settles_without_chatter(backend, dt, decimation):
    tau, speed, power = _airborne_wheels(backend, dt, decimation)
    after = np.arange(1, len(tau) + 1) * dt > 0.1
    np.testing.assert_allclose(speed[after], 5.0, atol=0.25)  # within 5 % of the target from 0.1 s on
    sig = tau[after] * (np.abs(tau[after]) > 0.06)  # torques above 1 % of the limit
    assert not np.any(sig[1:] * sig[:-1] < 0), "wheel torque changes sign after settling (chatter)"
    assert power[after].mean() / 4 < 0.5  # W per wheel


def test_airborne_wheel_chatters_with_the_old_gain():
    """The failure the gain bound prevents: kp 2 at dt 0.005 (kp dt / I = 3.6) flips +-6 N m every substep."""
    cfg = SimConfig(num_envs=1, wheel_kp=2.0, wheel_ki=5.0, wheel_i_limit=1.0)
    with pytest.raises(ValueError, match="unstable"):
        Simulator(cfg)
    cfg.check_wheel_stability = False
    sim = Simulator(cfg)
    from wqwarp.robot import asset as robot

    sim.reset([0], robot.default_joint_q(sim.layout, base_height=50.0)[None], np.zeros((1, 22), np.float32))
    sim.wheel_qd_target.fill_(5.0)
    _run(sim, 0.2)
    assert sim.p_cost_wheels.numpy()[0] > 100.0  # ~131 W for four idle wheels


@pytest.mark.parametrize("backend", ["mujoco_cpu", "mujoco_warp"])
def test_standing_costs_under_ten_watts(backend):
    """Driving gait, zero command: the legs hold the default pose, the wheels hold still (paper: 'approaching zero')."""
    sim = Simulator(SimConfig(num_envs=1, backend=backend, device="cpu"))
    sim.wheel_qd_target.zero_()
    p = np.array(_run(sim, 2.0, lambda s: (float(s.p_cost_legs.numpy()[0]), float(s.p_cost_wheels.numpy()[0]))))
    legs, wheels = p[-50:].mean(0)
    assert legs + wheels < 10.0, (legs, wheels)
    np.testing.assert_allclose(sim.p_cost.numpy()[0], p[-1].sum(), rtol=1e-5)  # total = legs + wheels
