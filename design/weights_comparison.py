"""Table 1 at a design study's theta*: the paper's objective weights and certainty bounds (eq. 6)
beside ours, row by row (force only, deformation only, optimal for c1, for c5, combined), and the
Hessians behind them (:func:`weights_table`, ``indent-studio design weights``)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .study import DesignStudy
from .weights import PAPER_HESSIAN, ComparisonRow, compare_with_paper

__all__ = ["WeightsTable", "weights_table"]


@dataclass
class WeightsTable:
    """Table 1 at a study's theta*: the paper's weights and bounds beside ours, row by row.

    Ours at the paper's weights and at our optimum (:func:`design.weights.compare_with_paper`).

    Attributes
    ----------
    study : DesignStudy
        The study at theta*.
    rows : list of ComparisonRow
        The table's rows.
    s : float
        The noise level of eq. 6.
    criterion : str
        What the weights were optimised for.
    fd_step : str or None
        The finite-difference step, for ``fd`` studies.
    """

    study: DesignStudy
    rows: list[ComparisonRow]
    s: float
    criterion: str
    fd_step: str | None = None

    @property
    def hessian_paper_weights(self) -> np.ndarray:
        """H(theta*) at the paper's combined weights (its eq. 14 beside it)."""
        return self.study.hessian(self.rows[-1].paper_weights)

    def to_dict(self) -> dict[str, Any]:
        """The table as ``design weights --json`` prints (and ``--out`` writes) it.

        Returns
        -------
        dict
            Our rows, the paper's rows, s, criterion, method, reading, the fd step, theta*, the
            Hessians (combined, at the paper's weights, the paper's, per term) and the spec.
        """
        rows, study = self.rows, self.study
        return {
            "rows": [
                {"name": r.name, "weights": list(r.weights), "c1_pct": r.c1_pct, "c5_pct": r.c5_pct}
                for r in rows
            ],
            "paper_rows": [r.__dict__ for r in rows],
            "s": self.s,
            "criterion": self.criterion,
            "method": study.method,
            "reading": study.reading,
            "fd_step": self.fd_step if study.method == "fd" else None,
            "theta_star": study.theta_star.tolist(),
            "hessian_combined": study.hessian(rows[-1].weights).tolist(),
            "hessian_paper_weights": self.hessian_paper_weights.tolist(),
            "paper_hessian": [list(r) for r in PAPER_HESSIAN],
            "term_hessians": study.term_hessians.tolist(),
            "spec": study.spec,
        }


def weights_table(
    study: DesignStudy, s: float = 0.05, criterion: str = "combined", *, fd_step: str | None = None
) -> WeightsTable:
    """Table 1 of a study: the paper's rows beside ours.

    Parameters
    ----------
    study : DesignStudy
        The study at theta*.
    s : float
        The noise level of eq. 6.
    criterion : str
        What our weights optimise: c1, c5, combined or det.
    fd_step : str or None
        The finite-difference step as given (recorded with an fd study).

    Returns
    -------
    WeightsTable
        The table.
    """
    return WeightsTable(study, compare_with_paper(study.term_hessians, s, criterion), s, criterion, fd_step)
