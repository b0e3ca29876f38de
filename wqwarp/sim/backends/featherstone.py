"""``featherstone``: Newton ``SolverFeatherstone`` with spring-damper ground contacts, the physics of the
differentiable path (``wqwarp.diff.rollout``, which builds it with :func:`penalty_physics` from here) for
forward-only use; slow, for few robots. Contact summaries from the penalty contacts
(``kernels.contacts.accumulate_penalty_contacts``)."""

from __future__ import annotations

import warnings

import warp as wp

from wqwarp.kernels.contacts import accumulate_penalty_contacts
from wqwarp.sim.backends.base import PhysicsBackend
from wqwarp.sim.model import shape_slots


def penalty_physics(model, cfg):
    """Set the spring-damper contact of ``cfg`` (``SimConfig.contact_*``) on every shape of ``model`` and build
    ``(SolverFeatherstone, CollisionPipeline, Contacts)`` for it."""
    import newton

    for name, value in (("ke", cfg.contact_ke), ("kd", cfg.contact_kd), ("kf", cfg.contact_kf), ("mu", cfg.contact_mu)):
        getattr(model, f"shape_material_{name}").fill_(float(value))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        solver = newton.solvers.SolverFeatherstone(model)
        pipeline = newton.CollisionPipeline(model, requires_grad=False)
    return solver, pipeline, pipeline.contacts()


class FeatherstoneBackend(PhysicsBackend):
    """Featherstone stepping Newton's state in place; no dynamics randomisation."""

    name = "featherstone"

    def __init__(self, sim) -> None:
        super().__init__(sim)
        self.solver, self._pipeline, self.contacts = penalty_physics(sim.model, sim.cfg)
        self._slots = shape_slots(sim.model, sim.layout)

    def step_substeps(self, actuate: bool) -> None:
        sim = self.sim
        st = sim.state
        for _ in range(sim.cfg.decimation):
            if actuate:
                sim.actuate_substep()
            self._pipeline.collide(st, self.contacts)
            st.clear_forces()
            # in place (Featherstone supports it; bit-identical to stepping into a second state and copying back),
            # so the views on sim.state stay valid
            self.solver.step(st, st, sim.control, self.contacts, sim.cfg.dt)
        c = self.contacts
        sim.wheel_force.zero_()
        sim.body_collision.zero_()
        wp.launch(
            accumulate_penalty_contacts,
            dim=c.rigid_contact_max,
            inputs=[
                c.rigid_contact_count,
                c.rigid_contact_shape0,
                c.rigid_contact_shape1,
                c.rigid_contact_point0,
                c.rigid_contact_point1,
                c.rigid_contact_normal,
                c.rigid_contact_margin0,
                c.rigid_contact_margin1,
                st.body_q,
                sim.model.shape_body,
                self._slots,
                float(sim.cfg.contact_ke),
            ],
            outputs=[sim.wheel_force, sim.body_collision],
            device=sim.device,
        )
