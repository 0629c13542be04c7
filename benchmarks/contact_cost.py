"""Benchmark (by hand, not in the test suite): what each contact costs, with and without
sensitivities, on one thread, and what the solver spends it on.

Runs the paper's protocol (or its first ``--steps`` steps) at {10, 350} kPa on a mesh preset or a
verification family's level, with the node-wise stick and the surface-integrated contact, and
prints wall time, Newton iterations, contact passes, factorisations, Krylov iterations and the
split between assembly and linear solves (``EmbeddedSolver.stats``).

    .venv/bin/python benchmarks/contact_cost.py --mesh fine --steps 8
    .venv/bin/python benchmarks/contact_cost.py --family 8x8:1.2:1.5 --level 2 --radius 8
"""

from __future__ import annotations

import argparse
import json
import time

from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Contact, Indenter, MeshChoice, ModelSpec, Protocol
from indentation_studio.studio.verification_cli import parse_family


def one_run(spec: ModelSpec, mesh, sensitivities: bool) -> dict:
    solver = EmbeddedSolver(spec, mesh)
    t = time.perf_counter()
    r = solver.run(sensitivities=sensitivities, threads=1)
    st = solver.stats
    return {
        "contact": spec.contact.describe(),
        "sensitivities": sensitivities,
        "nodes": solver.mesh.n_nodes,
        "wall_s": round(time.perf_counter() - t, 2),
        "force_last_mN": round(float(r.force[-1]), 2),
        "newton_iterations": int(r.convergence["newton_iterations"].sum()),
        "contact_passes": int(r.convergence["contact_passes"].sum()),
        "factorizations": int(st["factorizations"]),
        "krylov_iterations": int(st["krylov_iterations"]),
        "assembly_s": round(st["assembly_s"], 2),
        "linear_s": round(st["solve_s"], 2),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mesh", default="default", help="a mesh preset (unless --family)")
    ap.add_argument("--family", default=None, help="a verification family, CXYxCZ:H0:RATIO[:coreMM]")
    ap.add_argument("--level", type=int, default=2)
    ap.add_argument("--radius", type=float, default=4.77)
    ap.add_argument("--steps", type=int, default=28)
    ap.add_argument("--contacts", default="node,surface", help="node, surface (2x2), surface3 (3x3)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    mesh = parse_family(args.family).mesh(args.level) if args.family else None
    rows = []
    for name in args.contacts.split(","):
        contact = (
            Contact()
            if name == "node"
            else Contact(integration="surface", order=int(name[len("surface") :] or 2))
        )
        spec = ModelSpec(
            indenter=Indenter(args.radius),
            protocol=Protocol(steps=args.steps),
            mesh=MeshChoice(args.mesh),
            contact=contact,
        )
        for sens in (False, True):
            rows.append(one_run(spec, mesh, sens))
            if not args.json:
                print(rows[-1], flush=True)
    if args.json:
        print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
