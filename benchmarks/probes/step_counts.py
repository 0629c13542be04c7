"""Side-by-side counts of runs of one protocol over a range of steps: Newton iterations,
factorisations, Krylov iterations, back-substitutions and wall time summed, the force at the last
step, and each run's largest relative force difference from the first (docs/validation/
solver-and-speed.md, "The correction's cells by their distinct dofs").

    .venv/bin/python benchmarks/probes/step_counts.py FIRST RUN [RUN ...]

A RUN is a result (``.npz``) or a run's checkpoint (``.checkpoint.pkl``, a run still going or
stopped); the steps summed are FIRST to the last step every run reached.
"""

import pickle
import sys

import numpy as np

from indentation_studio.forward.result import SimulationResult

COUNTS = ("newton_iterations", "factorizations", "krylov_iterations", "back_substitutions", "wall_s")


def load(path: str) -> tuple[dict, np.ndarray]:
    """A run's convergence record and forces (step 0 first)."""
    if path.endswith(".npz"):
        result = SimulationResult.load(path)
        return result.convergence, np.asarray(result.force, float)
    with open(path, "rb") as f:
        state = pickle.load(f)["state"]
    return state["conv"], np.asarray(state["forces"], float)


first = int(sys.argv[1])
runs = {path: load(path) for path in sys.argv[2:]}
last = min(len(conv["newton_iterations"]) for conv, _ in runs.values()) - 1
steps = slice(first, last + 1)
print(f"steps {first} to {last}")
reference = next(iter(runs.values()))[1]
for path, (conv, force) in runs.items():
    sums = {k: round(float(np.sum(conv[k][steps])), 1) for k in COUNTS}
    moved = float(np.max(np.abs(force[steps] / reference[steps] - 1.0)))
    print(
        f"{path}: {sums}, force {force[last]:.2f} mN, largest relative difference from the first {moved:.1e}"
    )
    print("   factorisations a step", [int(x) for x in conv["factorizations"][steps]])
    print("   Krylov iterations a step", [int(x) for x in conv["krylov_iterations"][steps]])
