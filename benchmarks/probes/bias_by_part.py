"""Where a verification study's parameter bias comes from (by hand, on a study's stored runs).

For one case folder of ``indent-studio verification-study`` (``L<k>-s1.npz`` for each level, the
finest solved with sensitivities), each coarser level's response is fitted with the finest level's
model (``inference.budgets.study_quantities.parameter_bias``: one Gauss-Newton step, the paper's weights,
a 25 mm field) as a whole and in parts:

- ``field``: the level's top field with the finest level's force (what the field alone moves);
- ``field ux`` / ``uy`` / ``uz``: the same with the field weight on one component only
  (force 0.45, that component 0.55);
- ``interpolation``: the finest level's own field sampled at the level's top nodes and read back
  at the finest level's nodes (what reading a coarser field at other nodes costs by itself);
- ``rings >= k R``: the whole response with the top nodes nearer the axis than k R left out.

    .venv/bin/python benchmarks/probes/bias_by_part.py runs/verification/core13-R8/R8/c1-11_c5-330
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path

import numpy as np
from objective_options import fit_c5  # the sibling script's one Gauss-Newton step with rings left out

from indentation_studio.design.objective import PAPER_WEIGHTS
from indentation_studio.forward.convergence.mesh_study import top_field_interpolator
from indentation_studio.forward.predictor import Prediction
from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.budgets.mesh_check import prediction_at_nodes
from indentation_studio.inference.budgets.study_quantities import FIT_FIELD_OF_VIEW, parameter_bias

COMPONENTS = {"ux": (0.45, 0.55, 0.0, 0.0), "uy": (0.45, 0.0, 0.55, 0.0), "uz": (0.45, 0.0, 0.0, 0.55)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", type=Path, help="a case folder of a verification study")
    ap.add_argument("--rings", default="1.5,2,3", help="k of the inner rings left out (k R)")
    args = ap.parse_args()
    levels = sorted(int(p.name[1 : p.name.index("-")]) for p in args.case.glob("L*-s1.npz"))
    finest = levels[-1]
    model = SimulationResult.load(args.case / f"L{finest}-s1.npz")
    theta = np.array([model.spec["material"]["c1"], model.spec["material"]["c5"]], float)
    field = np.moveaxis(model.displacement, 0, 1)
    rings = [float(k) for k in args.rings.split(",") if k.strip()]
    pred = Prediction.from_results([model], ("c1", "c5"))
    print(f"{args.case}: c5 bias (% of {theta[1]:g} kPa) of each level fitted by level {finest}")
    head = ["level", "whole", "force", "field", *(f"field {c}" for c in COMPONENTS), "interpolation"]
    head += [f"rings >= {k:g} R" for k in rings]
    print("| " + " | ".join(head) + " |")
    print("|" + " --- |" * len(head))
    for level in levels[:-1]:
        run = SimulationResult.load(args.case / f"L{level}-s1.npz")
        with_model_force = replace(run, force=model.force)
        whole = parameter_bias(model, run)[1] / theta[1] - 1
        field_part = parameter_bias(model, with_model_force)[1] / theta[1] - 1
        parts = [
            parameter_bias(model, with_model_force, weights=w)[1] / theta[1] - 1 for w in COMPONENTS.values()
        ]
        resampled = top_field_interpolator(model.top_xyz, field)(run.top_xyz)
        interpolation = parameter_bias(
            model, replace(run, displacement=np.moveaxis(resampled, 1, 0), force=model.force)
        )
        target = prediction_at_nodes(run, model.top_xyz)
        inner = [
            fit_c5(model, pred, target, PAPER_WEIGHTS, FIT_FIELD_OF_VIEW, k)[0] / theta[1] - 1 for k in rings
        ]
        cells = [whole, whole - field_part, field_part, *parts, interpolation[1] / theta[1] - 1, *inner]
        print(f"| {level} | " + " | ".join(f"{100 * v:+.2f}" for v in cells) + " |")


if __name__ == "__main__":
    main()
