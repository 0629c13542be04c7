"""Benchmark (by hand, not in the test suite): what each contact costs, with and without
sensitivities, on one thread, and what the solver spends it on.

Runs the paper's protocol (or its first ``--steps`` steps) at {10, 350} kPa (or ``--c1``,
``--c5``) on a mesh preset or a verification family's level, with the node-wise stick and the
surface-integrated contact (each surface contact at every ``--penalties`` value), and prints wall
time, Newton iterations, contact passes, factorisations, Krylov iterations and the split between
assembly and linear solves (``EmbeddedSolver.stats``). ``--save DIR`` keeps each run (for
``benchmarks/probes/fitted_parameters.py``: what the penalty does to the fitted parameters);
``--no-sensitivities`` runs each once, without.

    .venv/bin/python benchmarks/contact_cost.py --mesh fine --steps 8
    .venv/bin/python benchmarks/contact_cost.py --family 8x8:1.2:1.5 --level 2 --radius 8
    .venv/bin/python benchmarks/contact_cost.py --family 8x8:1.2:1.5:core8 --level 1 --c1 3 --c5 540 \
        --contacts surface --penalties 1e4,1e5,1e6 --no-sensitivities --save runs/penalty
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from indentation_studio.forward.solver import EmbeddedSolver, SimulationError
from indentation_studio.forward.spec import Contact, Indenter, Material, MeshChoice, ModelSpec, Protocol
from indentation_studio.studio.verification_cli import parse_family


def one_run(spec: ModelSpec, mesh, sensitivities: bool, save: Path | None = None) -> dict:
    solver = EmbeddedSolver(spec, mesh)
    t = time.perf_counter()
    try:
        r = solver.run(sensitivities=sensitivities, threads=1)
    except SimulationError as exc:
        return {"contact": spec.contact.describe(), "sensitivities": sensitivities, "error": str(exc)}
    st = solver.stats
    c = spec.contact
    name = "node" if c.integration == "node" else f"surface{c.order}-penalty{c.penalty:g}"
    if save is not None:
        r.save(save / f"{name}{'-sens' if sensitivities else ''}.npz")
    return {
        "contact": spec.contact.describe(),
        "penalty": None if c.integration == "node" else c.penalty,
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
    ap.add_argument("--c1", type=float, default=10.0, help="kPa")
    ap.add_argument("--c5", type=float, default=350.0, help="kPa")
    ap.add_argument("--penalties", default="1e5", help="the surface contact's penalties, kPa/mm")
    ap.add_argument("--no-sensitivities", action="store_true", help="each run once, without")
    ap.add_argument("--save", type=Path, default=None, help="a folder to keep every run in")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    mesh = parse_family(args.family).mesh(args.level) if args.family else None
    if args.save is not None:
        args.save.mkdir(parents=True, exist_ok=True)
    contacts = []
    for name in args.contacts.split(","):
        if name == "node":
            contacts.append(Contact())
            continue
        order = int(name[len("surface") :] or 2)
        contacts += [
            Contact(integration="surface", order=order, penalty=float(p)) for p in args.penalties.split(",")
        ]
    rows = []
    for contact in contacts:
        spec = ModelSpec(
            indenter=Indenter(args.radius),
            protocol=Protocol(steps=args.steps),
            material=Material(c1=args.c1, c5=args.c5),
            mesh=MeshChoice(args.mesh),
            contact=contact,
        )
        for sens in (False,) if args.no_sensitivities else (False, True):
            rows.append(one_run(spec, mesh, sens, args.save))
            if not args.json:
                print(rows[-1], flush=True)
    if args.json:
        print(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
