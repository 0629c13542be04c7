"""Benchmark (by hand): the plain fit of experiments whose truth is known, as a table (issue 45).

Each experiment folder (e.g. made on contact-L4 and recorded as a lab would:
``make_synthetic_experiment.py --from-run RUN --lab``) is fitted the way a user fits it,
``fit_experiment`` with no option but the surrogate (``--surrogate R=FILE`` per radius; none: the
one shipped for its test). The table gives the truth, the fit, each half-width with its parts
(statistical, discrepancy, error budget, the surrogate's own error, the processing's), whether the
truth lies inside, the adequacy test's chi-square per degree of freedom and whether it flagged the
fit, and the wall time of the fit (its FE stage included).

    .venv/bin/python docs/figures/model_error_experiments.py /work/longruns/exp2/R8-4-200-lab-mis0.1 ... \\
        --surrogate 8=/work/longruns/camp/L3-stick-R8/surrogate-mf-loggp.safetensors --out table.json
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from indentation_studio.atomic_write import atomic_write_json
from indentation_studio.inference.experiment.data import load_experiment
from indentation_studio.inference.fit.workflow import fit_experiment


def _part(model: dict | None, key: str, j: int) -> float:
    """Part ``key`` of the model error's half-width of parameter ``j`` (0 where not carried)."""
    if not model:
        return 0.0
    value = model.get(key) if key != "processing_pct" else (model.get("processing") or {}).get(key)
    return 0.0 if value is None else float(value[j])


def row(folder: Path, surrogates: dict[float, str]) -> dict:
    """Fit one experiment and tabulate it."""
    exp = load_experiment(folder)
    surrogate = next((path for r, path in surrogates.items() if abs(r - exp.radius) < 1e-6), None)
    t0 = time.perf_counter()
    fit = fit_experiment(exp, surrogate)
    wall = time.perf_counter() - t0
    d = fit.to_dict()
    truth = np.asarray(exp.synthetic.get("theta", [np.nan, np.nan]), float)
    out = {"experiment": folder.name, "radius": exp.radius, "truth": truth.tolist(), "wall_s": round(wall, 1)}
    model = d.get("model_error")
    for j, name in enumerate(("c1", "c5")):
        value, half = float(d[name]), float(d[f"{name}_pct"])
        out[name] = {
            "fit": value,
            "half_pct": half,
            "error_pct": 100.0 * (value / truth[j] - 1.0),
            "inside": bool(abs(value - truth[j]) <= half / 100.0 * value),
            "statistical_pct": float(d["statistical_pct"][j]),
            "discrepancy_pct": _part(model, "discrepancy_pct", j),
            "budget_pct": _part(model, "error_budget_pct", j),
            "surrogate_pct": _part(model, "surrogate_pct", j),
            "processing_pct": _part(model, "processing_pct", j),
        }
    a = d.get("adequacy") or {}
    out["adequacy"] = {"per_degree": a.get("per_degree"), "dof": a.get("dof"), "flagged": a.get("flagged")}
    out["friction"] = d.get("friction")
    out["fe_stage_model"] = d["inputs"].get("fe_stage_model")
    out["surrogate"] = d["inputs"].get("surrogate")
    confirmation = d.get("fe_confirmation") or {}
    # the FE confirmation's Gauss-Newton step from the fit (None: the fit went on on the FE model)
    out["confirmation_step_pct"] = (confirmation.get("gauss_newton_shift_pct") or [None, None])[:2]
    out["fitted_on_fe"] = d.get("fe_fit") is not None
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("experiments", nargs="+", type=Path)
    ap.add_argument(
        "--surrogate", action="append", default=[], help="R=FILE: the surrogate for radius R (mm)"
    )
    ap.add_argument("--out", type=Path, help="the table as JSON")
    args = ap.parse_args()
    surrogates = {float(item.split("=", 1)[0]): item.split("=", 1)[1] for item in args.surrogate}
    rows = []
    print(
        "| experiment | truth | c1 fit (err %) | +- % (stat, disc, budget, sur, proc) | in | c5 fit (err %) | "
        "+- % (stat, disc, budget, sur, proc) | in | chi2/dof | flagged | FE step c1, c5 % | wall s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for folder in args.experiments:
        r = row(folder, surrogates)
        rows.append(r)
        cells = []
        for name in ("c1", "c5"):
            p = r[name]
            parts = ", ".join(
                f"{p[k]:.2f}"
                for k in (
                    "statistical_pct",
                    "discrepancy_pct",
                    "budget_pct",
                    "surrogate_pct",
                    "processing_pct",
                )
            )
            cells += [
                f"{p['fit']:.4g} ({p['error_pct']:+.2f})",
                f"{p['half_pct']:.2f} ({parts})",
                "yes" if p["inside"] else "NO",
            ]
        a = r["adequacy"]
        ratio = "n/a" if a["per_degree"] is None else f"{a['per_degree']:.3f}"
        step = r["confirmation_step_pct"]
        step = (
            "fitted on the FE model"
            if r["fitted_on_fe"]
            else ("n/a" if step[0] is None else f"{step[0]:+.2f}, {step[1]:+.2f}")
        )
        print(
            f"| {r['experiment']} | {r['truth']} | "
            + " | ".join(cells)
            + f" | {ratio} | {a['flagged']} | {step} | {r['wall_s']} |",
            flush=True,
        )
        if args.out:
            atomic_write_json(args.out, {"rows": rows, "command": "docs/figures/model_error_experiments.py"})


if __name__ == "__main__":
    main()
