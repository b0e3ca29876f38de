"""Batched simulation of N wheeled Go1 robots behind one interface, on CPU or CUDA.

Two physics paths share every buffer and kernel except the physics step itself:

* ``mujoco_cpu`` - the one-robot template is converted to MuJoCo by Newton's ``SolverMuJoCo`` once; N independent
  robot states are stepped with ``mujoco.rollout`` on all cores (Newton's own CPU path simulates only the template
  world when worlds are separate, upstream issue #4102). After every physics substep the MuJoCo states are mirrored
  into Newton ``joint_q`` / ``joint_qd`` by a Warp kernel.
* ``mujoco_warp`` - Newton ``SolverMuJoCo`` (mujoco_warp), one MuJoCo world per robot; on CUDA the whole decimation
  loop (actuation, power, physics) is captured once into a CUDA graph and replayed.

Both expose Newton ``State`` arrays (``joint_q``, ``joint_qd``, ``body_q``, ``body_qd``) as per-world 2-D Warp views,
plus applied joint torques, wheel contact forces / flags and body-collision flags, all viewable by torch without
copies (:meth:`Simulator.torch_views`).

Every physics substep runs the actuation kernel (leg PD, wheel PID; ``wqwarp.kernels.actuation``) and accumulates
the power metrics (``wqwarp.kernels.power``) averaged over the substeps of one policy step.
"""

from __future__ import annotations

import logging
import os
import tempfile
import warnings
from dataclasses import dataclass

import numpy as np
import warp as wp

from wqwarp.kernels import actuation, power
from wqwarp.kernels.contacts import accumulate_newton_contacts, accumulate_penalty_contacts, contacts_from_sensordata
from wqwarp.kernels.state import (
    clear_contact_rows,
    flag_unstable,
    gather_actuated,
    mujoco_state_to_newton,
    newton_state_to_mujoco,
    scatter_state_rows,
)
from wqwarp.robot import asset as robot
from wqwarp.robot import constants as C
from wqwarp.sim.config import SimConfig

_MUJOCO_LOG = logging.getLogger("wqwarp.mujoco")
MUJOCO_WARNINGS: list[str] = []
"""MuJoCo warnings of this process (last 100), e.g. "Nan, Inf or huge value in QACC at DOF 0 ... Time = t"."""


def route_mujoco_warnings() -> None:
    """Send MuJoCo's warnings to the ``wqwarp.mujoco`` logger (and :data:`MUJOCO_WARNINGS`) instead of MuJoCo's
    default, a ``MUJOCO_LOG.TXT`` file appended to in the working directory. The robot a warning concerns is
    flagged by :attr:`Simulator.unstable`."""
    import mujoco

    def handler(msg: str) -> None:
        MUJOCO_WARNINGS.append(msg)
        del MUJOCO_WARNINGS[:-100]
        _MUJOCO_LOG.warning("MuJoCo: %s", msg)

    mujoco.set_mju_user_warning(handler)


def index_array(env_ids, device, count: int) -> wp.array:
    """Robot indices as an int32 Warp array on ``device``. A Warp array or a torch tensor already on the device is
    used in place (no host round trip, no range check); a list or NumPy array is checked against ``[0, count)`` and
    copied once."""
    import torch

    if isinstance(env_ids, wp.array):
        return env_ids
    if isinstance(env_ids, torch.Tensor):
        return wp.from_torch(env_ids.reshape(-1).to(torch.int32).contiguous())
    ids = np.asarray(env_ids, dtype=np.int32).reshape(-1)
    if ids.size and (ids.min() < 0 or ids.max() >= count):
        raise IndexError(f"env_ids out of range [0, {count})")
    return wp.array(ids, dtype=wp.int32, device=device)


def apply_joint_model(model, layout, name: str) -> None:
    """Set the passive joint model ``name`` (``SimConfig.joint_model``) on the actuated joints of every world of a
    finalized Newton ``model``, before a solver is built from it (Newton converts ``joint_damping``,
    ``joint_armature`` and ``joint_friction`` to MuJoCo's ``dof_damping``, ``dof_armature`` and
    ``dof_frictionloss``). ``asset`` leaves the model as loaded."""
    if name == "asset":
        return
    worlds = model.joint_dof_count // layout.dofs_per_world
    dofs = (np.arange(worlds)[:, None] * layout.dofs_per_world + np.asarray(layout.actuated_dof)[None, :]).ravel()
    for key, value in C.AUTHORS_JOINT_MODEL.items():
        arr = getattr(model, f"joint_{key}")
        host = arr.numpy()
        host[dofs] = value
        arr.assign(host)


@dataclass
class _Buffers:
    """Per-robot control and measurement arrays, shape (N, ...), float32 unless noted."""

    leg_q_target: wp.array
    wheel_qd_target: wp.array
    motor_strength: wp.array
    torque_limit: wp.array
    joint_torque: wp.array
    wheel_integral: wp.array
    wheel_prev_error: wp.array
    p_cost: wp.array
    p_mech: wp.array
    p_joule: wp.array
    p_cost_legs: wp.array
    p_cost_wheels: wp.array
    p_mech_legs: wp.array
    p_mech_wheels: wp.array
    p_joule_legs: wp.array
    p_joule_wheels: wp.array
    torque_sq: wp.array
    power_sq: wp.array
    wheel_force: wp.array
    wheel_contact: wp.array  # int32
    body_collision: wp.array  # int32
    unstable: wp.array  # int32
    actuated_q: wp.array
    actuated_qd: wp.array


@wp.kernel
def _mask_from_ids(env_ids: wp.array(dtype=wp.int32), mask: wp.array(dtype=wp.bool)):
    mask[env_ids[wp.tid()]] = True


@wp.kernel
def _wheel_contact_flags(force: wp.array2d(dtype=wp.float32), threshold: float, flags: wp.array2d(dtype=wp.int32)):
    w, k = wp.tid()
    flags[w, k] = wp.where(force[w, k] > threshold, 1, 0)


class Simulator:
    """N wheeled Go1 robots stepped at ``dt`` with ``decimation`` substeps per :meth:`step`.

    Control inputs (write before :meth:`step`): ``leg_q_target`` (N, 12) [rad], ``wheel_qd_target`` (N, 4) [rad/s],
    ``motor_strength`` (N, 16) [-]. Outputs after :meth:`step`: ``joint_q`` (N, 23), ``joint_qd`` (N, 22),
    ``body_q`` (N, 21) transforms, ``body_qd`` (N, 21) spatial vectors, ``joint_torque`` (N, 16) [N m] (last
    substep), ``p_cost`` / ``p_mech`` / ``p_joule`` (N,) [W] averaged over the substeps, each also split into
    ``*_legs`` and ``*_wheels``, ``torque_sq`` / ``power_sq`` (N,) substep averages of sum tau^2 and sum (tau qd)^2
    (``wqwarp.kernels.power``), ``wheel_force`` (N, 4) [N],
    ``wheel_contact`` (N, 4) and ``body_collision`` (N, 9) int32 flags, ``unstable`` (N,) int32: 1 for a robot whose
    simulation diverged in this step (MuJoCo reset its data, or a coordinate, velocity or torque is non-finite or
    beyond the ``SimConfig.unstable_*`` limits; the caller must reset it), ``actuated_q`` / ``actuated_qd`` (N, 16) the
    actuated joints in project order (``wqwarp.robot.constants``).
    """

    def __init__(self, cfg: SimConfig):
        cfg.validate()
        self.cfg = cfg
        self.backend = cfg.resolved_backend()
        self.device = wp.get_device(cfg.device)
        if self.backend == "mujoco_cpu" and not self.device.is_cpu:
            raise ValueError("backend 'mujoco_cpu' needs device 'cpu'")
        n = cfg.num_envs
        self.num_envs = n
        with wp.ScopedDevice(self.device):
            self.model = robot.scene_builder(n).finalize(device=self.device)
            self.layout = robot.robot_layout(self.model)
            apply_joint_model(self.model, self.layout, cfg.joint_model)
            self.robot_mass = float(self.model.body_mass.numpy()[: self.layout.bodies_per_world].sum())
            """Mass of one robot as built [kg] (trunk, legs, wheels; without randomised added mass)."""
            lay = self.layout
            self.state = self.model.state()
            self.joint_q = self.state.joint_q.reshape((n, lay.coords_per_world))
            self.joint_qd = self.state.joint_qd.reshape((n, lay.dofs_per_world))
            self.body_q = self.state.body_q.reshape((n, lay.bodies_per_world))
            self.body_qd = self.state.body_qd.reshape((n, lay.bodies_per_world))
            self.control = self.model.control()
            if self.control.joint_f is None:
                self.control.joint_f = wp.zeros(self.model.joint_dof_count, dtype=wp.float32)
            self.joint_f = self.control.joint_f.reshape((n, lay.dofs_per_world))
            self.coord_index = wp.array(lay.actuated_coord, dtype=wp.int32)
            self.dof_index = wp.array(lay.actuated_dof, dtype=wp.int32)
            f32 = wp.float32
            self.buf = _Buffers(
                leg_q_target=wp.array(np.tile(np.asarray(C.DEFAULT_JOINT_POS[:12], np.float32), (n, 1)), dtype=f32),
                wheel_qd_target=wp.zeros((n, 4), dtype=f32),
                motor_strength=wp.ones((n, 16), dtype=f32),
                torque_limit=wp.array(np.asarray(C.TORQUE_LIMITS, np.float32), dtype=f32),
                joint_torque=wp.zeros((n, 16), dtype=f32),
                wheel_integral=wp.zeros((n, 4), dtype=f32),
                wheel_prev_error=wp.zeros((n, 4), dtype=f32),
                **{name: wp.zeros(n, dtype=f32) for name in power.POWER_OUTPUTS},
                wheel_force=wp.zeros((n, 4), dtype=f32),
                wheel_contact=wp.zeros((n, 4), dtype=wp.int32),
                body_collision=wp.zeros((n, len(C.COLLISION_BODY_NAMES)), dtype=wp.int32),
                unstable=wp.zeros(n, dtype=wp.int32),
                actuated_q=wp.zeros((n, 16), dtype=f32),
                actuated_qd=wp.zeros((n, 16), dtype=f32),
            )
            self._default_q = robot.default_joint_q(lay)
            self._all_ids = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32)
            self._actuation_cmds = self._record_actuation()
            if self.backend == "mujoco_cpu":
                self._init_mujoco_cpu()
            elif self.backend == "featherstone":
                self._init_featherstone()
            else:
                self._init_mujoco_warp()
            all_ids = np.arange(n, dtype=np.int32)
            self.reset(all_ids, np.tile(self._default_q, (n, 1)), np.zeros((n, lay.dofs_per_world), np.float32))

    # --- public control / output views -------------------------------------------------------------------------
    def __getattr__(self, name):  # expose buffer fields as attributes: sim.p_cost, sim.leg_q_target, ...
        buf = self.__dict__.get("buf")
        if buf is not None and hasattr(buf, name):
            return getattr(buf, name)
        raise AttributeError(name)

    @property
    def policy_dt(self) -> float:
        """Time of one :meth:`step` [s]."""
        return self.cfg.dt * self.cfg.decimation

    def torch_views(self) -> dict:
        """Zero-copy torch tensors of every state, control and measurement array (shared memory with Warp)."""
        names = ["joint_q", "joint_qd", "joint_f"]
        out = {k: wp.to_torch(getattr(self, k)) for k in names}
        out["body_q"] = wp.to_torch(self.body_q)  # (N, B, 7): position, quaternion xyzw
        out["body_qd"] = wp.to_torch(self.body_qd)  # (N, B, 6): linear, angular (world frame)
        for k in self.buf.__dataclass_fields__:
            out[k] = wp.to_torch(getattr(self.buf, k))
        return out

    # --- stepping ---------------------------------------------------------------------------------------------
    def _record_actuation(self) -> list:
        """Prepared launches of one substep's actuation and power kernels (packed once, replayed every substep)."""
        b, cfg = self.buf, self.cfg
        act = actuation.launch_actuation(
            self.joint_q, self.joint_qd, b.leg_q_target, b.wheel_qd_target, b.torque_limit, b.motor_strength,
            b.wheel_integral, b.wheel_prev_error, b.joint_torque, self.joint_f, self.coord_index, self.dof_index,
            leg_kp=cfg.leg_kp, leg_kd=cfg.leg_kd, wheel_kp=cfg.wheel_kp, wheel_ki=cfg.wheel_ki, wheel_kd=cfg.wheel_kd,
            wheel_i_limit=cfg.wheel_i_limit, dt=cfg.dt, device=self.device, record_cmd=True,
        )  # fmt: skip
        pwr = power.launch_power(
            b.joint_torque, self.joint_qd, [getattr(b, k) for k in power.POWER_OUTPUTS], self.dof_index,
            weight=1.0 / cfg.decimation, device=self.device, record_cmd=True,
        )  # fmt: skip
        return [act, pwr]

    def _actuate(self) -> None:
        """One substep's actuation kernel and power accumulation."""
        for cmd in self._actuation_cmds:
            cmd.launch()

    def step(self, actuate: bool = True) -> None:
        """Advance one policy step: ``decimation`` substeps of actuation + physics, then body poses and contacts.

        ``actuate=False`` skips the actuation and power kernels and keeps the last joint torques (benchmarks)."""
        b = self.buf
        for name in power.POWER_OUTPUTS:
            getattr(b, name).zero_()
        b.unstable.zero_()
        if self.backend == "mujoco_cpu":
            self._step_mujoco_cpu(actuate)
        elif self.backend == "featherstone":
            self._step_featherstone(actuate)
        else:
            self._step_mujoco_warp(actuate)
        cfg = self.cfg
        wp.launch(flag_unstable, dim=self.num_envs, inputs=[self.joint_q, self.joint_qd, b.joint_torque,
                  cfg.unstable_position_limit, cfg.unstable_velocity_limit], outputs=[b.unstable],
                  device=self.device)  # fmt: skip
        self._post_step()

    def _post_step(self) -> None:
        """Per policy step: contact flags and the project-order joint arrays."""
        b = self.buf
        wp.launch(_wheel_contact_flags, dim=(self.num_envs, 4), inputs=[b.wheel_force, self.cfg.contact_threshold],
                  outputs=[b.wheel_contact], device=self.device)  # fmt: skip
        wp.launch(gather_actuated, dim=(self.num_envs, 16), inputs=[self.joint_q, self.joint_qd, self.coord_index,
                  self.dof_index], outputs=[b.actuated_q, b.actuated_qd], device=self.device)  # fmt: skip

    def _ids(self, env_ids) -> wp.array:
        return index_array(env_ids, self.device, self.num_envs)

    def _rows(self, rows, k: int, width: int, what: str) -> wp.array:
        """(k, width) float32 Warp array on the device from a Warp array, torch tensor or NumPy array."""
        import torch

        if isinstance(rows, torch.Tensor):
            rows = wp.from_torch(rows.to(torch.float32).contiguous())
        elif not isinstance(rows, wp.array):
            rows = wp.array(np.ascontiguousarray(rows, dtype=np.float32), dtype=wp.float32, device=self.device)
        if tuple(rows.shape) != (k, width):
            raise ValueError(f"{what} must have shape {(k, width)}, got {tuple(rows.shape)}")
        return rows

    def reset(self, env_ids, joint_q=None, joint_qd=None) -> None:
        """Set robots ``env_ids`` to the given Newton coordinates ((k, 23) / (k, 22); default pose and rest if
        omitted), zero their wheel PID state, recompute their body poses and clear their contact summaries.

        ``env_ids`` and the coordinates may be Warp arrays or torch tensors on the simulator's device (what the
        environment passes: the reset runs in kernels, with no host copy) or NumPy arrays / lists."""
        ids = self._ids(env_ids)
        k = ids.shape[0]
        if k == 0:
            return
        lay = self.layout
        if joint_q is None:
            joint_q = np.tile(self._default_q, (k, 1))
        if joint_qd is None:
            joint_qd = wp.zeros((k, lay.dofs_per_world), dtype=wp.float32, device=self.device)
        self.set_state(ids, joint_q, joint_qd)
        b = self.buf
        actuation.launch_reset_wheel_pid(ids, b.wheel_integral, b.wheel_prev_error, self.device)
        wp.launch(clear_contact_rows, dim=k, inputs=[ids], outputs=[b.wheel_force, b.wheel_contact, b.body_collision,
                  b.unstable], device=self.device)  # fmt: skip
        if self.backend == "mujoco_warp":  # clear MuJoCo's warm start and applied forces: after a divergence (NaN)
            self._reset_mask.zero_()  # they would poison the next step even from a clean state
            wp.launch(_mask_from_ids, dim=k, inputs=[ids], outputs=[self._reset_mask], device=self.device)
            self.solver.reset(self.state, self._reset_mask, flags=0)
        import newton

        newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state, indices=ids)
        self._post_step()

    def set_state(self, env_ids, joint_q, joint_qd) -> None:
        """Overwrite the coordinates of robots ``env_ids`` ((k, 23) / (k, 22)) mid-episode (e.g. a push), keeping
        controller state. Accepts Warp arrays or torch tensors on the device (no host copy) or NumPy arrays."""
        ids = self._ids(env_ids)
        k = ids.shape[0]
        if k == 0:
            return
        lay = self.layout
        q = self._rows(joint_q, k, lay.coords_per_world, "joint_q")
        qd = self._rows(joint_qd, k, lay.dofs_per_world, "joint_qd")
        wp.launch(scatter_state_rows, dim=k, inputs=[ids, q, qd], outputs=[self.joint_q, self.joint_qd],
                  device=self.device)  # fmt: skip
        self.state_written(ids)

    def state_written(self, env_ids=None) -> None:
        """Tell the physics that ``joint_q`` / ``joint_qd`` of robots ``env_ids`` (default all) were written in place
        (e.g. through :meth:`torch_views`): ``mujoco_cpu`` copies them into its MuJoCo states; ``mujoco_warp`` reads
        Newton's state at every step and needs nothing."""
        if self.backend != "mujoco_cpu":
            return
        ids = self._all_ids if env_ids is None else self._ids(env_ids)
        if ids.shape[0] == 0:
            return
        wp.launch(newton_state_to_mujoco, dim=ids.shape[0], inputs=[self.joint_q, self.joint_qd, ids,
                  self._mj_qpos_start, self._root_com], outputs=[self._mj_state_wp[self._parity]],
                  device=self.device)  # fmt: skip

    def mujoco_qpos(self) -> np.ndarray:
        """(N, nq) MuJoCo ``qpos`` of every robot now, in the order of :attr:`mj_model` (``mujoco_cpu`` only): set it
        on an ``MjData`` of ``mj_model`` and call ``mj_forward`` to render or inspect a robot with MuJoCo's tools."""
        if self.backend != "mujoco_cpu":
            raise RuntimeError("mujoco_qpos needs the mujoco_cpu backend (device cpu)")
        s = self._mj_qpos_start
        return self._mj_state[self._parity][:, 0, s : s + self.mj_model.nq].copy()

    def set_dynamics(self, friction: np.ndarray, restitution: np.ndarray, added_mass: np.ndarray) -> None:
        """Per-robot contact friction [-], restitution [-] and mass added to the trunk [kg], each (N,).

        MuJoCo has no restitution coefficient; e is mapped to the contact damping ratio of a spring-damper whose
        bounce has that coefficient: zeta = -ln(e) / sqrt(pi^2 + ln(e)^2) (e -> 0 gives MuJoCo's default 1).
        """
        if self.backend == "featherstone":
            raise ValueError("backend 'featherstone' does not randomise dynamics (friction, restitution, mass); "
                             "turn domain randomisation off")  # fmt: skip
        n = self.num_envs
        mu = np.broadcast_to(np.asarray(friction, np.float64), (n,))
        e = np.clip(np.broadcast_to(np.asarray(restitution, np.float64), (n,)), 1e-6, 0.99)
        dm = np.broadcast_to(np.asarray(added_mass, np.float64), (n,))
        log_e = np.log(e)
        zeta = np.minimum(-log_e / np.sqrt(np.pi**2 + log_e**2), 1.0)
        if self.backend == "mujoco_cpu":
            import copy

            base = self.mj_model
            trunk = base.body("_wheeled_go1_trunk").id
            models = []
            for i in range(n):
                m = copy.copy(base)
                m.geom_friction[:, 0] = mu[i]
                m.geom_solref[:, 1] = zeta[i]
                m.body_mass[trunk] = base.body_mass[trunk] + dm[i]
                models.append(m)
            self._mj_models = models
        else:
            mm = self.solver.mjw_model
            fr = mm.geom_friction.numpy()
            fr[:, :, 0] = mu[:, None]
            mm.geom_friction.assign(fr)
            sr = mm.geom_solref.numpy()
            sr[:, :, 1] = zeta[:, None]
            mm.geom_solref.assign(sr)
            bm = mm.body_mass.numpy()
            bm[:, 1] = self._trunk_mass + dm  # MuJoCo body 1 is the trunk (body 0 is the world)
            mm.body_mass.assign(bm)

    # --- mujoco_cpu ---------------------------------------------------------------------------------------------
    def _init_mujoco_cpu(self) -> None:
        import mujoco
        import newton
        from mujoco import rollout

        cfg = self.cfg
        route_mujoco_warnings()
        template = robot.scene_builder(1).finalize(device="cpu")
        apply_joint_model(template, robot.robot_layout(template), cfg.joint_model)
        log = logging.getLogger("newton")
        level = log.level
        with tempfile.TemporaryDirectory() as tmp, warnings.catch_warnings():
            warnings.simplefilter("ignore")
            log.setLevel(logging.WARNING)  # Newton logs the temporary MJCF path at INFO
            path = os.path.join(tmp, "wheeled_go1.xml")
            newton.solvers.SolverMuJoCo(template, use_mujoco_cpu=True, save_to_mjcf=path,
                                        iterations=cfg.solver_iterations, ls_iterations=cfg.ls_iterations)  # fmt: skip
            spec = mujoco.MjSpec.from_file(path)
            log.setLevel(level)
        self._wheel_found_col, self._body_found_col = _add_contact_sensors(spec, mujoco)
        m = spec.compile()
        m.opt.timestep = cfg.dt
        self.mj_model = m
        self._nthread = max(1, min(cfg.nthread or os.cpu_count() or 1, self.num_envs))
        self._mj_datas = [mujoco.MjData(m) for _ in range(self._nthread)]
        self._mj_models = [m] * self.num_envs  # rollout with skip_checks takes one model per robot
        self._rollout = rollout.Rollout(nthread=self._nthread if self._nthread > 1 else 0)
        self._state_spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
        nstate = mujoco.mj_stateSize(m, self._state_spec)
        self._mj_qpos_start = mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_TIME.value)
        n = self.num_envs
        # Two (N, 1, nstate) buffers used in turn as rollout input and output: no copy between substeps.
        self._mj_state = [np.zeros((n, 1, nstate)), np.zeros((n, 1, nstate))]
        d = self._mj_datas[0]
        mujoco.mj_resetData(m, d)
        init = np.zeros(nstate)
        mujoco.mj_getState(m, d, init, self._state_spec)
        for s in self._mj_state:
            s[:] = init
        self._mj_state_wp = [wp.array(s.reshape(n, nstate), dtype=wp.float64, device="cpu", copy=False)
                             for s in self._mj_state]  # fmt: skip
        self._parity = 0
        self._mj_control = np.zeros((n, 1, m.nv))
        self._sensordata = np.zeros((n, 1, m.nsensordata))
        self._sensordata_wp = wp.array(self._sensordata.reshape(n, m.nsensordata), dtype=wp.float64, copy=False)
        self._joint_f_np = self.joint_f.numpy()  # zero-copy view on CPU
        self._unstable_np = self.buf.unstable.numpy()  # zero-copy view on CPU
        self._root_com = wp.vec3(*self.model.body_com.numpy()[self.layout.trunk_body])
        self._wheel_found_wp = wp.array(self._wheel_found_col, dtype=wp.int32)
        self._body_found_wp = wp.array(self._body_found_col, dtype=wp.int32)
        self._qfrc_spec = mujoco.mjtState.mjSTATE_QFRC_APPLIED.value
        # Mirror MuJoCo state -> Newton joint_q / joint_qd, one prepared launch per state buffer.
        self._mirror_cmds = [
            wp.launch(mujoco_state_to_newton, dim=n, inputs=[s, self._mj_qpos_start, self._root_com],
                      outputs=[self.joint_q, self.joint_qd], device=self.device, record_cmd=True)
            for s in self._mj_state_wp
        ]  # fmt: skip

    def _step_mujoco_cpu(self, actuate: bool) -> None:
        for _ in range(self.cfg.decimation):
            if actuate:
                self._actuate()
            self._mj_control[:, 0, :] = self._joint_f_np
            src, dst = self._mj_state[self._parity], self._mj_state[1 - self._parity]
            self._rollout.rollout(
                self._mj_models, self._mj_datas, src[:, 0, :], self._mj_control, control_spec=self._qfrc_spec,
                nstep=1, state=dst, sensordata=self._sensordata, skip_checks=True,
            )  # fmt: skip
            # MuJoCo resets the data of a diverged robot inside the step (a warning, time restarts at 0): its time
            # then falls behind. Flag it; the kernel after the loop adds non-finite and exploding states.
            self._unstable_np |= dst[:, 0, 0] < src[:, 0, 0]
            self._parity = 1 - self._parity
            self._mirror_cmds[self._parity].launch()
        import newton

        newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state)
        wp.launch(contacts_from_sensordata, dim=self.num_envs, inputs=[self._sensordata_wp, self._wheel_found_wp,
                  self._body_found_wp], outputs=[self.buf.wheel_force, self.buf.body_collision],
                  device=self.device)  # fmt: skip

    # --- mujoco_warp --------------------------------------------------------------------------------------------
    def _init_mujoco_warp(self) -> None:
        import newton

        cfg = self.cfg
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self.solver = newton.solvers.SolverMuJoCo(
                self.model, separate_worlds=True, iterations=cfg.solver_iterations, ls_iterations=cfg.ls_iterations,
                njmax=cfg.njmax, nconmax=cfg.nconmax,
            )  # fmt: skip
        self.contacts = newton.Contacts(self.solver.get_max_contact_count(), 0, device=self.device)
        kinds = {newton.solvers.SolverBase.ObservableKind.CONTACT_F}
        self.observables = self.solver.observables(kinds, contacts=self.contacts)
        self._ground_shape, self._shape_world, self._wheel_slot, self._body_slot = shape_slots(self.model, self.layout)
        self._graph = None
        self._use_graph = cfg.cuda_graph and self.device.is_cuda
        self._reset_mask = wp.zeros(self.num_envs + 1, dtype=wp.bool)  # per world, + Newton's global world
        self._trunk_mass = float(self.solver.mjw_model.body_mass.numpy()[0, 1])

    def _decimation_loop_warp(self, actuate: bool = True) -> None:
        for _ in range(self.cfg.decimation):
            if actuate:
                self._actuate()
            self.solver.step(
                self.state, self.state, self.control, self.contacts, self.cfg.dt, observables=self.observables
            )
        self.solver.update_contacts(self.contacts)
        b = self.buf
        b.wheel_force.zero_()
        b.body_collision.zero_()
        wp.launch(accumulate_newton_contacts, dim=self.contacts.rigid_contact_max,
                  inputs=[self.contacts.rigid_contact_count, self.contacts.rigid_contact_shape0,
                          self.contacts.rigid_contact_shape1, self.observables.contact_f, self._shape_world,
                          self._wheel_slot, self._body_slot, self._ground_shape],
                  outputs=[b.wheel_force, b.body_collision], device=self.device)  # fmt: skip

    def _step_mujoco_warp(self, actuate: bool) -> None:
        if not (self._use_graph and actuate):
            self._decimation_loop_warp(actuate)
            return
        if self._graph is None:
            self._decimation_loop_warp()  # warm-up: compiles kernels and allocates outside the capture
            with wp.ScopedCapture(device=self.device) as cap:
                self._decimation_loop_warp()
            self._graph = cap.graph
            return
        wp.capture_launch(self._graph)


    # --- featherstone -------------------------------------------------------------------------------------------
    def _init_featherstone(self) -> None:
        from wqwarp.diff import rollout as diffsim

        cfg = self.cfg
        self.solver, self._pipeline, self.contacts = diffsim.penalty_physics(self.model, cfg)
        self._ground_shape, self._shape_world, self._wheel_slot, self._body_slot = shape_slots(self.model, self.layout)

    def _step_featherstone(self, actuate: bool) -> None:
        st = self.state
        for _ in range(self.cfg.decimation):
            if actuate:
                self._actuate()
            self._pipeline.collide(st, self.contacts)
            st.clear_forces()
            # in place (Featherstone supports it; bit-identical to stepping into a second state and copying back),
            # so the views on self.state stay valid
            self.solver.step(st, st, self.control, self.contacts, self.cfg.dt)
        b, c = self.buf, self.contacts
        b.wheel_force.zero_()
        b.body_collision.zero_()
        wp.launch(accumulate_penalty_contacts, dim=c.rigid_contact_max,
                  inputs=[c.rigid_contact_count, c.rigid_contact_shape0, c.rigid_contact_shape1,
                          c.rigid_contact_point0, c.rigid_contact_point1, c.rigid_contact_normal,
                          c.rigid_contact_margin0, c.rigid_contact_margin1, st.body_q, self.model.shape_body,
                          self._shape_world, self._wheel_slot, self._body_slot, self._ground_shape,
                          float(self.cfg.contact_ke)],
                  outputs=[b.wheel_force, b.body_collision], device=self.device)  # fmt: skip


def shape_slots(model, layout) -> tuple[int, wp.array, wp.array, wp.array]:
    """Per Newton shape: its world, its wheel slot (0-3, -1 if not a wheel) and its collision-body slot
    (``constants.COLLISION_BODY_NAMES``, -1 if none), as int32 Warp arrays, and the ground plane's shape index."""
    shape_body = model.shape_body.numpy()
    shape_world = model.shape_world.numpy()
    wheel_slot = np.full(model.shape_count, -1, np.int32)
    body_slot = np.full(model.shape_count, -1, np.int32)
    ground = -1
    for s in range(model.shape_count):
        bdy = shape_body[s]
        if bdy < 0:
            ground = s
            continue
        local = bdy - shape_world[s] * layout.bodies_per_world
        hits = np.nonzero(layout.wheel_body == local)[0]
        if hits.size:
            wheel_slot[s] = hits[0]
        hits = np.nonzero(layout.collision_body == local)[0]
        if hits.size:
            body_slot[s] = hits[0]
    as_wp = lambda a: wp.array(a, dtype=wp.int32, device=model.device)  # noqa: E731
    return ground, as_wp(np.maximum(shape_world, 0).astype(np.int32)), as_wp(wheel_slot), as_wp(body_slot)


def _add_contact_sensors(spec, mujoco) -> tuple[list[int], list[int]]:
    """Add MuJoCo contact sensors against the ground: per wheel geom (found + force), per collision body (found).

    Returns the sensordata column of each wheel sensor and each collision-body sensor.
    """
    ground = next(g.name for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_PLANE)

    def find_geom(body_name: str) -> str:
        for g in spec.geoms:
            if g.name.startswith(f"/wheeled_go1/{body_name}/"):
                return g.name
        raise ValueError(f"no collision geom on {body_name}")

    found = 1 << mujoco.mjtConDataField.mjCONDATA_FOUND.value
    force = 1 << mujoco.mjtConDataField.mjCONDATA_FORCE.value
    netforce = 3  # mjtConDataReduce: none, mindist, maxforce, netforce
    col = 0
    wheel_cols, body_cols = [], []
    for name in C.WHEEL_BODY_NAMES:
        s = spec.add_sensor(type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=mujoco.mjtObj.mjOBJ_GEOM,
                            objname=find_geom(name), reftype=mujoco.mjtObj.mjOBJ_GEOM, refname=ground)  # fmt: skip
        s.intprm[0:3] = [found | force, netforce, 1]
        s.name = f"contact_{name}"
        wheel_cols.append(col)
        col += 4
    for name in C.COLLISION_BODY_NAMES:
        s = spec.add_sensor(
            type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=mujoco.mjtObj.mjOBJ_BODY, objname=f"_wheeled_go1_{name}",
            reftype=mujoco.mjtObj.mjOBJ_GEOM, refname=ground,
        )  # fmt: skip
        s.intprm[0:3] = [found, 0, 1]
        s.name = f"contact_{name}"
        body_cols.append(col)
        col += 1
    return wheel_cols, body_cols
