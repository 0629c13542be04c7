"""The embedded solver, warm: the paper protocol on ``default`` and a contact-L1 run with friction."""

from __future__ import annotations

from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec, Protocol

#: R = 4.77 mm, 28 x 0.5 mm: the paper's protocol.
PAPER = Protocol(step_size=0.5, steps=28)


def paper_spec(mesh: str = "default") -> ModelSpec:
    """The paper protocol at {10, 350} kPa on a mesh preset, the node-wise stick."""
    return ModelSpec(mesh=MeshChoice(mesh), indenter=Indenter(4.77), protocol=PAPER)


def contact_l1_spec() -> ModelSpec:
    """The FE confirmation of the shipped example's fit: contact-L1, {11.96, 245} kPa, mu = 1.58."""
    spec = ModelSpec(mesh=MeshChoice("contact-L1"), indenter=Indenter(4.77), protocol=PAPER)
    return spec.with_material(c1=11.96, c5=245.0).with_friction(1.58)


class PaperProtocol:
    """``forward_speed.py --meshes default``: one warm run on one solver."""

    number = 1
    repeat = (1, 5, 120.0)
    warmup_time = 0
    timeout = 1800

    def setup(self):
        self.solver = EmbeddedSolver(paper_spec())
        self.solver.run()  # numba's kernels compiled, the mesh built

    def time_paper_default(self):
        self.solver.run()

    def track_newton_iterations(self):
        return int(self.solver.run().newton_iterations)

    track_newton_iterations.unit = "iterations"


class ContactL1:
    """``thread_waits.py``'s run: contact-L1, Coulomb mu = 1.58, with sensitivities."""

    number = 1
    repeat = (1, 3, 300.0)
    warmup_time = 0
    timeout = 3600

    def setup(self):
        self.solver = EmbeddedSolver(contact_l1_spec())
        self.solver.run(sensitivities=True)

    def time_contact_l1_friction_sensitivities(self):
        self.solver.run(sensitivities=True)
