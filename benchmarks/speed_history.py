"""Speed benchmark with a stored history: run it before landing any change to ``forward/``.

Each case (the paper protocol on FEBio's baseline mesh, R = 4.77 mm, 28 x 0.5 mm, {10, 350} kPa;
the same with sensitivities, with Coulomb mu = 0.3, and at R = 8 mm) is timed warm in this process,
interleaved with a fixed amount of numpy work (dense products and a sparse factorisation on one
thread). The figure kept is the **ratio** of the case's median time on one thread to the numpy
work's median time (also on one thread): a slower or busier machine slows both, so the ratio moves
little with machine noise, while a slower solver moves it one for one. The case is also timed with
the thread policy's choice (``forward.threads``; the time a user sees), which a busy machine moves
twice: fewer idle cores, fewer threads. Cold figures (a fresh ``indent-studio simulate --json``: its
``wall_s`` and the whole command timed from outside) are recorded beside it.

Every run appends one record (date, commit, machine, load average, every figure) to
``benchmarks/history/speed.jsonl``. A case whose one-thread ratio is more than ``--threshold``
(1.3) times the median of its last five one-thread records' (older records count where their
thread policy had chosen one thread) is reported loudly and the script exits with status 1.

    .venv/bin/python benchmarks/speed_history.py                 # all cases, 5 repeats, record
    .venv/bin/python benchmarks/speed_history.py --cases paper --repeats 3 --no-record
    .venv/bin/python benchmarks/speed_history.py --json

Its figures go on the docs' validation page (docs/validation/speed.md).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]
FEB = ROOT.parent / "shared" / "febio" / "baseline" / "baseline.feb"
HISTORY = ROOT / "benchmarks" / "history" / "speed.jsonl"
CASES = {
    "paper": {"sensitivities": False, "friction": None, "radius": 4.77},
    "sensitivities": {"sensitivities": True, "friction": None, "radius": 4.77},
    "mu0.3": {"sensitivities": False, "friction": 0.3, "radius": 4.77},
    "R8": {"sensitivities": False, "friction": None, "radius": 8.0},
}


#: The yardstick's version: records compare only with records of the same yardstick.
YARDSTICK = 2


def reference_work() -> float:
    """A fixed amount of numpy and scipy work on one thread (s), the yardstick of the machine.

    It mixes what the solver does: dense products in cache, streaming over arrays far larger than
    the caches (the assembly's memory traffic, which other jobs on the machine contend for) and a
    sparse LU of a 3D Laplacian (a factorisation with fill-in)."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((300, 300))
    big = rng.random(8_000_000)
    lap = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(20, 20), format="csc")
    eye = sp.identity(20, format="csc")
    grid = (
        sp.kron(sp.kron(lap, eye), eye) + sp.kron(sp.kron(eye, lap), eye) + sp.kron(sp.kron(eye, eye), lap)
    ).tocsc()
    with threadpool_limits(1):
        t0 = time.perf_counter()
        for _ in range(150):
            a = np.tanh(a @ a.T / 300.0)
        for _ in range(6):
            b = big * 1.0001 + 0.5
            np.sqrt(b, out=b)
            big = b - 0.5
        lu = spla.splu(grid)
        for _ in range(10):
            lu.solve(np.ones(grid.shape[0]))
        return time.perf_counter() - t0


def solve_case(case: str, threads: int | None = None) -> dict[str, Any]:
    """One warm run of ``case`` on ``threads`` threads (None: the thread policy's choice); returns
    its wall time and solver statistics."""
    from indentation_studio.forward.solver import EmbeddedSolver
    from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec

    opts = CASES[case]
    spec = ModelSpec(mesh=MeshChoice(feb_file=str(FEB)), indenter=Indenter(opts["radius"]))
    spec = spec.with_friction(opts["friction"])
    solver = EmbeddedSolver(spec)
    t0 = time.perf_counter()
    result = solver.run(sensitivities=opts["sensitivities"], threads=threads)
    return {
        "wall_s": time.perf_counter() - t0,
        "force_14mm_mN": float(result.force[-1]),
        "newton_iterations": int(result.newton_iterations),
        "factorizations": int(solver.stats["factorizations"]),
        "assembly_s": float(solver.stats["assembly_s"]),
        "linear_s": float(solver.stats["solve_s"] + solver.stats["factorize_s"]),
    }


def cold_cli(repeats: int) -> dict[str, Any]:
    """A fresh ``indent-studio simulate --json`` on FEBio's mesh: its ``wall_s`` and the whole command."""
    exe = Path(sys.executable).with_name("indent-studio")
    walls, commands = [], []
    for _ in range(repeats):
        out = ROOT / "runs" / "speed-history" / "cold.npz"
        t0 = time.perf_counter()
        proc = subprocess.run(
            [str(exe), "simulate", "--mesh-from", str(FEB), "--json", "--out", str(out)],
            capture_output=True,
            text=True,
            check=True,
        )
        commands.append(time.perf_counter() - t0)
        walls.append(json.loads(proc.stdout)["wall_s"])
    return {"wall_s": statistics.median(walls), "command_s": statistics.median(commands), "runs": repeats}


def measure(cases: list[str], repeats: int, cold_repeats: int) -> dict[str, Any]:
    """Every case warm (``repeats`` times, interleaved with the yardstick), then the cold CLI."""
    from indentation_studio.forward.threads import solver_threads

    solve_case(cases[0])  # compile and load everything once; not timed
    figures: dict[str, Any] = {}
    yardstick: list[float] = []
    for case in cases:
        times, one, refs, last = [], [], [], {}
        for k in range(repeats):
            refs.append(reference_work())
            one.append(solve_case(case, threads=1)["wall_s"])
            last = solve_case(case)
            times.append(last["wall_s"])
            print(
                f"{case} {k + 1}/{repeats}: {times[-1]:.3f} s, one thread {one[-1]:.3f} s "
                f"(yardstick {refs[-1]:.3f} s)",
                file=sys.stderr,
            )
        yardstick += refs
        figures[case] = {
            "median_s": statistics.median(times),
            "runs_s": [round(t, 4) for t in times],
            "one_thread_s": statistics.median(one),
            "ratio": statistics.median(one) / statistics.median(refs),
            "ratio_policy": statistics.median(times) / statistics.median(refs),
            **{k: v for k, v in last.items() if k != "wall_s"},
        }
    out = {
        "cases": figures,
        "yardstick": YARDSTICK,
        "yardstick_s": statistics.median(yardstick),
        "threads_chosen": solver_threads(),
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
    }
    if cold_repeats:
        try:
            out["cold_cli"] = cold_cli(cold_repeats)
        except subprocess.CalledProcessError as exc:  # recorded, never lost: the warm figures stand
            out["cold_cli"] = {"error": (exc.stderr or "")[-500:]}
    return out


def commit() -> str:
    try:
        return subprocess.run(
            ["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def read_history(path: Path) -> list[dict[str, Any]]:
    if not path.is_file():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def regressions(record: dict[str, Any], history: list[dict[str, Any]], threshold: float) -> list[str]:
    """Cases whose one-thread ratio exceeds ``threshold`` x the median ratio of their last five
    records."""
    out = []
    for case, fig in record["cases"].items():
        past = [
            h["cases"][case]["ratio"]
            for h in history
            if case in h.get("cases", {})
            and h.get("yardstick", 1) == YARDSTICK
            and ("one_thread_s" in h["cases"][case] or h.get("threads_chosen") == 1)  # one thread
        ][-5:]
        if not past:
            continue
        base = statistics.median(past)
        if fig["ratio"] > threshold * base:
            out.append(
                f"{case}: ratio {fig['ratio']:.2f} is {fig['ratio'] / base:.2f} x the median "
                f"{base:.2f} of its last {len(past)} records ({fig['median_s']:.3f} s now)"
            )
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma-separated, of {', '.join(CASES)}")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cold", type=int, default=5, help="fresh CLI runs timed (0: none)")
    ap.add_argument("--threshold", type=float, default=1.3)
    ap.add_argument("--history", type=Path, default=HISTORY)
    ap.add_argument("--no-record", action="store_true", help="compare only; append nothing")
    ap.add_argument("--note", default="", help="a word on this record (e.g. 'before', 'beside one job')")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    cases = [c for c in args.cases.split(",") if c]
    unknown = sorted(set(cases) - set(CASES))
    if unknown:
        ap.error(f"unknown case(s) {unknown}; use {sorted(CASES)}")
    record = {
        "date": time.strftime("%Y-%m-%dT%H:%M:%S"),
        "commit": commit(),
        "note": args.note,
        "machine": {"cpus": os.cpu_count(), "processor": platform.processor() or platform.machine()},
        "load_average_before": os.getloadavg(),
        **measure(cases, args.repeats, args.cold),
        "load_average_after": os.getloadavg(),
    }
    history = read_history(args.history)
    slow = regressions(record, history, args.threshold)
    record["regressions"] = slow
    if not args.no_record:
        args.history.parent.mkdir(parents=True, exist_ok=True)
        with args.history.open("a") as fh:
            fh.write(json.dumps(record) + "\n")
    if args.json:
        print(json.dumps(record, indent=1))
    else:
        for case, fig in record["cases"].items():
            print(
                f"{case:14s} median {fig['median_s']:.3f} s ({record['threads_chosen']} threads), "
                f"one thread {fig['one_thread_s']:.3f} s, ratio {fig['ratio']:.2f}  "
                f"Newton {fig['newton_iterations']}  factorisations {fig['factorizations']}  "
                f"F(14 mm) {fig['force_14mm_mN']:.1f} mN"
            )
        if "wall_s" in record.get("cold_cli", {}):
            c = record["cold_cli"]
            print(f"cold CLI       wall_s {c['wall_s']:.3f} s  whole command {c['command_s']:.3f} s")
        print(f"peak RSS {record['peak_rss_mb']:.0f} MB; load average {record['load_average_before'][0]:.2f}")
    if slow:
        bar = "!" * 78
        print(f"\n{bar}\nSPEED REGRESSION (> {args.threshold:g} x):\n  " + "\n  ".join(slow) + f"\n{bar}")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
