"""The error budget of a model (computing one fits a reference campaign, which is inference's;
reading a measured one is
:mod:`indentation_studio.surrogate.error_budgets`'s): the parameter bias it causes in a fit, beside what a typical
experiment can resolve.

At each test point theta_t of a reference campaign (noise-free responses of a finer model), the
reference is read at the model's top nodes and fitted with the model, with the fit's own
objective (eq. 4, 5, Appendix B weights) and weights. The bias is theta_fit / theta_t - 1. It is
set beside the 95 % half-width of eq. 6 to 8 that a typical experiment gives on the same
objective: force noise ``force_noise`` (relative, per step) and DIC noise ``dic_noise`` (mm, per
node), whose expected objective value F_noise = sum_k eta_k E|r_k|^2 gives s by eq. 8.

A model is converged for that test when its bias is well inside the half-width; the studio asks
for a third (:data:`CONVERGED_FRACTION`). For a surrogate the bias is split into a
discretisation part (the FE model it emulates, fitted the same way) and a surrogate part (the
rest). FE models are fitted by Gauss-Newton from theta_t (with their exact
sensitivities, at most ``fe_steps``: each one simulation); surrogates by Levenberg-Marquardt to
convergence."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from ...design.certainty import bounds_pct, s_from_data
from ...design.objective import PAPER_WEIGHTS, Objective, check_weights
from ...forward.convergence.richardson import RichardsonPredictor
from ...forward.fe_predictor import FESolverPredictor
from ...forward.mesh import build_mesh
from ...forward.predictor import CachedPredictor, Prediction
from ...forward.result import SimulationResult
from ..fit.inverse_fit import fit_parameters
from .budget_models import resolve_model
from .budget_table import CONVERGED_FRACTION, ErrorBudget
from .mesh_check import prediction_at_nodes

__all__ = [
    "CONVERGED_FRACTION",
    "ErrorBudget",
    "compute_error_budget",
    "model_top_xyz",
    "noise_objective_value",
    "reference_prediction",
    "resolve_model",
]


def noise_objective_value(objective: Objective, eta, force_noise: float, dic_noise: float) -> float:
    """E[F] of eq. 5 for pure measurement noise, through the objective's normalisation and weights.

    Parameters
    ----------
    objective : Objective
        The objective (its normalisation and nodal weights).
    eta : array_like
        The weights of eq. 5.
    force_noise : float
        Relative force noise per step.
    dic_noise : float
        DIC noise at every measured node, mm.

    Returns
    -------
    float
        The expected F.
    """
    e = check_weights(eta)
    steps = len(objective.steps)
    force_term = steps * force_noise**2
    scale = objective.displacement_residual_scale()[objective.measured]  # (nodes, 3)
    field_terms = steps * dic_noise**2 * np.sum(scale**2, axis=0)
    return float(e[0] * force_term + e[1:] @ field_terms)


def model_top_xyz(model) -> np.ndarray:
    """The top nodes a Predictor answers on: a surrogate's ``top_xyz``, an FE model's mesh top."""
    if hasattr(model, "top_xyz"):
        return np.asarray(model.top_xyz, float)
    if _is_fe(model):
        mesh = build_mesh(model.spec)
        return mesh.nodes[mesh.top]
    raise TypeError(f"cannot tell the top nodes of {type(model).__name__}")


def reference_prediction(result: SimulationResult, top_xyz: np.ndarray) -> Prediction:
    """A reference simulation read at other top nodes (steps without depth 0)."""
    return prediction_at_nodes(result, top_xyz)


def _is_fe(model) -> bool:
    """FE models (fitted by Gauss-Newton from the truth) as opposed to surrogates."""
    inner = model.predictor if isinstance(model, CachedPredictor) else model
    return isinstance(inner, FESolverPredictor | RichardsonPredictor)


def _check_same_test(name: str, model, result: SimulationResult) -> None:
    """The model must simulate the reference's test: the same depths and indenter radius."""
    if _is_fe(model):
        depth, radius = np.asarray(model.spec.protocol.depths), model.spec.indenter.radius
    else:
        spec = (getattr(model, "meta", {}).get("campaign") or {}).get("model") or {}
        depth, radius = np.asarray(model.depth), (spec.get("indenter") or {}).get("radius")
    ref_depth, ref_radius = np.asarray(result.depth[1:]), float(result.spec["indenter"]["radius"])
    if depth.shape != ref_depth.shape or not np.allclose(depth, ref_depth):
        raise ValueError(f"model {name!r} simulates other depths than the reference ({len(depth)} steps)")
    if radius is not None and abs(float(radius) - ref_radius) > 1e-9:
        raise ValueError(f"model {name!r} has R = {radius:g} mm, the reference R = {ref_radius:g} mm")


def _fit_bias(model, objective: Objective, eta: np.ndarray, theta_t: np.ndarray, fe_steps: int) -> tuple:
    """(theta_fit, Jacobian in log theta at the fit) for one model and one reference target."""
    if _is_fe(model):  # Gauss-Newton from the truth, exact sensitivities
        theta = theta_t.copy()
        for _ in range(fe_steps):
            pred = model.predict(theta[None, :], jacobian=True)
            r = objective.residuals(pred, eta)[0]
            J = objective.jacobian(pred, eta)[0] * theta
            delta, *_ = np.linalg.lstsq(J, -r, rcond=None)
            theta = theta * np.exp(delta)
            if np.max(np.abs(delta)) < 1e-3:
                break
        return theta, J
    fit = fit_parameters(objective, model, eta, theta0=theta_t)
    pred = model.predict(fit.theta[None, :], jacobian=True)
    return fit.theta, objective.jacobian(pred, eta)[0] * fit.theta


def compute_error_budget(
    reference: Sequence[SimulationResult],
    models: Mapping[str, object],
    *,
    fe_models: Mapping[str, object] | None = None,
    weights=PAPER_WEIGHTS,
    force_noise: float = 0.02,
    dic_noise: float = 0.02,
    reference_source: dict | None = None,
    fe_steps: int = 3,
    progress: Callable[[str], None] | None = None,
    fov_mm: float | None = 25.0,
    done_rows: Sequence[dict] = (),
    on_row: Callable[[ErrorBudget], None] | None = None,
    fe_names: Mapping[str, str] | None = None,
    reading: str = "fit",
) -> ErrorBudget:
    """Fit each model to each noise-free reference response and tabulate the biases.

    The biases stand beside the typical 95 % half-width at the given noise.

    Parameters
    ----------
    reference : sequence of SimulationResult
        The noise-free responses (the test points).
    models : mapping of str to Predictor
        Name -> an FE model or a surrogate.
    fe_models : mapping of str to Predictor, optional
        Name -> the FE Predictor a surrogate of that name emulates: splits a surrogate's bias into
        discretisation and surrogate parts.
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    force_noise : float, default 0.02
        Relative force noise per step.
    dic_noise : float, default 0.02
        DIC noise, mm.
    reference_source : dict, optional
        Where the reference came from (provenance).
    fe_steps : int, default 3
        Gauss-Newton steps of the FE models' fits.
    progress : callable, optional
        Told of every fit.
    fov_mm : float or None, default 25.0
        Only the top nodes within this of the indentation axis are measured (a DIC field of
        view; None: the whole top).
    done_rows : sequence of dict, default ()
        Rows of an earlier, interrupted budget with the same settings (as in its JSON): those
        (model, test point) pairs are kept, not fitted again.
    on_row : callable, optional
        Called with the budget so far after every new row, so that a caller can save it.
    fe_names : mapping of str to str, optional
        Surrogate name -> the name its FE model has among ``models`` (e.g. its mesh preset): when
        that FE model is budgeted too, its fit at the same point is the surrogate's
        discretisation part, not fitted a second time.
    reading : str, default "fit"
        How eq. 4 is read (:class:`Objective`): by default as the studio's fits read it (DIC
        from 1.5 R), so that the budget is the bias of those fits.

    Returns
    -------
    ErrorBudget
        The table of biases and half-widths.

    Raises
    ------
    ValueError
        If there is no reference response, or a noise level is not positive.
    """
    eta = check_weights(weights)
    if not reference:
        raise ValueError("the error budget needs at least one reference response")
    if not (force_noise > 0 and dic_noise > 0):
        raise ValueError(f"noise levels must be positive, got {force_noise}, {dic_noise}")
    fe_models, fe_names = dict(fe_models or {}), dict(fe_names or {})
    rows: list[dict] = []
    previous = {_row_key(r["model"], (r["c1_true"], r["c5_true"])): dict(r) for r in done_rows}
    known = dict(previous)  # every row at hand, kept or fitted here, by (model, test point)

    def budget() -> ErrorBudget:
        source = dict(reference_source or {})
        return ErrorBudget(pd.DataFrame(rows), eta, force_noise, dic_noise, source, fov_mm, fe_steps, reading)

    for name, model in models.items():
        top = None
        fe = fe_models.get(name)
        for result in reference:
            _check_same_test(name, model, result)
            m = result.spec["material"]
            theta_t = np.array([m["c1"], m["c5"]], float)
            key = _row_key(name, theta_t)
            if key in previous:
                rows.append(previous[key])
                continue
            top = model_top_xyz(model) if top is None else top
            if progress is not None:
                progress(f"{name} at {theta_t.round(3).tolist()} kPa")
            target = reference_prediction(result, top)
            in_view = None if fov_mm is None else np.linalg.norm(top[:, :2], axis=1) <= fov_mm
            objective = Objective.from_prediction(
                target, radius=float(result.spec["indenter"]["radius"]), mask=in_view, reading=reading
            )
            theta_fit, J = _fit_bias(model, objective, eta, theta_t, fe_steps)
            s = s_from_data(
                noise_objective_value(objective, eta, force_noise, dic_noise), objective.data_points(eta)
            )
            half = bounds_pct(2.0 * J.T @ J, s)
            bias = 100.0 * (theta_fit / theta_t - 1.0)
            row = {"model": name, "c1_true": theta_t[0], "c5_true": theta_t[1]}
            row |= {"c1_fit": theta_fit[0], "c5_fit": theta_fit[1]}
            row |= {"c1_bias_pct": bias[0], "c5_bias_pct": bias[1]}
            row |= {"c1_half_width_pct": half[0], "c5_half_width_pct": half[1]}
            if fe is not None:
                fe_row = known.get(_row_key(fe_names.get(name), theta_t))
                if fe_row is not None:  # that FE model is in the budget too: its fit is the split
                    fe_fit = np.array([fe_row["c1_fit"], fe_row["c5_fit"]], float)
                else:
                    fe_fit, _ = _fit_bias(fe, objective, eta, theta_t, fe_steps)
                disc = 100.0 * (fe_fit / theta_t - 1.0)
                row |= {"c1_discretisation_pct": disc[0], "c5_discretisation_pct": disc[1]}
                row |= {"c1_surrogate_pct": bias[0] - disc[0], "c5_surrogate_pct": bias[1] - disc[1]}
            rows.append(row)
            known[key] = row
            if on_row is not None:
                on_row(budget())
    return budget()


def _row_key(model: str | None, theta_t) -> tuple:
    """A (model, test point) pair, the unit an interrupted budget resumes by."""
    return (str(model), *(round(float(t), 9) for t in theta_t))
