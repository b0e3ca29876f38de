"""``mujoco_warp``: Newton ``SolverMuJoCo`` (mujoco_warp), one MuJoCo world per robot, on CPU or CUDA.

On CUDA the whole decimation loop (actuation, power, physics, contact summaries) is captured once into a CUDA graph
and replayed. Contact summaries come from Newton's contact list and MuJoCo's contact forces
(``kernels.contacts.accumulate_newton_contacts``).
"""

from __future__ import annotations

import warnings

import numpy as np
import warp as wp

from wqwarp.kernels.contacts import accumulate_newton_contacts
from wqwarp.sim.backends.base import PhysicsBackend
from wqwarp.sim.model import shape_slots


@wp.kernel
def _mask_from_ids(env_ids: wp.array(dtype=wp.int32), mask: wp.array(dtype=wp.bool)):
    mask[env_ids[wp.tid()]] = True


class MujocoWarpBackend(PhysicsBackend):
    """mujoco_warp through Newton, stepping Newton's state in place."""

    name = "mujoco_warp"

    def __init__(self, sim) -> None:
        import newton

        super().__init__(sim)
        cfg = sim.cfg
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            self.solver = newton.solvers.SolverMuJoCo(
                sim.model,
                separate_worlds=True,
                iterations=cfg.solver_iterations,
                ls_iterations=cfg.ls_iterations,
                njmax=cfg.njmax,
                nconmax=cfg.nconmax,
            )
        self.contacts = newton.Contacts(self.solver.get_max_contact_count(), 0, device=sim.device)
        kinds = {newton.solvers.SolverBase.ObservableKind.CONTACT_F}
        self.observables = self.solver.observables(kinds, contacts=self.contacts)
        self._slots = shape_slots(sim.model, sim.layout)
        self._graph = None
        self._use_graph = cfg.cuda_graph and sim.device.is_cuda
        self._reset_mask = wp.zeros(sim.num_envs + 1, dtype=wp.bool)  # per world, + Newton's global world
        self._trunk_mass = float(self.solver.mjw_model.body_mass.numpy()[0, 1])

    def _decimation_loop(self, actuate: bool = True) -> None:
        sim = self.sim
        for _ in range(sim.cfg.decimation):
            if actuate:
                sim.actuate_substep()
            self.solver.step(sim.state, sim.state, sim.control, self.contacts, sim.cfg.dt, observables=self.observables)
        self.solver.update_contacts(self.contacts)
        sim.wheel_force.zero_()
        sim.body_collision.zero_()
        c = self.contacts
        wp.launch(
            accumulate_newton_contacts,
            dim=c.rigid_contact_max,
            inputs=[
                c.rigid_contact_count,
                c.rigid_contact_shape0,
                c.rigid_contact_shape1,
                self.observables.contact_f,
                self._slots,
            ],
            outputs=[sim.wheel_force, sim.body_collision],
            device=sim.device,
        )

    def step_substeps(self, actuate: bool) -> None:
        if not (self._use_graph and actuate):
            self._decimation_loop(actuate)
            return
        if self._graph is None:
            self._decimation_loop()  # warm-up: compiles kernels and allocates outside the capture
            with wp.ScopedCapture(device=self.sim.device) as cap:
                self._decimation_loop()
            self._graph = cap.graph
            return
        wp.capture_launch(self._graph)

    def reset_rows(self, env_ids: wp.array) -> None:
        # clear MuJoCo's warm start and applied forces: after a divergence (NaN) they would poison the next step
        # even from a clean state
        self._reset_mask.zero_()
        wp.launch(
            _mask_from_ids, dim=env_ids.shape[0], inputs=[env_ids], outputs=[self._reset_mask], device=self.sim.device
        )
        self.solver.reset(self.sim.state, self._reset_mask, flags=0)

    def set_dynamics(self, friction: np.ndarray, damping_ratio: np.ndarray, added_mass: np.ndarray) -> None:
        mm = self.solver.mjw_model
        fr = mm.geom_friction.numpy()
        fr[:, :, 0] = friction[:, None]
        mm.geom_friction.assign(fr)
        sr = mm.geom_solref.numpy()
        sr[:, :, 1] = damping_ratio[:, None]
        mm.geom_solref.assign(sr)
        bm = mm.body_mass.numpy()
        bm[:, 1] = self._trunk_mass + added_mass  # MuJoCo body 1 is the trunk (body 0 is the world)
        mm.body_mass.assign(bm)
