"""Choose the ``default`` mesh preset (by hand): run candidate gradings of the quarter block and
report eq. 1a / 1b against a saved ``reference`` result (from ``indent-studio mesh-study
--out-dir DIR`` or ``indent-studio simulate --mesh reference --out DIR/reference.npz``), with
node counts and wall times. ``default`` is the smallest candidate with E_f < 1 % and E_u < 1 %
(the paper's criterion), E_f taken without eq. 1a's 1/N_s factor.

    .venv/bin/python benchmarks/probes/mesh_candidates.py DIR/reference.npz [NAME,NAME,...] [--save DIR]

Each candidate is written as a grading ``h0-core-graded`` per axis: ``GradedAxis(h0, n_core,
n_graded)`` in x and y, then in z.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from indentation_studio.forward.convergence.mesh_study import mesh_errors
from indentation_studio.forward.mesh import MESH_PRESETS, GradedAxis, MeshPreset, structured_block
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import ModelSpec

CANDIDATES = {
    "h0.6-g10x11": MeshPreset(GradedAxis(0.6, 0, 10), GradedAxis(0.6, 0, 11)),  # FEBio's baseline mesh
    "h0.6-g12x11": MeshPreset(GradedAxis(0.6, 0, 12), GradedAxis(0.6, 0, 11)),
    "h0.6-g14x12": MeshPreset(GradedAxis(0.6, 0, 14), GradedAxis(0.6, 0, 12)),
    "h0.6-c2-g14x13": MeshPreset(GradedAxis(0.6, 2, 14), GradedAxis(0.6, 2, 13)),
    "h0.5-g12x13": MeshPreset(GradedAxis(0.5, 0, 12), GradedAxis(0.5, 0, 13)),
    "h0.5-c4-g14x14": MeshPreset(GradedAxis(0.5, 4, 14), GradedAxis(0.5, 4, 14)),
    "h0.4-g16x16": MeshPreset(GradedAxis(0.4, 0, 16), GradedAxis(0.4, 0, 16)),
    "h0.4-c6-g16x16": MeshPreset(GradedAxis(0.4, 6, 16), GradedAxis(0.4, 6, 16)),
} | {f"preset-{k}": v for k, v in MESH_PRESETS.items() if k != "reference"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("reference", type=Path)
    ap.add_argument("names", nargs="?", default=",".join(CANDIDATES))
    ap.add_argument("--save", type=Path, help="keep each candidate's result file here (and reuse it)")
    args = ap.parse_args()
    ref = SimulationResult.load(args.reference)
    spec = ModelSpec.from_dict(ref.spec)
    for name in args.names.split(","):
        mesh = structured_block(spec.geometry, CANDIDATES[name], name)
        saved = args.save / f"{name}.npz" if args.save else None
        if saved is not None and saved.exists():
            r = SimulationResult.load(saved)
        else:
            r = EmbeddedSolver(spec, mesh=mesh).run()
            if saved is not None:
                saved.parent.mkdir(parents=True, exist_ok=True)
                r.save(saved)
        e = mesh_errors(r, ref)
        print(
            f"{name:18s} nodes {mesh.n_nodes:6d}  E_f(1a) {e.E_f_pct:.3f} %  ||dF||/||F|| {e.E_f_rel_pct:.2f} %  "
            f"E_u(1b) contact {e.E_u_contact_pct:.2f} % ({e.contact_nodes} nodes), whole top {e.E_u_pct:.2f} %  "
            f"wall {r.wall_s:.1f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
