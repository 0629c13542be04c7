"""Benchmark (by hand): what threads that spin cost beside another process (docs/validation/solver-and-speed.md,
"Threads that wait").

One contact-L1 run with sensitivities at the FE confirmation of the shipped example's fit (R = 4.77 mm,
{11.96, 245} kPa, mu = 1.58, 28 x 0.5 mm), with numba's and MKL's thread counts set by hand and the solver's
own thread policy bypassed, each in a fresh process (an OpenMP runtime reads its wait policy when it starts),
first on the machine as it is ("idle": run it with nothing else running), then beside a busy loop on one
core ("one core busy"). Prints a Markdown table and, with ``--json``, writes the times.

    .venv/bin/python benchmarks/thread_waits.py [--json out.json] [--repeats 1]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

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


def one_run(nb: int, mkl: int, extra: dict[str, str]) -> float:
    """The wall time of one run in a fresh process, s."""
    env = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "KMP_BLOCKTIME")}
    env["OMP_WAIT_POLICY"] = "ACTIVE"  # the runtimes' default, which the package would otherwise change
    env.update(extra)
    out = subprocess.run(
        [sys.executable, "-c", RUN.format(nb=nb, mkl=mkl)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--json", help="write the times here")
    args = ap.parse_args()
    rows = {}
    for state in ("idle", "one core busy"):
        busy = None
        if state != "idle":
            busy = subprocess.Popen([sys.executable, "-c", "while True: pass"])
            time.sleep(1.0)
        try:
            for label, nb, mkl, extra in CONFIGS:
                times = [one_run(nb, mkl, extra) for _ in range(args.repeats)]
                rows.setdefault(label, {})[state] = statistics.median(times)
                print(f"{state}: {label}: {rows[label][state]:.1f} s", file=sys.stderr, flush=True)
        finally:
            if busy is not None:
                busy.kill()
    print("| the FE confirmation's run | idle | one core busy |\n| --- | --- | --- |")
    for label, t in rows.items():
        print(f"| {label} | {t['idle']:.1f} s | {t['one core busy']:.1f} s |")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"load_at_start": os.getloadavg()[0], "seconds": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
