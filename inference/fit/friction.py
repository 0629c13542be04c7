"""The friction path of a fit: mu known, identified or marginalised, on a surrogate trained with mu
or through the FE stage of one without (paper 2.8.2 with mu; README, 'Friction'): how mu is treated
when not told, the range it is kept in, the surrogate stage with mu, the FE stage's start in mu and
the restarts from a better point found at a range end."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...design.friction_treatment import DEFAULT_MU_RANGE, FixedParameter, FrictionTreatment
from ...forward.solver import SimulationError
from ..adequacy.of_fit import training_box_ends
from ..budgets.model_error import has_high_fidelity_level
from ..experiment.processing_error import REGISTRATION_MM
from .error_parts import (
    model_error_with_mu,
    mu_held_out_refits,
    mu_model_error_pct,
    mu_model_error_unmeasured,
    stick_mesh_budget,
    with_processing_part,
)
from .inputs import FitInputs
from .inverse_fit import PAPER_START, FitResult, _told, fit_parameters
from .mu_reach import _mu_reach
from .result import ExperimentFit, _confirm

__all__ = [
    "FE_MU_STARTS",
    "MAX_RESTARTS",
    "check_parameter_order",
    "default_friction",
    "fit_on_surrogate_with_mu",
    "surrogate_with_mu",
]


def default_friction(surrogate, fe_stage: bool = True) -> FrictionTreatment:
    """How a fit treats mu when not told.

    On a surrogate trained with mu: marginalised (a log-uniform prior over its mu range; it has
    no contact to assume). On one without: marginalised
    over 0.1 .. 3 when the FE stage can bring mu in (``fe_stage``: the FE refinement and no mesh
    check, which is made with the stick) and the surrogate is single-level (a multi-fidelity
    surrogate's FE stage is the high-fidelity mesh's Gauss-Newton check, with its own model
    error); else the surrogate's contact assumed, the fit warning what that costs.
    Why (README, "Friction"): on synthetic data made with mu = 0.3, 1, 3 and the perfect stick
    (two truths), a perfect-stick fit put c5 28 to 34 % low at mu = 0.3, the truth outside its
    bounds, while the marginalised fit held the truth in every case; where nothing slips it gives
    the stick's (c1, c5) and bounds, mu's interval then reaching the range's upper end.

    Parameters
    ----------
    surrogate : FieldSurrogate
        The surrogate the fit starts on.
    fe_stage : bool, default True
        Whether the FE stage can bring mu in (the FE refinement and no mesh check).

    Returns
    -------
    FrictionTreatment
        ``marginalise`` (no range of its own: the fit takes the surrogate's mu range, else
        0.1 .. 3) or ``assumed``.
    """
    if "mu" in surrogate.parameters or (fe_stage and not has_high_fidelity_level(surrogate)):
        return FrictionTreatment("marginalise")
    return FrictionTreatment()


def _mu_range(treatment: FrictionTreatment, surrogate, fe_stage: bool = False) -> tuple[float, float] | None:
    """The range mu is kept in (identify) or the prior's (marginalise): the treatment's, else the
    surrogate's training range when mu is one of its parameters, else DEFAULT_MU_RANGE. A range
    or a known mu outside the surrogate's training range is refused (the surrogate would
    extrapolate) unless an FE stage follows (``fe_stage``: the surrogate stage then keeps to its
    own range and the FE stage takes the one asked for)."""
    if "mu" not in surrogate.parameters:
        return (treatment.mu_range or DEFAULT_MU_RANGE) if treatment.fits_mu else None
    j = surrogate.parameters.index("mu")
    lo, hi = float(surrogate.scaler.lo[j]), float(surrogate.scaler.hi[j])
    wanted = treatment.mu_range or (lo, hi)
    if treatment.mode == "known":
        wanted = (treatment.value, treatment.value)
    if not fe_stage and (wanted[0] < lo * (1 - 1e-9) or wanted[1] > hi * (1 + 1e-9)):
        raise ValueError(
            f"friction: mu {wanted[0]:g}..{wanted[1]:g} lies outside the range the surrogate was trained "
            f"on ({lo:g}..{hi:g}); fit with the FE stage on a surrogate without mu, or train one wider"
        )
    return wanted if treatment.fits_mu else None


def check_parameter_order(model) -> None:
    """A surrogate with mu must take theta as (c1, c5, mu): the fits, the bounds and the posterior
    read mu as the third parameter. Campaign grids are put in that order whatever the order
    written (:func:`campaign.designs.parse_grid`); a surrogate of another order is refused here."""
    names = tuple(model.parameters)
    if "mu" in names and names != ("c1", "c5", "mu"):
        raise ValueError(
            f"friction: this surrogate's parameters are {names}; a fit with mu needs them as "
            "('c1', 'c5', 'mu'): train it again on a campaign whose grid gives c1, c5, mu"
        )


def surrogate_with_mu(
    model, treatment: FrictionTreatment, mu_range: tuple[float, float] | None
) -> tuple[object, tuple[np.ndarray, np.ndarray]]:
    """The Predictor a fit or a posterior on a surrogate trained with mu (its third parameter) works
    on, and the box theta stays in: mu held (``known``: a FixedParameter over (c1, c5), mu at the
    training range's nearest end if outside it) or fitted within ``mu_range`` (identify,
    marginalise), inside the box the surrogate was trained on (outside it a GP falls back to its
    mean)."""
    check_parameter_order(model)
    inside = (np.array(model.scaler.lo, float), np.array(model.scaler.hi, float))  # copies
    lo, hi = inside[0][2], inside[1][2]
    if treatment.mode == "known":
        held = FixedParameter(model, "mu", float(np.clip(treatment.value, lo, hi)))
        return held, (inside[0][:2], inside[1][:2])
    if not treatment.fits_mu:
        raise ValueError(f"friction {treatment.mode}: a surrogate with mu needs mu held or fitted")
    inside[0][2], inside[1][2] = np.clip(mu_range[0], lo, hi), np.clip(mu_range[1], lo, hi)
    if inside[1][2] <= inside[0][2]:
        raise ValueError(f"friction: mu's range {mu_range} misses the surrogate's ({lo:g}..{hi:g})")
    return model, inside


def fit_on_surrogate_with_mu(
    objective,
    model,
    eta,
    treatment: FrictionTreatment,
    mu_range: tuple[float, float] | None,
    f_stop: float | None = None,
) -> FitResult:
    """The surrogate stage of a fit on a surrogate trained with mu (:func:`surrogate_with_mu`):
    with mu fitted, from the paper's start at three mu spread in log over the range (where nothing
    slips d/dmu = 0 holds a single start still), the best kept."""
    predictor, box = surrogate_with_mu(model, treatment, mu_range)
    if treatment.mode == "known":
        return fit_parameters(objective, predictor, eta, f_stop=f_stop, box=box)
    starts = np.geomspace(box[0][2], box[1][2], 3)
    fits = [fit_parameters(objective, model, eta, (*PAPER_START, m), f_stop, box=box) for m in starts]
    return min(fits, key=lambda fit: fit.F)


def _fit_with_friction(
    inputs: FitInputs,
    treatment: FrictionTreatment,
    stage: str,
    f_stop: float | None,
    check_mesh: str | None,
    say: Callable[[str], None],
    registration_mm: float = REGISTRATION_MM,
) -> ExperimentFit:
    """fit_experiment with mu known, identified or marginalised (or a surrogate with mu)."""
    model, spec = inputs.surrogate, inputs.spec
    with_mu = "mu" in model.parameters
    if with_mu and treatment.mode == "assumed":
        raise ValueError(
            "friction: this surrogate was trained with mu as a parameter; say how the fit treats it "
            "(a value, 'identify' or 'marginalise')"
        )
    if with_mu:
        check_parameter_order(model)
    if check_mesh is not None:
        raise ValueError("friction: the mesh check is made with the perfect stick; fit without --check-mesh")
    refine = stage == "fit"
    mu_range = _mu_range(treatment, model, fe_stage=refine)
    if not with_mu and not refine and treatment.fits_mu:
        raise ValueError(
            f"friction {treatment.mode}: the surrogate has no mu, so only the FE stage can bring it in; "
            "fit with the FE refinement (--fe-stage fit)"
        )
    if not with_mu and not refine:  # mu known: the surrogate's contact is not that mu's
        raise ValueError(
            f"friction {treatment.mode}: the surrogate has no mu, so only the FE fit can hold it at "
            f"{treatment.value:g}; fit with --fe-stage fit"
        )
    obj, eta = inputs.objective, inputs.eta
    say(
        f"fitting on the {model.kind} surrogate ({treatment.describe(spec.contact.describe(), mu_range)}) ..."
    )
    if with_mu:
        first = fit_on_surrogate_with_mu(obj, model, eta, treatment, mu_range, f_stop)
        inside = surrogate_with_mu(model, treatment, mu_range)[1]
    else:  # (c1, c5) with the surrogate's contact: the FE stage's start
        first = fit_parameters(obj, model, eta, f_stop=f_stop)
        inside = None
    final = first
    fitted_on, fit_box = model, inside
    edge = [model.parameters[j] for j, _ in training_box_ends(model, first.theta) if j < 2]
    if stage == "confirm" and with_mu and edge:
        # the surrogate cannot give a value outside its box, and a Gauss-Newton step from its edge
        # is held there: the FE model, which can, fits instead
        say(
            f"the surrogate's fit sits at the edge of its training box in {', '.join(edge)}: the data may "
            "want a value outside it; fitting on the FE model instead (LM with exact sensitivities) ..."
        )
        stage, refine = "fit", True
    if refine:
        box = None
        if treatment.mode == "known":
            fe = inputs.fe_model(friction=treatment.value)
            start = first.theta
        else:
            fe = inputs.fe_model(with_mu=True)
            box = (np.array([0.0, 0.0, mu_range[0]]), np.array([np.inf, np.inf, mu_range[1]]))
            start = first.theta if with_mu else _fe_start(obj, fe, eta, first.theta, mu_range, say)
        say(f"refining on the FE solver from {np.round(start, 3).tolist()} ...")
        final = fit_parameters(obj, fe, eta, theta0=start, f_stop=f_stop, box=box, progress=_told(say))
        fitted_on, inside, fit_box = fe, None, box
    reach, notes, restarts = None, {}, []
    if treatment.fits_mu:
        say("checking mu's certainty region up to its range's ends (c1, c5 fitted again there) ...")
        reach, notes, better = _mu_reach(obj, fitted_on, eta, final, mu_range, inside)
        # a point at a range end with F below the fit's certainty region: the fit is a local
        # minimum (a poor surrogate stage can start the FE stage in another basin), so fit again
        while better is not None and len(restarts) < MAX_RESTARTS:
            theta_b, F_b = better
            say(
                f"F = {F_b:.4g} at {np.round(theta_b, 3).tolist()} lies below the fit's F = {final.F:.4g}: "
                "the fit was a local minimum; fitting again from there ..."
            )
            again = fit_parameters(
                obj,
                fitted_on,
                eta,
                theta0=theta_b,
                f_stop=f_stop,
                box=fit_box,
                progress=_told(say) if refine else None,
            )
            restarts.append(
                {"from": theta_b.tolist(), "F_there": F_b, "F_before": final.F, "F_after": again.F}
            )
            if again.F >= final.F:
                break
            final = again
            reach, notes, better = _mu_reach(obj, fitted_on, eta, final, mu_range, inside)
    fit = ExperimentFit(
        inputs,
        first,
        fit=final,
        refined=refine,
        mesh_check=None,
        check_mesh=None,
        model_error=None,
        friction=treatment,
        mu_range=mu_range,
    )
    if with_mu:
        fit.model_error = model_error_with_mu(
            inputs,
            treatment,
            mu_range,
            final.theta,
            on_surrogate=not refine,
            registration_mm=registration_mm,
            say=say,
        )
    else:  # the stick surrogate's field at (c1, c5) stands for the model's
        error = stick_mesh_budget(model, fit.contact, spec.contact.describe(), theta=final.theta)
        fit.model_error = with_processing_part(
            error, inputs, final.theta[:2], fit.contact, registration_mm, say
        )
    fit.mu_reach, fit.mu_reach_notes, fit.restarts = reach, notes, restarts
    if with_mu and treatment.fits_mu:
        refits = mu_held_out_refits(inputs, final.theta)
        if refits is not None:
            say(
                f"mu made again with each of the discrepancy's held-out errors: {refits.refits.shape[0]} refits ..."
            )
        fit.mu_refits = refits
        fit.mu_unmeasured = mu_model_error_unmeasured(inputs)
        fit.mu_model_pct = mu_model_error_pct(
            inputs,
            final.theta,
            on_surrogate=not refine,
            refits=refits,
            model_error=fit.model_error,
        )
    if stage == "confirm":
        say(f"confirming on the FE solver at {np.round(final.theta, 3).tolist()} ...")
        if treatment.mode == "known":
            fe = inputs.fe_model(friction=treatment.value)
        else:
            fe = inputs.fe_model(with_mu=True)
        fit.confirmation = _confirm(fit, fe, inside if treatment.fits_mu else None)
    return fit


#: Starts in mu of the FE stage of a fit with mu on a surrogate without it (spread in log over mu's range).
FE_MU_STARTS = 3


def _fe_start(objective, fe, eta, theta: np.ndarray, mu_range: tuple[float, float], say) -> np.ndarray:
    """Where the FE stage of a fit with mu starts when the surrogate has no mu: (c1, c5) of the
    surrogate stage with the mu of ``FE_MU_STARTS`` spread in log over the range whose F is lowest
    (one run each, no sensitivities). The objective is flat in mu where nothing slips and not
    smooth where nodes switch between stick and slip, so a single start in the middle of the range
    can hold the fit in a valley far above the data's minimum (FEBio's baseline: from mu = 0.55 the
    fit stopped at F = 0.043 near mu = 0.5, where mu = 3 gives 0.030)."""
    best, best_F, skipped = None, np.inf, []
    for mu in np.geomspace(mu_range[0], mu_range[1], FE_MU_STARTS):
        point = np.append(theta, mu)
        try:
            F = float(objective.value(fe.predict(point[None, :]), eta)[0])
        except SimulationError as exc:  # a start, not the fit: skipped and counted, no alarm
            skipped.append(f"mu = {mu:.3g} (stops at {exc.depth_reached:g} mm)")
            continue
        say(f"  start at mu = {mu:.3g}: F = {F:.4g}")
        if F < best_F:
            best, best_F = point, F
    if skipped:
        say(
            f"  {len(skipped)} of {FE_MU_STARTS} starts skipped, not simulable at this (c1, c5): {', '.join(skipped)}"
        )
    if best is None:
        raise SimulationError(f"no start of the FE stage in mu's range {mu_range} could be simulated", 0.0)
    return best


#: How often a fit with mu starts again from a better point its range-end check found.
MAX_RESTARTS = 2
