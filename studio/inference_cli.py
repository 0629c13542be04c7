"""``indent-studio fit | posterior | confirm``: from a measured experiment to (c1, c5) with bounds,
a posterior and an FE confirmation (paper 2.7, 2.8, 3.4)."""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console

from .options import JSON, err, fail

EXPERIMENT = Annotated[Path, typer.Option(help="experiment folder (README: experiment data format)")]
SURROGATE = Annotated[Path, typer.Option(help="a trained surrogate file (indent-studio surrogate train)")]
WEIGHTS = Annotated[str, typer.Option(help="eta = force,ux,uy,uz on the simplex")]
OUT = Annotated[Path | None, typer.Option(help="folder for the result files (default: <experiment>/results)")]


@dataclass
class _Setup:
    model: object  # the surrogate
    spec: object  # the FE model it emulates
    objective: object
    dic: object  # the registered DIC data
    eta: np.ndarray


def _setup(experiment: Path, surrogate: Path, weights: str) -> _Setup:
    """The experiment, the surrogate, the FE model it emulates and the objective."""
    from ..design.objective import check_weights
    from ..forward.spec import ModelSpec
    from ..inference.experiment_data import load_experiment
    from ..inference.experiment_processing import experiment_objective
    from ..surrogate.persistence import load_surrogate

    eta = check_weights([float(v) for v in weights.split(",")])
    exp = load_experiment(experiment)
    model = load_surrogate(surrogate)
    campaign = model.meta.get("campaign") or {}
    if "model" not in campaign:
        raise ValueError(f"{surrogate}: the surrogate does not record the model it was trained on")
    spec = ModelSpec.from_dict(campaign["model"])
    if (
        abs(spec.indenter.radius - exp.radius) > 1e-6
        or len(model.depth) != exp.steps
        or not np.allclose(model.depth, exp.depths)
    ):
        raise ValueError(
            f"the experiment (R = {exp.radius:g} mm, {exp.steps} x {exp.step_size:g} mm) does not match the "
            f"surrogate's model (R = {spec.indenter.radius:g} mm, {len(model.depth)} steps to {model.depth[-1]:g} mm)"
        )
    objective, dic = experiment_objective(exp, model.top_xyz)
    return _Setup(model, spec, objective, dic, eta)


def _mesh_check(spec, objective, eta, theta: np.ndarray, preset: str) -> dict:
    """FE runs at theta on the fit's mesh (with sensitivities) and on the finer ``preset``; the
    mesh check (inference/mesh_check.py) with the statistical bounds at theta (eq. 6 to 8)."""
    from ..forward.predictor import Prediction
    from ..forward.solver import simulate
    from ..forward.spec import MeshChoice
    from ..inference.mesh_check import mesh_check

    at = spec.with_material(c1=float(theta[0]), c5=float(theta[1]))
    err.print(f"solving at {np.round(theta, 3).tolist()} kPa on the fit's mesh and on '{preset}' ...")
    coarse = simulate(at, sensitivities=True)
    check = mesh_check(objective, eta, coarse, simulate(replace(at, mesh=MeshChoice(preset))))
    report = {
        "check_mesh": preset,
        "nodes": list(check.nodes),
        "refinement_ratio": check.refinement_ratio,
        "order": check.order,
        "safety_factor": check.safety,
        "shift_pct": check.shift_pct.tolist(),
        "theta": theta.tolist(),
        "theta_on_finer_mesh": check.corrected_theta.tolist(),
        "uncertainty_pct": check.uncertainty_pct.tolist(),
        "statistical_pct": check.statistical_pct.tolist(),
        "combined_pct": check.combined_pct.tolist(),
        "corrected_uncertainty_pct": check.corrected_uncertainty_pct.tolist(),
        "corrected_combined_pct": check.corrected_combined_pct.tolist(),
        "s": check.s,
    }
    return {"prediction": Prediction.from_results([coarse], ("c1", "c5")), "report": report}


def _mesh_check_report(path: Path, experiment: Path, theta_fit: np.ndarray) -> dict:
    """The mesh check of a fit.json or confirm.json, refused if it belongs to another experiment or lies far
    from this fit (its shift is a first-order result at its own theta)."""
    try:
        payload = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a readable fit.json or confirm.json ({exc})") from exc
    check = payload.get("mesh_check")
    if not isinstance(check, dict) or "corrected_uncertainty_pct" not in check or "theta" not in check:
        raise ValueError(
            f"{path}: no mesh check in it; run 'indent-studio fit' or 'confirm' with --check-mesh PRESET"
        )
    where = (payload.get("inputs") or {}).get("experiment")
    if where is not None and Path(where).resolve() != Path(experiment).resolve():
        raise ValueError(f"{path}: the mesh check was made for experiment {where}, not {experiment}")
    theta = np.asarray(check["theta"], float)
    far = np.abs(theta / np.asarray(theta_fit, float) - 1.0)
    if np.any(far > 0.1):
        raise ValueError(
            f"{path}: the mesh check was made at {theta.round(4).tolist()} kPa, more than 10 % from this fit "
            f"{np.round(theta_fit, 4).tolist()}; confirm at the fit first"
        )
    return {
        "file": str(path),
        "check_mesh": check["check_mesh"],
        "nodes": check["nodes"],
        "theta": theta.tolist(),
        "shift_pct": check["shift_pct"],
        "corrected_uncertainty_pct": check["corrected_uncertainty_pct"],
    }


def register(app: typer.Typer) -> None:
    """Add the inference commands to the studio's CLI."""

    @app.command("fit")
    def fit(
        experiment: EXPERIMENT,
        surrogate: SURROGATE,
        weights: WEIGHTS = "0.45,0.35,0.2,0",
        refine: Annotated[bool, typer.Option(help="refine on the FE solver with exact sensitivities")] = True,
        paper_stop: Annotated[bool, typer.Option(help="stop as soon as F < 3e-2 (the paper's rule)")] = False,
        check_mesh: Annotated[
            str | None,
            typer.Option(
                help="then solve at the fit on this finer mesh preset (e.g. reference): the fit carried "
                "there, with bounds that add that mesh's discretisation uncertainty (inference/mesh_check.py)"
            ),
        ] = None,
        out: OUT = None,
        as_json: JSON = False,
    ) -> None:
        """Inverse fit (2.8.2): Levenberg-Marquardt from {6, 300} kPa on the surrogate, then on the FE
        solver with its exact sensitivities; bounds from eq. 6 to 8 with s from the data. With
        --check-mesh, the mesh check of ``confirm --check-mesh`` at the fit, and the fit carried
        to the finer mesh (``posterior --mesh-check`` reads fit.json then)."""
        from ..forward.predictor import FESolverPredictor
        from ..inference.inverse_fit import PAPER_F_STOP, fit_parameters

        f_stop = PAPER_F_STOP if paper_stop else None
        try:
            st = _setup(experiment, surrogate, weights)
            model, spec, objective, dic, eta = st.model, st.spec, st.objective, st.dic, st.eta
            err.print(f"fitting on the {model.kind} surrogate ...")
            first = fit_parameters(objective, model, eta, f_stop=f_stop)
            final = first
            if refine:
                err.print(f"refining on the FE solver from {np.round(first.theta, 3).tolist()} kPa ...")
                final = fit_parameters(
                    objective, FESolverPredictor(spec), eta, theta0=first.theta, f_stop=f_stop
                )
            check = None
            if check_mesh is not None:
                check = _mesh_check(spec, objective, eta, final.theta, check_mesh)["report"]
        except (ValueError, OSError, RuntimeError) as exc:
            fail(str(exc), as_json)
        payload = {
            "c1": float(final.theta[0]),
            "c5": float(final.theta[1]),
            "c1_pct": float(final.bounds_pct[0]),
            "c5_pct": float(final.bounds_pct[1]),
            "F": final.F,
            "s": final.s,
            "n": final.n_residuals,
            "hessian": final.hessian.tolist(),
            "surrogate_fit": {"theta": first.theta.tolist(), "F": first.F, "wall_s": first.wall_s},
            "fe_fit": {"evaluations": final.evaluations, "wall_s": final.wall_s} if refine else None,
            "fiber_angle_deg": dic.fiber_angle_deg,
            "fiber_angle_estimated": dic.fiber_angle_estimated,
            "measured_nodes": int(objective.measured.sum()),
            "weights": eta.tolist(),
            "mesh_check": check,
            "inputs": {
                "experiment": str(experiment),
                "surrogate": str(surrogate),
                "model": spec.to_dict(),
            },
        }
        folder = out or Path(experiment) / "results"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "fit.json").write_text(json.dumps(payload, indent=1))
        payload["result_file"] = str(folder / "fit.json")
        if as_json:
            print(json.dumps(payload))
            return
        Console().print(
            f"c1 = {payload['c1']:.3f} kPa +- {payload['c1_pct']:.1f} %, c5 = {payload['c5']:.1f} kPa +- "
            f"{payload['c5_pct']:.1f} %  (F = {final.F:.3g}, s = {final.s:.3g}, n = {final.n_residuals})"
        )
        if check is not None:
            t, u = check["theta_on_finer_mesh"], check["corrected_combined_pct"]
            Console().print(
                f"carried to '{check_mesh}' ({check['nodes'][1]} nodes): c1 = {t[0]:.3f} kPa +- {u[0]:.1f} %, "
                f"c5 = {t[1]:.1f} kPa +- {u[1]:.1f} % (95 %, statistical and that mesh's GCI); on the fit's mesh "
                f"with its GCI: +- {check['combined_pct'][0]:.1f} %, +- {check['combined_pct'][1]:.1f} %"
            )

    @app.command("posterior")
    def posterior(
        experiment: EXPERIMENT,
        surrogate: SURROGATE,
        weights: WEIGHTS = "0.45,0.35,0.2,0",
        walkers: Annotated[int, typer.Option(help="emcee walkers")] = 32,
        steps: Annotated[int, typer.Option(help="emcee steps per walker")] = 4000,
        seed: Annotated[int, typer.Option(help="random seed")] = 0,
        mesh_check: Annotated[
            Path | None,
            typer.Option(
                help="a fit.json or confirm.json made with --check-mesh: carry the posterior to the "
                "finer mesh (shifted by the check's shift, spread by that mesh's GCI)"
            ),
        ] = None,
        out: OUT = None,
        as_json: JSON = False,
    ) -> None:
        """Posterior of (c1, c5) with emcee on the surrogate: log L = -F / (2 sigma^2) with sigma^2 =
        F(theta_hat) / (n - p), the residual variance of the surrogate fit (eq. 8's s is that times
        sqrt(p F_{p,n-p}^0.95), the 95 % factor, so it would widen the posterior by ~2.4x);
        uniform prior on the surrogate's training box; corner plot with the eq. 6 ellipse."""
        from ..design.certainty import bounds_pct
        from ..inference.inverse_fit import fit_parameters
        from ..inference.posterior import carried_to_finer_mesh, sample_posterior
        from .figures import corner_figure

        try:
            st = _setup(experiment, surrogate, weights)
            model, objective, eta = st.model, st.objective, st.eta
            fit = fit_parameters(objective, model, eta)
            sigma = float(np.sqrt(fit.F / (fit.n_residuals - len(fit.theta))))
            box = (model.scaler.lo, model.scaler.hi)
            err.print(f"sampling with {walkers} walkers x {steps} steps (sigma = {sigma:.3g}) ...")
            post = sample_posterior(objective, model, eta, sigma, box, fit.theta, walkers, steps, seed)
            carried, mark = None, fit.theta
            if mesh_check is not None:
                carried = _mesh_check_report(mesh_check, experiment, fit.theta)
                post = carried_to_finer_mesh(
                    post, carried["theta"], carried["shift_pct"], carried["corrected_uncertainty_pct"], seed
                )
                # the fit moved as the samples were
                mark = fit.theta + np.asarray(carried["theta"]) * np.asarray(carried["shift_pct"]) / 100.0
            folder = out or Path(experiment) / "results"
            png = corner_figure(post, folder / "corner.png", mark, fit.hessian, fit.s)
        except (ValueError, OSError, RuntimeError) as exc:
            fail(str(exc), as_json)
        summary = post.summary()
        # the Gaussian approximation at the fit: cov = 2 sigma^2 H^-1 (H in log theta ~ theta_bar)
        hessian_sd = fit.theta * bounds_pct(fit.hessian, sigma) / 100.0
        payload = {
            **summary,
            "corner_png": str(png),
            "fit": fit.theta.tolist(),
            "hessian_sd": hessian_sd.tolist(),
            "hessian_bounds_pct": bounds_pct(fit.hessian, fit.s).tolist(),
            "sigma": sigma,
            "carried_to_finer_mesh": carried,
        }
        (folder / "posterior.json").write_text(json.dumps(payload, indent=1))
        if as_json:
            print(json.dumps(payload))
            return
        for k, name in enumerate(post.parameters):
            lo, hi = summary["ci95"][k]
            Console().print(
                f"{name}: median {summary['median'][k]:.4g}, 95 % [{lo:.4g}, {hi:.4g}], sd {summary['std'][k]:.3g} "
                f"(Hessian sd {hessian_sd[k]:.3g})"
            )
        Console().print(
            f"acceptance {post.acceptance_fraction:.2f}, autocorrelation {np.round(post.autocorrelation_steps, 1).tolist()} "
            f"steps, converged {post.converged}; {png}"
        )
        if carried is not None:
            Console().print(
                f"carried to the '{carried['check_mesh']}' mesh ({carried['nodes'][1]} nodes): shifted by "
                f"{np.round(carried['shift_pct'], 2).tolist()} %, spread by its GCI "
                f"{np.round(carried['corrected_uncertainty_pct'], 2).tolist()} % (95 %)"
            )

    @app.command("confirm")
    def confirm(
        experiment: EXPERIMENT,
        surrogate: SURROGATE,
        c1: Annotated[float, typer.Option(help="fitted c1, kPa")],
        c5: Annotated[float, typer.Option(help="fitted c5, kPa")],
        weights: WEIGHTS = "0.45,0.35,0.2,0",
        solver: Annotated[str, typer.Option(help="embedded or febio")] = "embedded",
        check_mesh: Annotated[
            str | None,
            typer.Option(
                help="also solve on this finer mesh preset (e.g. fine): how far the mesh moves the fit, "
                "and its discretisation uncertainty (inference/mesh_check.py)"
            ),
        ] = None,
        out: OUT = None,
        as_json: JSON = False,
    ) -> None:
        """FE confirmation of a fit: F(theta_hat) from an FE run, and how far the surrogate's
        prediction is from that run. With --check-mesh, the parameter shift the finer mesh would
        give, the fit's bounds with the mesh's uncertainty added, and the fit carried to the
        finer mesh with that mesh's uncertainty (embedded solver). Written to confirm.json
        (``indent-studio posterior --mesh-check`` reads it)."""
        from ..forward.predictor import FESolverPredictor

        check = None
        try:
            st = _setup(experiment, surrogate, weights)
            model, spec, objective, eta = st.model, st.spec, st.objective, st.eta
            theta = np.array([[c1, c5]])
            if check_mesh is None:
                fe = FESolverPredictor(spec, solver=solver).predict(theta)
            else:
                if solver != "embedded":
                    raise ValueError("--check-mesh needs the embedded solver (exact sensitivities)")
                check = _mesh_check(spec, objective, eta, theta[0], check_mesh)
                fe = check["prediction"]
            sur = model.predict(theta)
        except (ValueError, OSError, RuntimeError) as exc:
            fail(str(exc), as_json)
        u_max = np.abs(fe.displacement[0]).max(axis=(0, 1))
        payload = {
            "F_fe": float(objective.value(fe, eta)[0]),
            "F_surrogate": float(objective.value(sur, eta)[0]),
            "force_diff_max_pct": float(100 * np.abs(sur.force[0] / fe.force[0] - 1).max()),
            "displacement_diff_max_pct": float(
                100 * (np.abs(sur.displacement[0] - fe.displacement[0]) / u_max).max()
            ),
            "solver": solver,
        }
        if check is not None:
            payload["mesh_check"] = check["report"]
        payload["inputs"] = {
            "experiment": str(experiment),
            "surrogate": str(surrogate),
            "theta": [c1, c5],
            "weights": eta.tolist(),
            "model": spec.to_dict(),
        }
        folder = out or Path(experiment) / "results"
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "confirm.json").write_text(json.dumps(payload, indent=1))
        payload["result_file"] = str(folder / "confirm.json")
        if as_json:
            print(json.dumps(payload))
            return
        Console().print(
            f"F(theta_hat) on {solver}: {payload['F_fe']:.4g} (surrogate {payload['F_surrogate']:.4g}); surrogate vs FE: "
            f"force {payload['force_diff_max_pct']:.2f} %, field {payload['displacement_diff_max_pct']:.2f} % of max |u|"
        )
        if check is not None:
            m = check["report"]
            Console().print(
                f"mesh check ({m['nodes'][0]} -> {m['nodes'][1]} nodes): the finer mesh moves c1 by "
                f"{m['shift_pct'][0]:+.2f} % and c5 by {m['shift_pct'][1]:+.2f} %; 95 % bounds c1 +-"
                f"{m['statistical_pct'][0]:.2f} % (statistical, eq. 6-8) -> +-{m['combined_pct'][0]:.2f} % with the "
                f"mesh's uncertainty, c5 +-{m['statistical_pct'][1]:.2f} % -> +-{m['combined_pct'][1]:.2f} %"
            )
            t, u = m["theta_on_finer_mesh"], m["corrected_combined_pct"]
            Console().print(
                f"carried to the finer mesh: c1 = {t[0]:.4g} kPa +- {u[0]:.2f} %, c5 = {t[1]:.4g} kPa +- {u[1]:.2f} % "
                f"(95 %, statistical and the finer mesh's GCI)"
            )
