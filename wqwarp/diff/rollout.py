"""Differentiable rollouts of the wheeled Go1 on Newton's Featherstone solver with spring-damper contacts.

The MuJoCo solvers behind :class:`wqwarp.sim.simulator.Simulator` are not differentiable. This module runs the same
robot, the same actuation (``kernels.actuation``: leg PD, wheel PID, torque limits) and the same power metrics
(``kernels.power``) on ``newton.solvers.SolverFeatherstone``, whose steps ``wp.Tape`` can differentiate, with
Newton's penalty contact (``SimConfig.contact_ke``, ``contact_kd``, ``contact_kf``, ``contact_mu``). The same physics
is available to forward-only code as ``SimConfig(backend="featherstone")``; the solver and contacts of both are
built by ``wqwarp.sim.backends.featherstone.penalty_physics``.

:class:`DiffRollout` records an open-loop rollout of N robots following the nominal gait (``kernels.gait.
open_loop_gait_targets``, parameters h_b, h_s, f, DF_swing, stance x per robot) plus constant leg-target and
wheel-target offsets, and returns the gradients of the horizon means of the smooth p_cost
(``kernels.power.p_cost_term_smooth``) and of the base velocity with respect to those inputs.

What makes a multi-step tape correct here (checked by ``tests/sim/test_diffsim.py`` against finite differences):

* every substep has its own state, joint forces, torques, PID state and target arrays, so nothing that the adjoint
  reads is overwritten;
* Featherstone keeps its mass matrix, Jacobian and Cholesky factor (``M``, ``J``, ``P``, ``H``, ``L``) in solver-wide
  buffers; they are swapped for per-substep copies before every step;
* collision detection runs outside the tape: contact points and normals are held fixed within a substep, while
  penetration depth, contact velocity and so the forces stay functions of the state;
* the contact forces are evaluated by ``kernels.contacts.anchored_penalty_contacts`` (``anchored_contacts``), which
  carries a wheel's contact point with its calf instead of the spinning wheel: held on the wheel, the point turns
  with it within a substep, which adds a spurious dependence on the spin angle (the wheel-speed gradient was 30 % off
  finite differences). The forward forces are the same as Newton's own evaluation.

Gradients are truncated to the taped horizon: the warm-up that brings the robots to a settled gait is not taped.
How far they can be trusted against horizon and dt: ``tools/studies/gradient_study.py``, docs/differentiable.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import warp as wp

from wqwarp.control.gaits import GAIT_LIBRARY, gait_index
from wqwarp.kernels import actions, actuation, power
from wqwarp.kernels import gait as gait_kernels
from wqwarp.kernels.contacts import anchor_contact_points, anchored_penalty_contacts
from wqwarp.kernels.state import accumulate_base_motion
from wqwarp.robot import asset as robot
from wqwarp.robot import constants as C
from wqwarp.sim.backends.featherstone import penalty_physics
from wqwarp.sim.model import apply_joint_model

SOLVER_MATRICES = ("M", "J", "P", "H", "L")
"""Featherstone's solver-wide buffers that one step writes and its adjoint reads."""

PARAM_NAMES = gait_kernels.GAIT_PARAM_NAMES
FALL_HEIGHT = 0.12
"""A trunk below this height [m] counts as fallen (standing: ~0.27 m)."""


def shape_anchor_bodies(model, layout) -> np.ndarray:
    """Per shape, the body whose frame carries its contact points in :func:`kernels.contacts.anchored_penalty_contacts`:
    for a wheel its parent (the calf side, which does not spin), for any other shape its own body (0 for the
    ground, unused)."""
    parent = np.full(model.body_count, -1, np.int64)
    parent[model.joint_child.numpy()] = model.joint_parent.numpy()
    wheels = set()
    for w in range(model.world_count):
        wheels.update((layout.wheel_body + w * layout.bodies_per_world).tolist())
    body = model.shape_body.numpy()
    return np.array([parent[b] if b in wheels else max(b, 0) for b in body], np.int32)


def gait_params(gait: str, h_b: float = C.NOMINAL_BODY_HEIGHT, h_s: float = C.NOMINAL_SWING_HEIGHT) -> np.ndarray:
    """(5,) float32 nominal-gait parameters (``PARAM_NAMES``) of Table I gait ``gait`` at body height ``h_b`` [m] and
    swing height ``h_s`` [m]."""
    g = GAIT_LIBRARY[gait_index(gait)]
    return np.array([h_b, h_s, g.frequency, g.df_swing, g.stance_x], np.float32)


@dataclass
class RolloutResult:
    """Horizon means per robot (float64 NumPy arrays, shape (N,) unless noted)."""

    p_cost: np.ndarray
    """Exact p_cost = sum |tau| |qd| [W]."""
    p_cost_legs: np.ndarray
    p_cost_wheels: np.ndarray
    p_cost_smooth: np.ndarray
    """The smooth p_cost whose gradient is taken [W] (``kernels.power.p_cost_term_smooth``)."""
    base_velocity: np.ndarray
    """(N, 3) v_x, v_y [m/s], w_z [rad/s] of the trunk COM in the base frame."""
    base_height: np.ndarray
    """Trunk height [m]."""
    fell: np.ndarray
    """bool: the trunk went below ``FALL_HEIGHT`` or the state stopped being finite."""


class DiffRollout:
    """A taped open-loop rollout of ``num_envs`` robots in gait ``gait`` under a constant ``command``.

    ``cfg`` (``SimConfig``) gives dt, decimation, gains, joint model and contact; ``horizon`` policy steps are
    taped after ``warmup`` untaped policy steps from the default pose. Inputs (Warp arrays with gradients, set with
    :meth:`set_inputs`): ``params`` (N, 5) gait parameters, ``leg_offset`` (N, 12) [rad] and ``wheel_offset`` (N, 4)
    [rad/s] added to the nominal targets. ``eps_tau`` [N m] and ``eps_qd`` [rad/s] set the smooth |x| of the power.

    Memory grows with the taped substeps (a state with Featherstone's work arrays, solver matrices and a contact
    buffer each: ~5 MB per substep for 8 robots, measured); the tape is for short windows of few robots.
    """

    def __init__(
        self,
        cfg,
        gait: str,
        command=(0.3, 0.0, 0.0),
        horizon: int = 25,
        warmup: int = 50,
        eps_tau: float = 0.05,
        eps_qd: float = 0.05,
        anchored_contacts: bool = True,
        *,
        _swap_matrices: bool = True,
    ):
        cfg.validate()
        if horizon < 1 or warmup < 0:
            raise ValueError(f"need horizon >= 1 and warmup >= 0 policy steps, got {horizon} and {warmup}")
        self.cfg = cfg
        self.device = wp.get_device(cfg.device)
        self.num_envs = n = cfg.num_envs
        self.horizon, self.warmup = horizon, warmup
        self.eps_tau, self.eps_qd = float(eps_tau), float(eps_qd)
        self.gait = gait
        self._swap = _swap_matrices  # off only in the test that shows why the swap is needed
        self.anchored_contacts = anchored_contacts
        """Evaluate the contact forces with ``kernels.contacts.anchored_penalty_contacts`` (a wheel's contact point
        carried by its calf, so it does not turn with the wheel within a substep) instead of inside Featherstone
        (Newton's ``eval_body_contact``, the point fixed on the wheel). Same forward forces (docs/differentiable.md)."""
        with wp.ScopedDevice(self.device):
            self.model = robot.scene_builder(n, cfg.robot or None).finalize(device=self.device, requires_grad=True)
            self.layout = lay = robot.robot_layout(self.model)
            apply_joint_model(self.model, lay, cfg.joint_model)
            self.solver, self.pipeline, _ = penalty_physics(self.model, cfg)
            substeps = horizon * cfg.decimation
            self.states = [self.model.state(requires_grad=True) for _ in range(substeps + 1)]
            self._scratch = [self.model.state(requires_grad=False) for _ in range(2)]
            self.contacts = [self.pipeline.contacts() for _ in range(substeps)]
            cmax = self.contacts[0].rigid_contact_max
            self.anchored = [(wp.zeros(cmax, dtype=wp.vec3), wp.zeros(cmax, dtype=wp.vec3)) for _ in range(substeps)]
            self.shape_anchor = wp.array(shape_anchor_bodies(self.model, lay), dtype=wp.int32)
            self.control = self.model.control()
            dofs = self.model.joint_dof_count
            self.joint_f = [wp.zeros(dofs, dtype=float, requires_grad=True) for _ in range(substeps)]
            self._warm_f = wp.zeros(dofs, dtype=float)
            z = lambda *shape: wp.zeros(shape, dtype=float, requires_grad=True)  # noqa: E731
            self.integral = [z(n, 4) for _ in range(substeps + 1)]
            self.prev_error = [z(n, 4) for _ in range(substeps + 1)]
            self.torque = [z(n, 16) for _ in range(substeps)]
            self.leg_nominal = [z(n, 12) for _ in range(horizon)]
            self.wheel_nominal = [z(n, 4) for _ in range(horizon)]
            self.leg_target = [z(n, 12) for _ in range(horizon)]
            self.wheel_target = [z(n, 4) for _ in range(horizon)]
            self.matrices = [
                {
                    k: wp.zeros_like(getattr(self.solver, k), requires_grad=True)
                    for k in SOLVER_MATRICES
                    if getattr(self.solver, k, None) is not None
                }
                for _ in range(substeps)
            ]
            self.params = z(n, len(PARAM_NAMES))
            self.leg_offset = z(n, 12)
            self.wheel_offset = z(n, 4)
            g = GAIT_LIBRARY[gait_index(gait)]
            self.phase_offsets = wp.array(np.tile(np.asarray(g.phase_offsets, np.float32), (n, 1)), dtype=float)
            self.command = wp.array(np.tile(np.asarray(command, np.float32), (n, 1)), dtype=float)
            self.coord_index = wp.array(lay.actuated_coord, dtype=wp.int32)
            self.dof_index = wp.array(lay.actuated_dof, dtype=wp.int32)
            self.torque_limit = wp.array(np.asarray(C.TORQUE_LIMITS, np.float32), dtype=float)
            self.strength = wp.ones((n, 16), dtype=float)
            self.p_cost_legs = z(n)
            self.p_cost_wheels = z(n)
            self.p_cost_smooth = z(n)
            self.base_velocity = z(n, 3)
            self.base_height = z(n)
            self.min_height = np.full(n, np.inf)
        self.tape: wp.Tape | None = None
        self.set_inputs(np.tile(gait_params(gait), (n, 1)))

    # --- inputs -------------------------------------------------------------------------------------------------
    def set_inputs(self, params=None, leg_offset=None, wheel_offset=None) -> None:
        """Set any of the inputs from NumPy arrays ((N, 5), (N, 12), (N, 4); a 1-D row is used for every robot)."""
        for arr, value in ((self.params, params), (self.leg_offset, leg_offset), (self.wheel_offset, wheel_offset)):
            if value is not None:
                v = np.broadcast_to(np.asarray(value, np.float32), arr.shape)
                arr.assign(np.ascontiguousarray(v))

    # --- rollout --------------------------------------------------------------------------------------------------
    def _rows(self, state, name: str, width: int):
        return getattr(state, name).reshape((self.num_envs, width))

    def _actuate(self, state, leg_t, wheel_t, i_in, e_in, i_out, e_out, torque, joint_f) -> None:
        """``kernels.actuation.apply_actuation``: PID state read from ``i_in``/``e_in``, written to ``i_out``/``e_out``
        (separate arrays on the tape; the same arrays for the untaped loops, which update it in place)."""
        cfg, lay = self.cfg, self.layout
        actuation.launch_actuation(
            self._rows(state, "joint_q", lay.coords_per_world),
            self._rows(state, "joint_qd", lay.dofs_per_world),
            leg_t,
            wheel_t,
            self.torque_limit,
            self.strength,
            i_in,
            e_in,
            torque,
            joint_f.reshape((self.num_envs, lay.dofs_per_world)),
            self.coord_index,
            self.dof_index,
            leg_kp=cfg.leg_kp,
            leg_kd=cfg.leg_kd,
            wheel_kp=cfg.wheel_kp,
            wheel_ki=cfg.wheel_ki,
            wheel_kd=cfg.wheel_kd,
            wheel_i_limit=cfg.wheel_i_limit,
            dt=cfg.dt,
            wheel_integral_out=i_out,
            wheel_prev_error_out=e_out,
        )

    def _targets(self, step: int, t: float, leg_t, wheel_t) -> None:
        n = self.num_envs
        wp.launch(
            gait_kernels.open_loop_gait_targets,
            dim=(n, 4),
            inputs=[self.params, self.phase_offsets, self.command, float(t), float(C.MAX_HORIZONTAL_OFFSET)],
            outputs=[self.leg_nominal[step], self.wheel_nominal[step]],
        )
        wp.launch(
            actions.offset_targets,
            dim=n,
            inputs=[self.leg_nominal[step], self.wheel_nominal[step], self.leg_offset, self.wheel_offset],
            outputs=[leg_t, wheel_t],
        )

    def _untaped(self, first: int, steps: int, measure: bool = False, reset: bool = False) -> np.ndarray:
        """Run policy steps ``first`` .. ``first + steps`` untaped on the two scratch states (from the default pose if
        ``reset``; the PID state lives in ``integral[0]`` / ``prev_error[0]``). With ``measure``, add each substep's
        exact and smooth p_cost and base motion, weighted 1 / (steps * decimation), to the output arrays. Returns
        the lowest trunk height per robot seen at the policy steps."""
        import newton

        cfg, lay, n = self.cfg, self.layout, self.num_envs
        a, b = self._scratch
        if reset:
            a.joint_q.assign(np.tile(robot.default_joint_q(lay), (n, 1)).reshape(-1))
            a.joint_qd.zero_()
            newton.eval_fk(self.model, a.joint_q, a.joint_qd, a)
            self.integral[0].zero_()
            self.prev_error[0].zero_()
        self.control.joint_f = self._warm_f
        contacts = self.contacts[0]
        weight = 1.0 / max(1, steps * cfg.decimation)
        low = np.full(n, np.inf)
        for p in range(first, first + steps):
            self._targets(0, p * self.policy_dt, self.leg_target[0], self.wheel_target[0])
            for _ in range(cfg.decimation):
                self._actuate(
                    a,
                    self.leg_target[0],
                    self.wheel_target[0],
                    self.integral[0],
                    self.prev_error[0],
                    self.integral[0],
                    self.prev_error[0],
                    self.torque[0],
                    self._warm_f,
                )
                if measure:
                    wp.launch(
                        power.accumulate_p_cost_taped,
                        dim=n,
                        inputs=[
                            self.torque[0],
                            self._rows(a, "joint_qd", lay.dofs_per_world),
                            self.dof_index,
                            weight,
                            self.eps_tau,
                            self.eps_qd,
                        ],
                        outputs=[self.p_cost_legs, self.p_cost_wheels, self.p_cost_smooth],
                    )
                self.pipeline.collide(a, contacts)
                a.clear_forces()
                self.solver.step(a, b, self.control, contacts, cfg.dt)
                if measure:
                    wp.launch(
                        accumulate_base_motion,
                        dim=n,
                        inputs=[
                            self._rows(b, "body_q", lay.bodies_per_world),
                            self._rows(b, "body_qd", lay.bodies_per_world),
                            int(lay.trunk_body),
                            weight,
                        ],
                        outputs=[self.base_velocity, self.base_height],
                    )
                a, b = b, a
            low = np.minimum(low, a.joint_q.numpy().reshape(n, -1)[:, 2])
        self._scratch = [a, b]
        return low

    def _warm_start(self) -> None:
        """Untaped warm-up from the default pose; leaves its final state in ``states[0]`` (PID state in
        ``integral[0]`` / ``prev_error[0]``)."""
        import newton

        self._untaped(0, self.warmup, reset=True)
        a, s0 = self._scratch[0], self.states[0]
        wp.copy(s0.joint_q, a.joint_q)
        wp.copy(s0.joint_qd, a.joint_qd)
        newton.eval_fk(self.model, s0.joint_q, s0.joint_qd, s0)
        self.min_height = a.joint_q.numpy().reshape(self.num_envs, -1)[:, 2].astype(np.float64)

    def measure(self, seconds: float, warm_start: bool = True) -> RolloutResult:
        """Untaped, no gradient: the warm-up (``warm_start``; else continue from the end of the last one, which
        :meth:`run` left in ``states[0]``), then ``seconds`` more of the same open-loop gait, and the means over those
        seconds (exact and smooth p_cost, base velocity, height). A longer, less noisy estimate than the taped window
        of :meth:`run`, on the same physics. It overwrites the outputs and the start PID state of the last
        :meth:`run`: call :meth:`gradients` first."""
        import newton

        steps = max(1, round(seconds / self.policy_dt))
        for arr in (self.p_cost_legs, self.p_cost_wheels, self.p_cost_smooth, self.base_velocity, self.base_height):
            arr.zero_()
        if warm_start:
            self._untaped(0, self.warmup, reset=True)
        else:
            a, s0 = self._scratch[0], self.states[0]
            wp.copy(a.joint_q, s0.joint_q)
            wp.copy(a.joint_qd, s0.joint_qd)
            newton.eval_fk(self.model, a.joint_q, a.joint_qd, a)
        low = self._untaped(self.warmup, steps, measure=True)
        final = self._scratch[0].joint_q.numpy().reshape(self.num_envs, -1)
        return self._result(low, final)

    def _result(self, low: np.ndarray, final: np.ndarray) -> RolloutResult:
        return RolloutResult(
            p_cost=self.p_cost_legs.numpy().astype(np.float64) + self.p_cost_wheels.numpy(),
            p_cost_legs=self.p_cost_legs.numpy().astype(np.float64),
            p_cost_wheels=self.p_cost_wheels.numpy().astype(np.float64),
            p_cost_smooth=self.p_cost_smooth.numpy().astype(np.float64),
            base_velocity=self.base_velocity.numpy().astype(np.float64),
            base_height=self.base_height.numpy().astype(np.float64),
            fell=(low < FALL_HEIGHT) | ~np.isfinite(final).all(axis=1),
        )

    def _anchored_contact_forces(self, state, c, anchored) -> None:
        cfg, m = self.cfg, self.model
        wp.launch(
            anchored_penalty_contacts,
            dim=c.rigid_contact_max,
            inputs=[
                c.rigid_contact_count,
                c.rigid_contact_shape0,
                c.rigid_contact_shape1,
                anchored[0],
                anchored[1],
                c.rigid_contact_normal,
                c.rigid_contact_margin0,
                c.rigid_contact_margin1,
                state.body_q,
                state.body_qd,
                m.body_com,
                m.shape_body,
                self.shape_anchor,
                float(cfg.contact_ke),
                float(cfg.contact_kd),
                float(cfg.contact_kf),
                float(cfg.contact_mu),
            ],
            outputs=[state.body_f],
        )

    @property
    def policy_dt(self) -> float:
        return self.cfg.dt * self.cfg.decimation

    def run(self, record: bool = True, warm_start: bool = True) -> RolloutResult:
        """Warm up (``warm_start``; else start from the last warm-up's end state, so that finite differences see the
        same start as the truncated gradient), then run the horizon (on a new ``wp.Tape`` if ``record``) and return
        its means."""
        cfg, lay, n = self.cfg, self.layout, self.num_envs
        if warm_start:
            self._warm_start()
        for arr in (self.p_cost_legs, self.p_cost_wheels, self.p_cost_smooth, self.base_velocity, self.base_height):
            arr.zero_()
        substeps = self.horizon * cfg.decimation
        weight = 1.0 / substeps
        tape = wp.Tape() if record else None
        self.tape = tape
        saved = {k: getattr(self.solver, k) for k in self.matrices[0]}

        def taped(fn):
            if tape is None:
                fn()
                return
            with tape:
                fn()

        try:
            for p in range(self.horizon):
                t = (self.warmup + p) * self.policy_dt
                taped(lambda p=p, t=t: self._targets(p, t, self.leg_target[p], self.wheel_target[p]))
                for k in range(cfg.decimation):
                    i = p * cfg.decimation + k
                    s, s1 = self.states[i], self.states[i + 1]
                    c = self.contacts[i]
                    self.pipeline.collide(s, c)  # untaped: contact geometry fixed in the substep
                    s.clear_forces()
                    if self.anchored_contacts:
                        wp.launch(
                            anchor_contact_points,
                            dim=c.rigid_contact_max,
                            inputs=[
                                c.rigid_contact_count,
                                c.rigid_contact_shape0,
                                c.rigid_contact_shape1,
                                c.rigid_contact_point0,
                                c.rigid_contact_point1,
                                s.body_q,
                                self.model.shape_body,
                                self.shape_anchor,
                            ],
                            outputs=list(self.anchored[i]),
                        )
                    for name, arr in self.matrices[i].items() if self._swap else ():
                        setattr(self.solver, name, arr)
                    self.control.joint_f = self.joint_f[i]

                    def substep(i=i, p=p, s=s, s1=s1):
                        self._actuate(
                            s,
                            self.leg_target[p],
                            self.wheel_target[p],
                            self.integral[i],
                            self.prev_error[i],
                            self.integral[i + 1],
                            self.prev_error[i + 1],
                            self.torque[i],
                            self.joint_f[i],
                        )
                        wp.launch(
                            power.accumulate_p_cost_taped,
                            dim=n,
                            inputs=[
                                self.torque[i],
                                self._rows(s, "joint_qd", lay.dofs_per_world),
                                self.dof_index,
                                weight,
                                self.eps_tau,
                                self.eps_qd,
                            ],
                            outputs=[self.p_cost_legs, self.p_cost_wheels, self.p_cost_smooth],
                        )
                        contacts = self.contacts[i]
                        if self.anchored_contacts:
                            self._anchored_contact_forces(s, contacts, self.anchored[i])
                            contacts = None
                        self.solver.step(s, s1, self.control, contacts, cfg.dt)
                        wp.launch(
                            accumulate_base_motion,
                            dim=n,
                            inputs=[
                                self._rows(s1, "body_q", lay.bodies_per_world),
                                self._rows(s1, "body_qd", lay.bodies_per_world),
                                int(lay.trunk_body),
                                weight,
                            ],
                            outputs=[self.base_velocity, self.base_height],
                        )

                    taped(substep)
        finally:
            for name, arr in saved.items():
                setattr(self.solver, name, arr)
        # every substep's state is kept: read the trunk heights once, after the loop (no host copy per substep)
        heights = np.stack([st.joint_q.numpy().reshape(n, -1)[:, 2] for st in self.states[1:]])
        h = np.minimum(self.min_height, heights.min(axis=0))
        final = self.states[-1].joint_q.numpy().reshape(n, -1)
        return self._result(h, final)

    def gradients(self, p_cost_weight=None, velocity_weight=None, height_weight=None) -> dict:
        """Backward pass of the last recorded :meth:`run`: the gradient of
        sum_w (p_cost_weight[w] * p_cost_smooth[w] + velocity_weight[w] . base_velocity[w] + height_weight[w] *
        base_height[w]) with respect to ``params`` (N, 5), ``leg_offset`` (N, 12) and ``wheel_offset`` (N, 4), as
        NumPy arrays. Weights: (N,), (N, 3) and (N,) NumPy arrays or None (0)."""
        if self.tape is None:
            raise RuntimeError("no recorded rollout: call run(record=True) first")
        n = self.num_envs
        seeds = {}
        for arr, w, shape in (
            (self.p_cost_smooth, p_cost_weight, (n,)),
            (self.base_velocity, velocity_weight, (n, 3)),
            (self.base_height, height_weight, (n,)),
        ):
            if w is not None:
                seeds[arr] = wp.array(
                    np.broadcast_to(np.asarray(w, np.float32), shape).copy(), dtype=float, device=self.device
                )
        self.tape.zero()
        self.tape.backward(grads=seeds)
        out = {
            "params": self.params.grad.numpy().copy(),
            "leg_offset": self.leg_offset.grad.numpy().copy(),
            "wheel_offset": self.wheel_offset.grad.numpy().copy(),
        }
        return out
