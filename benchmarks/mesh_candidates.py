"""Choose the ``default`` mesh preset (by hand): run candidate gradings of the quarter block and
report eq. 1a / 1b against a saved ``reference`` result (from ``indent-studio mesh-study
--out-dir DIR``), with node counts and wall times. ``default`` is the smallest candidate with
E_f < 1 % and E_u < 1 % (the paper's criterion), E_f taken without eq. 1a's 1/N_s factor.

    .venv/bin/python benchmarks/mesh_candidates.py DIR/reference.npz
"""

from __future__ import annotations

import sys

from indentation_studio.forward.mesh import GradedAxis, MeshPreset, structured_block
from indentation_studio.forward.mesh_study import mesh_errors
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import ModelSpec

CANDIDATES = {
    "h0.6-g10x11": MeshPreset(GradedAxis(0.6, 0, 10), GradedAxis(0.6, 0, 11)),  # FEBio's baseline mesh
    "h0.5-g12x13": MeshPreset(GradedAxis(0.5, 0, 12), GradedAxis(0.5, 0, 13)),
    "h0.4-g14x15": MeshPreset(GradedAxis(0.4, 0, 14), GradedAxis(0.4, 0, 15)),
    "h0.5-c4-g10x12": MeshPreset(GradedAxis(0.5, 4, 10), GradedAxis(0.5, 4, 12)),
    "h0.4-c6-g10x12": MeshPreset(GradedAxis(0.4, 6, 10), GradedAxis(0.4, 6, 12)),
    "h0.3-c8-g11x13": MeshPreset(GradedAxis(0.3, 8, 11), GradedAxis(0.3, 8, 13)),
}


def main() -> None:
    ref = SimulationResult.load(sys.argv[1])
    spec = ModelSpec.from_dict(ref.spec)
    names = sys.argv[2].split(",") if len(sys.argv) > 2 else list(CANDIDATES)
    for name in names:
        mesh = structured_block(spec.geometry, CANDIDATES[name], name)
        r = EmbeddedSolver(spec, mesh=mesh).run()
        e = mesh_errors(r, ref)
        print(
            f"{name:16s} nodes {mesh.n_nodes:6d}  E_f(1a) {e.E_f_pct:.3f} %  ||dF||/||F|| {e.E_f_rel_pct:.2f} %  "
            f"E_u(1b) {e.E_u_pct:.2f} %  wall {r.wall_s:.1f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
