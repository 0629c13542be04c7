"""Benchmark (by hand): how much a fit's (c1, c5) depend on the contact (issue 17).

Synthetic experiments are made with the embedded solver on a given mesh with Coulomb friction
mu (or the perfect stick), DIC-like points over a 25 mm field of view with the indenter's
shadow, a registration error, 2 % force noise and 0.02 mm DIC noise; each is fitted with
``fit_experiment`` and a perfect-stick surrogate trained on the same mesh, so that the mesh's own
error is left out and what remains is the contact's. The table gives the bias of c1 and c5 and
whether the truth lies inside the fit's bounds. With ``--identify-mu`` each is fitted again with mu
identified beside (c1, c5): Gauss-Newton on the frictional FE model from the stick fit and mu = 0.5,
with its exact d/dmu; bounds of eq. 6 from the 3 x 3 Hessian.

    .venv/bin/python benchmarks/friction_fit_bias.py --surrogate runs/demo-s5/surrogate-gp.safetensors \\
        [--truth 10,350] [--mu 0.3,1,3,stick] [--mesh default] [--identify-mu] [--out runs/friction-bias]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from indentation_studio.forward.predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec
from indentation_studio.inference.experiment_fit import fit_experiment
from indentation_studio.inference.fit_inputs import prepare_fit
from indentation_studio.inference.inverse_fit import gauss_newton_refine
from indentation_studio.inference.synthetic_experiment import write_synthetic_experiment


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--surrogate", required=True, type=Path, help="a perfect-stick surrogate")
    ap.add_argument("--truth", default="10,350", help="c1,c5 (kPa); several as 10,350;3,540")
    ap.add_argument("--mu", default="0.3,1,3,stick", help="friction coefficients ('stick': perfect)")
    ap.add_argument("--mesh", default="default")
    ap.add_argument("--misregistration", type=float, default=0.1, help="registration error, mm")
    ap.add_argument("--identify-mu", action="store_true", help="also fit (c1, c5, mu) on the FE model")
    ap.add_argument(
        "--mu-start", type=float, default=0.5, help="start of mu's fit (d/dmu is 0 where nothing slips)"
    )
    ap.add_argument("--out", type=Path, default=Path("runs/friction-bias"))
    args = ap.parse_args()
    truths = [np.array([float(v) for v in t.split(",")]) for t in args.truth.split(";")]
    mus = [None if m == "stick" else float(m) for m in args.mu.split(",")]
    table = []
    for i, truth in enumerate(truths):
        for mu in mus:
            spec = ModelSpec(mesh=MeshChoice(args.mesh)).with_friction(mu)
            name = f"exp-{truth[0]:g}-{truth[1]:g}-mu{'stick' if mu is None else f'{mu:g}'}"
            t0 = time.perf_counter()
            exp = write_synthetic_experiment(
                FESolverPredictor(spec),
                truth,
                args.out / name,
                radius=spec.indenter.radius,
                step_size=spec.protocol.step_size,
                f_noise=0.02,
                u_noise_mm=0.02,
                misregistration_mm=args.misregistration,
                seed=200 + i,
            )
            sim_s = time.perf_counter() - t0
            t0 = time.perf_counter()
            d = fit_experiment(exp, args.surrogate).to_dict()
            fit_s = time.perf_counter() - t0
            theta = np.array([d["c1"], d["c5"]])
            half = np.array([d["c1_pct"], d["c5_pct"]])
            row = {
                "truth": truth.tolist(),
                "mu": mu,
                "fit": theta.tolist(),
                "bias_pct": (100 * (theta / truth - 1)).tolist(),
                "half_width_pct": half.tolist(),
                "statistical_pct": d["statistical_pct"],
                "bounds_include": d.get("bounds_include"),
                "inside": (np.abs(truth - theta) <= theta * half / 100).tolist(),
                "simulation_s": sim_s,
                "fit_s": fit_s,
            }
            if args.identify_mu:
                t0 = time.perf_counter()
                inputs = prepare_fit(exp, args.surrogate)
                fe = FESolverPredictor(ModelSpec(mesh=MeshChoice(args.mesh)), parameters=("c1", "c5", "mu"))
                three = gauss_newton_refine(
                    inputs.objective,
                    fe,
                    inputs.eta,
                    np.array([theta[0], theta[1], args.mu_start]),
                    max_steps=8,
                )
                truth3 = np.append(truth, np.nan if mu is None else mu)
                row["with_mu"] = {
                    "fit": three.theta.tolist(),
                    "statistical_pct": three.bounds_pct.tolist(),
                    "bias_pct": (100 * (three.theta[:2] / truth - 1)).tolist(),
                    "inside": (np.abs(truth3 - three.theta) <= three.theta * three.bounds_pct / 100).tolist(),
                    "message": three.message,
                    "fit_s": time.perf_counter() - t0,
                }
            table.append(row)
            print(json.dumps(row), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "friction-bias.json").write_text(json.dumps(table, indent=1))


if __name__ == "__main__":
    main()
