"""The fiber term at the Gauss points against once per element, level by level of a verification
study's mesh family: the force at 2, 7 and 14 mm, the Newton iterations, and the (c1, c5) that one
fitting model (a finest level, solved with sensitivities) fits to each level's noise-free response
(``inference.verification_study.parameter_bias``: the studio's default objective and weights, 25 mm
field).

The runs are the ``L<k>-s1.npz`` files two ``indent-studio verification-study`` calls wrote, one
with ``--fiber-stretch gauss`` (the default) and one with ``--fiber-stretch mean``, e.g.

    .venv/bin/indent-studio verification-study --family 8x8:1.2:1.5:core8 --levels 0,1,2 \\
        --points 3:540 --radii 4.77 --substeps 1 --contact surface --fiber-stretch mean \\
        --out-dir runs/verification/core8-mean
    .venv/bin/python benchmarks/fiber_stretch_levels.py \\
        --gauss runs/verification/core8/R4.77/c1-3_c5-540 \\
        --mean runs/verification/core8-mean/R4.77/c1-3_c5-540 \\
        --model runs/verification/core8/R4.77/c1-3_c5-540/L3-s1.npz
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.verification_study import parameter_bias


def _at(result: SimulationResult, depth: float) -> float:
    return float(result.force[int(np.argmin(np.abs(result.depth - depth)))])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--gauss", type=Path, required=True, help="folder of the Gauss-point runs (L<k>-s1.npz)"
    )
    parser.add_argument("--mean", type=Path, required=True, help="folder of the element-mean runs")
    parser.add_argument(
        "--model", type=Path, required=True, help="the fitting model: a run with sensitivities"
    )
    args = parser.parse_args()
    model = SimulationResult.load(args.model)
    truth = np.array([model.spec["material"]["c1"], model.spec["material"]["c5"]])
    print(f"fitting model: {args.model} (c1, c5) = {truth.tolist()} kPa")
    print("fiber | level | F(2 mm) | F(7 mm) | F(14 mm) mN | Newton | fit c1, c5 kPa | c5 from the model's")
    for label, folder in (("gauss", args.gauss), ("mean", args.mean)):
        for path in sorted(folder.glob("L*-s1.npz")):
            r = SimulationResult.load(path)
            c1, c5 = parameter_bias(model, r)
            newton = int(np.sum(r.convergence["newton_iterations"]))
            print(
                f"{label} | {path.stem.split('-')[0]} | {_at(r, 2):.1f} | {_at(r, 7):.1f} | {_at(r, 14):.1f} | "
                f"{newton} | {c1:.3f}, {c5:.1f} | {100 * (c5 / truth[1] - 1):+.1f} %"
            )


if __name__ == "__main__":
    main()
