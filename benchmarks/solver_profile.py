"""Benchmark (by hand, not in the test suite): where one run's time goes (issue 58, "Speed, part 2").

Runs one or more of the issue's worst cases on one thread and prints a markdown table of the
solver's counters (``EmbeddedSolver.stats`` and the per-step convergence record): Newton
iterations, cut-backs, contact passes, PARDISO's symbolic analysis and numerical factorisations,
back-substitutions (those inside the Krylov preconditioner apart), Krylov iterations and matrix
products, assemblies (the contact's share apart), the contact's corrections and status checks,
the sensitivity solves; each with its count, its seconds and its share of the run's wall time.
With ``--py-spy`` the run is also sampled by py-spy (``record -f raw`` on this process) and the
samples are split by what they were doing (the counters do not reach inside MKL or the
preconditioner's Python). The cases:

* ``a``: contact-L4, R = 4.77 mm, {c1, c5} = {3, 120} kPa, stick (the surface penalty);
* ``b``: contact-L4, R = 8 mm, {7, 520} kPa, Coulomb mu = 0.3;
* ``c``: contact-L1, R = 4.77 mm, {3, 540} kPa, mu = 0.3;
* ``d``: contact-L3, R = 4.77 mm, {10, 350} kPa, stick, with sensitivities;
* ``e``: ``c``'s point with the stick (the yardstick of the goal "friction at most twice the stick").

All run the paper's 0.5 mm steps, 28 of them unless ``--steps`` says fewer (the L4 cases take
an hour or more: their first steps only). Each case's inputs, the code's version (commit, and
whether the tree differs from it), the counters, the per-step records and the forces are written to
``--json`` (one file per case: ``PATH`` with the case's name inserted before the suffix when more
than one case runs); ``--table`` prints the table of JSON files written before. ``--candidate``
runs with a cure candidate patched into this process (not in the solver), ``--compare`` compares
two runs' forces and force sensitivities step by step.

    .venv/bin/python benchmarks/solver_profile.py --case c --json runs/profile/c.json --py-spy
    .venv/bin/python benchmarks/solver_profile.py --case a --steps 2 --json runs/profile/a.json --py-spy
    .venv/bin/python benchmarks/solver_profile.py --table runs/profile/{a,b,c,d}.json
    .venv/bin/python benchmarks/solver_profile.py --case d --json runs/profile/d-cure.json --candidate sensitivity-factorises-first
    .venv/bin/python benchmarks/solver_profile.py --compare runs/profile/d.json runs/profile/d-cure.json
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from collections import Counter
from datetime import date
from pathlib import Path

import numpy as np

from indentation_studio import __version__
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError
from indentation_studio.forward.spec import Contact, Indenter, Material, MeshChoice, ModelSpec, Protocol

REPO = Path(__file__).resolve().parents[1]

#: The issue's worst cases: mesh, radius (mm), c1, c5 (kPa), mu (None: stick), sensitivities.
CASES: dict[str, dict] = {
    "a": {"mesh": "contact-L4", "radius": 4.77, "c1": 3.0, "c5": 120.0, "friction": None, "sens": False},
    "b": {"mesh": "contact-L4", "radius": 8.0, "c1": 7.0, "c5": 520.0, "friction": 0.3, "sens": False},
    "c": {"mesh": "contact-L1", "radius": 4.77, "c1": 3.0, "c5": 540.0, "friction": 0.3, "sens": False},
    "d": {"mesh": "contact-L3", "radius": 4.77, "c1": 10.0, "c5": 350.0, "friction": None, "sens": True},
    # (c)'s point with the stick: the goal's yardstick (contact-L1 with friction at most twice it)
    "e": {"mesh": "contact-L1", "radius": 4.77, "c1": 3.0, "c5": 540.0, "friction": None, "sens": False},
}

#: py-spy's samples by what they were doing: the first rule (in this order) whose frames all occur
#: in a sample's stack (function name, file) names it.
PYSPY_RULES: list[tuple[str, tuple[tuple[str, str], ...]]] = [
    ("PARDISO factorisation", (("_factorize_pardiso", "linear_solver.py"),)),
    (
        "back-subst.: sensitivity CG",
        (("sensitivity_solve", "sensitivity_solves.py"), ("solve", "linear_solver.py")),
    ),
    (
        "back-subst.: inverse columns",
        (("inverse_columns", "linear_solver.py"), ("solve", "linear_solver.py")),
    ),
    (
        "back-subst.: CG preconditioner",
        (("preconditioner", "linear_steps.py"), ("solve", "linear_solver.py")),
    ),
    ("back-subst.: Newton corrections", (("solve", "linear_solver.py"),)),
    ("contact correction (W D S^-1)", (("apply", "linear_solver.py"),)),
    ("CG matvecs", (("matvec", "linear_steps.py"),)),
    ("assembly: contact", (("add_to_system", "penalty_contact.py"),)),
    ("assembly: elements", (("assemble", "solver.py"),)),
    ("contact statuses", (("_statuses_follow", "penalty_newton.py"),)),
    ("Krylov (scipy, rest)", (("krylov", "linear_steps.py"),)),
    ("contact (rest)", (("penalty_contact.py",), ("penalty_newton.py",))),
]


def sensitivity_factorises_first() -> None:
    """Cure candidate (issue 58; landed since in ``SensitivitySolves.sensitivity_solve``, so a no-op on
    today's solver, kept to make the measurement again on the commits before): the sensitivity
    solve factorises the converged
    tangent at once where the factorisation in hand is the one the previous sensitivity solve left
    (the CG to 1e-11 preconditioned with it, a step old, mostly fails after ``krylov_maxiter()``
    iterations and factorises then). Patches :meth:`SensitivitySolves.sensitivity_solve` in this process."""
    from indentation_studio.forward.sensitivity_solves import SensitivitySolves

    today = SensitivitySolves.sensitivity_solve

    def sensitivity_solve(self, K, cmask, b):
        if self.stats["factorizations"] == getattr(self, "_factorizations_at_sensitivity", -1):
            self.factorize(K, cmask)
            self.stats["sensitivity_factorizations"] += 1
        x = today(self, K, cmask, b)
        self._factorizations_at_sensitivity = self.stats["factorizations"]
        return x

    SensitivitySolves.sensitivity_solve = sensitivity_solve


#: Cure candidates ``--candidate`` applies to this process before the run.
CANDIDATES = {"sensitivity-factorises-first": sensitivity_factorises_first}


def compare(today: dict, other: dict) -> str:
    """Forces (and force sensitivities) of two runs of a case compared step by step."""
    fa, fb = np.asarray(today["force_mN"])[1:], np.asarray(other["force_mN"])[1:]
    n = min(fa.size, fb.size)
    rel = np.abs(fb[:n] - fa[:n]) / np.maximum(np.abs(fa[:n]), 1e-300)
    differ = np.flatnonzero(rel > 0)
    lines = [
        f"forces: largest relative difference {rel.max():.3g} (step {rel.argmax() + 1}); "
        + (f"equal to the last bit up to step {differ[0]}" if differ.size else "equal at every step"),
        "relative difference by step: " + ", ".join(f"{x:.2g}" for x in rel),
    ]
    if today.get("force_sensitivity") and other.get("force_sensitivity"):
        sa = np.asarray(today["force_sensitivity"])[1 : n + 1]
        sb = np.asarray(other["force_sensitivity"])[1 : n + 1]
        rs = np.abs(sb - sa) / np.abs(sa).max(axis=0)
        lines.append(f"force sensitivities: largest difference {rs.max():.3g} of each parameter's largest")
    for key in ("wall_s", "cpu_s"):
        lines.append(f"{key}: {today[key]:.1f} -> {other[key]:.1f}")
    for key in ("factorizations", "krylov_iterations", "back_substitutions", "sensitivity_s"):
        lines.append(f"{key}: {today['stats'][key]:.6g} -> {other['stats'][key]:.6g}")
    return "\n".join(lines)


def code_version() -> dict:
    """The package version, the commit and whether the tracked files differ from it."""

    def git(*args: str) -> str:
        try:
            return subprocess.run(
                ["git", *args], cwd=REPO, capture_output=True, text=True, check=True
            ).stdout.strip()
        except (OSError, subprocess.CalledProcessError):
            return ""

    return {
        "version": __version__,
        "commit": git("rev-parse", "HEAD"),
        "dirty_files": git("status", "--porcelain", "--untracked-files=no").splitlines(),
    }


def case_spec(case: dict, steps: int) -> ModelSpec:
    """The :class:`ModelSpec` of a case, its first ``steps`` steps of 0.5 mm."""
    return ModelSpec(
        mesh=MeshChoice(case["mesh"]),
        indenter=Indenter(radius=case["radius"]),
        material=Material(c1=case["c1"], c5=case["c5"]),
        protocol=Protocol(steps=steps, step_size=0.5),
        contact=Contact(friction=case["friction"]),
    )


def start_pyspy(out: Path, rate: int) -> subprocess.Popen:
    """py-spy recording this process (raw, collapsed stacks) into ``out``."""
    cmd = [str(Path(sys.executable).parent / "py-spy"), "record", "-f", "raw", "-r", str(rate)]
    cmd += ["-o", str(out), "--pid", str(os.getpid())]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    time.sleep(1.0)  # let it attach
    return proc


def stop_pyspy(proc: subprocess.Popen) -> None:
    """Stop py-spy as Ctrl-C would (it writes its file then)."""
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(timeout=120)
    except subprocess.TimeoutExpired:
        proc.kill()


def frame_of(frame: str) -> tuple[str, str]:
    """(function, file name) of a raw py-spy frame ``Class.func (path/file.py:line)``."""
    name, _, where = frame.partition(" (")
    return name.strip().rsplit(".", 1)[-1], Path(where.rstrip(")").rsplit(":", 1)[0]).name


def pyspy_shares(raw: Path) -> dict:
    """py-spy's samples of a raw file split by ``PYSPY_RULES``.

    Parameters
    ----------
    raw : pathlib.Path
        ``py-spy record -f raw`` output: one collapsed stack and its sample count per line.

    Returns
    -------
    dict
        ``samples`` (the solver run's, those under ``EmbeddedSolver.run``) and ``shares`` (category
        -> fraction of those samples).
    """
    counts: Counter[str] = Counter()
    for line in raw.read_text().splitlines():
        stack, _, n = line.rpartition(" ")
        if not stack or not n.isdigit():
            continue
        frames = [frame_of(f) for f in stack.split(";")]
        names = {(f, file) for f, file in frames}
        files = {file for _, file in frames}
        if ("run", "solver.py") not in names:
            continue  # the benchmark's own set-up, the mesh's construction
        for label, needs in PYSPY_RULES:
            if all((need in names) if len(need) == 2 else (need[0] in files) for need in needs):
                counts[label] += int(n)
                break
        else:
            counts["other"] += int(n)
    total = sum(counts.values())
    return {
        "samples": total,
        "shares": {k: v / total for k, v in counts.most_common()} if total else {},
    }


def run_case(
    name: str,
    steps: int,
    threads: int,
    pyspy: Path | None,
    rate: int,
    mesh: str | None = None,
    candidate: str | None = None,
) -> dict:
    """Run one case (on ``mesh`` instead of its own if given) and collect its counters."""
    case = {**CASES[name], **({"mesh": mesh} if mesh else {})}
    spec = case_spec(case, steps)
    t0 = time.perf_counter()
    solver = EmbeddedSolver(spec)
    setup_s = time.perf_counter() - t0
    load_before = os.getloadavg()
    spy = start_pyspy(pyspy, rate) if pyspy is not None else None
    cpu0, t1 = time.process_time(), time.perf_counter()
    error = None
    try:
        result = solver.run(sensitivities=case["sens"], threads=threads)
    except SimulationError as exc:
        error, result = str(exc), exc.partial
    wall = time.perf_counter() - t1
    cpu = time.process_time() - cpu0
    if spy is not None:
        stop_pyspy(spy)
    out = {
        "case": name,
        "inputs": {**case, "steps": steps, "step_size": 0.5, "threads": threads, "spec": spec.to_dict()},
        "code": code_version(),
        "date": date.today().isoformat(),
        "machine": {"cores": os.cpu_count(), "load_before": load_before, "load_after": os.getloadavg()},
        "mesh": {"nodes": solver.mesh.n_nodes, "elements": solver.mesh.n_elements, "dofs": solver.n_dofs},
        "single_precision": bool(solver.linear.single_precision),
        "setup_s": setup_s,
        "wall_s": wall,
        "cpu_s": cpu,
        "error": error,
        "candidate": candidate,
        "stats": {k: (float(v) if isinstance(v, float) else int(v)) for k, v in solver.stats.items()},
    }
    if result is not None:
        if result.force_sensitivity is not None:
            out["force_sensitivity"] = np.asarray(result.force_sensitivity).tolist()
        out["convergence"] = {k: np.asarray(v).tolist() for k, v in result.convergence.items()}
        out["force_mN"] = np.asarray(result.force).tolist()
        out["depth_mm"] = np.asarray(result.depth).tolist()
    if pyspy is not None and pyspy.is_file():
        out["py_spy"] = {"file": str(pyspy), "rate_hz": rate, **pyspy_shares(pyspy)}
    return out


def cell(count: float | None, seconds: float | None, wall: float) -> str:
    """``count / seconds (share of wall)``; parts that are None left out."""
    parts = []
    if count is not None:
        parts.append(f"{count:,.0f}" if float(count).is_integer() else f"{count:,.1f}")
    if seconds is not None:
        parts.append(f"{seconds:,.1f} s ({100 * seconds / wall:.0f} %)")
    return " / ".join(parts) if parts else ""


def table(runs: list[dict]) -> str:
    """The markdown table of several cases' counters (a column per case)."""
    cols = []
    for r in runs:
        st, conv, wall = r["stats"], r.get("convergence", {}), r["wall_s"]
        steps = max(len(conv.get("newton_iterations", [0])) - 1, 1)
        newton = sum(conv.get("newton_iterations", [0]))
        back_other = st["back_substitutions"] - st["preconditioner_applications"]
        rows = {
            "mesh, dofs": f"{r['inputs']['mesh']}, {r['mesh']['dofs']:,}",
            "steps run": f"{steps} of 0.5 mm" + (" (failed)" if r.get("error") else ""),
            "wall / CPU": f"{wall:,.0f} s / {r['cpu_s']:,.0f} s ({wall / steps:,.0f} s a step)",
            "Newton iterations (a step: mean, max)": (
                f"{newton} ({newton / steps:.1f}, {max(conv.get('newton_iterations', [0]))})"
            ),
            "increments / cut-backs / contact passes": "{} / {} / {}".format(
                *(sum(conv.get(k, [0])) for k in ("increments", "cutbacks", "contact_passes"))
            ),
            "assemblies: tangent / residual only": (
                f"{st['tangent_assemblies']:,} / {st['assemblies'] - st['tangent_assemblies']:,}, "
                + cell(None, st["assembly_s"], wall)
            ),
            "contact updates (in the assemblies)": cell(
                st.get("contact_updates"), st.get("contact_update_s"), wall
            ),
            "symbolic analysis (PARDISO phase 11)": cell(st["symbolic_analyses"], st["symbolic_s"], wall),
            "numerical factorisations": cell(st["numeric_factorizations"], st["numeric_factorize_s"], wall),
            "... of them fresh Newton steps / for sensitivities": (
                f"{st['fresh_steps']} / {st['sensitivity_factorizations']}"
            ),
            "back-substitutions (all; columns)": (
                cell(st["back_substitutions"], st["back_substitution_s"], wall)
                + f"; {st['back_substitution_columns']:,} col."
            ),
            "... in the Krylov preconditioner": cell(
                st["preconditioner_applications"], st["preconditioner_s"], wall
            ),
            "... others (Newton corrections, inverse columns, direct), seconds about": cell(
                back_other, max(st["back_substitution_s"] - st["preconditioner_s"], 0.0), wall
            ),
            "... inverse columns of W (calls; columns)": (
                cell(st["inverse_column_solves"], st["inverse_columns_s"], wall)
                + f"; {st['inverse_columns']:,}"
            ),
            "Krylov solves: calls / failed": f"{st['krylov_calls']:,} / {st['krylov_failures']:,}",
            "Krylov iterations (in all)": cell(st["krylov_iterations"], st["krylov_s"], wall),
            "... matrix products": cell(st["krylov_matvecs"], st["krylov_matvec_s"], wall),
            "Newton corrections (old factorisation)": cell(st["solves"], None, wall),
            "contact corrections made (low rank)": cell(
                st.get("contact_corrections"), st.get("contact_correction_s"), wall
            ),
            "status checks / changes within Newton": (
                f"{st.get('status_checks', 0):,} / {st.get('status_changes', 0):,}, "
                + cell(None, st.get("status_s", 0.0), wall)
            ),
            "damped-step trials / halvings": f"{st.get('step_trials', 0):,} / {st.get('step_halvings', 0):,}",
            "turning-point re-solves": f"{st.get('turning_rounds', 0):,}",
            "sensitivity solves (columns)": (
                cell(st["sensitivity_solves"], st["sensitivity_s"], wall) + f" ({st['sensitivity_columns']})"
                if st["sensitivity_solves"]
                else "-"
            ),
            "... their Krylov iterations": f"{st['sensitivity_krylov_iterations']:,}"
            if st["sensitivity_solves"]
            else "-",
        }
        if "py_spy" in r:
            shares = r["py_spy"]["shares"]
            for label, _ in [*PYSPY_RULES, ("other", ())]:
                rows[f"py-spy: {label}"] = f"{100 * shares.get(label, 0.0):.0f} %"
        cols.append(rows)
    keys = list(dict.fromkeys(k for c in cols for k in c))
    head = "| | " + " | ".join(f"({r['case']})" for r in runs) + " |"
    lines = [head, "| --- |" + " --- |" * len(runs)]
    lines += ["| " + k + " | " + " | ".join(c.get(k, "") for c in cols) + " |" for k in keys]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", action="append", choices=sorted(CASES), help="a case (repeat for more)")
    ap.add_argument("--steps", type=int, default=28, help="the first this many steps of 0.5 mm")
    ap.add_argument("--mesh", help="run the cases on this mesh preset instead of their own (a smoke test)")
    ap.add_argument("--threads", type=int, default=1, help="the solver's threads (numba, MKL)")
    ap.add_argument("--json", type=Path, help="where to write the counters (one file per case)")
    ap.add_argument(
        "--py-spy", action="store_true", help="also sample the run with py-spy (raw file beside the JSON)"
    )
    ap.add_argument("--rate", type=int, default=20, help="py-spy's samples per second")
    ap.add_argument(
        "--candidate", choices=sorted(CANDIDATES), help="run with a cure candidate (not in the solver)"
    )
    ap.add_argument(
        "--compare", nargs=2, type=Path, metavar=("TODAY", "OTHER"), help="compare two runs' JSONs"
    )
    ap.add_argument("--table", nargs="*", type=Path, default=None, help="print the table of these JSON files")
    args = ap.parse_args()
    if args.compare:
        print(compare(*(json.loads(p.read_text()) for p in args.compare)))
        return
    if args.table is not None:
        print(table([json.loads(p.read_text()) for p in args.table]))
        return
    if not args.case or args.json is None:
        ap.error("give --case and --json (or --table FILES)")
    if args.candidate:
        CANDIDATES[args.candidate]()
    runs = []
    for name in args.case:
        path = args.json if len(args.case) == 1 else args.json.with_stem(f"{args.json.stem}-{name}")
        path.parent.mkdir(parents=True, exist_ok=True)
        raw = path.with_suffix(".pyspy.txt") if args.py_spy else None
        r = run_case(name, args.steps, args.threads, raw, args.rate, args.mesh, args.candidate)
        path.write_text(json.dumps(r, indent=1))
        runs.append(r)
        print(f"case {name}: {r['wall_s']:.1f} s, written {path}", file=sys.stderr)
    print(table(runs))


if __name__ == "__main__":
    main()
