"""Benchmark (by hand): what single-precision factorisations would do on small meshes.

Meshes under ``forward.solver.SINGLE_PRECISION_DOFS`` (20,000 dofs) factorise in double. This
times each case with that rule, with single precision everywhere (the rule at 0) and with single
precision everywhere and PARDISO held to one thread while numba's kernel takes the run's threads
(``--pinned``), alternated, warm, on one and on two threads, and compares each rule's result on 1
and 2 threads (what the thread-count test of the speed issue asks to stay within round-off).

    .venv/bin/python benchmarks/single_precision_option.py [--repeats 2] [--pinned]
"""

from __future__ import annotations

import argparse
import contextlib
import statistics
import time
from collections.abc import Iterator
from pathlib import Path

import numba
import numpy as np
from threadpoolctl import threadpool_limits

import indentation_studio.forward.solver as solver_module
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Indenter, Material, MeshChoice, ModelSpec

FEB = Path(__file__).resolve().parents[2] / "shared" / "febio" / "baseline" / "baseline.feb"
#: label -> (SINGLE_PRECISION_DOFS, PARDISO held to one thread)
RULES = {"double below 20,000 dofs": (20_000, False), "single everywhere": (0, False)}
PINNED = {"single, PARDISO on one thread": (0, True)}
THREAD_LIMITS = solver_module.thread_limits


@contextlib.contextmanager
def kernel_threads_only(threads: int | None) -> Iterator[None]:
    """numba's kernel on ``threads`` threads, MKL's PARDISO on one: its factorisations then do not
    depend on the run's thread count."""
    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads or 1, numba.config.NUMBA_NUM_THREADS)))
    try:
        with threadpool_limits(1):
            yield
    finally:
        numba.set_num_threads(before)


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


def run(spec: ModelSpec, sensitivities: bool, threads: int, rule: tuple[int, bool]):
    solver_module.SINGLE_PRECISION_DOFS = rule[0]
    solver_module.thread_limits = kernel_threads_only if rule[1] else THREAD_LIMITS
    t0 = time.perf_counter()
    result = EmbeddedSolver(spec).run(sensitivities=sensitivities, threads=threads)
    return time.perf_counter() - t0, result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--pinned", action="store_true", help="also single precision with PARDISO on one thread")
    args = ap.parse_args()
    rules = {**RULES, **(PINNED if args.pinned else {})}
    for name, (spec, sens) in cases().items():
        run(spec, sens, 1, RULES["double below 20,000 dofs"])  # warm: compiled kernels, MKL
        times = {(label, n): [] for label in rules for n in (1, 2)}
        for _ in range(args.repeats):
            for label, rule in rules.items():
                for n in (1, 2):
                    times[label, n].append(run(spec, sens, n, rule)[0])
        line = [f"{name}: median of {args.repeats}, one thread / two threads:"]
        for label, rule in rules.items():
            _, one = run(spec, sens, 1, rule)
            _, two = run(spec, sens, 2, rule)
            du = float(np.abs(one.displacement - two.displacement).max())
            df = float(np.abs(one.force[1:] / two.force[1:] - 1.0).max())
            line.append(
                f"  {label}: {statistics.median(times[label, 1]):.3f} s / {statistics.median(times[label, 2]):.3f} s, "
                f"Newton {one.newton_iterations}; 1 vs 2 threads: max |du| {du:.2g} mm, force {df:.2g} relative"
            )
        print("\n".join(line), flush=True)


if __name__ == "__main__":
    main()
