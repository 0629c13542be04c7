"""Benchmark (by hand): mesh convergence of the composite phantom's indentation force (issue 19).

Compares the force against depth of composite runs on meshes of different densities (each the
``composite-result.npz`` of ``indent-studio composite indent``, or a ``simulate --mesh composite*``
result): the force per depth on each, and each coarser mesh's relative gap to the finest, with
the nodes, Newton iterations and wall time of each run.

    .venv/bin/python benchmarks/probes/composite_mesh_convergence.py RESULT.npz RESULT.npz [...] \\
        [--json runs/composite/mesh-convergence.json]
"""

from __future__ import annotations

import argparse

import numpy as np

from indentation_studio.atomic_write import atomic_write_json, strict_json
from indentation_studio.forward.result import SimulationResult


def convergence(paths: list[str]) -> dict:
    runs = [SimulationResult.load(p) for p in paths]
    if any("composite" not in r.spec for r in runs):
        raise SystemExit("every result must be a composite phantom's")
    runs_paths = sorted(zip(runs, paths, strict=True), key=lambda rp: rp[0].solver["mesh"]["nodes"])
    finest, _ = runs_paths[-1]
    out = {"depth_mm": finest.depth.tolist(), "runs": []}
    for r, p in runs_paths:
        n = min(len(r.depth), len(finest.depth))
        f, ref = r.force[:n], finest.force[:n]
        gap = np.divide(f - ref, ref, out=np.zeros(n), where=ref != 0)
        out["runs"].append(
            {
                "result": p,
                "mesh": r.solver["mesh"],
                "radius_mm": r.spec["indenter"]["radius"],
                "force_mN": r.force.tolist(),
                "rel_gap_to_finest": gap.tolist(),
                "max_abs_gap_beyond_1mm": float(np.max(np.abs(gap[r.depth[:n] >= 1.0]), initial=0.0)),
                "newton_iterations": r.newton_iterations,
                "wall_s": r.wall_s,
            }
        )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", nargs="+")
    ap.add_argument("--json", default=None, help="also write the table here")
    a = ap.parse_args()
    out = convergence(a.results)
    print(f"{'depth':>6} " + " ".join(f"{r['mesh']['nodes']:>12d}" for r in out["runs"]))
    for k, d in enumerate(out["depth_mm"]):
        cells = []
        for r in out["runs"]:
            f = r["force_mN"][k] if k < len(r["force_mN"]) else float("nan")
            g = r["rel_gap_to_finest"][k] if k < len(r["rel_gap_to_finest"]) else float("nan")
            cells.append(f"{f:8.1f}{100 * g:+5.1f}%")
        print(f"{d:6.2f} " + " ".join(cells))
    for r in out["runs"]:
        print(
            f"{r['mesh']['source']}: {r['mesh']['nodes']} nodes, max |gap| beyond 1 mm "
            f"{100 * r['max_abs_gap_beyond_1mm']:.1f} %, {r['newton_iterations']} Newton iterations, "
            f"{r['wall_s']:.0f} s"
        )
    if a.json:
        atomic_write_json(a.json, out)
    else:
        print(strict_json({k: v for k, v in out.items() if k != "runs"}))


if __name__ == "__main__":
    main()
