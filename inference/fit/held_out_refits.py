"""The model's held-out errors pushed through a fit without linearising it: the fit made again on the
surrogate with its outputs moved by each held-out error vector.

To first order a held-out error e_k moves a fit by -(J^T J)^-1 J^T dr_k
(:func:`~indentation_studio.inference.budgets.fit_moves.emulation_error_pct`). For mu that is not
enough: where nothing slips the objective is flat in mu above some value, so an error that the
linearisation at the fit calls small can carry mu to its range's end. Issue 57: on data made with
the stick at the soft corner {1.5, 560} kPa (R = 8 mm) the fit claimed mu = 1.17 with a model part
of +-44 %; made again with each of the discrepancy's 25 held-out errors, one refit ended on mu's
upper end. The refits say what the linearisation cannot: whether the model's own errors reach an end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...forward.predictor import Prediction
from ..budgets.fit_moves import FEW_HELD_OUT, moved_prediction
from .inverse_fit import fit_parameters

__all__ = ["END_SHARE", "MAX_REFITS", "HeldOutRefits", "held_out_refits"]

#: At most this many held-out errors are refitted per error set (spread over the set, in a fixed
#: order, so that a fit is reproducible): a refit on the surrogate costs about a second.
MAX_REFITS = 40
#: A refit within this share of the parameter's range (in log) of an end counts as ending there.
END_SHARE = 0.05


class _ShiftedPredictor:
    """A predictor whose outputs are moved by one output-space error: log force per step, then the
    field (the layout of :class:`~indentation_studio.surrogate.emulation_error.EmulationError`)."""

    def __init__(self, predictor, error: np.ndarray, steps: int) -> None:
        self.predictor = predictor
        self.parameters = predictor.parameters
        self.scaler = getattr(predictor, "scaler", None)
        self._force_log = np.asarray(error[:steps], float)
        self._field = np.asarray(error[steps:], float)

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        return moved_prediction(
            self.predictor.predict(theta, jacobian=jacobian), self._force_log, self._field
        )


@dataclass(frozen=True)
class HeldOutRefits:
    """A fit made again with each of a model's held-out errors.

    Attributes
    ----------
    theta : numpy.ndarray
        (k,) the fit's parameters, kPa (and mu).
    refits : numpy.ndarray
        (m, k) the refits' parameters.
    box : tuple of numpy.ndarray
        The (lo, hi) the fits were held in.
    source : str
        The held-out errors, in words.
    """

    theta: np.ndarray
    refits: np.ndarray
    box: tuple[np.ndarray, np.ndarray]
    source: str

    def half_width_pct(self, column: int) -> float:
        """The refits' spread about the fit as a 95 % half-width, percent.

        The 95th percentile of |log(theta_k / theta)| (the largest below
        :data:`~indentation_studio.inference.budgets.fit_moves.FEW_HELD_OUT` refits), as the
        linear push reads its moves.

        Parameters
        ----------
        column : int
            The parameter.

        Returns
        -------
        float
        """
        moves = np.abs(np.log(self.refits[:, column] / self.theta[column]))
        q = 1.0 if len(moves) < FEW_HELD_OUT else 0.95
        return 100.0 * float(np.expm1(np.quantile(moves, q, method="higher")))

    def reaches(self, column: int) -> dict[str, bool]:
        """Whether any refit ends on the box's lower or upper end in one parameter.

        Within :data:`END_SHARE` of the box's width in log. One is enough: a claim the model's own
        error can undo is not made.

        Parameters
        ----------
        column : int
            The parameter.

        Returns
        -------
        dict
            ``{"lower": bool, "upper": bool}``.
        """
        lo, hi = float(self.box[0][column]), float(self.box[1][column])
        tol = END_SHARE * np.log(hi / lo)
        values = np.log(self.refits[:, column])
        return {
            "lower": bool(np.any(values - np.log(lo) <= tol)),
            "upper": bool(np.any(np.log(hi) - values <= tol)),
        }

    def describe(self, column: int) -> dict:
        """What fit.json records of the refits in one parameter.

        Parameters
        ----------
        column : int
            The parameter.

        Returns
        -------
        dict
        """
        values = self.refits[:, column]
        return {
            "source": self.source,
            "refits": len(values),
            "min": float(values.min()),
            "max": float(values.max()),
            "half_width_pct": self.half_width_pct(column),
            "reaches_range_end": self.reaches(column),
        }


def held_out_refits(
    objective,
    eta,
    surrogate,
    theta: np.ndarray,
    box: tuple[np.ndarray, np.ndarray],
    errors,
    *,
    limit: int = MAX_REFITS,
) -> HeldOutRefits | None:
    """Fit again from ``theta`` with the surrogate's outputs moved by each held-out error.

    Parameters
    ----------
    objective : Objective
        The fit's objective (eq. 4, 5).
    eta : array_like
        The weights of eq. 5.
    surrogate : FieldSurrogate
        The surrogate fitted.
    theta : numpy.ndarray
        (k,) the fit.
    box : tuple of numpy.ndarray
        (lo, hi) the refits stay in (the surrogate's training box).
    errors : EmulationError or None
        The held-out errors (``surrogate.discrepancy_error``, ``surrogate.emulation_error``).
    limit : int, optional
        At most this many, spread evenly over the set.

    Returns
    -------
    HeldOutRefits or None
        None where there are no errors.
    """
    if errors is None:
        return None
    e = errors.errors()
    rows = np.unique(np.linspace(0, len(e) - 1, min(limit, len(e))).round().astype(int))
    theta = np.asarray(theta, float)
    refits = np.array(
        [
            fit_parameters(
                objective, _ShiftedPredictor(surrogate, e[k], errors.steps), eta, theta0=theta, box=box, s=1.0
            ).theta
            for k in rows
        ]
    )
    # (s = 1: eq. 6's bounds of a refit are not read, and a refit that matches the data exactly has s = 0)
    source = f"{len(rows)} of {errors.source}" if len(rows) < len(e) else errors.source
    return HeldOutRefits(theta, refits, (np.asarray(box[0], float), np.asarray(box[1], float)), source)
