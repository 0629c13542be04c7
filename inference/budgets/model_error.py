"""Model error carried into a fit's bounds and its posterior.

The bounds of eq. 6 to 8 are statistical: they hold the measurement noise only. A fit on a
multi-fidelity surrogate also knows two model errors, which are reported beside them:

* the discrepancy's uncertainty: the surrogate's predictive covariance of the high-fidelity
  response, L^T L in its output space (log force per step, top-surface field), pushed through
  the fit: each row l of L moves the residuals by dr_l and the fit, to first order, by
  d log theta_l = -(J^T J)^-1 J^T dr_l; the covariance is sum_l d log theta_l d log theta_l^T;
* what the error budget leaves: the largest bias of the high-fidelity mesh itself against the
  reference at the budget's test points (``inference.budgets.error_budget``), a systematic half-width
  recorded in the surrogate's provenance (``meta['error_budget']``);
* the surrogate's own error (issue 46), for a fit whose final stage is on the surrogate: its error
  vectors at held-out points (``surrogate.emulation_error``), each moving the fit to first order
  as above, d log theta_k = -(J^T J)^-1 J^T dr_k; the part is the 95th percentile of |d log theta_k|
  over the held-out points (the largest of them when there are fewer than 20), a systematic
  half-width, not a standard deviation.

A single-level surrogate knows the second part only, when an error budget of its own mesh for the
same test is known (given at training, or shipped with the studio:
:func:`surrogate.error_budgets.shipped_budget`); its bounds then hold that mesh's error and say so.

Both are 95 % half-widths in percent of theta_hat and are combined with the statistical one by
root sum of squares (independent sources, as ASME V&V 20 combines uncertainties).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...design.objective import Objective, check_weights
from ...forward.predictor import Prediction
from ...forward.spec import ModelSpec
from ...surrogate.error_budgets import budget_at, surrogate_error_budget
from ..experiment.processing_error import ProcessingError

__all__ = [
    "Z95",
    "ModelError",
    "budget_correction",
    "combined_pct",
    "emulation_error_pct",
    "model_error_at",
    "model_error_scope",
    "residual_changes",
    "with_emulation_error",
    "with_model_error",
    "with_processing_error",
]

Z95 = 1.959963984540054


@dataclass(frozen=True)
class ModelError:
    """Model-error parts of a fit's 95 % half-width (percent of theta_hat).

    Attributes
    ----------
    discrepancy_pct : numpy.ndarray
        (p,) from the discrepancy's predictive uncertainty.
    budget_pct : numpy.ndarray
        (p,) the high-fidelity mesh's remaining bias (error budget).
    covariance_log : numpy.ndarray
        (p, p) the discrepancy part's covariance of log theta.
    budget_source : dict or None
        What the budget part was read from.
    has_discrepancy : bool
        False: a single-level surrogate, the mesh's error budget only.
    contact : str
        The contact the surrogate's model assumes (``Contact.describe()``).
    surrogate_pct : numpy.ndarray or None
        (p,) the surrogate's own error (its held-out errors pushed through the fit); None: not
        carried (a fit whose final stage is on the FE model, or a surrogate without held-out errors).
    surrogate_source : str or None
        Where the surrogate's held-out errors came from, in words.
    processing : ProcessingError or None
        The experiment's processing (DIC points to nodes, registration) measured at the fit
        (``inference.experiment.processing_error``); None: not carried.
    correction_pct : numpy.ndarray or None
        (p,) what a corrected error budget moves the fit by, percent of it (the budget's model
        brought to its reference, ``inference.with_finest_reference``); None: no correction.
    """

    discrepancy_pct: np.ndarray  # from the discrepancy's predictive uncertainty
    budget_pct: np.ndarray  # the high-fidelity mesh's remaining bias (error budget)
    covariance_log: np.ndarray  # (p, p) the discrepancy part's covariance of log theta
    budget_source: dict | None = None  # what the budget part was read from
    has_discrepancy: bool = True  # False: a single-level surrogate, the mesh's error budget only
    contact: str = "perfect stick"  # the contact the surrogate's model assumes (Contact.describe())
    surrogate_pct: np.ndarray | None = None  # the surrogate's own error, pushed through the fit
    surrogate_source: str | None = None  # where its held-out errors came from
    processing: ProcessingError | None = None  # the experiment's processing, measured at the fit
    correction_pct: np.ndarray | None = None  # a corrected budget's move of the fit, percent

    def with_mu(self, mu_pct: float | None) -> ModelError:
        """The parts over (c1, c5, mu), mu's own model error as its budget part.

        ``mu_pct`` is a 95 % half-width in percent of mu
        (:func:`inference.fit.error_parts.mu_model_error_pct`); no correlation with (c1, c5) (theirs
        are taken with mu held); nothing corrected in mu.

        Parameters
        ----------
        mu_pct : float or None
            mu's model error; None: 0.

        Returns
        -------
        ModelError
            The parts padded to three parameters.
        """
        cov = np.zeros((3, 3))
        cov[:2, :2] = self.covariance_log[:2, :2]
        return replace(
            self,
            discrepancy_pct=np.append(self.discrepancy_pct[:2], 0.0),
            budget_pct=np.append(self.budget_pct[:2], 0.0 if mu_pct is None else float(mu_pct)),
            covariance_log=cov,
            surrogate_pct=None if self.surrogate_pct is None else np.append(self.surrogate_pct[:2], 0.0),
            processing=None if self.processing is None else self.processing.padded(3),
        )

    def corrected(self, theta: np.ndarray) -> np.ndarray:
        """``theta`` moved by the budget's correction (its first parameters; the rest as they are).

        Parameters
        ----------
        theta : numpy.ndarray
            (..., q) values, q >= p or q < p (the first min(p, q) are corrected).

        Returns
        -------
        numpy.ndarray
            The corrected values, theta (1 + c / 100).
        """
        theta = np.array(theta, float)
        if self.correction_pct is None:
            return theta
        c = np.asarray(self.correction_pct, float)
        k = min(c.size, theta.shape[-1])
        theta[..., :k] = theta[..., :k] * (1.0 + c[:k] / 100.0)
        return theta

    def _systematic_pct(self) -> np.ndarray:
        """(p,) the systematic parts (budget, surrogate, processing), root sum of squares."""
        parts = [self.budget_pct]
        if self.surrogate_pct is not None:
            parts.append(self.surrogate_pct)
        if self.processing is not None:
            parts.append(self.processing.half_width_pct)
        return np.sqrt(np.sum(np.square(parts), axis=0))

    @property
    def half_width_pct(self) -> np.ndarray:
        """(p,) the model error's 95 % half-width: the parts' root sum of squares, percent."""
        return np.hypot(self.discrepancy_pct, self._systematic_pct())

    def covariance_with_budget(self) -> np.ndarray:
        """Covariance of log theta of all parts, each systematic one read as a normal.

        The budget, the surrogate's own error and the processing are each read as a normal with
        their 95 % half-width.

        Returns
        -------
        numpy.ndarray
            (p, p) the covariance of log theta.
        """
        return self.covariance_log + np.diag((self._systematic_pct() / (100.0 * Z95)) ** 2)

    def to_dict(self) -> dict:
        """The parts as fit.json records them, with what they include in words.

        Returns
        -------
        dict
            ``discrepancy_pct``, ``error_budget_pct``, ``model_pct``, ``error_budget_source``,
            ``includes``.
        """
        return {
            "discrepancy_pct": self.discrepancy_pct.tolist(),
            "error_budget_pct": self.budget_pct.tolist(),
            "model_pct": self.half_width_pct.tolist(),
            "error_budget_source": self.budget_source,
            "surrogate_pct": None if self.surrogate_pct is None else self.surrogate_pct.tolist(),
            "surrogate_source": self.surrogate_source,
            "processing": None if self.processing is None else self.processing.to_dict(),
            "correction_pct": None if self.correction_pct is None else self.correction_pct.tolist(),
            "includes": model_error_scope(self),
        }


def model_error_scope(
    model: ModelError | None, noise: str = "statistical (eq. 6 to 8)", contact: str | None = None
) -> str:
    """What a fit's bounds (or a posterior's intervals) hold, in words, as fit.json and the CLI say it.

    A reported bound must always say what it includes and what it leaves out.

    Parameters
    ----------
    model : ModelError or None
        The model-error parts; None: none known.
    noise : str, default "statistical (eq. 6 to 8)"
        What the statistical part is; ``"measurement noise"`` for a posterior's intervals.
    contact : str, optional
        The contact the model assumes (``Contact.describe()``): no bound holds its error (README,
        "Friction": a stick fit of data with mu = 0.3 puts c5 about 30 % low); by default the
        model error's own, or the perfect stick.

    Returns
    -------
    str
        The sentence.

    Examples
    --------
    >>> from indentation_studio.inference import model_error_scope
    >>> "hold no model error" in model_error_scope(None)
    True
    """
    contact = contact or (model.contact if model is not None else "perfect stick")
    assumed = f"the contact model's ({contact} assumed)"
    if model is None:
        return (
            f"{noise} only: no error budget is known for this surrogate's mesh and test "
            f"and it has no high-fidelity level, so these bounds hold no model error (mesh, contact: "
            f"{contact} assumed); train a multi-fidelity surrogate, give the surrogate an error budget "
            "or use --check-mesh"
        )
    budget = ""
    src = model.budget_source
    if isinstance(src, dict) and src.get("model"):
        measured = f", measured with the {src['measured_with']}" if src.get("measured_with") else ""
        budget = f" ({_budget_words(src)}{measured})"
    held = []  # the systematic parts beside the budget, in words
    if model.surrogate_pct is not None:
        held.append(f"the surrogate's own error ({model.surrogate_source}, pushed through this fit)")
    if model.processing is not None:
        held.append(model.processing.describe())
    extra = "".join(f", {part}" for part in held)
    own = "" if model.surrogate_pct is not None else "not the surrogate's own error; "
    if model.has_discrepancy:
        return (
            f"{noise} and model error (the discrepancy's uncertainty, the error budget{budget}{extra}); "
            f"not {assumed}"
        )
    if model.budget_source is None and not np.any(model.budget_pct):
        return (
            f"{noise}{extra}; no error budget is known for this mesh and test, so they hold no mesh "
            f"error; {own}not {assumed}"
        )
    return f"{noise}, the mesh's error budget{budget}{extra}; {own}not {assumed}"


def _budget_words(src: dict) -> str:
    """Where a budget's value at a fit came from (``surrogate.error_budgets.budget_at``), in words."""
    model, points, file = src.get("model"), src.get("points"), src.get("file")
    where = src.get("where")
    corrected = (
        f"; {model}'s fit corrected to level {src['reference_level']} of the verification study ({src['rule']})"
        if src.get("reference_level") is not None and src.get("rule")
        else ""
    )
    if where == "interpolated":
        return f"{model}'s bias interpolated at the fit between {points} test points of {file}{corrected}"
    if where == "outside":
        nearest = ", ".join("{" + f"{c1:g}, {c5:g}" + "}" for c1, c5 in src.get("nearest", []))
        return (
            f"the fit lies outside the verified region (the {points} test points of {file}): {model}'s "
            f"largest bias at the nearest ({nearest} kPa), never narrower than there{corrected}"
        )
    if where == "largest" and not src.get("reference_extrapolated", True):
        return (
            f"{model}'s largest bias at {points} test points of {file}, held at every theta: "
            "measured against one finer mesh, not interpolated"
        )
    return f"{model}'s largest bias at {points} test points of {file}"


def combined_pct(statistical_pct: np.ndarray, model: ModelError | None) -> np.ndarray:
    """The 95 % half-width of statistical and model parts, root sum of squares.

    Parameters
    ----------
    statistical_pct : numpy.ndarray
        (p,) the statistical half-width (eq. 6), percent.
    model : ModelError or None
        The model-error parts; None: the statistical part alone.

    Returns
    -------
    numpy.ndarray
        (p,) the combined half-width, percent.

    Examples
    --------
    >>> from indentation_studio.inference import combined_pct
    >>> combined_pct([3.0, 4.0], None)
    array([3., 4.])
    """
    stat = np.asarray(statistical_pct, float)
    return stat if model is None else np.hypot(stat, model.half_width_pct)


def has_high_fidelity_level(surrogate) -> bool:
    """Whether a surrogate knows a discrepancy to a high-fidelity model (a multi-fidelity one)."""
    return callable(getattr(surrogate, "discrepancy_covariance_factor", None))


def _perturbed(prediction: Prediction, force_log: np.ndarray, field: np.ndarray) -> Prediction:
    """The prediction with its log force and field moved by one discrepancy direction."""
    return replace(
        prediction,
        force=prediction.force * np.exp(force_log)[None],
        displacement=prediction.displacement + field.reshape(prediction.displacement.shape[1:])[None],
        force_jacobian=None,
        displacement_jacobian=None,
    )


def _contact_of(surrogate) -> str:
    """The contact of the FE model a surrogate emulates, in words (the perfect stick when its
    file does not say)."""
    model = (getattr(surrogate, "meta", None) or {}).get("campaign", {}).get("model")
    return ModelSpec.from_dict(model).contact.describe() if model else "perfect stick"


def _fit_moves(
    objective: Objective, e, surrogate, theta: np.ndarray, free: int, outputs: np.ndarray
) -> np.ndarray:
    """How far each output-space change moves the fit, to first order: (k, free) in log theta.

    ``outputs`` (k, steps + steps * nodes * 3): log force per step, then the field (mm). Each row
    moves the residuals by dr_k, and the fit by -(J^T J)^-1 J^T dr_k over the first ``free``
    parameters, the rest held at ``theta``."""
    pred = surrogate.predict(theta[None, :], jacobian=True)
    J = (objective.jacobian(pred, e)[0] * theta)[:, :free]  # d r / d log theta (the free ones)
    dr = residual_changes(objective, e, pred, outputs)  # (k, m)
    A = np.linalg.solve(J.T @ J, J.T)  # (free, m)
    return -dr @ A.T


def residual_changes(objective: Objective, eta, prediction: Prediction, outputs: np.ndarray) -> np.ndarray:
    """How each output-space change moves eq. 5's residual vector at a prediction.

    Parameters
    ----------
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    prediction : Prediction
        One point's prediction (the residuals' base).
    outputs : numpy.ndarray
        (k, steps + steps * nodes * 3): log force per step, then the field (mm).

    Returns
    -------
    numpy.ndarray
        (k, residuals) r(prediction moved by row k) - r(prediction).
    """
    e = check_weights(eta)
    r0 = objective.residuals(prediction, e)[0]
    steps = prediction.force.shape[1]
    return np.stack(
        [objective.residuals(_perturbed(prediction, row[:steps], row[steps:]), e)[0] - r0 for row in outputs]
    )


#: Below this many held-out points the surrogate's part is the largest move, not a percentile.
FEW_HELD_OUT = 20


def emulation_error_pct(
    objective: Objective, eta, surrogate, theta: np.ndarray, *, free: int | None = None
) -> np.ndarray | None:
    """The surrogate's own error as a 95 % half-width of the fit at ``theta`` (issue 46).

    Each of the surrogate's held-out error vectors (``surrogate.emulation_error``) moves the fit,
    to first order, by d log theta_k = -(J^T J)^-1 J^T dr_k; the half-width is the 95th percentile
    of |d log theta_k| over the held-out points (their largest when there are fewer than
    :data:`FEW_HELD_OUT`), in percent.

    Parameters
    ----------
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The surrogate fitted.
    theta : numpy.ndarray
        (p,) the fit.
    free : int, optional
        The first ``free`` parameters move, the rest are held (as :func:`model_error_at`).

    Returns
    -------
    numpy.ndarray or None
        (free,) percent; None when the surrogate kept no held-out errors.
    """
    emulation = getattr(surrogate, "emulation_error", None)
    if emulation is None:
        return None
    theta = np.asarray(theta, float)
    free = len(theta) if free is None else free
    # to first order a held-out error moves the fit by its scores times the moves along the kept
    # directions: one residual evaluation per direction (each scaled to a typical error), not one
    # per held-out point on the whole (points x outputs) error matrix
    scores = emulation.scores.astype(float)
    scale = np.sqrt(np.mean(scores**2, axis=0))
    scale = np.where(scale > 0, scale, 1.0)
    along = _fit_moves(
        objective,
        check_weights(eta),
        surrogate,
        theta,
        free,
        emulation.directions.astype(float) * scale[:, None],
    )
    moves = np.abs((scores / scale) @ along)
    q = 1.0 if len(moves) < FEW_HELD_OUT else 0.95
    return 100.0 * np.expm1(np.quantile(moves, q, axis=0, method="higher"))


def with_emulation_error(
    model: ModelError | None,
    objective: Objective,
    eta,
    surrogate,
    theta: np.ndarray,
    *,
    free: int | None = None,
) -> ModelError | None:
    """``model`` with the surrogate's own error added (:func:`emulation_error_pct`).

    For a fit whose final stage is on ``surrogate``; a fit refined on the FE model does not carry it.

    Parameters
    ----------
    model : ModelError or None
        The other parts (None: none known).
    objective, eta, surrogate, theta, free
        As :func:`emulation_error_pct`.

    Returns
    -------
    ModelError or None
        The parts with ``surrogate_pct`` set; ``model`` unchanged when the surrogate kept no
        held-out errors.
    """
    pct = emulation_error_pct(objective, eta, surrogate, theta, free=free)
    if pct is None:
        return model
    source = surrogate.emulation_error.source
    if model is None:
        p = len(pct)
        return ModelError(
            np.zeros(p), np.zeros(p), np.zeros((p, p)), None, False, _contact_of(surrogate), pct, source
        )
    return replace(model, surrogate_pct=pct, surrogate_source=source)


def with_processing_error(model: ModelError | None, processing: ProcessingError, contact: str) -> ModelError:
    """``model`` with the experiment's processing part (``inference.experiment.processing_error``) added.

    Parameters
    ----------
    model : ModelError or None
        The other parts (None: none known).
    processing : ProcessingError
        The processing's parts at the fit.
    contact : str
        The contact the model assumes, for a ``model`` of None.

    Returns
    -------
    ModelError
        The parts with ``processing`` set.
    """
    if model is None:
        p = len(processing.interpolation_pct)
        return ModelError(
            np.zeros(p), np.zeros(p), np.zeros((p, p)), None, False, contact, processing=processing
        )
    return replace(model, processing=processing)


def model_error_at(
    objective: Objective,
    eta,
    surrogate,
    theta: np.ndarray,
    *,
    free: int | None = None,
    on_surrogate: bool = True,
) -> ModelError | None:
    """The model-error parts at the fit ``theta`` on ``surrogate``.

    A multi-fidelity surrogate gives the discrepancy's part (its predictive covariance carried to
    theta by the linearised fit) and its error budget's. A single-level surrogate with an error
    budget of its mesh (``meta['error_budget']``) carries that budget alone. A fit whose final
    stage is on the surrogate (``on_surrogate``) also carries the surrogate's own error when it
    kept held-out errors (:func:`with_emulation_error`).

    Parameters
    ----------
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The surrogate fitted.
    theta : numpy.ndarray
        (p,) the fit, kPa.
    free : int, optional
        Only the first ``free`` parameters move with the discrepancy, the rest held at ``theta``
        (mu of a fit with friction, whose own bound is its profile's; at mu's range ends, where
        nothing slips, d/dmu vanishes and a fit over all three would not be determined). The parts
        are then over those ``free`` parameters. Default all.
    on_surrogate : bool, default True
        The fit's final stage is on the surrogate (False: refined on the FE model, whose fit the
        surrogate's own error does not move).

    Returns
    -------
    ModelError or None
        The parts; None for a single-level surrogate without a budget or held-out errors (its
        bounds then hold no model error, and say so).
    """
    budget = budget_at(surrogate_error_budget(surrogate), theta) or {}
    contact = _contact_of(surrogate)
    theta = np.asarray(theta, float)
    names = surrogate.parameters[:free]
    budget_pct = np.array([float(budget.get(f"{name}_pct", 0.0)) for name in names])
    correction = budget_correction(budget, names)
    p = len(names)
    if not has_high_fidelity_level(surrogate):
        known = (
            ModelError(
                np.zeros(p),
                budget_pct,
                np.zeros((p, p)),
                budget.get("source"),
                False,
                contact,
                correction_pct=correction,
            )
            if budget
            else None
        )
    else:
        L = surrogate.discrepancy_covariance_factor(theta)  # (k, steps + steps * nodes * 3)
        moves = _fit_moves(objective, check_weights(eta), surrogate, theta, p, L)  # (k, p) in log theta
        cov = moves.T @ moves
        known = ModelError(
            discrepancy_pct=100.0 * Z95 * np.sqrt(np.diag(cov)),
            budget_pct=budget_pct,
            covariance_log=cov,
            budget_source=budget.get("source") if budget else None,
            contact=contact,
            correction_pct=correction,
        )
    if not on_surrogate:
        return known
    return with_emulation_error(known, objective, eta, surrogate, theta, free=free)


def budget_correction(budget: dict | None, names) -> np.ndarray | None:
    """A budget's correction of the fit at a point (``surrogate.error_budgets.budget_at``), or None.

    Parameters
    ----------
    budget : dict or None
        What ``budget_at`` read at the fit.
    names : sequence of str
        The fit's parameters; those without a correction in the budget (mu) get 0.

    Returns
    -------
    numpy.ndarray or None
        (len(names),) percent; None where the budget corrects nothing.
    """
    if not budget or budget.get("c1_correction_pct") is None:
        return None
    return np.array([float(budget.get(f"{name}_correction_pct", 0.0)) for name in names])


def with_model_error(
    samples: np.ndarray,
    model: ModelError,
    seed: int = 0,
    *,
    box: tuple[np.ndarray, np.ndarray] | None = None,
    tries: int = 50,
) -> np.ndarray:
    """Posterior samples spread by the model error: each multiplied by exp(e).

    e is normal with the model error's covariance of log theta (discrepancy, error budget and
    the surrogate's own error). With a prior ``box``, the spread is truncated to it (the prior
    times the spread): a sample moved outside is drawn again, so a parameter whose model error
    is as wide as its range (mu on data with no slip) fills the range instead of piling at its ends.

    Parameters
    ----------
    samples : numpy.ndarray
        (n, p) the samples.
    model : ModelError
        The model-error parts.
    seed : int, default 0
        Seed of e.
    box : tuple of numpy.ndarray, optional
        (lo, hi) the prior's box; None: no truncation.
    tries : int, default 50
        Draws of e for a sample before it is held at its own value (its spread then nil).

    Returns
    -------
    numpy.ndarray
        (n, p) the spread samples.
    """
    rng = np.random.default_rng(seed)
    cov = model.covariance_with_budget()
    samples = np.asarray(samples, float)
    e = rng.multivariate_normal(np.zeros(len(cov)), cov, size=len(samples), method="eigh")
    out = samples * np.exp(e)
    if box is None:
        return out
    lo, hi = (np.asarray(b, float) for b in box)
    outside = ~np.all((out > lo) & (out < hi), axis=1)
    for _ in range(tries):
        if not outside.any():
            break
        e = rng.multivariate_normal(np.zeros(len(cov)), cov, size=int(outside.sum()), method="eigh")
        out[outside] = samples[outside] * np.exp(e)
        outside = ~np.all((out > lo) & (out < hi), axis=1)
    out[outside] = samples[outside]
    return out
