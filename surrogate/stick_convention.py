"""Where a multi-fidelity surrogate takes the perfect stick on a low level with mu
(:mod:`surrogate.multi_fidelity`, eq. 2): a stick campaign compared with the stick-plus-slip low
level at ``stick_mu`` (its mu range end, where nothing slips), a merged campaign's stick points
told apart by that mu (its box check, its k-fold's strata), and the surrogate's stick level."""

from __future__ import annotations

import numpy as np

from ..forward.predictor import FixedParameter
from .base import TrainingData
from .fidelity_levels import LowAtStickMu
from .slip_surrogate import SlipSurrogate

__all__ = ["StickConvention"]


class StickConvention:
    """The stick's mu, a base of :class:`~surrogate.multi_fidelity.MultiFidelitySurrogate` (which
    holds ``low``, ``stick_mu`` and, once trained, ``discrepancy``)."""

    @property
    def learned_at_stick(self) -> bool:
        """Whether the discrepancy was learned at the perfect stick and is applied at every mu.

        True when it is over fewer parameters (c1, c5) than the low level's (c1, c5, mu):
        :mod:`surrogate.multi_fidelity` eq. 2a, 2b.

        Returns
        -------
        bool
        """
        return len(self.discrepancy.parameters) < len(self.low.parameters)

    def _low_for(self, data: TrainingData):
        """The low level the high campaign ``data`` is compared with: the low surrogate itself over
        the same parameters, or, when ``data`` is a perfect-stick campaign over (c1, c5), a
        stick-plus-slip low level at ``stick_mu`` (eq. 2; its stick surrogate where ``stick_mu``
        is None)."""
        low = self.low
        if tuple(data.parameters) == tuple(low.parameters):
            return low
        if isinstance(low, SlipSurrogate) and tuple(data.parameters) == tuple(low.stick.parameters):
            return low.stick if self.stick_mu is None else LowAtStickMu(low, self._resolved_stick_mu())
        raise ValueError(
            f"parameters: {low.parameters} (low) vs {tuple(data.parameters)} (high); a high campaign over "
            "(c1, c5) needs a stick-plus-slip low surrogate ('slip') to be learned at the stick"
        )

    def _resolved_stick_mu(self) -> float:
        """``stick_mu`` as a number: "end" is the low level's mu range end."""
        if self.stick_mu == "end":
            return float(self.low.scaler.hi[list(self.low.parameters).index("mu")])
        return float(self.stick_mu)

    def _inside_low_box(self, low, theta: np.ndarray) -> np.ndarray:
        """Which high points the low level ``low`` covers: its box, and for a campaign merged over
        (c1, c5, mu) also a stick point (mu at ``stick_mu``) whose (c1, c5) lies in the stick
        surrogate's box, as :class:`LowAtStickMu` judges a stick campaign's (the slip's change is
        learned a little inside that box, c1 from 1.016 rather than 1 kPa in the shipped ones)."""
        inside = low.inside_box(theta)
        if low is self.low and isinstance(low, SlipSurrogate) and self.stick_mu is not None:
            inside |= self._at_stick_mu(theta) & low.stick.inside_box(theta[:, :-1])
        return inside

    def _at_stick_mu(self, theta: np.ndarray) -> np.ndarray:
        """Which points over (c1, c5, mu) are a merged stick campaign's: mu at ``stick_mu``
        (:func:`~.training_set.merged_training_data` sets it exactly)."""
        return np.isclose(theta[:, -1], self._resolved_stick_mu(), rtol=1e-9, atol=0.0)

    def _strata(self, data: TrainingData) -> np.ndarray | None:
        """For a campaign merged over (c1, c5, mu) with stick points at ``stick_mu`` and points with
        a mu axis: which are stick points (the k-fold is stratified by it); None otherwise."""
        if not isinstance(self.low, SlipSurrogate) or self.stick_mu is None or "mu" not in data.parameters:
            return None
        at_stick = self._at_stick_mu(data.theta)
        return at_stick if 0 < at_stick.sum() < data.n else None

    def stick_level(self):
        """This surrogate at the perfect stick, over (c1, c5).

        What a high stick campaign is validated against: itself at ``stick_mu``, where a stick
        campaign's discrepancy was learned (eq. 2, or a merged campaign's stick points); for a
        file made before ``stick_mu`` (None), the low level's stick surrogate plus the same
        discrepancy.

        Returns
        -------
        Predictor
            Over (c1, c5).

        Raises
        ------
        ValueError
            If neither: the discrepancy was learned over the low level's parameters with no mu
            taken as the stick.
        """
        if self.stick_mu is not None:
            return FixedParameter(self, "mu", self._resolved_stick_mu())
        if not self.learned_at_stick:
            raise ValueError("the discrepancy was learned over the low level's parameters, not at the stick")
        model = type(self)(self.low.stick, **self.hyperparameters())
        model.discrepancy, model.interpolation = self.discrepancy, self.interpolation
        model.parameters = tuple(self.discrepancy.parameters)
        model.depth, model.top_xyz = self.depth, self.top_xyz
        model.n_steps, model.n_nodes = self.n_steps, self.n_nodes
        model.discrepancy_error = self.discrepancy_error
        model._set_box()
        return model
