"""Benchmark (by hand): what threads that spin cost beside another process (docs/validation/solver-and-speed.md,
"Threads that wait").

One contact-L1 run with sensitivities at the FE confirmation of the shipped example's fit (R = 4.77 mm,
{11.96, 245} kPa, mu = 1.58, 28 x 0.5 mm), with numba's and MKL's thread counts set by hand and the solver's
own thread policy bypassed, each in a fresh process (an OpenMP runtime reads its wait policy when it starts),
first on the machine as it is ("idle": run it with nothing else running), then beside a busy loop on one
core ("one core busy"). Prints a Markdown table and, with ``--json``, writes the times.

With ``--waits`` it compares the OpenMP wait settings instead (issue 58, "the thread policy without
its idle price"): the paper protocol on FEBio's baseline mesh, warm (the median of three runs after
one untimed), and the FE confirmation's run, both on two threads (numba and PARDISO), in a fresh
process per setting with the package's own choice overridden, idle and beside a busy loop; the
settings alternate ``--repeats`` times so that the machine's drift falls on all of them.

    .venv/bin/python benchmarks/thread_waits.py [--json out.json] [--repeats 1]
    .venv/bin/python benchmarks/thread_waits.py --waits [--repeats 2] [--json out.json]
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

from indentation_studio.thread_waits import USER_CHOICES

#: (label, numba threads, MKL threads, extra environment)
CONFIGS = [
    ("numba 1, PARDISO 1", 1, 1, {}),
    ("numba 2, PARDISO 2", 2, 2, {}),
    ("numba 1, PARDISO 2", 1, 2, {}),
    ("numba 2, PARDISO 1", 2, 1, {}),
    ("numba 2, PARDISO 2, OMP_WAIT_POLICY=PASSIVE", 2, 2, {"OMP_WAIT_POLICY": "PASSIVE"}),
    ("numba 1, PARDISO 2, KMP_BLOCKTIME=0", 1, 2, {"KMP_BLOCKTIME": "0"}),
]

RUN = """
import contextlib, sys, time
import numba
from threadpoolctl import threadpool_limits
from indentation_studio.forward import solver as S
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec, Protocol
spec = ModelSpec(mesh=MeshChoice("contact-L1"), indenter=Indenter(4.77),
                 protocol=Protocol(step_size=0.5, steps=28)).with_material(c1=11.96, c5=245.0).with_friction(1.58)
s = S.EmbeddedSolver(spec)
S.thread_limits = lambda n: contextlib.nullcontext()  # the counts below, not the solver's policy
numba.set_num_threads({nb})
t = time.perf_counter()
with threadpool_limits({mkl}):
    s.run(sensitivities=True)
print(time.perf_counter() - t)
"""


FEB = Path(__file__).resolve().parents[2] / "shared" / "febio" / "baseline" / "baseline.feb"

#: (label, environment): the OpenMP wait settings ``--waits`` compares (GNU OpenMP reads them)
WAIT_SETTINGS = [
    ("OMP_WAIT_POLICY=PASSIVE", {"OMP_WAIT_POLICY": "PASSIVE"}),
    ("the runtime's default", {"OMP_WAIT_POLICY": ""}),
    ("GOMP_SPINCOUNT=1000", {"GOMP_SPINCOUNT": "1000"}),
    ("GOMP_SPINCOUNT=3000", {"GOMP_SPINCOUNT": "3000"}),
    ("GOMP_SPINCOUNT=10000", {"GOMP_SPINCOUNT": "10000"}),
]

WARM = """
import contextlib, statistics, sys, time
import numba
from threadpoolctl import threadpool_limits
from indentation_studio.forward import solver as S
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec
S.thread_limits = lambda n: contextlib.nullcontext()
numba.set_num_threads(2)
spec = ModelSpec(mesh=MeshChoice(feb_file={feb!r}), indenter=Indenter(4.77))
times = []
with threadpool_limits(2):
    for _ in range(4):
        t = time.perf_counter()
        S.EmbeddedSolver(spec).run()
        times.append(time.perf_counter() - t)
print(statistics.median(times[1:]))
"""


def run_code(code: str, extra: dict[str, str]) -> float:
    """The number a snippet prints last, run in a fresh process with ``extra`` in its environment."""
    env = {k: v for k, v in os.environ.items() if k not in USER_CHOICES}
    env.update(extra)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


@contextlib.contextmanager
def machine_in(state: str) -> Iterator[None]:
    """Nothing for ``"idle"``; otherwise a busy loop on one core for the block's length."""
    busy = None
    if state != "idle":
        busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
        time.sleep(1.0)
    try:
        yield
    finally:
        if busy is not None:
            busy.kill()


def compare_waits(repeats: int) -> dict[str, dict[str, list[float]]]:
    """The paper protocol warm and the FE confirmation's run on two threads under each wait
    setting, idle and beside a busy loop, the settings alternating ``repeats`` times."""
    rows: dict[str, dict[str, list[float]]] = {}
    for state in ("idle", "one core busy"):
        with machine_in(state):
            for _ in range(repeats):
                for label, extra in WAIT_SETTINGS:
                    cell = rows.setdefault(label, {})
                    paper = run_code(WARM.format(feb=str(FEB)), extra)
                    confirm = run_code(RUN.format(nb=2, mkl=2), extra)
                    cell.setdefault(f"paper {state}", []).append(paper)
                    cell.setdefault(f"confirmation {state}", []).append(confirm)
                    print(
                        f"{state}: {label}: paper {paper:.3f} s, confirmation {confirm:.2f} s",
                        file=sys.stderr,
                        flush=True,
                    )
    return rows


def one_run(nb: int, mkl: int, extra: dict[str, str]) -> float:
    """The wall time of one run in a fresh process, s."""
    # the runtimes' default, which the package would otherwise change
    return run_code(RUN.format(nb=nb, mkl=mkl), {"OMP_WAIT_POLICY": "ACTIVE", **extra})


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--json", help="write the times here")
    ap.add_argument("--waits", action="store_true", help="compare the OpenMP wait settings (two threads)")
    args = ap.parse_args()
    if args.waits:
        waits = compare_waits(args.repeats)
        cols = ("paper idle", "paper one core busy", "confirmation idle", "confirmation one core busy")
        print("| wait setting | " + " | ".join(cols) + " |\n| --- |" + " --- |" * len(cols))
        for label, cell in waits.items():
            print(f"| {label} | " + " | ".join(f"{statistics.median(cell[c]):.3g} s" for c in cols) + " |")
        if args.json:
            with open(args.json, "w") as fh:
                json.dump({"load_at_start": os.getloadavg()[0], "seconds": waits}, fh, indent=1)
        return
    rows = {}
    for state in ("idle", "one core busy"):
        with machine_in(state):
            for label, nb, mkl, extra in CONFIGS:
                times = [one_run(nb, mkl, extra) for _ in range(args.repeats)]
                rows.setdefault(label, {})[state] = statistics.median(times)
                print(f"{state}: {label}: {rows[label][state]:.1f} s", file=sys.stderr, flush=True)
    print("| the FE confirmation's run | idle | one core busy |\n| --- | --- | --- |")
    for label, t in rows.items():
        print(f"| {label} | {t['idle']:.1f} s | {t['one core busy']:.1f} s |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"load_at_start": os.getloadavg()[0], "seconds": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
