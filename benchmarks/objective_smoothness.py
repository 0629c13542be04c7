"""Is the objective smooth in the parameters on the FE model? (issue 46, deliverable 3)

The fit issue saw F jump between 0.0325 and 0.0418 at c5 = 298.3556 and 298.3555 kPa in an FE
stage on ``default`` (the node-wise stick). This evaluates the objective (eq. 4, 5, the fit's
reading) of an experiment on the FE model at theta0 + k h e_c5, k = -K..K, and prints F, the
largest relative change between neighbours and, per point, the number of nodes attached to the
indenter at each step (the node-wise contact's state), so a jump can be traced to its cause.

    .venv/bin/python benchmarks/objective_smoothness.py --experiment examples/synthetic-12-250 \\
        --c1 12 --c5 298.3555 --h 1e-4 --mesh default --contact node
    .venv/bin/python benchmarks/objective_smoothness.py --experiment examples/synthetic-12-250 \\
        --c1 12 --c5 298.3555 --h 1e-4 --mesh contact-L1
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from indentation_studio.design.objective import PAPER_WEIGHTS
from indentation_studio.forward.predictor import FESolverPredictor, Prediction
from indentation_studio.forward.spec import Contact, Indenter, MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.experiment.data import load_experiment
from indentation_studio.inference.experiment.processing import experiment_objective


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--experiment", required=True)
    parser.add_argument("--c1", type=float, required=True)
    parser.add_argument("--c5", type=float, required=True)
    parser.add_argument("--h", type=float, default=1e-4, help="step in c5, kPa")
    parser.add_argument("--k", type=int, default=3, help="points each side")
    parser.add_argument("--mesh", default="contact-L1")
    parser.add_argument("--contact", default=None, help="node or surface (default the mesh's own)")
    parser.add_argument("--friction", type=float, default=None)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()

    exp = load_experiment(args.experiment)
    contact = Contact(integration=args.contact) if args.contact else Contact()
    spec = ModelSpec(
        mesh=MeshChoice(args.mesh),
        indenter=Indenter(exp.radius),
        protocol=Protocol(step_size=exp.step_size, steps=exp.steps),
        contact=contact,
    ).with_friction(args.friction)
    fe = FESolverPredictor(spec)
    rows, objective = [], None
    for k in range(-args.k, args.k + 1):
        theta = np.array([args.c1, args.c5 + k * args.h])
        t0 = time.perf_counter()
        result = fe.simulate(theta)
        wall = time.perf_counter() - t0
        pred = Prediction.from_results([result], fe.parameters)
        if objective is None:
            objective, _ = experiment_objective(exp, pred.top_xyz)
        F = float(objective.value(pred, PAPER_WEIGHTS)[0])
        attached = np.asarray(result.convergence.get("attached_nodes", [])).tolist()
        rows.append({"c5": float(theta[1]), "F": F, "wall_s": wall, "attached_nodes": attached})
        print(f"c5 = {theta[1]:.6f}  F = {F:.6g}  ({wall:.1f} s)", flush=True)
    F = np.array([r["F"] for r in rows])
    jump = float(np.max(np.abs(np.diff(F)) / F[:-1]))
    changed = [
        (rows[i]["c5"], rows[i + 1]["c5"])
        for i in range(len(rows) - 1)
        if rows[i]["attached_nodes"] != rows[i + 1]["attached_nodes"]
    ]
    summary = {
        "spec": {"mesh": args.mesh, "contact": spec.contact.describe(), "friction": args.friction},
        "largest_relative_change": jump,
        "contact_state_changes": changed,
        "rows": rows,
    }
    print(f"largest relative change of F between neighbours: {100 * jump:.4g} %")
    print(f"contact state (attached nodes per step) changes between: {changed or 'none'}")
    if args.json:
        print(json.dumps(summary))


if __name__ == "__main__":
    main()
