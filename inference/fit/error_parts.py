"""The model-error parts a fit carries beside its statistical bound: the processing's part at the
fit, the mesh's budget measured with the perfect stick, and the parts of a fit on a surrogate
trained with mu (those of (c1, c5), mu held, and what the model's errors leave on mu)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ...design.friction_treatment import FrictionTreatment
from ...surrogate.error_budgets import budget_at, surrogate_error_budget
from ...surrogate.mesh_differences import surrogate_mesh_differences
from ..budgets.freed_mu_moves import with_freed_mu
from ..budgets.model_error import (
    ModelError,
    budget_correction,
    emulation_error_pct,
    has_high_fidelity_level,
    model_error_at,
    with_emulation_error,
    with_processing_error,
)
from ..experiment.processing_error import REGISTRATION_MM, processing_error_at
from .held_out_refits import HeldOutRefits, held_out_refits
from .inputs import FitInputs

#: The treatments under which a fit frees mu (its budget's mesh error then moves with mu free).
MU_FREED = ("identify", "marginalise")

__all__ = [
    "FRICTION_DISCREPANCY_UNMEASURED",
    "MU_FREED",
    "left_out_with_friction",
    "mesh_move_on_mu_pct",
    "model_error_with_mu",
    "mu_held_out_refits",
    "mu_model_error_pct",
    "mu_model_error_unmeasured",
    "stick_mesh_budget",
    "with_processing_part",
]


def model_error_with_mu(
    inputs: FitInputs,
    treatment: FrictionTreatment,
    mu_range: tuple[float, float] | None,
    theta: np.ndarray,
    *,
    on_surrogate: bool,
    registration_mm: float = REGISTRATION_MM,
    say: Callable[[str], None] | None = None,
) -> ModelError | None:
    """The model-error parts of (c1, c5) at a fit on a surrogate trained with mu, mu held there.

    The discrepancy's uncertainty and the error budget of a multi-fidelity surrogate
    (:func:`~indentation_studio.inference.budgets.model_error.model_error_at`, mu held: at mu's range ends
    nothing slips and d/dmu vanishes), or the stick-measured budget of a single-level one
    (:func:`stick_mesh_budget`); the surrogate's own error where the final stage is on it; the
    processing's part. A fit and a posterior of the same data carry the same parts.

    Parameters
    ----------
    inputs : FitInputs
        The experiment, surrogate (with mu) and objective.
    treatment : FrictionTreatment
        How mu is treated.
    mu_range : tuple of float or None
        mu's range (identify, marginalise).
    theta : numpy.ndarray
        The fit: (c1, c5, mu), or (c1, c5) with mu known.
    on_surrogate : bool
        The final stage is on the surrogate (its own error counted).
    registration_mm : float, default REGISTRATION_MM
        The indentation point's uncertainty, mm.
    say : callable, optional
        Where progress messages go.

    Returns
    -------
    ModelError or None
        The parts over (c1, c5); None where nothing is known.
    """
    say = say or (lambda message: None)
    model, obj, eta = inputs.surrogate, inputs.objective, inputs.eta
    contact = treatment.describe(inputs.spec.contact.describe(), mu_range)
    at = _with_held_mu(theta, model, treatment)
    if has_high_fidelity_level(model):  # its discrepancy (learned at the stick or over mu)
        say("the model error at the fit (discrepancy and error budget, mu held) ...")
        error = model_error_at(obj, eta, model, at, free=2, on_surrogate=on_surrogate)
    else:
        error = stick_mesh_budget(model, contact, inputs.spec.contact.describe(), theta=theta)
        if on_surrogate:  # the final stage on the surrogate: its own error too
            error = with_emulation_error(error, obj, eta, model, at, free=2)
    differences = surrogate_mesh_differences(model) if treatment.mode in MU_FREED else None
    if error is not None and differences is not None:  # the fit frees mu: the mesh's error moves more
        say("the mesh's error with mu free (the budget's points' level-3 less level-4 outputs) ...")
        error = with_freed_mu(error, obj, eta, model, at, differences)
    elif error is not None and treatment.mode in MU_FREED and isinstance(error.budget_source, dict):
        error = replace(error, budget_source=error.budget_source | {"mu_free": {"measured": False}})
    error = None if error is None else replace(error, contact=contact)
    return with_processing_part(error, inputs, at, contact, registration_mm, say, free=2)


#: What bounds on a surrogate whose discrepancy was learned at the stick leave out when the fit has
#: friction: the discrepancy is applied at every mu, and no high-fidelity run with friction measured
#: how it changes (issue 57, session 32).
FRICTION_DISCREPANCY_UNMEASURED = (
    "how the discrepancy, learned at the stick, changes with friction (no high-fidelity run with "
    "friction entered it; at R = 4.77 mm, {15, 200} kPa, mu = 1, level 3's own record was fitted with "
    "c5 3.0 % low, where the surrogate's own part near the fit was 0.7 %)"
)


def mu_model_error_unmeasured(inputs: FitInputs) -> str | None:
    """Why the model's error on mu is not measured at the high fidelity, or None where it is.

    A multi-fidelity surrogate whose discrepancy was learned at the stick (``learned_at_stick``)
    corrects (c1, c5) toward the high fidelity but takes mu's effect from the low level's friction
    alone: no high-fidelity run with friction ever entered it, so nothing says how far the high
    fidelity's mu lies from the low level's. Measured (issue 57): data made on contact-L3 at
    R = 8 mm, {6, 380} kPa, mu = 0.5, recorded as a lab would, fitted on the R = 8 mm box surrogate
    gave mu = 1.12 with 95 % in (0.61, 1.64) while (c1, c5) were within 0.2 and 0.7 %. A fit on such
    a surrogate therefore does not claim mu: its interval is mu's whole range.

    Parameters
    ----------
    inputs : FitInputs
        The experiment, surrogate (with mu) and objective.

    Returns
    -------
    str or None
        The reason, in words; None for a surrogate without a high-fidelity level (its own budget
        counts) or whose discrepancy was learned over mu.
    """
    if _discrepancy_learned_at_stick(inputs.surrogate):
        return (
            "mu's model error at the high fidelity is not measured: the discrepancy was learned at the stick "
            "(no high-fidelity run with friction), so mu rests on the low level's friction alone"
        )
    return None


def left_out_with_friction(inputs: FitInputs) -> tuple[str, ...]:
    """What (c1, c5)'s bounds leave out on a surrogate with friction whose discrepancy was learned at
    the stick, whether mu is held or fitted (:data:`FRICTION_DISCREPANCY_UNMEASURED`).

    Parameters
    ----------
    inputs : FitInputs
        The experiment, surrogate and objective.

    Returns
    -------
    tuple of str
        The parts left out, in words (for ``model_error_scope``'s ``unmeasured``); empty otherwise.
    """
    model = inputs.surrogate
    if "mu" in model.parameters and _discrepancy_learned_at_stick(model):
        return (FRICTION_DISCREPANCY_UNMEASURED,)
    return ()


def _discrepancy_learned_at_stick(model) -> bool:
    """A multi-fidelity surrogate whose discrepancy was learned at the stick (applied at every mu)."""
    return has_high_fidelity_level(model) and getattr(model, "learned_at_stick", False)


def mu_held_out_refits(inputs: FitInputs, theta: np.ndarray) -> HeldOutRefits | None:
    """The fit made again on its surrogate with each of the discrepancy's held-out errors.

    A multi-fidelity surrogate's ``discrepancy_error`` (its k-fold errors at the high-fidelity
    points; :func:`~indentation_studio.inference.fit.held_out_refits.held_out_refits`), the fit
    held in the surrogate's training box.

    Parameters
    ----------
    inputs : FitInputs
        The experiment, surrogate (with mu) and objective.
    theta : numpy.ndarray
        (c1, c5, mu) the fit.

    Returns
    -------
    HeldOutRefits or None
        None where the surrogate keeps no such errors.
    """
    model = inputs.surrogate
    errors = getattr(model, "discrepancy_error", None)
    if errors is None:
        return None
    box = (np.asarray(model.scaler.lo, float), np.asarray(model.scaler.hi, float))
    inside = np.clip(np.asarray(theta, float), box[0], box[1])
    return held_out_refits(inputs.objective, inputs.eta, model, inside, box, errors)


def mesh_move_on_mu_pct(model_error: ModelError | None) -> float | None:
    """The mesh's move on mu that a fit freeing mu carries in its model error
    (``budget_source['mu_free']['mu_pct']``, :func:`~indentation_studio.inference.budgets.freed_mu_moves.with_freed_mu`),
    percent of mu; None where it was not measured.

    Parameters
    ----------
    model_error : ModelError or None
        The fit's model error over (c1, c5).

    Returns
    -------
    float or None
    """
    source = getattr(model_error, "budget_source", None)
    if not isinstance(source, dict):
        return None
    return (source.get("mu_free") or {}).get("mu_pct")


def mu_model_error_pct(
    inputs: FitInputs,
    theta: np.ndarray,
    *,
    on_surrogate: bool,
    refits: HeldOutRefits | None = None,
    model_error: ModelError | None = None,
) -> float | None:
    """What the model's own errors leave on a fitted mu: a 95 % half-width, percent of mu.

    Every parameter free (mu's certainty is what is asked): the surrogate's held-out errors pushed
    through the fit where its final stage is on it
    (:func:`~indentation_studio.inference.budgets.model_error.emulation_error_pct`), and, on a
    multi-fidelity surrogate with mu inside its range, the discrepancy's uncertainty pushed the same
    way (:func:`~indentation_studio.inference.budgets.model_error.model_error_at` over all three)
    and its held-out errors at the high-fidelity points (``refits``: the fit made again with each,
    :func:`mu_held_out_refits`, not linearised), root sum of squares. A model error that moves mu by its whole range is
    what makes data with no slip in them look as if they held a mu: the discrepancy's predictive
    uncertainty alone is what it believes of itself, its held-out errors what it gets wrong.

    Parameters
    ----------
    inputs : FitInputs
        The experiment, surrogate (with mu) and objective.
    theta : numpy.ndarray
        (c1, c5, mu) the fit.
    on_surrogate : bool
        The final stage is on the surrogate.
    refits : HeldOutRefits, optional
        :func:`mu_held_out_refits` at ``theta``, where made.
    model_error : ModelError, optional
        The fit's model error over (c1, c5): the mesh's move on mu it carries
        (:func:`mesh_move_on_mu_pct`: the error budget's points' level-3 less level-4 outputs moved
        through the fit with mu free) is a part too:
        the discrepancy's errors are level 3's, and on level-4 stick data a surrogate that learned
        friction took the mesh's error for slip (mu 0.32, 95 % within (0.27, 0.38), session 35).

    Returns
    -------
    float or None
        The half-width; None where no part is known.
    """
    model, obj, eta = inputs.surrogate, inputs.objective, inputs.eta
    parts = []
    if on_surrogate:
        moved = emulation_error_pct(obj, eta, model, theta)
        if moved is not None:
            parts.append(float(moved[2]))
    lo, hi = (float(model.scaler.lo[2]), float(model.scaler.hi[2]))
    if has_high_fidelity_level(model) and lo * 1.01 < theta[2] < hi / 1.01:
        try:
            error = model_error_at(obj, eta, model, theta, on_surrogate=False)
        except np.linalg.LinAlgError:  # mu not determined there: nothing to push through
            error = None
        if error is not None and np.isfinite(error.discrepancy_pct[2]):
            parts.append(float(error.discrepancy_pct[2]))
    if refits is not None:
        parts.append(refits.half_width_pct(2))
    mesh_mu_pct = mesh_move_on_mu_pct(model_error)
    if mesh_mu_pct is not None and np.isfinite(mesh_mu_pct):
        parts.append(float(mesh_mu_pct))
    return float(np.hypot.reduce(parts)) if parts else None


def with_processing_part(
    model_error: ModelError | None,
    inputs: FitInputs,
    theta: np.ndarray,
    contact: str,
    registration_mm: float,
    say: Callable[[str], None],
    *,
    free: int | None = None,
) -> ModelError:
    """The fit's model error with the experiment's processing part measured at ``theta``.

    On the fit's surrogate (``inference.experiment.processing_error``: the DIC points carried to
    the nodes and the registration), beside the parts ``model_error`` holds.

    Parameters
    ----------
    model_error : ModelError or None
        The other parts.
    inputs : FitInputs
        The experiment, surrogate and objective.
    theta : numpy.ndarray
        The fit, kPa (and mu).
    contact : str
        The contact the fit assumed, in words.
    registration_mm : float
        How far the registration may be off, mm.
    say : callable
        Progress messages.
    free : int, optional
        The first ``free`` parameters move, the rest are held.

    Returns
    -------
    ModelError
        ``model_error`` with the processing part.
    """
    say(
        f"the processing's part at the fit (DIC points to nodes, registration within {registration_mm:g} mm) ..."
    )
    processing = processing_error_at(
        inputs.objective,
        inputs.dic,
        inputs.surrogate,
        theta,
        inputs.eta,
        used_steps=inputs.experiment.used_steps,
        registration_mm=registration_mm,
        free=free,
    )
    return with_processing_error(model_error, processing, contact)


def _with_held_mu(theta: np.ndarray, model, treatment: FrictionTreatment) -> np.ndarray:
    """(c1, c5, mu) of a fit on a surrogate with mu: mu as fitted, or the value held (at the
    training range's nearest end, as :func:`surrogate_with_mu` holds it)."""
    theta = np.asarray(theta, float)
    if theta.size == len(model.parameters):
        return theta
    return np.append(theta, np.clip(treatment.value, model.scaler.lo[2], model.scaler.hi[2]))


def stick_mesh_budget(surrogate, contact: str, measured_with: str, *, theta) -> ModelError | None:
    """The mesh's error budget of the surrogate's (c1, c5), measured with the perfect stick, for a
    fit with friction.

    That mesh's error does not vanish when mu is held or fitted, and no budget measured with
    friction is shipped; leaving it out would leave bounds of noise alone (a fit of FEBio's
    baseline with mu identified: c5 +34 % outside +-3.9 %).

    Parameters
    ----------
    surrogate : FieldSurrogate
        The fit's surrogate.
    contact : str
        The contact the fit assumed, in words.
    measured_with : str
        The contact the budget was measured with (the surrogate's campaign's, which the shipped
        budget was matched on); recorded in its source.
    theta : array_like
        The fit, where the budget is read (``surrogate.error_budgets.budget_at``).

    Returns
    -------
    ModelError or None
        The budget's part (and its correction); None where the surrogate has no budget.
    """

    budget = budget_at(surrogate_error_budget(surrogate), theta)
    if not budget:
        return None
    source = dict(budget.get("source") or {}) | {"measured_with": measured_with}
    pct = np.array([float(budget.get("c1_pct", 0.0)), float(budget.get("c5_pct", 0.0))])
    correction = budget_correction(budget, ("c1", "c5"))
    return ModelError(np.zeros(2), pct, np.zeros((2, 2)), source, False, contact, correction_pct=correction)
