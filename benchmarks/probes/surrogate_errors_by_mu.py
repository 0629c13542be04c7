"""Benchmark (by hand): a surrogate over (c1, c5, mu)'s held-out errors, split by mu.

k-fold cross-validation on a campaign with a mu axis (the studio's validation metric,
:func:`surrogate.validation.prediction_errors`: the force's relative error over every point and
step, the field's error over every node and step relative to max |u| of that direction at that
point), the held-out points of every fold pooled within each mu band (< 0.5, 0.5 to 1, > 1) and
over all, and the field's over the nodes outside the indenter's radius (what a DIC system sees:
node by node, a node at the contact's edge switches between stick and slip, or touches, from one
parameter point to the next, which no smooth surrogate follows); the campaign's failed points are
counted beside it.

    .venv/bin/python benchmarks/probes/surrogate_errors_by_mu.py runs/mu-R4.77 [--kind mlp] [--folds 5]
    .venv/bin/python benchmarks/probes/surrogate_errors_by_mu.py runs/mu-R4.77 --kind slip --stick runs/stick-R4.77/surrogate-mlp.safetensors
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd
from sklearn.model_selection import KFold

from indentation_studio.atomic_write import atomic_write_json
from indentation_studio.campaign.loader import load_campaign
from indentation_studio.surrogate.base import TrainingData
from indentation_studio.surrogate.persistence import load_surrogate
from indentation_studio.surrogate.training import make_surrogate

BANDS = (("mu < 0.5", 0.0, 0.5), ("0.5 <= mu <= 1", 0.5, 1.0), ("mu > 1", 1.0, np.inf), ("all", 0.0, np.inf))
KEYS = ("force_rms_pct", "displacement_rms_pct", "ux_rms_pct", "uy_rms_pct", "uz_rms_pct", "outside_rms_pct")


def _squared_errors(pred, data: TrainingData, rows: np.ndarray, outside: np.ndarray) -> dict[str, np.ndarray]:
    """Per held-out point, the mean squared errors of the studio's metric
    (:func:`surrogate.validation.prediction_errors`), and the field's over the nodes outside the
    indenter's radius (what a DIC system sees; the normalisation is the same max abs u)."""
    rel_f = pred.force / data.force[rows] - 1.0
    u = data.displacement[rows]
    rel_u = (pred.displacement - u) / np.maximum(np.abs(u).max(axis=(1, 2)), 1e-12)[:, None, None, :]
    return {
        "force_rms_pct": np.mean(rel_f**2, axis=1),
        "displacement_rms_pct": np.mean(rel_u**2, axis=(1, 2, 3)),
        **{f"u{'xyz'[j]}_rms_pct": np.mean(rel_u[..., j] ** 2, axis=(1, 2)) for j in range(3)},
        "outside_rms_pct": np.mean(rel_u[:, :, outside] ** 2, axis=(1, 2, 3)),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign", type=Path)
    ap.add_argument("--kind", default="mlp")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--stick", type=Path, help="--kind slip: the perfect-stick surrogate file")
    ap.add_argument(
        "--max-components", type=int, help="PCA components per output at most (default the kind's)"
    )
    ap.add_argument("--pca-tol", type=float, default=1e-3)
    args = ap.parse_args()
    extra = {} if args.stick is None else {"stick": load_surrogate(args.stick)}
    if args.max_components is not None:
        extra["max_components"] = args.max_components
    data = TrainingData.from_campaign(load_campaign(args.campaign))
    index = pd.read_parquet(args.campaign / "index.parquet")
    radius = float(data.source["model"]["indenter"]["radius"])
    outside = np.hypot(data.top_xyz[:, 0], data.top_xyz[:, 1]) > radius
    j = data.parameters.index("mu")
    per_point = {k: np.full(data.n, np.nan) for k in KEYS}
    t0 = time.perf_counter()
    for fold, (train, test) in enumerate(
        KFold(args.folds, shuffle=True, random_state=args.seed).split(data.theta)
    ):
        model = make_surrogate(args.kind, pca_tol=args.pca_tol, **extra).fit(
            data.subset(train), seed=args.seed
        )
        for k, v in _squared_errors(model.predict(data.theta[test]), data, test, outside).items():
            per_point[k][test] = v
        print(f"fold {fold + 1}/{args.folds} ({time.perf_counter() - t0:.0f} s)", flush=True)
    table = {}
    for name, lo, hi in BANDS:
        rows = (data.theta[:, j] >= lo) & (data.theta[:, j] < hi)
        table[name] = {"points": int(rows.sum())} | {
            k: float(100 * np.sqrt(np.mean(per_point[k][rows]))) for k in KEYS if rows.any()
        }
    status = index["status"].value_counts().to_dict()
    out = {
        "campaign": str(args.campaign),
        "kind": args.kind,
        "folds": args.folds,
        "status": status,
        "wall_s_sum": float(index["wall_s"].sum()),
        "failed_mu": index.loc[index["status"] == "failed", "mu"].round(3).tolist(),
        "errors": table,
        "outside_radius_mm": radius,
    }
    atomic_write_json(args.campaign / f"errors-by-mu-{args.kind}.json", out)
    print(f"{args.campaign}: points {status}, {args.kind}, {args.folds}-fold held-out errors")
    print(
        "| mu band | points | force rms % | field rms % of max abs u | ux / uy / uz rms % | field outside r = R |"
    )
    print("|---|---|---|---|---|---|")
    for name, row in table.items():
        if row["points"]:
            print(
                f"| {name} | {row['points']} | {row['force_rms_pct']:.3f} | {row['displacement_rms_pct']:.3f} "
                f"| {row['ux_rms_pct']:.3f} / {row['uy_rms_pct']:.3f} / {row['uz_rms_pct']:.3f} "
                f"| {row['outside_rms_pct']:.3f} |"
            )
    print(f"failed points' mu: {out['failed_mu']}")


if __name__ == "__main__":
    main()
