"""Benchmark (by hand): how far the model's mesh moves fitted parameters, to first order.

Data: a finer mesh's noise-free response at theta (a saved result file, e.g. the ``reference``
of ``indent-studio mesh-study --out-dir``), interpolated at each model mesh's top nodes. Model:
candidate meshes solved at the same theta with exact sensitivities. The Gauss-Newton step of the
objective (eq. 4, 5 with weights eta, paper reading) from theta is then the parameter bias that
discretisation error alone causes in a fit (to first order), printed beside the eq. 6 half-width
for a given s, i.e. what a fit on that mesh can resolve before its own mesh misleads it. The step
is ``inference.budgets.mesh_check.mesh_check`` with the data mesh as the finer one.

    .venv/bin/python benchmarks/probes/mesh_bias.py DATA.npz [--meshes default,fine] [--eta 0.45,0.35,0.2,0]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from indentation_studio.design.certainty import bounds_pct
from indentation_studio.design.objective import Objective
from indentation_studio.forward.mesh import MESH_PRESETS, GradedAxis, MeshPreset, structured_block
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import ModelSpec
from indentation_studio.inference.budgets.mesh_check import mesh_check, prediction_at_nodes

sys.path.insert(0, str(Path(__file__).parent))
from mesh_candidates import CANDIDATES


def mesh_preset(name: str) -> MeshPreset:
    if name in MESH_PRESETS:
        return MESH_PRESETS[name]
    if name in CANDIDATES:
        return CANDIDATES[name]
    h, core, gxy, gz = name.split(",")  # "h0,core,graded_xy,graded_z"
    return MeshPreset(GradedAxis(float(h), int(core), int(gxy)), GradedAxis(float(h), int(core), int(gz)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path)
    ap.add_argument("--meshes", default="default,fine")
    ap.add_argument("--eta", default="0.45,0.35,0.2,0")
    ap.add_argument("--s", type=float, default=0.05, help="s of eq. 6 for the printed bounds")
    args = ap.parse_args()
    eta = np.array([float(v) for v in args.eta.split(",")])
    data = SimulationResult.load(args.data)
    spec = ModelSpec.from_dict(data.spec)
    theta = np.array([spec.material.c1, spec.material.c5])
    print(
        f"data: {args.data} ({data.solver['mesh']['nodes']} nodes), theta = {theta.tolist()} kPa, eta = {eta}"
    )
    for name in args.meshes.split(","):
        mesh = structured_block(spec.geometry, mesh_preset(name), name)
        r = EmbeddedSolver(spec, mesh=mesh).run(sensitivities=True)
        # the objective's target is the data at this mesh's nodes: the mesh check's shift toward
        # the data mesh is minus the bias a fit on this mesh has
        objective = Objective.from_prediction(
            prediction_at_nodes(data, r.top_xyz), radius=spec.indenter.radius
        )
        check = mesh_check(objective, eta, r, data)
        bias = -check.shift_pct
        half = bounds_pct(check.hessian, args.s)
        print(
            f"{name:16s} nodes {mesh.n_nodes:6d}  bias c1 {bias[0]:+.2f} %  c5 {bias[1]:+.2f} %  "
            f"(eq. 6 half-width at s = {args.s}: c1 {half[0]:.2f} %, c5 {half[1]:.2f} %)  wall {r.wall_s:.1f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
