"""The adequacy test of a fit: the noise model, the other readings and the model's own uncertainty
put together, and the chi-square test at the fit. The parameters that sit at an end of their range are named and, where the fit is
flagged, mu identified narrowly while the model misses (mu on a composite: it absorbs model
error).
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from ..budgets.model_error import has_high_fidelity_level, residual_changes
from ..experiment.processing import (
    node_interpolation,
)
from .chi_square import Adequacy, chi_square_test
from .field_error import field_variance, shipped_field_error
from .noise import noise_model
from .registration import (
    _gradients,
    operator_bias,
    registration_alternatives,
)

__all__ = ["fit_adequacy", "model_adequacy", "parameters_at_ends", "training_box_ends"]


def _named(fr: dict, flagged: bool, at_ends: list[dict]) -> list[dict]:
    """The parameters a fit names: those at a range end and, when it is flagged, mu fitted
    (``fr``: fit.json's 'friction') while the model misses the data: identified (a narrow
    interval: it absorbs model error) or pressed against an end of its range (its interval
    reaching it: the fit moves it as far as it may to take up the misfit)."""
    named = list(at_ends)
    if not flagged or "mu" not in fr or any(d["parameter"] == "mu" for d in named):
        return named
    lo, hi = fr["mu_interval"]
    ends = [side for side, reached in (fr.get("mu_reaches_range_end") or {}).items() if reached]
    if fr.get("mu_identified"):
        reason = (
            f"identified at {fr['mu']:.3g} (95 % within [{lo:.3g}, {hi:.3g}]) while the model misses the "
            "data: mu absorbs model error here, its value is not a friction coefficient"
        )
    elif ends:
        reason = (
            f"fitted at {fr['mu']:.3g}, its 95 % interval [{lo:.3g}, {hi:.3g}] reaching the range's "
            f"{' and '.join(ends)} end while the model misses the data: mu moves to take up the misfit, "
            "its value is not a friction coefficient"
        )
    else:
        return named
    return [*named, {"parameter": "mu", "reason": reason}]


def model_adequacy(
    inputs,
    fit,
    *,
    force_noise: float | None = None,
    dic_noise: float | None = None,
    at_ends: list[dict] | None = None,
    friction: dict | None = None,
    registration_mm: float = 0.0,
    model_directions: np.ndarray | None = None,
    field_variance: np.ndarray | None = None,
) -> Adequacy:
    """The adequacy test of ``fit`` (a :class:`inference.fit.inverse_fit.FitResult` carrying its
    residuals) on ``inputs`` (:class:`inference.fit.inputs.FitInputs`): the chi-square statistic
    of its residuals whitened by the data's noise (module docstring), its degrees of freedom and
    p-value; flagged beyond the upper ``ALPHA`` tail. ``force_noise`` (relative, one reading) and
    ``dic_noise`` (mm) are declared levels; ``at_ends`` are parameters the caller found at a range
    end ({"parameter", "reason"}), named; ``friction`` (fit.json's 'friction') names mu when it
    was identified narrowly while the fit is flagged; ``registration_mm`` the declared registration
    uncertainty, profiled (:func:`registration_alternatives`); ``model_directions`` the model's own stated uncertainty
    in residual space and ``field_variance`` its field error's variance at the nodes
    (:func:`chi_square_test`)."""
    if fit.residuals is None:
        raise ValueError("the fit records no residuals: the adequacy test needs them")
    objective, exp, dic = inputs.objective, inputs.experiment, inputs.dic
    steps = np.asarray(objective.steps, int) + 1
    # the declared registration uncertainty: profiled over (the processing run again about other
    # indentation points) where the residual vector is known to it, else in the covariance
    alternatives = None
    if registration_mm > 0:
        alternatives = fit.residuals[None, :] + registration_alternatives(
            objective, dic, exp.used_steps, inputs.eta, registration_mm
        )
    noise, f_inf = noise_model(exp, dic, steps, force_noise=force_noise, dic_noise=dic_noise)
    plan = node_interpolation(dic, np.asarray(objective.top_xyz)[:, :2], used_steps=exp.used_steps)
    grads = _gradients(plan, dic, steps, objective.measured)
    bias = None
    if fit.prediction is not None:
        bias = operator_bias(fit.prediction, plan, dic, steps, objective.measured)
    statistic, dof, terms = chi_square_test(
        fit.residuals,
        objective,
        inputs.eta,
        noise=noise,
        plan=plan,
        gradients=grads,
        p=fit.theta.size,
        operator_bias=bias,
        jacobian=fit.jacobian,
        model_directions=model_directions,
        alternatives=alternatives,
        field_variance=field_variance,
    )
    p_value = float(stats.chi2.sf(statistic, dof)) if dof > 0 else float("nan")
    force_pct = float(np.median(100.0 * noise.force_sd_mN / np.abs(f_inf)))
    out = Adequacy(
        float(statistic),
        int(dof),
        p_value=p_value,
        n=dof + fit.theta.size,
        p=fit.theta.size,
        terms=terms,
        noise=noise,
        force_sd_pct=force_pct,
    )
    out.named = _named(friction or {}, out.flagged, at_ends or [])
    return out


def training_box_ends(model, theta) -> list[tuple[int, str]]:
    """The entries of ``theta`` at or beyond an end of the box ``model`` was trained on, within
    0.5 % (outside it a surrogate extrapolates): (index, ``lower`` or ``upper``); none for a
    Predictor without a training box. ``theta`` may be shorter than the model's parameters (mu held)."""
    scaler = getattr(model, "scaler", None)
    if scaler is None:
        return []
    out = []
    for j in range(min(np.size(theta), len(model.parameters))):
        lo, hi = float(scaler.lo[j]), float(scaler.hi[j])
        where = "lower" if theta[j] <= lo * 1.005 else "upper" if theta[j] >= hi * 0.995 else None
        if where is not None:
            out.append((j, where))
    return out


def parameters_at_ends(result) -> list[dict]:
    """The parameters of an :class:`inference.fit.result.ExperimentFit` that sit at an end of
    their range: mu on its range's limit, and c1, c5 (and mu) at or beyond the ends of the box
    the surrogate was trained on (within 0.5 %: outside it a surrogate extrapolates, and where the
    FE stage went there the surrogate's start says nothing of it)."""
    out = []
    theta = np.asarray(result.fit.theta, float)
    names = ("c1", "c5", "mu")
    fr = result._friction_dict() if result.friction.fits_mu else {}
    if fr.get("mu_at_limit"):
        out.append(
            {
                "parameter": "mu",
                "reason": f"on its range's {fr['mu_at_limit']} limit ({fr['mu']:.3g}; range {fr['mu_range']})",
            }
        )
    model = result.inputs.surrogate
    for j, where in training_box_ends(model, theta):
        name = model.parameters[j]
        if name == "mu" and out:
            continue
        lo, hi = float(model.scaler.lo[j]), float(model.scaler.hi[j])
        beyond = theta[j] < lo or theta[j] > hi
        stage = "the FE stage's fit" if result.refined else "the fit"
        out.append(
            {
                "parameter": names[j] if name not in names else name,
                "reason": (
                    f"{theta[j]:.4g} is {'beyond' if beyond else 'at'} the {where} end of the {model.kind} "
                    f"surrogate's training range [{lo:.4g}, {hi:.4g}] ({stage})"
                ),
            }
        )
    return out


def _model_directions(result) -> np.ndarray | None:
    """A multi-fidelity fit's discrepancy uncertainty at its fit, in residual space (one standard
    deviation a row): what the model states it does not know, which the test allows beside the
    noise. None for a surrogate without a high-fidelity level."""
    model, tested = result.inputs.surrogate, result.tested_fit
    if not has_high_fidelity_level(model) or tested.prediction is None:
        return None
    factor = model.discrepancy_covariance_factor(result._theta_in_surrogate())
    return residual_changes(result.inputs.objective, result.inputs.eta, tested.prediction, factor)


def _field_error(result) -> tuple[np.ndarray | None, dict | None]:
    """The high fidelity's field error at the fit's nodes and steps (``field_variance``), and what
    it is, where a table was shipped for the test and mesh the surrogate was trained on (its
    campaign's model: the stick's, also for a fit that marginalises mu); else (None, None)."""
    model = result.inputs.surrogate
    campaign = ((getattr(model, "meta", {}) or {}).get("campaign") or {}).get("model")
    if not campaign or not has_high_fidelity_level(model):
        return None, None
    table = shipped_field_error(campaign, (campaign.get("mesh") or {}).get("preset"))
    if table is None:
        return None, None
    objective = result.inputs.objective
    nodes = np.asarray(objective.top_xyz)[objective.measured][:, :2]
    depths = np.asarray(result.inputs.spec.protocol.depths, float)[np.asarray(objective.steps, int)]
    try:
        variance = field_variance(table, nodes, depths)
    except ValueError:  # another protocol's depths: not measured for this test
        return None, None
    about = {
        "file": table["file"],
        "coarse_mesh": table["coarse_mesh"],
        "fine_mesh": table["fine_mesh"],
        "points": len(table.get("pairs", [])),
    }
    return variance, about


def fit_adequacy(
    result,
    *,
    force_noise: float | None = None,
    dic_noise: float | None = None,
    registration_mm: float = 0.0,
) -> tuple[Adequacy | None, str | None]:
    """The adequacy test of an :class:`inference.fit.result.ExperimentFit`'s final fit (its
    ``tested_fit``: the FE model's residuals at the fit when an FE confirmation ran), with
    the parameters it names, the declared registration uncertainty and, for a multi-fidelity
    surrogate, its discrepancy's uncertainty at the fit and its high fidelity's field error
    (:mod:`.field_error`, where measured) in the covariance; or None and why the test could not be made (the fit's residuals
    missing, a hold without a standard error and no noise declared, too few DIC points)."""
    try:
        fr = result._friction_dict() if result.friction.fits_mu else {}
        variance, about = _field_error(result)
        test = model_adequacy(
            result.inputs,
            result.tested_fit,
            force_noise=force_noise,
            dic_noise=dic_noise,
            at_ends=parameters_at_ends(result),
            friction=fr,
            registration_mm=registration_mm,
            model_directions=_model_directions(result),
            field_variance=variance,
        )
        test.field_error = about
        return test, None
    except (ValueError, np.linalg.LinAlgError) as exc:
        return None, f"the adequacy test could not be made: {exc}"
