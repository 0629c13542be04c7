"""Benchmark (by hand): surrogates trained on the paper campaign, tested where they were not trained.

    .venv/bin/python benchmarks/probes/surrogate_validation.py --train bench-paper --test lhs100

For the GP and the MLP: fit time; force and displacement errors on the test campaign; Table 1
bounds at theta* = (10, 350) from the surrogate's Jacobian beside the FE solver's exact
sensitivities (same objective reading, same weights); wall time to predict 1e5 points (force
curves and the field's PCA scores; the full fields of 1e5 points are 8 GB, so their
reconstruction is timed per 1e4-point chunk).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from indentation_studio.campaign.loader import load_campaign
from indentation_studio.design.certainty import bounds_pct, combine, gauss_newton_term_hessians
from indentation_studio.design.objective import Objective
from indentation_studio.design.weights import PAPER_TABLE1
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import ModelSpec
from indentation_studio.surrogate.base import TrainingData
from indentation_studio.surrogate.persistence import save_surrogate
from indentation_studio.surrogate.training import make_surrogate
from indentation_studio.surrogate.validation import prediction_errors

THETA_STAR = np.array([10.0, 350.0])


def table1_bounds(predictor, theta, radius) -> np.ndarray:
    """(rows, 2) bounds at the paper's Table 1 weights from a predictor's Jacobian at theta."""
    pred = predictor.predict(theta[None, :], jacobian=True)
    objective = Objective.from_prediction(pred, radius=radius)
    H = gauss_newton_term_hessians(objective, pred, theta)
    return np.array([bounds_pct(combine(H, eta), 0.05) for _, eta, _, _ in PAPER_TABLE1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--train", default="bench-paper")
    ap.add_argument("--test", default="lhs100")
    ap.add_argument("--kinds", default="gp,mlp")
    ap.add_argument("--input-scale", default="log")
    args = ap.parse_args()
    train_data = load_campaign(args.train)
    train = TrainingData.from_campaign(train_data)
    test = TrainingData.from_campaign(load_campaign(args.test))
    spec = ModelSpec.from_dict(train_data.spec["model"])
    fe_bounds = table1_bounds(FESolverPredictor(spec), THETA_STAR, spec.indenter.radius)
    report = {"train": args.train, "test": args.test, "fe_bounds": fe_bounds.tolist(), "kinds": {}}
    for kind in args.kinds.split(","):
        t0 = time.perf_counter()
        model = make_surrogate(kind, input_scale=args.input_scale).fit(train)
        fit_s = time.perf_counter() - t0
        errors = prediction_errors(model, test)
        model.meta["validation"] = {"test": errors}
        save_surrogate(model, Path("runs") / args.train / f"surrogate-{kind}.safetensors")
        sb = table1_bounds(model, THETA_STAR, spec.indenter.radius)
        rng = np.random.default_rng(0)
        theta = model.scaler.lo + rng.random((100_000, 2)) * (model.scaler.hi - model.scaler.lo)
        t0 = time.perf_counter()
        T, _ = model._regress(model.scaler(theta), False)
        S = T * model.score_std + model.score_mean
        force = np.exp(S[:, : model.k_force] @ model.force_pca.components_ + model.force_pca.mean_)
        scores_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        model.predict(theta[:10_000])
        chunk_s = time.perf_counter() - t0
        report["kinds"][kind] = {
            "fit_s": fit_s,
            "components": [model.meta["force_components"], model.meta["field_components"]],
            "test_errors": errors,
            "bounds": sb.tolist(),
            "bounds_rel_diff_pct": (100 * (sb / fe_bounds - 1)).tolist(),
            "predict_1e5_force_and_scores_s": scores_s,
            "predict_1e4_full_fields_s": chunk_s,
            "force_shape": list(force.shape),
        }
        e = errors
        print(
            f"{kind}: fit {fit_s:.1f} s, components {model.meta['force_components']} + {model.meta['field_components']}; "
            f"test ({e['points']} points): force RMS {e['force_rms_pct']:.3f} % max {e['force_max_pct']:.3f} %, "
            f"displacement RMS {e['displacement_rms_pct']:.3f} % max {e['displacement_max_pct']:.3f} % of max |u|"
        )
        print(f"   1e5 points (force + field scores): {scores_s:.3f} s; 1e4 full fields: {chunk_s:.3f} s")
        for (name, _, _, _), b, f in zip(PAPER_TABLE1, sb, fe_bounds, strict=True):
            print(
                f"   {name:18s} surrogate {b[0]:6.2f} / {b[1]:7.2f} %   FE exact {f[0]:6.2f} / {f[1]:7.2f} %   "
                f"diff {100 * (b[0] / f[0] - 1):+5.1f} / {100 * (b[1] / f[1] - 1):+5.1f} %"
            )
    Path("runs", args.train, "surrogate-validation.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
