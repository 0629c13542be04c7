"""A fit's model error, its parts (the discrepancy's uncertainty, the error budget, the
surrogate's own error, the processing) and their sum with the statistical bounds, in numbers
and in words (:mod:`.model_error` says where each part comes from)."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..experiment.processing_error import ProcessingError

__all__ = ["Z95", "ModelError", "combined_pct", "model_error_scope"]


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
    model: ModelError | None,
    noise: str = "statistical (eq. 6 to 8)",
    contact: str | None = None,
    *,
    unmeasured: tuple[str, ...] = (),
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
    unmeasured : tuple of str, default ()
        Other parts the bounds leave out, each said as "not ..." at the end.

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
    assumed = f"the contact model's ({contact} assumed)" + "".join(f"; not {u}" for u in unmeasured)
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
        budget = f" ({_where_words(src)}{measured}{_freed_mu_words(src.get('mu_free'))})"
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


def _where_words(src: dict) -> str:
    """Where a budget's value at a fit came from, and the correction it applies, in words."""
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


def _freed_mu_words(freed: dict | None) -> str:
    """What freeing mu adds to the mesh's error at a fit that frees it, in words ('' where mu is held)."""
    if not freed:
        return ""
    if freed.get("measured") is False:
        return (
            "; not what freeing mu, as this fit does, adds to the mesh's error: no level-3 less level-4 "
            "outputs are shipped for this test"
        )
    return (
        f"; with mu free as this fit has it, the mesh's error moves c1 by "
        f"{-freed['c1_correction_pct']:+.2f} % and c5 by {-freed['c5_correction_pct']:+.2f} % more "
        f"({freed['where']} between {freed['points']} points of {freed['file']}): corrected, and the "
        "width grown by as much"
    )


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
