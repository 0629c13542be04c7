"""Benchmark (by hand): how much a fit's (c1, c5) depend on the contact, and what fitting mu does (issue 17).

Synthetic experiments are made with the embedded solver on a given mesh with Coulomb friction
mu (or the perfect stick), DIC-like points over a 25 mm field of view with the indenter's
shadow, a registration error, 2 % force noise and 0.02 mm DIC noise; each is fitted with
``fit_experiment`` and a perfect-stick surrogate trained on the same mesh, so that the mesh's own
error is left out and what remains is the contact's. The table gives the bias of c1 and c5 and
whether the truth lies inside the fit's bounds. With ``--mu-surrogate`` (a surrogate trained with
mu as a parameter) each is fitted again with mu identified and with mu marginalised (the same fit,
bounds of eq. 6 from the 3 x 3 Hessian without and with the log-uniform prior over the surrogate's
mu range); ``--fe-stage`` adds the FE refinement on (c1, c5, mu) to those fits. With
``--stick-fe-mu`` each is also fitted from the perfect-stick surrogate with mu brought in by the FE
stage alone (``fit --friction marginalise`` on a surrogate without mu), identified and
marginalised. An experiment folder already under --out is reused, not simulated again.

    .venv/bin/python benchmarks/probes/friction_fit_bias.py --surrogate runs/demo-s5/surrogate-gp.safetensors \\
        [--mu-surrogate runs/fricmu/surrogate-gp.safetensors] [--fe-stage] \\
        [--stick-fe-mu] [--truth 10,350] [--mu 0.3,1,3,stick] [--mesh default] [--out runs/friction-bias]
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from indentation_studio.atomic_write import atomic_write_json, strict_json
from indentation_studio.design.friction_treatment import FrictionTreatment
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import MeshChoice, ModelSpec
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.workflow import fit_experiment


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def _row(fit, truth) -> dict:
    d = fit.to_dict()
    theta = np.array([d["c1"], d["c5"]])
    half = np.array([d["c1_pct"], d["c5_pct"]])
    fr = d["friction"]
    return {
        "fit": theta.tolist(),
        "bias_pct": (100 * (theta / truth - 1)).tolist(),
        "half_width_pct": half.tolist(),
        "inside": (np.abs(truth - theta) <= theta * half / 100).tolist(),
        "bounds_include": d["bounds_include"],
        "statistical_pct": d["statistical_pct"],
        **{
            k: fr[k]
            for k in (
                "mu",
                "mu_pct",
                "mu_interval",
                "mu_identified",
                "mu_reaches_range_end",
                "restarts",
                "mu_at_limit",
                "conditional_pct",
                "mu_share_pct",
            )
            if k in fr
        },
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--surrogate", required=True, type=Path, help="a perfect-stick surrogate")
    ap.add_argument("--mu-surrogate", type=Path, help="a surrogate trained with mu as a parameter")
    ap.add_argument("--fe-stage", action="store_true", help="refine the fits with mu on the FE model")
    ap.add_argument(
        "--stick-fe-mu", action="store_true", help="also fit mu from the stick surrogate by the FE stage"
    )
    ap.add_argument("--truth", default="10,350", help="c1,c5 (kPa); several as 10,350;3,540")
    ap.add_argument("--mu", default="0.3,1,3,stick", help="friction coefficients ('stick': perfect)")
    ap.add_argument("--mesh", default="default")
    ap.add_argument("--misregistration", type=float, default=0.1, help="registration error, mm")
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
            exp = args.out / name
            if not (exp / "experiment.json").is_file():
                write_synthetic_experiment(
                    FESolverPredictor(spec),
                    truth,
                    exp,
                    radius=spec.indenter.radius,
                    step_size=spec.protocol.step_size,
                    f_noise=0.02,
                    u_noise_mm=0.02,
                    misregistration_mm=args.misregistration,
                    seed=200 + i,
                )
            row = {"truth": truth.tolist(), "mu": mu, "simulation_s": time.perf_counter() - t0}
            t0 = time.perf_counter()
            row["stick"] = _row(fit_experiment(exp, args.surrogate, friction="assumed"), truth) | {
                "fit_s": time.perf_counter() - t0
            }
            if args.mu_surrogate is not None:
                t0 = time.perf_counter()
                ident = fit_experiment(exp, args.mu_surrogate, refine=args.fe_stage, friction="identify")
                row["identify"] = _row(ident, truth) | {"fit_s": time.perf_counter() - t0}
                # the same fit; the bounds with the prior on mu (marginalise: log-uniform over the range)
                marg = replace(ident, friction=FrictionTreatment("marginalise", mu_range=ident.mu_range))
                row["marginalise"] = _row(marg, truth)
            if args.stick_fe_mu:
                t0 = time.perf_counter()
                marg = fit_experiment(exp, args.surrogate, friction="marginalise", say=_say)
                row["fe_marginalise"] = _row(marg, truth) | {"fit_s": time.perf_counter() - t0}
                ident = replace(marg, friction=FrictionTreatment("identify", mu_range=marg.mu_range))
                row["fe_identify"] = _row(ident, truth)
            table.append(row)
            print(strict_json(row), flush=True)
    atomic_write_json(args.out / "friction-bias.json", table)


if __name__ == "__main__":
    main()
