"""The most distorted elements of a simulation where it stops: runs a spec for ``--steps`` steps
keeping every node's displacement, then ranks the elements at the last step by their smallest
Gauss-point det F (J) and prints the worst: where they sit (reference centroid), which material
set, J, the element's dilatation J_bar = v_e / V_e (the one J the three-field element's volumetric
energy sees), the largest and smallest principal stretch, and how far the centroid is from the sphere.

    .venv/bin/python benchmarks/probes/worst_element.py --mesh composite-medium --contact surface --steps 18

A run that stops is analysed at its last finished step (``SimulationError.partial``).
``--z-cells-finer K`` divides a composite mesh's first cell size in z by K (its growth and the
cells across the fibers kept): about K times the cells in the matrix between the top face and the top
fibers, the mesh's x and y unchanged.

``--eigen`` adds, at each step, the smallest eigenvalues of the body's tangent (the elements
only) with the supports and the top nodes touching the sphere held (the stick), relative to its
largest diagonal entry, and where the lowest mode's displacement is largest. It leaves the
contact's own stiffness out (a top node counts as held when it lies within 1 um of the sphere): on
the composite at R = 4.77 mm it turns indefinite at 4.5 mm both on `composite-medium`, which goes on
to 9 mm, and with finer cells in z, which stops at 5.5 mm, so by itself it does not tell where a
run stops (docs/validation/composite.md).
"""

from __future__ import annotations

import argparse

import numpy as np
import pypardiso
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from indentation_studio.forward import composite_mesh
from indentation_studio.forward.hex8_mean_dilatation import ReferenceGeometry
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError
from indentation_studio.forward.spec import (
    Contact,
    Indenter,
    MeshChoice,
    ModelSpec,
    Protocol,
    SolverOptions,
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mesh", default="composite-medium")
    parser.add_argument("--contact", default="node", choices=("node", "surface"))
    parser.add_argument("--order", type=int, default=2)
    parser.add_argument("--radius", type=float, default=4.77)
    parser.add_argument("--steps", type=int, default=18, help="steps of 0.5 mm to run")
    parser.add_argument("--worst", type=int, default=5)
    parser.add_argument("--fiber-stretch", default="gauss", choices=("gauss", "mean"))
    parser.add_argument("--z-cells-finer", type=float, default=1.0)
    parser.add_argument("--eigen", action="store_true")
    parser.add_argument("--keep", help="save the run (its full field) to this .npz")
    parser.add_argument("--run-from", help="a run saved with --keep, instead of running")
    args = parser.parse_args()
    composite = args.mesh.startswith("composite")
    if args.z_cells_finer != 1.0:
        axis = composite_mesh.conforming_axis

        def finer_in_z(length, fibers, fiber_cells, h0, growth, from_end=False, core=0.0):
            h0 = h0 / args.z_cells_finer if from_end else h0
            return axis(length, fibers, fiber_cells, h0, growth, from_end=from_end, core=core)

        composite_mesh.conforming_axis = finer_in_z
    fields = {
        "indenter": Indenter(args.radius),
        "protocol": Protocol(step_size=0.5, steps=args.steps),
        "contact": Contact(integration=args.contact, order=args.order),
        "solver": SolverOptions(fiber_stretch=args.fiber_stretch),
    }
    spec = (
        ModelSpec.composite_phantom(args.mesh, **fields)
        if composite
        else ModelSpec(mesh=MeshChoice(args.mesh), **fields)
    )
    solver = EmbeddedSolver(spec)
    print(f"{solver.mesh.n_nodes} nodes, {solver.mesh.n_elements} elements", flush=True)
    result = SimulationResult.load(args.run_from) if args.run_from else run(solver)
    if result is None:
        return
    if args.keep:
        result.save(args.keep)
    mesh = solver.mesh
    if args.eigen:
        lowest_modes(solver, spec, result)
    u = result.full_displacement[-1]
    geo = ReferenceGeometry.of(mesh)
    F = np.eye(3) + np.einsum("eai,egaJ->egiJ", u[mesh.elements], geo.dNdX)
    J = np.linalg.det(F)
    J_bar = (J * geo.wdetJ0).sum(axis=1) / geo.wdetJ0.sum(axis=1)  # v_e / V_e
    stretch = np.sqrt(np.linalg.eigvalsh(np.swapaxes(F, -1, -2) @ F))  # (ne, g, 3) ascending
    worst = np.argsort(J.min(axis=1))[: args.worst]
    depth = result.depth[-1]
    centre = np.array([0.0, 0.0, spec.geometry.height + spec.indenter.radius - depth])
    names = mesh.material_names or ("all",)
    print(f"{args.mesh}, {args.contact} contact, depth {depth:g} mm, force {result.force[-1]:.1f} mN")
    print(
        "element | set | reference centroid mm | smallest J | J_bar | stretches min, max | centroid's gap to the sphere mm"
    )
    for e in worst:
        x0 = mesh.nodes[mesh.elements[e]].mean(axis=0)
        x = x0 + u[mesh.elements[e]].mean(axis=0)
        material = names[mesh.element_material[e]] if mesh.element_material is not None else names[0]
        gap = np.linalg.norm(x - centre) - spec.indenter.radius
        print(
            f"{e} | {material} | ({x0[0]:.2f}, {x0[1]:.2f}, {x0[2]:.2f}) | {J[e].min():.3f} | {J_bar[e]:.3f} | "
            f"{stretch[e, :, 0].min():.3f}, {stretch[e, :, 2].max():.3f} | {gap:+.2f}"
        )


def run(solver: EmbeddedSolver) -> SimulationResult | None:
    """The run, or the steps it finished before it stopped (None: not one)."""
    try:
        return solver.run(
            full_field=True, progress=lambda k, n, f: print(f"step {k}/{n}: {f:.1f} mN", flush=True)
        )
    except SimulationError as exc:
        print(f"stopped: {exc}", flush=True)
        return exc.partial


def lowest_modes(solver: EmbeddedSolver, spec: ModelSpec, result) -> None:
    """The body's tangent's smallest eigenvalues at each step, the stick's nodes and supports held."""
    mesh, top = solver.mesh, solver.mesh.top
    print("depth mm | smallest eigenvalues / largest diagonal | lowest mode largest at (reference, mm)")
    for k, depth in enumerate(result.depth):
        u = result.full_displacement[k]
        st = solver._mat.element_state(solver.geometry, u[mesh.elements], tangent=True)
        K = solver.pattern.matrix(st.stiffness)
        centre = np.array([0.0, 0.0, spec.geometry.height + spec.indenter.radius - depth])
        x = mesh.nodes[top] + u[top]
        touching = top[np.linalg.norm(x - centre, axis=1) <= spec.indenter.radius + 1e-3]
        held = solver.bc_fixed.copy()
        held[touching] = True
        free = np.flatnonzero(~held.ravel())
        Kf = K[free][:, free].tocsc()
        scale = float(Kf.diagonal().max())
        sigma = -1e-6 * scale
        shifted = (Kf - sigma * sp.identity(Kf.shape[0], format="csc")).tocsr()
        inverse = spla.LinearOperator(
            Kf.shape, matvec=lambda b, A=shifted: pypardiso.spsolve(A, b), dtype=float
        )
        vals, vecs = spla.eigsh(Kf, k=3, sigma=sigma, which="LM", OPinv=inverse)
        order = np.argsort(vals)
        mode = np.zeros(solver.n_dofs)
        mode[free] = vecs[:, order[0]]
        node = int(np.argmax(np.linalg.norm(mode.reshape(-1, 3), axis=1)))
        print(
            f"{depth:g} | {', '.join(f'{v / scale:.2e}' for v in vals[order])} | "
            f"node {node} ({mesh.nodes[node][0]:.2f}, {mesh.nodes[node][1]:.2f}, {mesh.nodes[node][2]:.2f})",
            flush=True,
        )


if __name__ == "__main__":
    main()
