"""The (c1, c5) that one fitting model (a run solved with sensitivities) fits to each of several
runs' noise-free responses (``inference.budgets.study_quantities.parameter_bias``: the studio's default
objective and weights, 25 mm field), with each run's force at 2, 7 and 14 mm and its Newton
iterations. Use it on a verification study's runs to see what a level, an increment count or an
element option (e.g. ``--fiber-stretch mean`` against the default) does to the parameters.

    .venv/bin/python benchmarks/probes/fitted_parameters.py runs/verification/R8/c1-19_c5-120/L3-s1.npz \\
        runs/verification/R8/c1-19_c5-120/L3-s2.npz runs/verification/R8/c1-19_c5-120/L2-s1.npz
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.budgets.study_quantities import parameter_bias


def _at(run: SimulationResult, depth: float) -> float:
    return float(run.force[int(np.argmin(np.abs(run.depth - depth)))])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("model", type=Path, help="the fitting model: a run with sensitivities")
    parser.add_argument("runs", type=Path, nargs="+", help="the runs whose responses are fitted")
    args = parser.parse_args()
    model = SimulationResult.load(args.model)
    truth = np.array([model.spec["material"]["c1"], model.spec["material"]["c5"]])
    print(f"fitting model {args.model}: (c1, c5) = {truth.tolist()} kPa")
    print("run | F(2 mm) | F(7 mm) | F(14 mm) mN | Newton | fit c1 kPa | fit c5 kPa | c5 from the model's")
    for path in args.runs:
        run = SimulationResult.load(path)
        c1, c5 = parameter_bias(model, run)
        newton = int(np.sum(run.convergence["newton_iterations"]))
        print(
            f"{path} | {_at(run, 2):.1f} | {_at(run, 7):.1f} | {_at(run, 14):.1f} | {newton} | {c1:.3f} | "
            f"{c5:.2f} | {100 * (c5 / truth[1] - 1):+.2f} %"
        )


if __name__ == "__main__":
    main()
