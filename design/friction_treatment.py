"""How a fit treats the Coulomb friction coefficient mu between the indenter and the specimen
(issue 17; README, "Friction").

A real indenter on a painted specimen has a finite, unknown mu, and c5 lives in the in-plane
displacements around the indenter where the contact condition acts: fitted with the perfect stick,
data made with mu = 0.3 give c5 about 30 % low, the truth far outside eq. 6's bounds. A fit can

- ``assumed``: take the contact its model was built with (the paper's perfect stick), the bounds
  saying so;
- ``known``: hold mu at a measured value;
- ``identify``: fit mu with (c1, c5), eq. 6's bounds from the 3 x 3 Hessian (log theta);
- ``marginalise``: fit it too and carry a log-uniform prior on mu over a range (the surrogate's
  training range by default); the bounds of (c1, c5) are the marginal ones of the Laplace
  approximation, the prior's curvature that of a normal in log mu with 95 % of its mass over the
  range; mu's share of each bound, sqrt(marginal^2 - conditional^2), is reported beside it.

Above mu of about 1 nothing slips on the paper's tests and the data hold no information on mu
(d r / d mu -> 0): its bound is then infinite, while those of c1 and c5 tend to the stick's (the
Hessian's Schur complement), which is what they are: every such mu gives the same (c1, c5).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ..forward.predictor import FixedParameter
from .certainty import bounds_pct, s_for_parameters

__all__ = [
    "FRICTION_MODES",
    "FixedParameter",
    "FrictionTreatment",
    "friction_bounds",
]

FRICTION_MODES = ("assumed", "known", "identify", "marginalise")
#: mu's range when neither the surrogate nor the user gives one (the FE stage of a stick surrogate):
#: frictionless-like below, perfect-stick-like above on the paper's tests (README, "Friction").
DEFAULT_MU_RANGE = (0.1, 3.0)


@dataclass(frozen=True)
class FrictionTreatment:
    """How a fit treats the friction coefficient mu.

    Parameters
    ----------
    mode : {"assumed", "known", "identify", "marginalise"}, default "assumed"
        One of ``FRICTION_MODES``.
    value : float, optional
        mu (>= 0) for ``known``.
    mu_range : tuple of float, optional
        (lo, hi), 0 < lo < hi: for ``identify`` the range mu is kept inside, for ``marginalise``
        the log-uniform prior's support.

    Raises
    ------
    ValueError
        If the mode is unknown, a known mu is not a number >= 0, or the range is not 0 < lo < hi.

    Examples
    --------
    >>> from indentation_studio.design import FrictionTreatment
    >>> FrictionTreatment.parse("marginalise:0.2:2")
    FrictionTreatment(mode='marginalise', value=None, mu_range=(0.2, 2.0))
    """

    mode: str = "assumed"
    value: float | None = None
    mu_range: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        if self.mode not in FRICTION_MODES:
            raise ValueError(f"friction: unknown treatment {self.mode!r}; use a value, {FRICTION_MODES}")
        if self.mode == "known" and not (
            self.value is not None and np.isfinite(self.value) and self.value >= 0
        ):
            raise ValueError(f"friction: a known mu must be a number >= 0, got {self.value!r}")
        if self.mu_range is not None:
            lo, hi = self.mu_range
            if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
                raise ValueError(f"friction: mu's range must be 0 < LO < HI, got {self.mu_range}")

    @classmethod
    def parse(cls, text: str | float | FrictionTreatment | None) -> FrictionTreatment:
        """The treatment a value or a text names.

        Parameters
        ----------
        text : str, float, FrictionTreatment or None
            ``None`` or ``'assumed'``, a number (known mu), ``'identify'`` or ``'marginalise'``,
            the last two optionally with a range: ``'marginalise:0.2:2'``.

        Returns
        -------
        FrictionTreatment
            The treatment.
        """
        if text is None:
            return cls()
        if isinstance(text, FrictionTreatment):
            return text
        if isinstance(text, (int, float)):
            return cls("known", float(text))
        parts = str(text).strip().split(":")
        head = parts[0].lower()
        if head in ("marginalize", "marginalise"):
            head = "marginalise"
        if head in ("identify", "marginalise"):
            if len(parts) == 1:
                return cls(head)
            if len(parts) != 3:
                raise ValueError(f"friction {text!r}: expected {head} or {head}:LO:HI")
            try:
                lo, hi = float(parts[1]), float(parts[2])
            except ValueError as exc:
                raise ValueError(f"friction {text!r}: LO and HI must be numbers > 0") from exc
            return cls(head, mu_range=(lo, hi))
        if head == "assumed" and len(parts) == 1:
            return cls()
        try:
            value = float(text)
        except ValueError as exc:
            raise ValueError(
                f"friction {text!r}: give mu (a number), 'identify' or 'marginalise' (optionally :LO:HI)"
            ) from exc
        return cls("known", value)

    @property
    def fits_mu(self) -> bool:
        """mu is a fitted parameter (identify, marginalise)."""
        return self.mode in ("identify", "marginalise")

    def describe(self, assumed_contact: str, mu_range: tuple[float, float] | None = None) -> str:
        """What the bounds assume of the contact, in words, for ``bounds_include``.

        Parameters
        ----------
        assumed_contact : str
            The model's contact (``Contact.describe()``), said when mu is assumed.
        mu_range : tuple of float, optional
            The range the fit used; default the treatment's.

        Returns
        -------
        str
            The sentence.
        """
        if self.mode == "assumed":
            return assumed_contact
        if self.mode == "known":
            return (
                "frictionless (known)" if self.value == 0 else f"Coulomb friction mu = {self.value:g} (known)"
            )
        lo, hi = mu_range or self.mu_range or DEFAULT_MU_RANGE
        if self.mode == "identify":
            return f"Coulomb friction, mu identified with (c1, c5) within [{lo:g}, {hi:g}]"
        return f"Coulomb friction, mu marginalised over a log-uniform prior on [{lo:g}, {hi:g}]"


def log_prior_sd(mu_range: tuple[float, float]) -> float:
    """The sd in log mu of the normal whose central 95 % spans ``mu_range`` (the Laplace
    stand-in for the log-uniform prior's curvature)."""
    lo, hi = mu_range
    return float(np.log(hi / lo) / (2.0 * stats.norm.ppf(0.975)))


def friction_bounds(
    hessian: np.ndarray,
    s: float,
    sigma: float,
    treatment: FrictionTreatment,
    mu_range: tuple[float, float],
    n: int,
) -> dict:
    """Eq. 6's bounds (percent) of (c1, c5, mu) of a fit with mu, identified or marginalised.

    Parameters
    ----------
    hessian : numpy.ndarray
        The 3 x 3 Hessian of the fit with mu, in log theta (H = 2 J^T J).
    s : float
        Eq. 8's s of the fit with three parameters.
    sigma : float
        The residual standard deviation.
    treatment : FrictionTreatment
        ``identify`` or ``marginalise``; for marginalise the prior's precision 1 / sd^2 in log mu
        is added as 2 sigma^2 / sd^2 to H.
    mu_range : tuple of float
        The prior's support (marginalise).
    n : int
        Number of data points (to read eq. 8's s for p = 2).

    Returns
    -------
    dict
        ``bounds_pct``: (c1, c5) with mu fitted too (its Schur complement); ``mu_pct`` (inf when
        the data hold nothing on mu and it is identified alone); ``conditional_pct``: mu known at
        the fit (the 2 x 2 block, with eq. 8's s read for p = 2 of the ``n`` data points, as a fit
        with mu known would have it); ``mu_share_pct``, mu's share of each bound:
        sqrt(bounds^2 - block^2), the 2 x 2 block's bounds at the same s (so the share is the
        correlation with mu, 0 where the data hold nothing on mu; the rest of the difference to
        ``conditional_pct`` is the third parameter's s).

    Raises
    ------
    ValueError
        If the Hessian is not 3 x 3.
    """
    H = np.array(hessian, float)
    if H.shape != (3, 3):
        raise ValueError(f"a fit with mu has a 3 x 3 Hessian, got {H.shape}")
    if treatment.mode == "marginalise":
        H[2, 2] += 2.0 * sigma**2 / log_prior_sd(mu_range) ** 2
    A, b, c = H[:2, :2], H[:2, 2], H[2, 2]
    conditional = bounds_pct(A, s_for_parameters(s, n, 3, 2))
    # (c1, c5) with mu fitted too: the Schur complement A - b b^T / c (Cauchy-Schwarz: b -> 0 with c,
    # so that where the data hold nothing on mu the bounds are the conditional ones, not inf)
    informative = c > 1e-12 * np.trace(A)
    schur = A - np.outer(b, b) / c if informative else A
    marginal = bounds_pct(schur, s)
    mu_info = c - b @ np.linalg.solve(A, b) if informative else 0.0
    mu_pct = 100.0 * s * np.sqrt(2.0 / mu_info) if mu_info > 1e-12 * c else np.inf
    # mu's share: what its uncertainty adds at the same s (the extra parameter's wider s apart)
    share = np.sqrt(np.maximum(marginal**2 - bounds_pct(A, s) ** 2, 0.0))
    return {
        "bounds_pct": marginal.tolist(),
        "mu_pct": float(mu_pct),
        "conditional_pct": conditional.tolist(),
        "mu_share_pct": share.tolist(),
    }
