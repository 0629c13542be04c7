"""Benchmark (by hand): a surrogate over (c1, c5, mu)'s held-out errors, split by mu.

k-fold cross-validation on a campaign with a mu axis (the studio's validation metric,
:func:`surrogate.validation.prediction_errors`: the force's relative error over every point and
step, the field's error over every node and step relative to max |u| of that direction at that
point), the held-out points of every fold pooled within each mu band (< 0.5, 0.5 to 1, > 1) and
over all; the campaign's failed points are counted beside it.

    .venv/bin/python benchmarks/surrogate_errors_by_mu.py runs/mu-R4.77 [--kind mlp] [--folds 5]
    .venv/bin/python benchmarks/surrogate_errors_by_mu.py runs/mu-R4.77 --kind slip --stick runs/stick-R4.77/surrogate-mlp.safetensors
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
from indentation_studio.surrogate.validation import prediction_errors

BANDS = (("mu < 0.5", 0.0, 0.5), ("0.5 <= mu <= 1", 0.5, 1.0), ("mu > 1", 1.0, np.inf))
KEYS = ("force_rms_pct", "displacement_rms_pct", "ux_rms_pct", "uy_rms_pct", "uz_rms_pct")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign", type=Path)
    ap.add_argument("--kind", default="mlp")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--stick", type=Path, help="--kind slip: the perfect-stick surrogate file")
    args = ap.parse_args()
    extra = {} if args.stick is None else {"stick": load_surrogate(args.stick)}
    data = TrainingData.from_campaign(load_campaign(args.campaign))
    index = pd.read_parquet(args.campaign / "index.parquet")
    j = data.parameters.index("mu")
    sums: dict[str, dict[str, float]] = {name: dict.fromkeys(KEYS, 0.0) | {"n": 0} for name, *_ in BANDS}
    sums["all"] = dict.fromkeys(KEYS, 0.0) | {"n": 0}
    t0 = time.perf_counter()
    for fold, (train, test) in enumerate(
        KFold(args.folds, shuffle=True, random_state=args.seed).split(data.theta)
    ):
        model = make_surrogate(args.kind, **extra).fit(data.subset(train), seed=args.seed)
        for name, lo, hi in (*BANDS, ("all", 0.0, np.inf)):
            rows = test[(data.theta[test, j] >= lo) & (data.theta[test, j] < hi)]
            if len(rows) == 0:
                continue
            e = prediction_errors(model, data.subset(rows))
            for k in KEYS:
                sums[name][k] += e[k] ** 2 * len(rows)
            sums[name]["n"] += len(rows)
        print(f"fold {fold + 1}/{args.folds} ({time.perf_counter() - t0:.0f} s)", flush=True)
    table = {
        name: {"points": s["n"], **{k: float(np.sqrt(s[k] / s["n"])) for k in KEYS}}
        if s["n"]
        else {"points": 0}
        for name, s in sums.items()
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
    }
    atomic_write_json(args.campaign / f"errors-by-mu-{args.kind}.json", out)
    print(f"{args.campaign}: points {status}, {args.kind}, {args.folds}-fold held-out errors")
    print("| mu band | points | force rms % | field rms % of max abs u | ux / uy / uz rms % |")
    print("|---|---|---|---|---|")
    for name, row in table.items():
        if row["points"]:
            print(
                f"| {name} | {row['points']} | {row['force_rms_pct']:.3f} | {row['displacement_rms_pct']:.3f} "
                f"| {row['ux_rms_pct']:.3f} / {row['uy_rms_pct']:.3f} / {row['uz_rms_pct']:.3f} |"
            )
    print(f"failed points' mu: {out['failed_mu']}")


if __name__ == "__main__":
    main()
