"""An error budget's table: per model and test point the bias of its fit beside the half-width a
typical experiment resolves, and whether the model is converged for the test
(:data:`CONVERGED_FRACTION`); its summary and its JSON (``error-budget.json``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

__all__ = ["CONVERGED_FRACTION", "ErrorBudget"]


#: A model is good enough for a test when its bias is below this fraction of the test's half-width.
CONVERGED_FRACTION = 1.0 / 3.0


@dataclass
class ErrorBudget:
    """Bias of each model at each test point (percent of the truth) and the typical half-width.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (model, test point): ``c1_bias_pct``, ``c5_bias_pct``,
        ``c1_half_width_pct``, ``c5_half_width_pct``, ...
    weights : numpy.ndarray
        (4,) the weights of eq. 5.
    force_noise : float
        Relative force noise per step.
    dic_noise : float
        DIC noise, mm.
    reference : dict
        Where the reference came from (provenance); ``"extrapolated": true`` when its responses are
        extrapolated values (a verification study's), which lets a fit interpolate the budget
        between its points (``surrogate.error_budgets.budget_at``).
    fov_mm : float or None
        The field of view measured, mm (None: the whole top).
    fe_steps : int or None
        Gauss-Newton steps of the FE models' fits.
    reading : str
        The objective's reading (:class:`~indentation_studio.design.objective.Objective`): ``fit``
        (DIC from 1.5 R, the studio's fits) unless the budget was made for another.
    """

    table: pd.DataFrame  # one row per (model, test point)
    weights: np.ndarray
    force_noise: float
    dic_noise: float
    reference: dict = field(default_factory=dict)  # where the reference came from (provenance)
    fov_mm: float | None = 25.0
    fe_steps: int | None = None  # Gauss-Newton steps of the FE models' fits
    reading: str = "fit"

    def summary(self) -> pd.DataFrame:
        """The budget per model: largest bias, median half-width, their ratio, whether converged.

        Returns
        -------
        pandas.DataFrame
            Per model: the largest |bias| of c1 and c5, the median half-width, their ratio, and
            whether the model is converged for the test (every point's bias below
            ``CONVERGED_FRACTION`` of its half-width).
        """
        rows = []
        for model, t in self.table.groupby("model", sort=False):
            row = {"model": model, "points": len(t)}
            ok = True
            for p in ("c1", "c5"):
                bias = t[f"{p}_bias_pct"].abs()
                half = t[f"{p}_half_width_pct"]
                row[f"{p}_max_bias_pct"] = float(bias.max())
                row[f"{p}_median_half_width_pct"] = float(half.median())
                row[f"{p}_max_bias_over_half_width"] = float((bias / half).max())
                ok &= bool(np.all(bias <= CONVERGED_FRACTION * half))
            row["converged"] = ok
            rows.append(row)
        return pd.DataFrame(rows)

    def to_dict(self, complete: bool = True) -> dict:
        """The JSON of error-budget.json.

        Parameters
        ----------
        complete : bool, default True
            False while rows are still to come.

        Returns
        -------
        dict
            The weights, noise levels, field of view, converged fraction, what the half-width
            includes, the reference, the rows, the summary, ``fe_steps`` and ``complete``.
        """
        return {
            "weights": self.weights.tolist(),
            "force_noise": self.force_noise,
            "dic_noise_mm": self.dic_noise,
            "field_of_view_mm": self.fov_mm,
            "reading": self.reading,
            "converged_fraction": CONVERGED_FRACTION,
            "half_width_include": "eq. 6 to 8 of a typical experiment: measurement noise only "
            f"({100 * self.force_noise:g} % force, {self.dic_noise:g} mm DIC)",
            "reference": self.reference,
            "rows": self.table.to_dict(orient="records"),
            "summary": self.summary().to_dict(orient="records"),
            "fe_steps": self.fe_steps,
            "complete": complete,
        }
