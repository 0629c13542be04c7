"""``indent-studio demo``: from nothing to the paper's results on the embedded solver, with a report.

Steps (each reuses the packages; nothing here computes by itself): a campaign over the paper's
box (a 9 x 9 grid by default, the paper's 775 points with ``full``) and a 16-point Latin
hypercube to test on; both surrogates with their held-out errors; Table 1 beside the paper's;
Fig. 8 over the campaign; the design comparison of the 4.77 and 8 mm indenters; the fit of the
shipped example experiment (surrogate, then FE), its posterior and its FE confirmation; the
figures and one HTML page in ``runs/<name>/report/``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "synthetic-12-250"
THETA_STAR = np.array([10.0, 350.0])
ETA = (0.45, 0.35, 0.2, 0.0)


def _campaign(name: str, grid: str, spec, runs_dir: Path, jobs: int, say: Callable[[str], None]):
    from ..campaign.designs import design_from_option
    from ..campaign.loader import load_campaign
    from ..campaign.runner import run_campaign
    from ..campaign.store import CampaignSpec, CampaignStore

    store = CampaignStore.create_or_open(runs_dir, CampaignSpec(name, design_from_option(grid), spec))
    total = len(store.spec.design.points)

    def progress(done: int, todo: int, counts: dict) -> None:
        if done == todo or done % max(todo // 10, 1) == 0:
            say(f"campaign {name}: {counts['done']}/{total} done, {counts['failed']} failed")

    summary = run_campaign(store, jobs=jobs or -1, progress=progress)
    if summary["failed"]:
        say(f"campaign {name}: {summary['failed']} points failed (see runs/{name}/index.parquet); going on")
    return load_campaign(name, runs_dir), summary


def run_demo(
    name: str = "demo",
    full: bool = False,
    jobs: int = 0,
    runs_dir: str | Path = "runs",
    posterior_steps: int = 1500,
    say: Callable[[str], None] = print,
    spec=None,
    grid: str | None = None,
    test_grid: str = "lhs:16:11",
    experiment: str | Path = EXAMPLE,
    design_depths: tuple[float, ...] = (7.0, 10.5, 14.0),
) -> Path:
    """Run every step and write ``runs/<name>/report/index.html``; returns its path. ``spec``,
    ``grid``, ``test_grid``, ``experiment`` and ``design_depths`` default to the paper's setting
    (smaller ones serve the tests)."""
    from ..design.experiment_choice import candidate_grid, compare_designs
    from ..design.objective import Objective
    from ..design.study import fe_design_study
    from ..design.weights import PAPER_HESSIAN, compare_with_paper
    from ..forward.mesh import preset_mesh
    from ..forward.predictor import FESolverPredictor
    from ..forward.spec import ModelSpec
    from ..inference.experiment_data import load_experiment
    from ..inference.experiment_processing import experiment_objective, static_forces
    from ..inference.inverse_fit import fit_parameters
    from ..inference.posterior import sample_posterior
    from ..surrogate.base import TrainingData
    from ..surrogate.persistence import save_surrogate
    from ..surrogate.validation import prediction_errors
    from . import figures
    from .report import write_report
    from .surrogate_cli import make_surrogate

    t_start = time.perf_counter()
    runs_dir = Path(runs_dir)
    out = runs_dir / name / "report"
    out.mkdir(parents=True, exist_ok=True)
    spec = spec or ModelSpec()  # the paper's baseline: R = 4.77 mm, 28 x 0.5 mm, default mesh
    timings: dict[str, float] = {}

    def timed(key: str, t0: float) -> None:
        timings[key] = time.perf_counter() - t0
        say(f"[{time.perf_counter() - t_start:6.0f} s] {key} done in {timings[key]:.0f} s")

    # 1. campaigns
    t0 = time.perf_counter()
    grid = grid or ("paper" if full else "c1=1:21:9,c5=82.5:578:9")
    data, summary = _campaign(name, grid, spec, runs_dir, jobs, say)
    test, _ = _campaign(f"{name}-test", test_grid, spec, runs_dir, jobs, say)
    timed("campaigns", t0)

    # 2. surrogates
    t0 = time.perf_counter()
    train_set, test_set = TrainingData.from_campaign(data), TrainingData.from_campaign(test)
    models, errors = {}, {}
    for kind in ("gp", "mlp"):
        say(f"training the {kind} surrogate on {train_set.n} points ...")
        models[kind] = make_surrogate(kind).fit(train_set)
        errors[kind] = prediction_errors(models[kind], test_set)
        models[kind].meta["validation"] = {"test": errors[kind]}
        save_surrogate(models[kind], runs_dir / name / f"surrogate-{kind}.joblib")
    pred = models["mlp"].predict(test_set.theta)
    figures.parity_figure(
        {
            "force (mN)": (test_set.force, pred.force),
            "displacement (mm)": (test_set.displacement, pred.displacement),
        },
        out / "surrogate-parity.png",
        title=f"MLP surrogate against FE at {test_set.n} held-out points",
    )
    timed("surrogates", t0)

    # 3. Table 1 and Fig. 8
    t0 = time.perf_counter()
    study = fe_design_study(spec, THETA_STAR, method="exact")
    rows = compare_with_paper(study.term_hessians, 0.05)
    H = study.hessian(ETA)
    objective = Objective.from_prediction(study.baseline, radius=spec.indenter.radius)
    F = objective.value(data.prediction(), ETA)
    bars = data.theta / THETA_STAR
    figures.objective_map_figure(
        bars[:, 0],
        bars[:, 1],
        F,
        H,
        0.05,
        out / "figure8.png",
        title=f"F over {data.n} simulations (eq. 5, weights eq. 13)",
    )
    timed("Table 1 and Fig. 8", t0)

    # 4. which experiment
    t0 = time.perf_counter()
    designs = compare_designs(spec, candidate_grid(radii=(4.77, 8.0), depths=design_depths), THETA_STAR)
    designs.to_csv(out / "design-comparison.csv", index=False)
    figures.design_comparison_figure(designs, out / "design-comparison.png")
    timed("design comparison", t0)

    # 5. the example experiment: fit, posterior, confirmation
    t0 = time.perf_counter()
    exp = load_experiment(experiment)
    mlp = models["mlp"]
    exp_objective, dic = experiment_objective(exp, mlp.top_xyz)
    first = fit_parameters(exp_objective, mlp, ETA)
    fit = fit_parameters(exp_objective, FESolverPredictor(spec), ETA, theta0=first.theta)
    sigma = float(np.sqrt(fit.F / (fit.n_residuals - 2)))
    post = sample_posterior(
        exp_objective, mlp, ETA, sigma, (mlp.scaler.lo, mlp.scaler.hi), fit.theta, 32, posterior_steps
    )
    figures.corner_figure(post, out / "corner.png", fit.theta, fit.hessian, fit.s)
    fe_fit = FESolverPredictor(spec).predict(fit.theta)
    f_inf, f_std = static_forces(exp)
    figures.force_depth_figure(
        exp.depths,
        {
            "measured (eq. 9 f_inf)": f_inf,
            "FE at the fit": fe_fit.force[0],
            "MLP at the fit": mlp.predict(fit.theta).force[0],
        },
        out / "force-depth.png",
        errors=f_std,
        title="example experiment: force against depth",
    )
    figures.displacement_maps_figure(
        fe_fit.top_xyz,
        fe_fit.displacement[0, -1],
        out / "displacement-maps.png",
        title=f"FE at the fit, {spec.protocol.max_depth:g} mm",
    )
    confirm_F = float(exp_objective.value(fe_fit, ETA)[0])
    timed("fit, posterior, confirmation", t0)
    mesh = preset_mesh(spec.mesh.preset, spec.geometry)
    figures.mesh_figure(mesh.nodes, mesh.elements, out / "mesh.png")

    truth = json.loads((Path(experiment) / "experiment.json").read_text()).get("synthetic", {}).get("theta")
    results = {
        "campaign": {
            "grid": grid,
            "points": int(data.n),
            "failed": int(summary["failed"]),
            "wall_s": summary["wall_s"],
        },
        "surrogate_test_errors": errors,
        "table1": [r.__dict__ for r in rows],
        "hessian_at_paper_weights": H.tolist(),
        "paper_hessian": [list(r) for r in PAPER_HESSIAN],
        "fit": {
            "theta": fit.theta.tolist(),
            "bounds_pct": fit.bounds_pct.tolist(),
            "F": fit.F,
            "s": fit.s,
            "surrogate_theta": first.theta.tolist(),
            "truth": truth,
        },
        "posterior": post.summary(),
        "confirmation": {"F_fe": confirm_F, "F_fit": fit.F},
        "fiber_angle_deg": dic.fiber_angle_deg,
        "timings_s": timings,
        "wall_s": time.perf_counter() - t_start,
    }
    (out / "results.json").write_text(json.dumps(results, indent=1, default=float))
    sections = [
        (
            "campaign",
            f"{data.n} simulations over c1 in [1, 21] kPa, c5 in [82.5, 578] kPa ({grid}); {summary['failed']} failed.",
        ),
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
            "Example experiment: static forces (eq. 9) and the FE and surrogate forces at the fit.",
        ),
        (
            "displacement-maps.png",
            "Top-surface displacement of the FE model at the fit, 14 mm, fibers along +y.",
        ),
        ("corner.png", "Posterior of (c1, c5) with the fit and its eq. 6 ellipse."),
        ("mesh.png", "The default mesh (FEBio's baseline mesh, node for node)."),
    ]
    return write_report(out, results, sections)
