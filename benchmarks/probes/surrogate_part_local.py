"""Probe (issue 57): the surrogate's own part of a fit's bounds, over all its held-out points and
near the fit.

A fit on a surrogate carries the surrogate's own error as the 95th percentile, over its held-out
points, of how far each held-out error vector moves the fit
(:func:`inference.budgets.fit_moves.emulation_error_pct`). This probe takes a fitted experiment
(its folder with ``fit-shipped/fit.json`` or ``--fit``) and prints, for (c1, c5) with mu held at
the fit's as the fit holds it:

* that quantile over all held-out points (what the fit carries; checked against fit.json);
* the same by band of mu;
* the quantile over the ``k`` held-out points nearest the fit (log parameters scaled to the
  held-out points' range), and how well such a local quantile holds each held-out point's own
  move from its ``k`` nearest others (leave-one-out coverage; 0.95 is calibrated).

    .venv/bin/python benchmarks/probes/surrogate_part_local.py EXPERIMENT_DIR [--fit FIT.json] [--k 52]
"""

from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

from indentation_studio.inference.budgets.fit_moves import emulation_moves
from indentation_studio.inference.fit.inputs import prepare_fit


def moves_at_fit(experiment: Path, fit: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(held-out theta, |move| in percent (n, 2), the fit's theta) for a fit's (c1, c5), mu held."""
    inputs = prepare_fit(experiment, reading=fit.get("reading", "fit"))
    surrogate = inputs.surrogate
    theta = [fit["model_fit"]["c1"], fit["model_fit"]["c5"]]
    if len(surrogate.parameters) > 2:
        theta.append(fit["friction"]["mu"])
    theta = np.asarray(theta, float)
    moves = emulation_moves(inputs.objective, np.asarray(fit["weights"], float), surrogate, theta, free=2)
    return surrogate.emulation_error.theta, 100.0 * np.expm1(moves), theta


def nearest(z: np.ndarray, at: np.ndarray, k: int, skip: int | None = None) -> np.ndarray:
    """Indices of the ``k`` rows of ``z`` nearest ``at`` (row ``skip`` left out)."""
    d = np.linalg.norm(z - at, axis=1)
    if skip is not None:
        d[skip] = np.inf
    return np.argsort(d, kind="stable")[:k]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("experiment", type=Path)
    ap.add_argument("--fit", type=Path, help="fit.json (default EXPERIMENT/fit-shipped/fit.json)")
    ap.add_argument("--k", type=int, default=52, help="held-out points near the fit")
    args = ap.parse_args()
    fit = json.loads((args.fit or args.experiment / "fit-shipped" / "fit.json").read_text())
    theta, moves, at = moves_at_fit(args.experiment, fit)
    q = lambda m: np.quantile(m, 0.95, axis=0, method="higher")  # noqa: E731
    print(f"fit {np.round(at, 4).tolist()}, {len(theta)} held-out points")
    print(
        f"all held-out points: c1 {q(moves)[0]:.2f} %, c5 {q(moves)[1]:.2f} % (fit.json: {fit['model_error'].get('surrogate_pct')})"
    )
    if theta.shape[1] > 2:
        edges = np.geomspace(theta[:, 2].min(), theta[:, 2].max() * (1 + 1e-9), 7)
        for lo, hi in itertools.pairwise(edges):
            band = (theta[:, 2] >= lo) & (theta[:, 2] < hi)
            print(
                f"  mu {lo:.2f} to {hi:.2f} ({band.sum()} points): c1 {q(moves[band])[0]:.2f} %, c5 {q(moves[band])[1]:.2f} %"
            )
    logs = np.log(theta)
    lo, hi = logs.min(axis=0), logs.max(axis=0)
    z = (logs - lo) / np.where(hi > lo, hi - lo, 1.0)
    z_fit = (np.log(at) - lo) / np.where(hi > lo, hi - lo, 1.0)
    local = q(moves[nearest(z, z_fit, args.k)])
    held = np.array([moves[j] <= q(moves[nearest(z, z[j], args.k, skip=j)]) for j in range(len(z))])
    print(f"the {args.k} nearest the fit: c1 {local[0]:.2f} %, c5 {local[1]:.2f} %")
    print(
        f"leave-one-out coverage of the local quantile: c1 {held[:, 0].mean():.3f}, c5 {held[:, 1].mean():.3f}"
    )


if __name__ == "__main__":
    main()
