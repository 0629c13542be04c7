"""``indent-studio demo``: from nothing to the paper's results on the embedded solver, with a report.

Steps, each one call of the library: a campaign over the paper's box (a 9 x 9 grid by default, the
paper's 775 points with ``full``) and a 16-point Latin hypercube to test on; both surrogates with their
held-out errors; Table 1 beside the paper's; Fig. 8 over the campaign; the design comparison of the
4.77 and 8 mm indenters; the fit of the shipped example experiment (surrogate, then FE), its
posterior and its FE confirmation; the figures and one HTML page in ``runs/<name>/report/``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..atomic_write import atomic_write, atomic_write_json
from ..campaign.loader import load_campaign
from ..campaign.runner import run_named_campaign
from ..design.experiment_choice import candidate_grid, compare_designs
from ..design.objective import PAPER_WEIGHTS
from ..design.objective_over_plane import campaign_objective_map
from ..design.study import fe_design_study
from ..design.weights import PAPER_HESSIAN, compare_with_paper
from ..forward.mesh import build_mesh
from ..forward.spec import ModelSpec
from ..inference.confirmation import confirm
from ..inference.experiment.data import load_experiment
from ..inference.experiment.processing import static_forces
from ..inference.fit.workflow import fit_experiment
from ..inference.posterior.workflow import sample_posterior_for
from ..surrogate.persistence import save_surrogate
from ..surrogate.shipped import shipped_for_test
from ..surrogate.training import SURROGATE_KINDS, train_surrogate
from . import figures
from .report import write_report

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "synthetic-12-250"
THETA_STAR = np.array([10.0, 350.0])
ETA = PAPER_WEIGHTS

SECTIONS = [
    ("surrogate-parity.png", "MLP surrogate against the FE solver at held-out Latin-hypercube points."),
    (
        "figure8.png",
        "Objective (eq. 5, weights of eq. 13) over the campaign, certainty ellipse (s = 0.05) and theta*.",
    ),
    (
        "design-comparison.png",
        "Certainty bounds of c1 and c5 for the 4.77 and 8 mm indenters against the maximum depth.",
    ),
    (
        "force-depth.png",
        "Example experiment: static forces (eq. 9), the FE and surrogate forces at the fit and, for a "
        "synthetic example, the surrogate at the truth.",
    ),
    ("displacement-maps.png", "Top-surface displacement of the FE model at the fit, 14 mm, fibers along +y."),
    ("corner.png", "Posterior of (c1, c5) with the fit, its eq. 6 ellipse and the synthetic truth."),
    ("mesh.png", "The default mesh (FEBio's baseline mesh, node for node)."),
]


class _Clock:
    """Times the demo's steps and says when each is done."""

    def __init__(self, say: Callable[[str], None]) -> None:
        self.say, self.t_start, self.t0, self.timings = say, time.perf_counter(), time.perf_counter(), {}

    def done(self, key: str) -> None:
        now = time.perf_counter()
        self.timings[key] = now - self.t0
        self.say(f"[{now - self.t_start:6.0f} s] {key} done in {self.timings[key]:.0f} s")
        self.t0 = now


def run_demo(
    name: str = "demo",
    full: bool = False,
    jobs: int = 0,
    runs_dir: str | Path = "runs",
    posterior_steps: int = 1500,
    say: Callable[[str], None] = print,
    spec: ModelSpec | None = None,
    grid: str | None = None,
    test_grid: str = "lhs:16:11",
    experiment: str | Path = EXAMPLE,
    design_depths: tuple[float, ...] = (7.0, 10.5, 14.0),
) -> Path:
    """Run the demo: every step of the workflow, and write ``runs/<name>/report/index.html``.

    ``spec``, ``grid``, ``test_grid``, ``experiment`` and ``design_depths`` default to the paper's
    setting (smaller ones serve the tests).

    Parameters
    ----------
    name : str, default "demo"
        The campaigns' and report's name.
    full : bool, default False
        The paper's 775-point grid instead of a 9 x 9 one.
    jobs : int, default 0
        Worker processes of the campaigns (0: all cores).
    runs_dir : str or pathlib.Path, default "runs"
        Where the campaigns and the report go.
    posterior_steps : int, default 1500
        emcee steps per walker of the example's posterior.
    say : callable, default print
        Where progress messages go.
    spec : ModelSpec, optional
        The model; default the paper's baseline (``ModelSpec()``).
    grid : str, optional
        The training campaign's grid (:func:`campaign.design_from_option`).
    test_grid : str, default "lhs:16:11"
        The test campaign's grid.
    experiment : str or pathlib.Path
        The example experiment fitted.
    design_depths : tuple of float, default (7.0, 10.5, 14.0)
        Maximum depths of the design comparison, mm.

    Returns
    -------
    pathlib.Path
        The report's ``index.html``.
    """
    clock = _Clock(say)
    runs_dir = Path(runs_dir)
    out = runs_dir / name / "report"
    spec = spec or ModelSpec()  # the paper's baseline: R = 4.77 mm, 28 x 0.5 mm, default mesh
    grid = grid or ("paper" if full else "c1=1:21:9,c5=82.5:578:9")
    summary, data, test = _campaigns(name, grid, test_grid, spec, runs_dir, jobs, say)
    clock.done("campaigns")
    models = _surrogates(data, test, runs_dir / name, out, say)
    clock.done("surrogates")
    rows, omap = _table1_and_figure8(spec, data, out)
    clock.done("Table 1 and Fig. 8")
    _design_comparison(spec, design_depths, out)
    clock.done("design comparison")
    example = _example(experiment, models["mlp"], posterior_steps, out, spec, say)
    clock.done("fit, posterior, confirmation")
    mesh = build_mesh(spec)
    figures.save_figure(figures.mesh_figure(mesh.nodes, mesh.elements), out / "mesh.png", 120)
    results = {
        "campaign": {
            "grid": grid,
            "points": int(data.n),
            "failed": int(summary["failed"]),
            "wall_s": summary["wall_s"],
        },
        "surrogate_test_errors": {k: m.meta["validation"]["test"] for k, m in models.items()},
        "table1": [r.__dict__ for r in rows],
        "hessian_at_paper_weights": omap.hessian.tolist(),
        "paper_hessian": [list(r) for r in PAPER_HESSIAN],
        **example,
        "timings_s": clock.timings,
        "wall_s": time.perf_counter() - clock.t_start,
    }
    atomic_write_json(out / "results.json", results)
    line = f"{data.n} simulations over c1 in [1, 21] kPa, c5 in [82.5, 578] kPa ({grid}); {summary['failed']} failed."
    return write_report(out, results, [("campaign", line), *SECTIONS])


def _campaigns(
    name: str, grid: str, test_grid: str, spec: ModelSpec, runs_dir: Path, jobs: int, say
) -> tuple:
    """The training and held-out campaigns run (or resumed) and loaded: (summary, data, test)."""
    summary = run_named_campaign(
        name, grid, spec, runs_dir=runs_dir, jobs=jobs, progress=_progress(name, say)
    )
    run_named_campaign(
        f"{name}-test", test_grid, spec, runs_dir=runs_dir, jobs=jobs, progress=_progress(f"{name}-test", say)
    )
    if summary["failed"]:
        say(
            f"campaign {name}: {summary['failed']} points failed (see {summary['root']}/index.parquet); going on"
        )
    return summary, load_campaign(name, runs_dir), load_campaign(f"{name}-test", runs_dir)


def _table1_and_figure8(spec: ModelSpec, data, out: Path) -> tuple:
    """Table 1's rows beside the paper's, and Fig. 8 over the campaign: (rows, objective map)."""
    study = fe_design_study(spec, THETA_STAR, method="exact")
    rows = compare_with_paper(study.term_hessians, 0.05)
    omap = campaign_objective_map(data, THETA_STAR, ETA, 0.05, study=study)
    title = f"F over {data.n} simulations (eq. 5, weights eq. 13)"
    figures.save_figure(figures.objective_map_figure(omap, title), out / "figure8.png")
    return rows, omap


def _design_comparison(spec: ModelSpec, depths: tuple[float, ...], out: Path) -> None:
    """The candidate tests at both radii and ``depths``, as a CSV and a figure."""
    designs = compare_designs(spec, candidate_grid(radii=(4.77, 8.0), depths=depths), THETA_STAR)
    atomic_write(out / "design-comparison.csv", designs.to_csv(index=False))
    figures.save_figure(figures.design_comparison_figure(designs), out / "design-comparison.png")


def _progress(campaign: str, say: Callable[[str], None]) -> Callable[[int, int, dict], None]:
    def report(done: int, todo: int, counts: dict) -> None:
        if done == todo or done % max(todo // 10, 1) == 0:
            say(f"campaign {campaign}: {counts['done']} done, {counts['failed']} failed")

    return report


def _surrogates(data, test, folder: Path, out: Path, say: Callable[[str], None]) -> dict:
    """Both surrogates trained, tested on the held-out campaign and saved; the MLP's parity plot."""
    models = {}
    for kind in SURROGATE_KINDS:
        say(f"training the {kind} surrogate on {data.n} points ...")
        models[kind] = train_surrogate(data, kind, test_campaign=test)
        save_surrogate(models[kind], folder / f"surrogate-{kind}.safetensors")
    pred = models["mlp"].predict(test.theta)
    pairs = {
        "force (mN)": (test.force, pred.force),
        "displacement (mm)": (test.displacement, pred.displacement),
    }
    title = f"MLP surrogate against FE at {test.n} held-out points"
    figures.save_figure(figures.parity_figure(pairs, title=title), out / "surrogate-parity.png", 120)
    return models


def _example(experiment, mlp, posterior_steps: int, out: Path, spec: ModelSpec, say) -> dict:
    """The shipped example: fit, posterior, FE confirmation, their figures.

    On the surrogate shipped for the example's test (the fit's model: contact-L1 corrected toward
    contact-L3, mu marginalised), as a user's plain ``fit`` takes it; on the demo's own MLP (its
    contact assumed) where none is shipped for that test (the tests' small settings)."""
    loaded = load_experiment(experiment)
    truth = loaded.synthetic.get("theta")
    shipped = shipped_for_test(loaded.radius, loaded.depths)
    surrogate, friction = (None, None) if shipped is not None else (mlp, "assumed")
    if shipped is not None:
        say(f"the example on {shipped.describe()}")
    result = fit_experiment(experiment, surrogate, weights=ETA, say=say, friction=friction)
    fit = result.fit
    post = sample_posterior_for(
        experiment,
        surrogate,
        weights=ETA,
        walkers=32,
        steps=posterior_steps,
        fit=result.surrogate_fit,
        say=say,
    )
    mu = float(fit.theta[2]) if len(fit.theta) > 2 else None
    check = confirm(experiment, surrogate, fit.theta[:2], weights=ETA, friction=mu)
    _example_figures(out, result, post, check, truth, spec)
    record = result.to_dict()
    return {
        "fit": {
            "theta": np.append(
                result.theta, fit.theta[2:]
            ).tolist(),  # a corrected budget's correction applied
            "model_fit": fit.theta.tolist(),
            "bounds_pct": result.bounds_pct.tolist(),  # statistical and, where known, model error
            "statistical_pct": fit.bounds_pct.tolist(),
            "model_error": None if result.model_error is None else result.model_error.to_dict(),
            "bounds_include": record["bounds_include"],
            "F": fit.F,
            "s": fit.s,
            "surrogate_theta": result.surrogate_fit.theta.tolist(),
            "truth": truth,
            "adequacy": record["adequacy"],
            "fe_stage": "an LM fit on the FE model"
            if result.refined
            else ("one confirming FE run" if result.confirmation is not None else "none"),
            "error_budget": record["error_budget"],
            "correction": record.get("correction"),  # the budget's, as fit.json (None: not corrected)
            "friction": record.get("friction"),
        },
        "posterior": post.posterior.summary()
        | {"fit_bounds": post.fit_bounds.tolist(), "not_identified": list(post.not_identified)},
        "confirmation": {"F_fe": check.to_dict()["F_fe"], "F_fit": fit.F},
        "fiber_angle_deg": result.inputs.dic.fiber_angle_deg,
    }


def _example_figures(out: Path, result, post, check, truth, spec: ModelSpec) -> None:
    """The example's corner plot, force against depth and displacement maps at the fit."""
    fit = result.fit
    corner = figures.posterior_corner_figure(post, fit=fit, truth=truth)
    figures.save_figure(corner, out / "corner.png", 120)
    f_inf, f_std = static_forces(result.inputs.experiment)
    curves = {
        "measured (eq. 9 f_inf)": f_inf,
        "FE at the fit": check.fe.force[0],
        f"{result.inputs.surrogate.kind.upper()} at the fit": check.surrogate.force[0],
    }
    if truth is not None:  # a synthetic example: the model at the truth (mu as fitted), for comparison
        model = result.inputs.surrogate
        at = np.append(np.asarray(truth, float)[:2], fit.theta[2:])[: len(model.parameters)]
        label = f"{model.kind.upper()} at the truth {np.round(truth, 2).tolist()} kPa"
        curves[label] = model.predict(at[None]).force[0]
    depth = result.inputs.experiment.depths
    title = "example experiment: force against depth"
    figures.save_figure(
        figures.force_depth_figure(depth, curves, errors=f_std, title=title), out / "force-depth.png"
    )
    maps = figures.displacement_maps_figure(
        check.fe.top_xyz, check.fe.displacement[0, -1], title=f"FE at the fit, {spec.protocol.max_depth:g} mm"
    )
    figures.save_figure(maps, out / "displacement-maps.png", 120)
