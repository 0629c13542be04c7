"""The most distorted elements of a simulation where it stops: runs a spec for ``--steps`` steps
keeping every node's displacement, then ranks the elements at the last step by their smallest
Gauss-point det F (J) and prints the worst: where they sit (reference centroid), which material
set, J, the element's dilatation J_bar = v_e / V_e (the one J the three-field element's volumetric
energy sees), the largest and smallest principal stretch, and how far the centroid is from the sphere.

    .venv/bin/python benchmarks/probes/worst_element.py --mesh composite-medium --contact surface --steps 18
"""

from __future__ import annotations

import argparse

import numpy as np

from indentation_studio.forward.hex8_mean_dilatation import ReferenceGeometry
from indentation_studio.forward.solver import EmbeddedSolver
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
    args = parser.parse_args()
    composite = args.mesh.startswith("composite")
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
    result = solver.run(
        full_field=True, progress=lambda k, n, f: print(f"step {k}/{n}: {f:.1f} mN", flush=True)
    )
    mesh = solver.mesh
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


if __name__ == "__main__":
    main()
