"""Benchmark (by hand): what single-precision factorisations would do on small meshes.

Meshes under ``forward.solver.SINGLE_PRECISION_DOFS`` (20,000 dofs) factorise in double. This
times each case with that rule and with single precision everywhere (the rule at 0), alternated,
warm, and compares each rule's result on 1 and 2 threads (what the thread-count test of the speed
issue asks to stay within round-off).

    .venv/bin/python benchmarks/single_precision_option.py [--repeats 2]
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

import indentation_studio.forward.solver as solver_module
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Indenter, Material, MeshChoice, ModelSpec

FEB = Path(__file__).resolve().parents[2] / "shared" / "febio" / "baseline" / "baseline.feb"
RULES = {"double below 20,000 dofs": 20_000, "single everywhere": 0}


def cases() -> dict[str, tuple[ModelSpec, bool]]:
    """(spec, sensitivities) of each case, on FEBio's baseline mesh unless said."""
    febio = MeshChoice(feb_file=str(FEB))
    return {
        "paper": (ModelSpec(mesh=febio), False),
        "sensitivities": (ModelSpec(mesh=febio), True),
        "mu = 0.3": (ModelSpec(mesh=febio).with_friction(0.3), False),
        "R = 8": (ModelSpec(mesh=febio, indenter=Indenter(8.0)), False),
        "c1 = 1, c5 = 429 (default)": (ModelSpec(material=Material(c1=1.0, c5=429.35)), False),
    }


def run(spec: ModelSpec, sensitivities: bool, threads: int, rule: int):
    solver_module.SINGLE_PRECISION_DOFS = rule
    t0 = time.perf_counter()
    result = EmbeddedSolver(spec).run(sensitivities=sensitivities, threads=threads)
    return time.perf_counter() - t0, result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    for name, (spec, sens) in cases().items():
        run(spec, sens, 1, 20_000)  # warm: compiled kernels, MKL
        times = {label: [] for label in RULES}
        for _ in range(args.repeats):
            for label, rule in RULES.items():
                times[label].append(run(spec, sens, 1, rule)[0])
        line = [f"{name}: one thread, median of {args.repeats}:"]
        for label, rule in RULES.items():
            _, one = run(spec, sens, 1, rule)
            _, two = run(spec, sens, 2, rule)
            du = float(np.abs(one.displacement - two.displacement).max())
            df = float(np.abs(one.force[1:] / two.force[1:] - 1.0).max())
            line.append(
                f"  {label}: {statistics.median(times[label]):.3f} s, Newton {one.newton_iterations}; "
                f"1 vs 2 threads: max |du| {du:.2g} mm, force {df:.2g} relative"
            )
        print("\n".join(line), flush=True)


if __name__ == "__main__":
    main()
