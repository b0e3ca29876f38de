"""``mujoco_cpu``: N independent MuJoCo robot states stepped with ``mujoco.rollout`` on all cores.

The one-robot template is converted to MuJoCo by Newton's ``SolverMuJoCo`` once (Newton's own CPU path simulates
only the template world when worlds are separate, upstream issue #4102). After every physics substep the MuJoCo
states are mirrored into Newton ``joint_q`` / ``joint_qd`` by a Warp kernel (``kernels.state``); contact summaries
come from MuJoCo contact sensors against the ground.
"""

from __future__ import annotations

import copy
import logging
import os
import tempfile
import warnings

import numpy as np
import warp as wp

from wqwarp.kernels.contacts import contacts_from_sensordata
from wqwarp.kernels.state import mujoco_state_to_newton, newton_state_to_mujoco
from wqwarp.robot import asset as robot
from wqwarp.robot import constants as C
from wqwarp.sim.backends.base import PhysicsBackend
from wqwarp.sim.model import apply_joint_model

_MUJOCO_LOG = logging.getLogger("wqwarp.mujoco")
MUJOCO_WARNINGS: list[str] = []
"""MuJoCo warnings of this process (last 100), e.g. "Nan, Inf or huge value in QACC at DOF 0 ... Time = t"."""


def route_mujoco_warnings() -> None:
    """Send MuJoCo's warnings to the ``wqwarp.mujoco`` logger (and :data:`MUJOCO_WARNINGS`) instead of MuJoCo's
    default, a ``MUJOCO_LOG.TXT`` file appended to in the working directory. The robot a warning concerns is
    flagged by ``Simulator.unstable``."""
    import mujoco

    def handler(msg: str) -> None:
        MUJOCO_WARNINGS.append(msg)
        del MUJOCO_WARNINGS[:-100]
        _MUJOCO_LOG.warning("MuJoCo: %s", msg)

    mujoco.set_mju_user_warning(handler)


class MujocoCpuBackend(PhysicsBackend):
    """MuJoCo on the CPU, one ``MjModel`` per robot (a shared one until :meth:`set_dynamics`)."""

    name = "mujoco_cpu"
    requires_cpu = True

    def __init__(self, sim) -> None:
        import mujoco
        from mujoco import rollout

        super().__init__(sim)
        cfg, n = sim.cfg, sim.num_envs
        route_mujoco_warnings()
        m, self._wheel_found_col, self._body_found_col = _template_mj_model(cfg)
        m.opt.timestep = cfg.dt
        self.mj_model = m
        """The one-robot ``MjModel`` (contact sensors added), for rendering and inspection."""
        self._nthread = max(1, min(cfg.nthread or os.cpu_count() or 1, n))
        self._mj_datas = [mujoco.MjData(m) for _ in range(self._nthread)]
        self.mj_models = [m] * n
        """One ``MjModel`` per robot (rollout with skip_checks takes one per robot; :meth:`set_dynamics` copies)."""
        self.rollout = rollout.Rollout(nthread=self._nthread if self._nthread > 1 else 0)
        """The ``mujoco.rollout.Rollout`` that steps all robots."""
        self.state_spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
        """MuJoCo state signature of :meth:`current_state` rows."""
        nstate = mujoco.mj_stateSize(m, self.state_spec)
        self._qpos_start = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_TIME.value)
        # Two (N, 1, nstate) buffers used in turn as rollout input and output: no copy between substeps.
        self._mj_state = [np.zeros((n, 1, nstate)), np.zeros((n, 1, nstate))]
        d = self._mj_datas[0]
        mujoco.mj_resetData(m, d)
        init = np.zeros(nstate)
        mujoco.mj_getState(m, d, init, self.state_spec)
        for s in self._mj_state:
            s[:] = init
        self._mj_state_wp = [
            wp.array(s.reshape(n, nstate), dtype=wp.float64, device="cpu", copy=False) for s in self._mj_state
        ]
        self._parity = 0
        self._mj_control = np.zeros((n, 1, m.nv))
        self._sensordata = np.zeros((n, 1, m.nsensordata))
        self._sensordata_wp = wp.array(self._sensordata.reshape(n, m.nsensordata), dtype=wp.float64, copy=False)
        self._joint_f_np = sim.joint_f.numpy()  # zero-copy view on CPU
        self._unstable_np = sim.unstable.numpy()  # zero-copy view on CPU
        self._root_com = wp.vec3(*sim.model.body_com.numpy()[sim.layout.trunk_body])
        self._wheel_found_wp = wp.array(self._wheel_found_col, dtype=wp.int32)
        self._body_found_wp = wp.array(self._body_found_col, dtype=wp.int32)
        self._qfrc_spec = mujoco.mjtState.mjSTATE_QFRC_APPLIED.value
        # Mirror MuJoCo state -> Newton joint_q / joint_qd, one prepared launch per state buffer.
        self._mirror_cmds = [
            wp.launch(
                mujoco_state_to_newton,
                dim=n,
                inputs=[s, self._qpos_start, self._root_com],
                outputs=[sim.joint_q, sim.joint_qd],
                device=sim.device,
                record_cmd=True,
            )
            for s in self._mj_state_wp
        ]

    def current_state(self) -> np.ndarray:
        """(N, nstate) view of every robot's MuJoCo state now (``state_spec`` signature)."""
        return self._mj_state[self._parity][:, 0, :]

    def mujoco_qpos(self) -> np.ndarray:
        """(N, nq) copy of every robot's MuJoCo ``qpos`` now, in the order of :attr:`mj_model`."""
        s = self._qpos_start
        return self.current_state()[:, s : s + self.mj_model.nq].copy()

    def step_substeps(self, actuate: bool) -> None:
        import newton

        sim = self.sim
        for _ in range(sim.cfg.decimation):
            if actuate:
                sim.actuate_substep()
            self._mj_control[:, 0, :] = self._joint_f_np
            src, dst = self._mj_state[self._parity], self._mj_state[1 - self._parity]
            self.rollout.rollout(
                self.mj_models,
                self._mj_datas,
                src[:, 0, :],
                self._mj_control,
                control_spec=self._qfrc_spec,
                nstep=1,
                state=dst,
                sensordata=self._sensordata,
                skip_checks=True,
            )
            # MuJoCo resets the data of a diverged robot inside the step (a warning, time restarts at 0): its time
            # then falls behind. Flag it; the simulator's check after the loop adds non-finite and exploding states.
            self._unstable_np |= dst[:, 0, 0] < src[:, 0, 0]
            self._parity = 1 - self._parity
            self._mirror_cmds[self._parity].launch()
        newton.eval_fk(sim.model, sim.state.joint_q, sim.state.joint_qd, sim.state)
        wp.launch(
            contacts_from_sensordata,
            dim=sim.num_envs,
            inputs=[self._sensordata_wp, self._wheel_found_wp, self._body_found_wp],
            outputs=[sim.wheel_force, sim.body_collision],
            device=sim.device,
        )

    def state_written(self, env_ids: wp.array) -> None:
        sim = self.sim
        wp.launch(
            newton_state_to_mujoco,
            dim=env_ids.shape[0],
            inputs=[sim.joint_q, sim.joint_qd, env_ids, self._qpos_start, self._root_com],
            outputs=[self._mj_state_wp[self._parity]],
            device=sim.device,
        )

    def set_dynamics(self, friction: np.ndarray, damping_ratio: np.ndarray, added_mass: np.ndarray) -> None:
        base = self.mj_model
        trunk = _robot_body([base.body(i).name for i in range(base.nbody)], C.TRUNK_BODY)
        models = []
        for i in range(self.sim.num_envs):
            m = copy.copy(base)
            m.geom_friction[:, 0] = friction[i]
            m.geom_solref[:, 1] = damping_ratio[i]
            m.body_mass[trunk] = base.body_mass[trunk] + added_mass[i]
            models.append(m)
        self.mj_models = models


def _template_mj_model(cfg):
    """The one-robot ``MjModel`` that Newton's ``SolverMuJoCo`` writes for the template scene (joint model of
    ``cfg``), with ground contact sensors added; and the sensordata columns of the wheel and collision-body
    sensors."""
    import mujoco
    import newton

    template = robot.scene_builder(1, cfg.robot or None).finalize(device="cpu")
    apply_joint_model(template, robot.robot_layout(template), cfg.joint_model)
    log = logging.getLogger("newton")
    level = log.level
    with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        log.setLevel(logging.WARNING)  # Newton logs the temporary MJCF path at INFO
        path = os.path.join(tmp, "wheeled_go1.xml")
        newton.solvers.SolverMuJoCo(
            template,
            use_mujoco_cpu=True,
            save_to_mjcf=path,
            iterations=cfg.solver_iterations,
            ls_iterations=cfg.ls_iterations,
        )
        spec = mujoco.MjSpec.from_file(path)
        log.setLevel(level)
    wheel_cols, body_cols = _add_contact_sensors(spec, mujoco)
    return spec.compile(), wheel_cols, body_cols


def _robot_body(names: list[str], name: str) -> int:
    """Index in ``names`` (a MuJoCo model's body names) of the robot body ``name``: Newton names a body by its path,
    ``_wheeled_go1_FR_wheel`` from the USD, ``wheeled_go1_worldbody_trunk_..._FR_calf_FR_wheel`` from an MJCF."""
    matches = [i for i, n in enumerate(names) if n.endswith(f"_{name}")]
    if len(matches) != 1:
        raise ValueError(f"robot body {name}: {len(matches)} bodies named so in the MuJoCo model")
    return matches[0]


def _add_contact_sensors(spec, mujoco) -> tuple[list[int], list[int]]:
    """Add MuJoCo contact sensors against the ground: per wheel geom (found + force), per collision body (found).

    Returns the sensordata column of each wheel sensor and each collision-body sensor.
    """
    ground = next(g.name for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE)

    bodies = [b.name for b in spec.bodies]

    def find_body(name: str) -> str:
        return bodies[_robot_body(bodies, name)]

    def find_geom(body_name: str) -> str:
        body = find_body(body_name)
        for g in spec.geoms:
            if g.parent.name == body and (g.contype or g.conaffinity):
                return g.name
        raise ValueError(f"no collision geom on {body_name}")

    found = 1 << mujoco.mjtConDataField.mjCONDATA_FOUND.value
    force = 1 << mujoco.mjtConDataField.mjCONDATA_FORCE.value
    netforce = 3  # mjtConDataReduce: none, mindist, maxforce, netforce
    col = 0
    wheel_cols, body_cols = [], []
    for name in C.WHEEL_BODY_NAMES:
        s = spec.add_sensor(
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_GEOM,
            objname=find_geom(name),
            reftype=mujoco.mjtObj.mjOBJ_GEOM,
            refname=ground,
        )
        s.intprm[0:3] = [found | force, netforce, 1]
        s.name = f"contact_{name}"
        wheel_cols.append(col)
        col += 4
    for name in C.COLLISION_BODY_NAMES:
        s = spec.add_sensor(
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            objname=find_body(name),
            reftype=mujoco.mjtObj.mjOBJ_GEOM,
            refname=ground,
        )
        s.intprm[0:3] = [found, 0, 1]
        s.name = f"contact_{name}"
        body_cols.append(col)
        col += 1
    return wheel_cols, body_cols
