"""Benchmark (by hand): which test makes (c1, c5) least sensitive to the friction coefficient mu
(issue 17, design).

For each indenter radius and specimen mu, one embedded simulation with exact sensitivities
d/d(c1, c5, mu) at theta* = (10, 350) kPa; then for each test (maximum depth, DIC field of view,
objective weights) eq. 6's bounds of c1 and c5 (design s = 0.05) three ways
(:func:`design.study.friction_design_bounds`): mu known, mu identified with (c1, c5), and mu a
nuisance with a log-uniform prior on 0.1 .. 3; and mu's share of the nuisance bound,
sqrt(nuisance^2 - known^2). The test whose share is smallest is the one whose (c1, c5) depend
least on what mu is. Where nothing slips (mu large) the data hold nothing on mu and the
identified and nuisance bounds of (c1, c5) equal the known ones (the Schur complement).

    .venv/bin/python benchmarks/probes/friction_design_table.py [--mu 0.3,1] [--radius 4.77,8] \\
        [--mesh default] [--out runs/friction-design/table.json]
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from indentation_studio.atomic_write import atomic_write_json, strict_json
from indentation_studio.design.certainty import gauss_newton_term_hessians
from indentation_studio.design.objective import Objective
from indentation_studio.design.study import DesignStudy, friction_design_bounds
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec

WEIGHTS = {
    "paper (0.45, 0.35, 0.2, 0)": (0.45, 0.35, 0.2, 0.0),
    "field only (0, 0.5, 0.5, 0)": (0.0, 0.5, 0.5, 0.0),
    "force only": (1.0, 0.0, 0.0, 0.0),
}
THETA_STAR = (10.0, 350.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mu", default="0.3,1", help="the specimen's friction coefficients")
    ap.add_argument("--radius", default="4.77,8", help="indenter radii, mm")
    ap.add_argument("--depths", default="7,14", help="maximum depths, mm")
    ap.add_argument("--fov", default="10,25,whole", help="DIC fields of view (radius, mm; 'whole': the top)")
    ap.add_argument("--mesh", default="default")
    ap.add_argument("--mu-prior", default="0.1:3")
    ap.add_argument("--s", type=float, default=0.05, help="design noise level (eq. 6)")
    ap.add_argument("--out", type=Path, default=Path("runs/friction-design/table.json"))
    args = ap.parse_args()
    prior = tuple(float(v) for v in args.mu_prior.split(":"))
    rows = []
    for radius in (float(r) for r in args.radius.split(",")):
        for mu in (float(m) for m in args.mu.split(",")):
            spec = ModelSpec(mesh=MeshChoice(args.mesh)).with_friction(mu)
            spec = replace(spec, indenter=replace(spec.indenter, radius=radius))
            theta = np.array([*THETA_STAR, mu])
            t0 = time.perf_counter()
            base = FESolverPredictor(spec, sensitivities=True, parameters=("c1", "c5", "mu")).predict(theta)
            sim_s = time.perf_counter() - t0
            depth = np.asarray(base.depth, float)
            r_top = np.hypot(base.top_xyz[:, 0], base.top_xyz[:, 1])
            for max_depth in (float(d) for d in args.depths.split(",")):
                beyond = tuple(int(i) + 1 for i in np.flatnonzero(depth > max_depth + 1e-9))
                for fov in args.fov.split(","):
                    mask = None if fov == "whole" else r_top <= float(fov)
                    objective = Objective.from_prediction(
                        base, radius=radius, mask=mask, excluded_steps=beyond
                    )
                    H = gauss_newton_term_hessians(objective, base, theta)
                    study = DesignStudy(theta, H, "exact", "paper", spec.to_dict(), base, objective)
                    for label, eta in WEIGHTS.items():
                        b = friction_design_bounds(study, np.array(eta), args.s, prior)
                        known, nuis = np.array(b["known_pct"]), np.array(b["nuisance_pct"])
                        row = {
                            "radius_mm": radius,
                            "mu": mu,
                            "max_depth_mm": max_depth,
                            "fov_mm": fov,
                            "weights": label,
                            "known_pct": b["known_pct"],
                            "identified_pct": b["identified_pct"],
                            "nuisance_pct": b["nuisance_pct"],
                            "mu_share_pct": np.sqrt(np.maximum(nuis**2 - known**2, 0.0)).tolist(),
                            "identified_mu_pct": b["identified_mu_pct"],
                            "simulation_s": sim_s,
                        }
                        rows.append(row)
                        print(strict_json(row), flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_json(args.out, {"theta_star": THETA_STAR, "s": args.s, "mu_prior": prior, "rows": rows})


if __name__ == "__main__":
    main()
