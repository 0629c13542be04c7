"""Benchmark (by hand): do a plain fit's bounds and the posterior's intervals contain the truth?

Synthetic experiments are made from a reference campaign's stored responses (e.g. 'reference'
mesh points spread over the box): DIC-like points over a 25 mm field of view, the indenter's
shadow, a registration error, 2 % force noise and 0.02 mm DIC noise. Each is fitted with
``fit_experiment`` (no extra options) and sampled with ``sample_posterior_for``; the table gives
the truth, the fit, the statistical and model half-widths and whether the truth is inside.

    .venv/bin/python benchmarks/probes/model_error_coverage.py --reference budget-ref --surrogate FILE \\
        [--points 0,2,4,6,8] [--steps 5000] [--out runs/coverage]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from indentation_studio.campaign.loader import StoredResponses, load_campaign
from indentation_studio.inference.experiment.synthetic import write_synthetic_experiment
from indentation_studio.inference.fit.workflow import fit_experiment
from indentation_studio.inference.posterior.workflow import sample_posterior_for


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reference", required=True, help="campaign of the responses the data are made from")
    ap.add_argument("--surrogate", required=True, type=Path)
    ap.add_argument("--points", default="", help="indices of the campaign's points (default: all)")
    ap.add_argument("--steps", type=int, default=5000, help="posterior steps per walker (0: no posterior)")
    ap.add_argument("--misregistration", type=float, default=0.1, help="registration error, mm")
    ap.add_argument("--out", type=Path, default=Path("runs/coverage"))
    ap.add_argument("--runs-dir", type=Path, default=Path("runs"))
    args = ap.parse_args()
    data = load_campaign(args.reference, args.runs_dir)
    stored = StoredResponses(data)
    rows = [int(i) for i in args.points.split(",")] if args.points else range(data.n)
    table = []
    for k, i in enumerate(rows):
        truth = data.theta[i]
        exp = write_synthetic_experiment(
            stored,
            truth,
            args.out / f"exp-{i:02d}",
            radius=stored.spec.indenter.radius,
            step_size=stored.spec.protocol.step_size,
            f_noise=0.02,
            u_noise_mm=0.02,
            misregistration_mm=args.misregistration,
            seed=100 + k,
        )
        t0 = time.perf_counter()
        result = fit_experiment(exp, args.surrogate, friction="assumed")  # the mesh's error alone
        fit_s = time.perf_counter() - t0
        d = result.to_dict()
        theta = np.array([d["c1"], d["c5"]])
        half = np.array([d["c1_pct"], d["c5_pct"]])
        # the bounds are theta_hat (1 +- half / 100): half-widths are in percent of the fit
        inside = np.abs(truth - theta) <= theta * half / 100
        row = {
            "truth": truth.tolist(),
            "fit": theta.tolist(),
            "error_pct": (100 * (theta / truth - 1)).tolist(),
            "statistical_pct": d["statistical_pct"],
            "model_pct": None if d["model_error"] is None else d["model_error"]["model_pct"],
            "half_width_pct": half.tolist(),
            "inside": inside.tolist(),
            "fit_s": fit_s,
        }
        if args.steps:
            t0 = time.perf_counter()
            post = sample_posterior_for(exp, args.surrogate, steps=args.steps, seed=k)
            ci = post.posterior.interval(0.95)
            row["posterior_ci95"] = ci.tolist()
            row["posterior_inside"] = ((ci[:, 0] <= truth) & (truth <= ci[:, 1])).tolist()
            row["posterior_s"] = time.perf_counter() - t0
        table.append(row)
        print(json.dumps(row), flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "coverage.json").write_text(json.dumps(table, indent=1))
    print(f"truth inside the fit's bounds: {sum(all(r['inside']) for r in table)} of {len(table)}")


if __name__ == "__main__":
    main()
