"""Benchmark (by hand, not in the test suite): the paper protocol on the embedded solver.

R = 4.77 mm, 28 x 0.5 mm, c1 = 10 kPa, c5 = 350 kPa, on FEBio's baseline mesh
(../shared/febio/baseline/baseline.feb) and on the ``default`` preset; N runs each, every run in
a fresh process so that peak memory is that run's. Prints median wall time, peak memory, Newton
iterations per step and the split between assembly and linear solves.

    .venv/bin/python benchmarks/forward_speed.py [--runs 5] [--substeps 1] [--json]
    .venv/bin/python benchmarks/forward_speed.py --meshes default --friction stick,3,1,0.3   # issue 17's cost
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

FEB = Path(__file__).resolve().parents[2] / "shared" / "febio" / "baseline" / "baseline.feb"


def one_run(mesh: str, substeps: int, friction: str = "stick") -> dict:
    from indentation_studio.forward.solver import EmbeddedSolver
    from indentation_studio.forward.spec import MeshChoice, ModelSpec, SolverOptions

    choice = MeshChoice(feb_file=str(FEB)) if mesh == "febio" else MeshChoice(mesh)
    spec = ModelSpec(mesh=choice, solver=SolverOptions(substeps=substeps))
    spec = spec.with_friction(None if friction == "stick" else float(friction))
    t0 = time.perf_counter()
    solver = EmbeddedSolver(spec)
    setup = time.perf_counter() - t0
    r = solver.run()
    its = r.convergence["newton_iterations"][1:]
    return {
        "mesh": mesh,
        "friction": friction,
        "nodes": solver.mesh.n_nodes,
        "wall_s": r.wall_s,
        "setup_s": setup,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "newton_per_step_mean": float(its.mean()),
        "newton_per_step_max": int(its.max()),
        "increments": int(r.convergence["increments"].sum()),
        "cutbacks": int(r.convergence["cutbacks"].sum()),
        "assembly_s": solver.stats["assembly_s"],
        "linear_s": solver.stats["solve_s"],
        "assemblies": solver.stats["assemblies"],
        "factorizations": solver.stats["factorizations"],
        "linear_solver": solver.linear_solver,
        "force_14mm_mN": float(r.force[-1]),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument(
        "--substeps", type=int, default=1, help="solver increments per step (the default of SolverOptions)"
    )
    ap.add_argument("--meshes", default="febio,default")
    ap.add_argument("--friction", default="stick", help="contacts: 'stick' or Coulomb mu, comma-separated")
    ap.add_argument("--single", help=argparse.SUPPRESS)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    if args.single:
        print(json.dumps(one_run(args.single, args.substeps, args.friction)))
        return
    summary = []
    for mesh, friction in ((m, f) for m in args.meshes.split(",") for f in args.friction.split(",")):
        runs = []
        for k in range(args.runs):
            out = subprocess.run(
                [
                    sys.executable,
                    __file__,
                    "--single",
                    mesh,
                    "--substeps",
                    str(args.substeps),
                    "--friction",
                    friction,
                ],
                capture_output=True,
                text=True,
                check=True,
            )
            runs.append(json.loads(out.stdout.strip().splitlines()[-1]))
            print(f"{mesh} {friction} run {k + 1}/{args.runs}: {runs[-1]['wall_s']:.2f} s", file=sys.stderr)
        med = {
            key: statistics.median(r[key] for r in runs)
            for key in ("wall_s", "peak_rss_mb", "newton_per_step_mean", "assembly_s", "linear_s")
        }
        summary.append(
            {**runs[0], **{f"median_{k}": v for k, v in med.items()}, "walls": [r["wall_s"] for r in runs]}
        )
    if args.json:
        print(json.dumps(summary, indent=1))
        return
    for s in summary:
        print(
            f"{s['mesh']:8s} {s['friction']:>5s} nodes {s['nodes']:6d}  median wall {s['median_wall_s']:.2f} s "
            f"(runs {', '.join(f'{w:.2f}' for w in s['walls'])})  peak RSS {s['median_peak_rss_mb']:.0f} MB  "
            f"Newton/step {s['median_newton_per_step_mean']:.1f} (max {s['newton_per_step_max']})  "
            f"assembly {s['median_assembly_s']:.2f} s  linear {s['median_linear_s']:.2f} s  "
            f"({s['assemblies']} assemblies, {s['factorizations']} factorisations, {s['linear_solver']})  "
            f"increments {s['increments']}, cutbacks {s['cutbacks']}"
        )


if __name__ == "__main__":
    main()
