"""Benchmark (by hand): the default fit on a surrogate over (c1, c5, mu) with its FE confirmation,
against the FE-stage fit of a perfect-stick surrogate (mu brought in by the FE model), side by side.

Synthetic experiments are made on the given mesh (default ``default``) with Coulomb friction mu or
the perfect stick, recorded as a lab would (``LAB_RECORDING``: 0.02 mm DIC noise, 2 % force noise,
0.1 mm misregistration); each is fitted twice, both with mu marginalised as the studio does when
not told: ``new`` (``fit_experiment(exp, mu_surrogate)``: the fit on the surrogate with mu and one FE
confirmation) and ``fe`` (``fit_experiment(exp, stick_surrogate)``: the FE-stage fit over
(c1, c5, mu)). Each row gives c1, c5, mu, the reported bounds, whether the truth lies inside them,
the confirmation's Gauss-Newton shift and the wall time. A case already under --out is reused.

    .venv/bin/python benchmarks/probes/surrogate_fit_with_mu.py \\
        --mu-surrogate 4.77=runs/mu-R4.77/surrogate-mlp.safetensors --mu-surrogate 8=runs/mu-R8/surrogate-mlp.safetensors \\
        --stick-surrogate 4.77=runs/stick-R4.77/surrogate-mlp.safetensors --stick-surrogate 8=runs/stick-R8/surrogate-mlp.safetensors \\
        [--cases paper] [--only new] [--out runs/mu-fits]

``--cases paper`` are issue 31's eight: mu = 0.3, 1 and the stick at {10, 350} and {3, 540} kPa,
R = 4.77 mm; mu = 0.3 and the stick at {10, 350}, R = 8 mm. ``R:c1,c5:mu`` items separated by ``;``
give others (``8:19,120:0.5``; ``stick`` for the perfect stick).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from indentation_studio.atomic_write import atomic_write_json, strict_json
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec
from indentation_studio.inference.experiment.synthetic import LAB_RECORDING, write_synthetic_experiment
from indentation_studio.inference.fit.workflow import fit_experiment

PAPER_CASES = (
    "4.77:10,350:0.3;4.77:10,350:1;4.77:10,350:stick;4.77:3,540:0.3;4.77:3,540:1;4.77:3,540:stick;"
    "8:10,350:0.3;8:10,350:stick"
)


def _say(message: str) -> None:
    print(f"  {message}", file=sys.stderr, flush=True)


def _cases(text: str) -> list[tuple[float, np.ndarray, float | None]]:
    out = []
    for item in (PAPER_CASES if text == "paper" else text).split(";"):
        radius, truth, mu = item.split(":")
        out.append(
            (
                float(radius),
                np.array([float(v) for v in truth.split(",")]),
                None if mu == "stick" else float(mu),
            )
        )
    return out


def _row(fit, truth: np.ndarray, mu: float | None, wall_s: float) -> dict:
    d = fit.to_dict()
    theta, half = np.array([d["c1"], d["c5"]]), np.array([d["c1_pct"], d["c5_pct"]])
    fr, conf = d["friction"], d["fe_confirmation"]
    return {
        "c1": theta[0],
        "c5": theta[1],
        "bias_pct": (100 * (theta / truth - 1)).tolist(),
        "bounds_pct": half.tolist(),
        "statistical_pct": d["statistical_pct"],
        "inside": (np.abs(truth - theta) <= theta * half / 100).tolist(),
        "mu": fr.get("mu"),
        "mu_interval": fr.get("mu_interval"),
        "mu_inside": None
        if mu is None or "mu_interval" not in fr
        else bool(fr["mu_interval"][0] <= mu <= fr["mu_interval"][1]),
        "shift_pct": None if conf is None else conf["gauss_newton_shift_pct"],
        "F_fe": None if conf is None else conf["F_fe"],
        "F": d["F"],
        "adequacy_flagged": d["adequacy"].get("flagged"),
        "warnings": d["warnings"],
        "wall_s": wall_s,
    }


def _pair(text: list[str]) -> dict[float, Path]:
    return {float(k): Path(v) for k, v in (t.split("=", 1) for t in text)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--mu-surrogate", action="append", default=[], help="RADIUS=FILE, a surrogate over (c1, c5, mu)"
    )
    ap.add_argument(
        "--stick-surrogate", action="append", default=[], help="RADIUS=FILE, a perfect-stick surrogate"
    )
    ap.add_argument("--cases", default="paper")
    ap.add_argument("--only", choices=("new", "fe"), help="run one of the two fits")
    ap.add_argument("--mesh", default="default")
    ap.add_argument("--out", type=Path, default=Path("runs/mu-fits"))
    args = ap.parse_args()
    surrogates = {"new": _pair(args.mu_surrogate), "fe": _pair(args.stick_surrogate)}
    kinds = [args.only] if args.only else ["new", "fe"]
    table = []
    for i, (radius, truth, mu) in enumerate(_cases(args.cases)):
        spec = ModelSpec(indenter=Indenter(radius), mesh=MeshChoice(args.mesh)).with_friction(mu)
        name = f"R{radius:g}-{truth[0]:g}-{truth[1]:g}-mu{'stick' if mu is None else f'{mu:g}'}"
        exp = args.out / name
        if not (exp / "experiment.json").is_file():
            print(f"{name}: simulating ...", file=sys.stderr, flush=True)
            write_synthetic_experiment(
                FESolverPredictor(spec),
                truth,
                exp,
                radius=radius,
                step_size=0.5,
                seed=300 + i,
                recording=LAB_RECORDING,
            )
        row = {"case": name, "radius": radius, "truth": truth.tolist(), "mu_truth": mu}
        for kind in kinds:
            done = exp / f"fit-{kind}.json"
            if done.is_file():
                row[kind] = json.loads(done.read_text())
                continue
            if radius not in surrogates[kind]:
                continue
            print(f"{name}: fit {kind} ...", file=sys.stderr, flush=True)
            t0 = time.perf_counter()
            fit = fit_experiment(exp, surrogates[kind][radius], say=_say)
            row[kind] = _row(fit, truth, mu, time.perf_counter() - t0)
            fit.save(exp / f"results-{kind}")
            atomic_write_json(done, row[kind])
        table.append(row)
        print(strict_json(row), flush=True)
    atomic_write_json(args.out / "mu-fits.json", table)
    print(
        "\n| case | fit | c1 (bias, bound) | c5 (bias, bound) | truth inside | mu [interval] | GN shift c1/c5 % | s |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for row in table:
        for kind in kinds:
            r = row.get(kind)
            if r is None:
                continue
            interval = (
                "" if r["mu_interval"] is None else f" [{r['mu_interval'][0]:.2f}, {r['mu_interval'][1]:.2f}]"
            )
            mu = "" if r["mu"] is None else f"{r['mu']:.3g}{interval}"
            shift = "" if r["shift_pct"] is None else f"{r['shift_pct'][0]:+.2f} / {r['shift_pct'][1]:+.2f}"
            print(
                f"| {row['case']} | {kind} | {r['c1']:.3f} ({r['bias_pct'][0]:+.2f} %, +-{r['bounds_pct'][0]:.2f} %) "
                f"| {r['c5']:.1f} ({r['bias_pct'][1]:+.2f} %, +-{r['bounds_pct'][1]:.2f} %) "
                f"| {'yes' if all(r['inside']) else 'NO'} | {mu} | {shift} | {r['wall_s']:.1f} |"
            )


if __name__ == "__main__":
    main()
