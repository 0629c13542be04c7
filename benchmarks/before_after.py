"""Benchmark (by hand): one simulation before and after a change, interleaved in one run.

The speed issue asks for the paper protocol on FEBio's baseline mesh "before and after, in one
run": a fresh ``indent-studio simulate --mesh-from baseline.feb --json`` (its ``wall_s`` and the
whole command timed from outside) and warm runs in one process, for the paper protocol, with
sensitivities, with Coulomb mu = 0.3 and at R = 8 mm. *Before* is a git worktree of ``--before``
(made under ``runs/before-after/``), *after* this checkout (or a worktree of ``--after``); each is
reached through ``PYTHONPATH``, a folder whose ``indentation_studio`` maps onto that tree's
packages, so both run with this checkout's virtual environment and numba caches of their own.
Each cold run of one tree is followed by the same run of the other; the warm runs take the thread
policy of each tree (``EmbeddedSolver(spec).run(...)``, the first of ``repeats + 1`` left out). The
load average is read before every cold run; medians are printed.

    .venv/bin/python benchmarks/before_after.py --before c32403e [--after HEAD] [--repeats 5]
        [--cases paper,sensitivities,mu0.3,R8] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FEB = ROOT.parent / "shared" / "febio" / "baseline" / "baseline.feb"
EXE = Path(sys.executable).with_name("indent-studio")
WORK = ROOT / "runs" / "before-after"
#: the top-level folders mapped into ``indentation_studio`` (pyproject.toml's package-dir)
SUBPACKAGES = ("forward", "design", "surrogate", "studio", "campaign", "inference")
CASES = {
    "paper": [],
    "sensitivities": ["--sensitivities"],
    "mu0.3": ["--friction", "0.3"],
    "R8": ["--radius", "8"],
}
WARM = r"""
import json, sys, time
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec
case, n, feb = sys.argv[1], int(sys.argv[2]), sys.argv[3]
spec = ModelSpec(mesh=MeshChoice(feb_file=feb), indenter=Indenter(8.0 if case == "R8" else 4.77))
spec = spec.with_friction(0.3 if case == "mu0.3" else None)
times = []
for _ in range(n + 1):
    solver = EmbeddedSolver(spec)
    t0 = time.perf_counter()
    result = solver.run(sensitivities=case == "sensitivities")
    times.append(time.perf_counter() - t0)
print(json.dumps({"warm_s": times[1:], "force_14mm_mN": float(result.force[-1]),
                  "newton_iterations": int(result.newton_iterations),
                  "solver_file": sys.modules[EmbeddedSolver.__module__].__file__}))
"""


def tree_path(rev: str) -> Path:
    """A worktree of ``rev`` and a folder that maps ``indentation_studio`` onto it (its PYTHONPATH)."""
    sha = subprocess.run(
        ["git", "rev-parse", "--short", rev], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.strip()
    tree, path = WORK / f"tree-{sha}", WORK / f"path-{sha}"
    if not tree.exists():
        subprocess.run(["git", "worktree", "add", "--detach", str(tree), sha], cwd=ROOT, check=True)
    package = tree / "indentation_studio"
    for name in SUBPACKAGES:
        link = package / name
        if not link.exists():
            link.symlink_to(tree / name)
    path.mkdir(parents=True, exist_ok=True)
    if not (path / "indentation_studio").exists():
        (path / "indentation_studio").symlink_to(package)
    return path


def environment(path: Path | None) -> dict[str, str]:
    env = dict(os.environ)
    if path is not None:
        env["PYTHONPATH"] = str(path)
    return env


def cold(env: dict[str, str], case: str, out: Path) -> tuple[float, float]:
    """One fresh ``simulate --json``: (its wall_s, the whole command's time)."""
    t0 = time.perf_counter()
    proc = subprocess.run(
        [str(EXE), "simulate", "--mesh-from", str(FEB), *CASES[case], "--json", "--out", str(out)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(proc.stdout)["wall_s"], time.perf_counter() - t0


def warm(env: dict[str, str], case: str, repeats: int, path: Path | None) -> dict:
    """Warm runs in one fresh process of the tree on ``path`` (None: this checkout). ``-P`` keeps
    the current folder off ``sys.path``: this checkout's own ``indentation_studio`` folder would
    otherwise shadow the other tree's."""
    proc = subprocess.run(
        [sys.executable, "-P", "-c", WARM, case, str(repeats), str(FEB)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    out = json.loads(proc.stdout)
    tree = (path / "indentation_studio").resolve().parent if path is not None else ROOT
    if not Path(out["solver_file"]).resolve().is_relative_to(tree):
        raise RuntimeError(f"the warm runs imported {out['solver_file']}, not the tree on {path}")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="the commit before the change")
    ap.add_argument("--after", default=None, help="the commit after it (default: this checkout)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--cases", default=",".join(CASES))
    ap.add_argument("--json", action="store_true", help="print every figure as JSON at the end")
    args = ap.parse_args()
    trees = {"before": tree_path(args.before), "after": tree_path(args.after) if args.after else None}
    envs = {label: environment(path) for label, path in trees.items()}
    for label, env in envs.items():  # fill each tree's numba cache, untimed
        cold(env, "paper", WORK / f"{label}.npz")
    record: dict[str, dict] = {}
    for case in args.cases.split(","):
        for _ in range(args.repeats):
            for label, env in envs.items():
                load = os.getloadavg()[0]
                wall, command = cold(env, case, WORK / f"{label}.npz")
                r = record.setdefault(f"{label}:{case}", {"wall_s": [], "command_s": [], "load": []})
                r["wall_s"].append(wall)
                r["command_s"].append(command)
                r["load"].append(load)
        for label, env in envs.items():
            record[f"{label}:{case}"].update(warm(env, case, args.repeats, trees[label]))
        for label in envs:
            r = record[f"{label}:{case}"]
            print(
                f"{case:14s} {label:6s}: wall_s {statistics.median(r['wall_s']):.3f} s, command "
                f"{statistics.median(r['command_s']):.3f} s, warm {statistics.median(r['warm_s']):.3f} s "
                f"(median of {args.repeats}; load {min(r['load']):.2f} to {max(r['load']):.2f}; "
                f"F(14 mm) {r['force_14mm_mN']:.1f} mN, Newton {r['newton_iterations']})",
                flush=True,
            )
    if args.json:
        print(json.dumps(record))


if __name__ == "__main__":
    main()
