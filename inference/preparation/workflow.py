"""Prepare a test from nothing: campaigns, verification study, error budget, surrogate, manifest.

Every stage resumes where it stopped: a campaign solves only its points not done (its store),
the study reads back its runs (:mod:`inference.budgets.verification_study`), a trained file
newer than what it was trained from is used as it is. The campaigns run on joblib's local
processes or on a dask cluster given its address (``campaign.runner``: a worker lost loses only
its point, which another worker solves).
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, replace
from datetime import UTC, datetime
from pathlib import Path

from ... import __version__
from ...atomic_write import atomic_write_json
from ...campaign.loader import campaign_record
from ...campaign.runner import run_named_campaign
from ...forward.convergence.mesh_family import contact_family
from ...forward.spec import Indenter
from ...forward.threads import available_cores
from ...surrogate.error_budgets import remaining_bias
from ...surrogate.persistence import load_surrogate, save_surrogate, versions
from ...surrogate.shipped import add_to_manifest, file_sha256
from ...surrogate.training import train_multi_fidelity, train_surrogate
from ..budgets.study_budget import study_error_budget
from ..budgets.verification_study import run_verification_study
from .cost import CostEstimate, estimate_cost
from .recipe import TestRecipe

__all__ = ["PreparedTest", "prepare_test"]

#: The campaigns of a preparation: (stage, name suffix, the recipe's grid, which mesh).
CAMPAIGNS = (
    ("stick campaign", "stick", "stick_grid", "low_mesh"),
    ("held-out campaign", "stick-test", "test_grid", "low_mesh"),
    ("mu campaign", "mu", "mu_grid", "low_mesh"),
    ("high campaign", "high-stick", "high_grid", "high_mesh"),
)


@dataclass(frozen=True)
class PreparedTest:
    """What a preparation made.

    Attributes
    ----------
    folder : pathlib.Path
        The test's folder (``manifest.json``, the surrogate, the budget, ``runs/``, ``study/``).
    surrogate : pathlib.Path
        The multi-fidelity surrogate file.
    budget : pathlib.Path
        The error budget.
    solved_now : int
        Points and runs solved by this call (0: everything was there).
    wall_s : float
        This call's wall time, s.
    estimate : CostEstimate
        What it was estimated to cost from nothing.
    """

    folder: Path
    surrogate: Path
    budget: Path
    solved_now: int
    wall_s: float
    estimate: CostEstimate


def _commit() -> str:
    """The source tree's commit, where the package runs from a git checkout."""
    root = Path(__file__).resolve().parents[2]
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=False)
    return head.stdout.strip() or "unknown"


def _recipe_file(folder: Path, recipe: TestRecipe) -> None:
    """Write ``recipe.json``, or check that the folder was begun with the same recipe."""
    path = folder / "recipe.json"
    if path.is_file():
        found = json.loads(path.read_text())
        if found != json.loads(json.dumps(recipe.to_dict())):
            differs = sorted(
                k for k in found if found.get(k) != json.loads(json.dumps(recipe.to_dict())).get(k)
            )
            raise ValueError(
                f"{folder}: begun with another recipe (it differs in {', '.join(differs)}); prepare this test in "
                "another folder"
            )
        return
    atomic_write_json(path, recipe.to_dict())


def _stamp(path: Path) -> str:
    """What an input of a trained file is, by content: a campaign by its finished point files, a
    study by its cases, any other file by its sha256 (a stage run again that changes nothing leaves
    it as it was, so nothing downstream is made again)."""
    if path.is_dir():  # a campaign: its points' files
        files = sorted(
            (f.name, f.stat().st_size, f.stat().st_mtime_ns) for f in (path / "points").glob("*.npz")
        )
        return hashlib.sha256(json.dumps(files).encode()).hexdigest()
    if path.name == "study.json":
        cases = json.loads(path.read_text()).get("cases")
        return hashlib.sha256(json.dumps(cases, sort_keys=True).encode()).hexdigest()
    return file_sha256(path)


def _up_to_date(target: Path, *inputs: Path) -> bool:
    """Whether ``target`` was made from exactly these inputs (its ``.inputs.json`` beside it)."""
    record = target.with_name(target.name + ".inputs.json")
    if not (target.is_file() and record.is_file()):
        return False
    return json.loads(record.read_text()) == {f"{p.parent.name}/{p.name}": _stamp(p) for p in inputs}


def _made_from(target: Path, *inputs: Path) -> None:
    """Record what ``target`` was made from (:func:`_up_to_date`)."""
    atomic_write_json(
        target.with_name(target.name + ".inputs.json"),
        {f"{p.parent.name}/{p.name}": _stamp(p) for p in inputs},
    )


def prepare_test(
    recipe: TestRecipe,
    folder: str | Path,
    *,
    jobs: int = 0,
    scheduler: str | None = None,
    say: Callable[[str], None] | None = None,
    seed: int = 0,
) -> PreparedTest:
    """Prepare a test: what a shipped test has, made for ``recipe`` in ``folder``.

    1. the fit's model's stick campaign (a GP), its held-out points, its (c1, c5, mu) campaign (the
       slip's MLP, with ``kfold`` held-out errors), and the high fidelity's stick campaign over
       the box (the discrepancy), on joblib or dask;
    2. the verification study (levels ``budget_levels`` at ``budget_points``) and the error budget
       of both models against the high level, its GCI carried
       (:func:`~indentation_studio.inference.budgets.study_budget.study_error_budget`);
    3. the multi-fidelity surrogate, its budget recorded in it;
    4. ``manifest.json``: the surrogate's and the budget's sha256, the test, the campaigns, the
       held-out errors, the choices made with less than the shipped tests' study, the versions and
       the recipe. ``fit``, ``posterior`` and ``confirm`` find the test there and refuse files that
       do not match it.

    Parameters
    ----------
    recipe : TestRecipe
        The test and its plan.
    folder : str or pathlib.Path
        The test's folder; begun again, it resumes (with the same recipe only).
    jobs : int, default 0
        Local worker processes of the campaigns (0: all cores).
    scheduler : str, optional
        A dask.distributed scheduler's address: the campaigns run on its workers.
    say : callable, optional
        Progress, the estimate first.
    seed : int, default 0
        Seed of the training.

    Returns
    -------
    PreparedTest
        The files and what this call solved.

    Raises
    ------
    ValueError
        If the folder was begun with another recipe, or a stage fails (its message names it; what
        was solved is kept).
    """
    say = say or (lambda message: None)
    t0 = time.perf_counter()
    root = Path(folder)
    root.mkdir(parents=True, exist_ok=True)
    _recipe_file(root, recipe)
    runs = root / "runs"
    cores = jobs if jobs > 0 else available_cores()
    estimate = estimate_cost(recipe, cores=cores)
    say(f"{recipe.name}: " + estimate.describe())
    for choice in recipe.choices():
        say(f"note: {choice}")
    solved, spent = 0, 0.0
    names = {}
    for stage, suffix, grid_field, mesh_field in CAMPAIGNS:
        name = names[suffix] = f"{suffix}"
        model = recipe.model(getattr(recipe, mesh_field))
        t = time.perf_counter()
        summary = run_named_campaign(
            name, getattr(recipe, grid_field), model, runs_dir=runs, jobs=jobs, scheduler=scheduler
        )
        if summary.get("failed"):
            say(
                f"{stage}: {summary['failed']} points failed (kept as failed; the surrogates train on the rest)"
            )
        solved += int(summary.get("solved_now", 0))
        spent += estimate.stages[stage][1]
        left = max(estimate.cpu_s - spent, 0.0) / max(cores, 1)
        say(
            f"{stage} done ({summary.get('solved_now', 0)} solved now, {time.perf_counter() - t:.0f} s); about {left / 3600:.1f} h left"
        )
    study_dir = root / "study"
    radius = recipe.spec.indenter.radius
    high = recipe.high_level
    say(f"verification study: levels {list(recipe.budget_levels)} at {len(recipe.budget_points)} points ...")
    before = len(list(study_dir.rglob("*.npz"))) if study_dir.exists() else 0
    run_verification_study(
        replace(recipe.spec, indenter=Indenter(radius)),
        contact_family(radius),
        recipe.budget_levels,
        points=recipe.budget_points,
        radii=(radius,),
        substeps=(1,),
        out_dir=study_dir,
        fitting_level=high,
        say=say,
    )
    solved += len(list(study_dir.rglob("*.npz"))) - before
    budget_path = root / "error-budget.json"
    if not _up_to_date(budget_path, study_dir / "study.json"):
        say("the error budget against the study's high level ...")
        budget = study_error_budget(
            study_dir,
            (recipe.low_mesh, recipe.high_mesh),
            reference_level=high,
            fov_mm=recipe.field_of_view_mm,
        )
        payload = budget.to_dict() | {
            "description": f"{recipe.name}: prepared test's budget (indent-studio test prepare)",
            "choices": recipe.choices(),
        }
        atomic_write_json(budget_path, payload)
        _made_from(budget_path, study_dir / "study.json")
    index = {suffix: runs / name for suffix, name in names.items()}  # the campaigns, by their points
    stick = runs / names["stick"] / "surrogate-gp.safetensors"
    if not _up_to_date(stick, index["stick"], index["stick-test"]):
        say("training the stick surrogate ...")
        model = train_surrogate(
            names["stick"], "gp", test_campaign=names["stick-test"], runs_dir=runs, seed=seed
        )
        save_surrogate(model, stick)
        _made_from(stick, index["stick"], index["stick-test"])
    slip = runs / names["mu"] / "surrogate-slip.safetensors"
    if not _up_to_date(slip, index["mu"], stick):
        say("training the slip surrogate ...")
        model = train_surrogate(
            names["mu"], "slip", stick=stick, kfold=recipe.kfold, runs_dir=runs, seed=seed
        )
        save_surrogate(model, slip)
        _made_from(slip, index["mu"], stick)
    target = root / f"{recipe.name}.safetensors"
    if not _up_to_date(target, index["high-stick"], slip, budget_path):
        say("training the multi-fidelity surrogate ...")
        model = train_multi_fidelity(
            slip,
            names["high-stick"],
            runs_dir=runs,
            seed=seed,
            error_budget=remaining_bias(budget_path, recipe.high_mesh),
        )
        save_surrogate(model, target)
        _made_from(target, index["high-stick"], slip, budget_path)
    model = load_surrogate(target)
    s = recipe.spec
    entry = {
        "name": recipe.name,
        "file": target.name,
        "sha256": file_sha256(target),
        "bytes": target.stat().st_size,
        "test": {
            "radius_mm": s.indenter.radius,
            "steps": s.protocol.steps,
            "step_mm": s.protocol.step_size,
            "depths_mm": [round(s.protocol.step_size * k, 9) for k in range(1, s.protocol.steps + 1)],
            "block_mm": asdict(s.geometry),
        },
        "kind": model.kind,
        "parameters": list(model.parameters),
        "models": {"low": recipe.low_mesh, "high": recipe.high_mesh},
        "campaigns": [campaign_record(runs, name) for name in names.values()],
        "held_out": {
            "slip": load_surrogate(slip).meta.get("emulation_error"),
            "discrepancy_kfold": model.meta.get("discrepancy_kfold"),
        },
        "error_budget": model.meta.get("error_budget"),
        "error_budget_file": {"file": budget_path.name, "sha256": file_sha256(budget_path)},
        "choices": recipe.choices(),
        "estimate": estimate.to_dict(),
        "made": {
            "indentation_studio": __version__,
            "commit": _commit(),
            "date": datetime.now(UTC).isoformat(timespec="seconds"),
            "versions": versions(),
        },
        "recipe": "indent-studio test prepare (the plan: this entry's 'plan')",
        "plan": recipe.to_dict(),
    }
    add_to_manifest(root, entry)
    wall = time.perf_counter() - t0
    say(f"{recipe.name}: prepared in {root} ({solved} runs solved now, {wall:.0f} s)")
    return PreparedTest(root, target, budget_path, solved, wall, estimate)
