"""Multi-fidelity emulator: a surrogate trained on a large low-fidelity campaign (a coarser mesh)
corrected by a Gaussian-process model of its discrepancy from a small high-fidelity campaign.

With F_lo, u_lo the LOW SURROGATE's predictions (so the discrepancy also absorbs the low
surrogate's own error) and W the fixed linear interpolation from the low to the high top nodes
(:func:`interpolation_matrix`), the prediction on the high campaign's top nodes is

    log F(theta) = log F_lo(theta) + delta_f(theta)                                    (1a)
    u(theta)     = W u_lo(theta)   + delta_u(theta)                                    (1b)

delta = (delta_f, delta_u) is learned from D_i = [log F_hi,i - log F_lo(theta_i),
u_hi,i - W u_lo(theta_i)] at the high campaign's points by a :class:`GaussianProcessSurrogate`
(PCA of each part, one GP per part on the standardised scores, log-scaled inputs over the high
campaign's box): its "force" is the ratio F_hi / F_lo, which it learns in log, i.e. delta_f. The
Jacobians follow from (1) through both levels; the reduced basis stacks the low basis carried by
W with the discrepancy's. The discrepancy's predictive covariance (GP variance of each score
through its PCA components) and its k-fold errors (what the PCA truncation and the GP leave) are
what a fit can add to its bounds as model error.

Friction. With a low surrogate over (c1, c5, mu) made of a perfect-stick surrogate plus the slip
(:class:`surrogate.slip_surrogate.SlipSurrogate`), the high campaign may be a perfect-stick
campaign over (c1, c5): delta is then learned from the high points' differences to the low
level at mu_s, the end of its mu range where nothing slips (``stick_mu``), and applied at every mu,

    log F(c1, c5, mu) = log F_lo(c1, c5, mu) + delta_f(c1, c5)                          (2a)
    u(c1, c5, mu)     = W u_lo(c1, c5, mu)   + delta_u(c1, c5)                          (2b)

with delta_i = [log F_hi,i - log F_lo(theta_i, mu_s), u_hi,i - W u_lo(theta_i, mu_s)], so that at
mu_s the surrogate gives the high level's stick back. Learned against the low level's stick
surrogate instead (files made before 2026-11-30, ``stick_mu`` None), it could not: the low
level's slip at its range end is not its stick (contact-L1 at mu = 3 against the stick: 0.04 % in
force, 0.20 mm in the field at the contact's edge; contact-L3: 0.005 %, 0.018 mm), and a fit of
stick data with mu free took a wrong mu and moved c5 (the shipped R = 8 mm surrogate on its own
stick runs at c1 = 1 kPa: c5 -6.0 %, mu 0.79; against mu_s: -0.5 %, mu 3.0;
docs/validation/model-error.md). Eq. 2 holds where the finer mesh changes the response the same
way whatever the friction (docs/validation/surrogates.md, "A multi-fidelity surrogate with mu").
A high campaign with the mu axis (or a stick campaign merged with one,
:func:`~.training_set.merged_training_data`) learns delta over (c1, c5, mu) instead, with eq. 1.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..forward.predictor import Prediction, ReducedBasis
from .base import FieldSurrogate, InputScaler, TrainingData, padded_jacobian
from .carried_emulation_error import CarriedEmulationError
from .discrepancy_covariance import DiscrepancyCovariance
from .discrepancy_errors import k_fold_discrepancy_errors, pca_truncation_errors
from .fidelity_levels import interpolation_matrix
from .gaussian_process import GaussianProcessSurrogate
from .slip_surrogate import SlipSurrogate
from .stick_convention import StickConvention
from .two_level import TwoLevelSurrogate, model_differences

__all__ = ["MultiFidelitySurrogate", "interpolation_matrix", "model_differences"]


class MultiFidelitySurrogate(
    StickConvention, DiscrepancyCovariance, CarriedEmulationError, TwoLevelSurrogate
):
    """A low-fidelity surrogate plus a GP of its discrepancy from a high-fidelity campaign.

    Predicts the high fidelity on the high campaign's top nodes (module docstring, eq. 1a, 1b).
    A Predictor, with Jacobians and a reduced basis like the single-fidelity surrogates;
    :meth:`fit` takes the high campaign.

    Parameters
    ----------
    low : FieldSurrogate
        The trained low-fidelity surrogate.
    input_scale : {"log", "linear"}, default "log"
        Scaling of the discrepancy GP's inputs over the high campaign's box.
    pca_tol : float, default 1e-3
        PCA tolerance of the discrepancy.
    max_components : int, default 8
        At most this many PCA components per part of the discrepancy.
    restarts : int, default 3
        Restarts of the discrepancy GP's optimiser.
    per_component : bool, default True
        One GP per discrepancy score.
    folds : int, default 5
        With ``folds`` >= 2, the discrepancy's k-fold errors go to ``meta['discrepancy_kfold']``.
    stick_mu : float, "end" or None, default "end"
        Over a stick-plus-slip low level, the mu a stick campaign is compared at (eq. 2): "end",
        the low level's mu range end (resolved when trained); None, its stick surrogate (files
        made before 2026-11-30).
    """

    kind = "mf"
    levels = ("low", "discrepancy")
    first_meta_key = "low_fidelity"

    def __init__(
        self,
        low: FieldSurrogate,
        input_scale: str = "log",
        pca_tol: float = 1e-3,
        max_components: int = 8,
        restarts: int = 3,
        per_component: bool = True,
        folds: int = 5,
        stick_mu: float | str | None = "end",
    ) -> None:
        self.low = low
        super().__init__(input_scale, pca_tol, max_components)
        self.restarts, self.per_component, self.folds = restarts, per_component, folds
        self.stick_mu = stick_mu

    def hyperparameters(self) -> dict[str, Any]:
        """The constructor's arguments (the low surrogate apart)."""
        return {
            **super().hyperparameters(),
            "restarts": self.restarts,
            "per_component": self.per_component,
            "folds": self.folds,
            "stick_mu": self.stick_mu,
        }

    def _discrepancy_model(self) -> GaussianProcessSurrogate:
        return GaussianProcessSurrogate(
            restarts=self.restarts,
            per_component=self.per_component,
            input_scale=self.input_scale,
            pca_tol=self.pca_tol,
            max_components=self.max_components,
        )

    # ------------------------------------------------------------------ training
    def _check_compatible(self, data: TrainingData) -> None:
        problems = []
        try:
            low = self._low_for(data)
        except ValueError as exc:
            raise ValueError(
                f"the high-fidelity campaign does not describe the low-fidelity surrogate's test: {exc}"
            ) from None
        contact = ((data.source or {}).get("model") or {}).get("contact") or {}
        if low is not self.low and contact.get("friction") is not None:
            problems.append(
                f"contact: a high campaign over (c1, c5) with mu = {contact['friction']:g} cannot be learned "
                "at the stick; run it with the perfect stick or with a mu axis"
            )
        problems += self._same_test_problems(data, ("low", "high"))
        if problems:
            raise ValueError(
                "the high-fidelity campaign does not describe the low-fidelity surrogate's test: "
                + "; ".join(problems)
            )
        outside = ~self._inside_low_box(low, data.theta)
        if outside.any():
            raise ValueError(
                f"{int(outside.sum())} high-fidelity points (e.g. {data.theta[outside][0].tolist()} kPa) lie "
                f"outside the low-fidelity surrogate's training box {low.scaler.lo.tolist()} .. "
                f"{low.scaler.hi.tolist()}: it would extrapolate there"
            )

    def discrepancy_data(self, data: TrainingData) -> TrainingData:
        """The discrepancies D of the high-fidelity ``data`` from the low surrogate (module eq. 1a, 1b).

        Its 'force' is F_hi / F_lo (learned in log: delta_f of eq. 1a), its field u_hi - W u_lo
        (eq. 1b).

        Parameters
        ----------
        data : TrainingData
            The high-fidelity campaign.

        Returns
        -------
        TrainingData
            The discrepancies at the same points.
        """
        low = self._low_for(data).predict(data.theta)
        return self._correction_data(data, low.force, self._carried(low.displacement))

    def fit(self, data: TrainingData, seed: int = 0) -> MultiFidelitySurrogate:
        """Learn the discrepancy of the low surrogate from the high-fidelity campaign ``data``.

        With ``folds`` >= 2 also its k-fold errors (``meta['discrepancy_kfold']``).

        Parameters
        ----------
        data : TrainingData
            The high-fidelity campaign (same test as the low surrogate's).
        seed : int, default 0
            Seed of the GP's training.

        Returns
        -------
        MultiFidelitySurrogate
            ``self``, trained.
        """
        t0 = time.perf_counter()
        if not isinstance(self.low, SlipSurrogate):
            self.stick_mu = None  # no stick to take at a mu
        elif self.stick_mu is not None:
            self.stick_mu = self._resolved_stick_mu()
        self._check_compatible(data)
        self.parameters = tuple(self.low.parameters)
        self.depth = np.asarray(data.depth, float)
        self.top_xyz = np.asarray(data.top_xyz, float)
        self.n_steps, self.n_nodes = data.displacement.shape[1], data.displacement.shape[2]
        self.interpolation = interpolation_matrix(self.low.top_xyz, self.top_xyz)
        D = self.discrepancy_data(data)
        self.discrepancy = self._discrepancy_model().fit(D, seed=seed)
        self._set_box()
        d = self.discrepancy.meta
        self.meta.update(
            {
                "kind": self.kind,
                "input_scale": self.input_scale,
                "training_points": int(data.n),
                "force_components": d["force_components"],
                "field_components": d["field_components"],
                "pca_tol": self.pca_tol,
                "box": [self.scaler.lo.tolist(), self.scaler.hi.tolist()],
                "discrepancy_parameters": list(self.discrepancy.parameters),
                "discrepancy": {
                    **{k: d[k] for k in ("kernels", "force_pca_error", "field_pca_error")},
                    "truncation": pca_truncation_errors(self.discrepancy, D),
                },
                "campaign": data.source,
                "low_fidelity": self.low.meta,
            }
        )
        if self.folds >= 2:
            self.discrepancy_error, self.meta["discrepancy_kfold"] = k_fold_discrepancy_errors(
                self._discrepancy_model,
                D,
                folds=self.folds,
                seed=seed,
                steps=self.n_steps,
                strata=self._strata(D),
            )
        self.meta["fit_s"] = time.perf_counter() - t0
        return self

    def _set_box(self) -> None:
        """The box a fit stays in: the discrepancy's over its parameters (the high campaign's), the
        low level's over the rest (mu, for a discrepancy learned at the stick)."""
        d, k = self.discrepancy.scaler, len(self.discrepancy.parameters)
        lo = np.concatenate([d.lo, self.low.scaler.lo[k:]])
        hi = np.concatenate([d.hi, self.low.scaler.hi[k:]])
        self.scaler = InputScaler(lo, hi, d.scale)

    def _discrepancy_theta(self, theta: np.ndarray) -> np.ndarray:
        """The parameters the discrepancy is a function of: all, or (c1, c5) when learned at the stick."""
        return theta[:, : len(self.discrepancy.parameters)]

    def corrected(self, low_model) -> MultiFidelitySurrogate:
        """The high fidelity as ``low_model`` plus this surrogate's discrepancy.

        Eq. 1a, 1b with the low level's model in place of its surrogate.

        With ``low_model`` the low level's FE model, this is what a fit's FE stage runs: one run of
        the low level (seconds) corrected toward the high fidelity by the learned discrepancy,
        instead of a run of the high fidelity (minutes to an hour); the difference from this
        surrogate is then the low surrogate's own error alone.

        Parameters
        ----------
        low_model : Predictor
            A model of the low level on its top nodes, over (c1, c5) or (c1, c5, mu)
            (e.g. :class:`~indentation_studio.forward.fe_predictor.FESolverPredictor`).

        Returns
        -------
        MultiFidelitySurrogate
            Sharing this one's discrepancy and interpolation, over ``low_model``'s parameters.

        Raises
        ------
        ValueError
            If ``low_model`` is over other parameters, or the discrepancy needs mu it does not have.
        """
        params = tuple(low_model.parameters)
        if params[:2] != ("c1", "c5") or len(params) < len(self.discrepancy.parameters):
            raise ValueError(
                f"the low model is over {params}; the discrepancy needs {tuple(self.discrepancy.parameters)}"
            )
        model = type(self)(low_model, **self.hyperparameters())
        model.discrepancy, model.interpolation = self.discrepancy, self.interpolation
        model.parameters = params
        model.depth, model.top_xyz = self.depth, self.top_xyz
        model.n_steps, model.n_nodes = self.n_steps, self.n_nodes
        model.scaler = InputScaler(
            self.scaler.lo[: len(params)], self.scaler.hi[: len(params)], self.scaler.scale
        )
        model._meta = self.meta
        model.discrepancy_error = self.discrepancy_error
        return model

    # ------------------------------------------------------------------ prediction
    def _carried(self, u: np.ndarray) -> np.ndarray:
        """A low-fidelity array with the top nodes on axis 2, (n, steps, nodes, ...), at the high
        top nodes: W applied along that axis (eq. 1b)."""
        moved = np.moveaxis(u, 2, 0)
        out = self.interpolation @ moved.reshape(moved.shape[0], -1)
        return np.moveaxis(out.reshape(-1, *moved.shape[1:]), 0, 2)

    def predict(self, theta, jacobian: bool = False) -> Prediction:
        """Force curves and fields of the high fidelity at ``theta`` (module eq. 1a, 1b).

        Parameters
        ----------
        theta : array_like
            (n, p) points, kPa.
        jacobian : bool, default False
            Also their Jacobians, through both levels.

        Returns
        -------
        Prediction
            On the high campaign's top nodes.
        """
        theta = self._checked_theta(theta)
        low = self.low.predict(theta, jacobian)
        delta = self.discrepancy.predict(self._discrepancy_theta(theta), jacobian)  # force: exp(delta_f)
        force = low.force * delta.force
        disp = self._carried(low.displacement) + delta.displacement
        fj = dj = None
        if jacobian:
            p = theta.shape[1]  # d delta / d mu = 0 when learned at the stick (eq. 2)
            dfj, ddj = (padded_jacobian(j, p) for j in (delta.force_jacobian, delta.displacement_jacobian))
            fj = low.force_jacobian * delta.force[..., None] + low.force[..., None] * dfj
            dj = self._carried(low.displacement_jacobian) + ddj
        return Prediction(force, disp, self.depth, self.top_xyz, self.parameters, fj, dj)

    def reduced_basis(self) -> ReducedBasis:
        """The low basis carried to the high nodes stacked with the discrepancy's basis.

        The coordinates are both levels' scores side by side (eq. 1 is affine in them).

        Returns
        -------
        ReducedBasis
            The stacked basis.
        """
        low, delta = self.low.reduced_basis(), self.discrepancy.reduced_basis()
        shape = (low.steps, low.nodes, 3)

        def carried(rows: np.ndarray) -> np.ndarray:
            rows = np.atleast_2d(rows)
            return self._carried(rows.reshape(len(rows), *shape)).reshape(len(rows), -1)

        def coordinates(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            theta = self._checked_theta(theta)
            (zf, zu), (df, du) = low.coordinates(theta), delta.coordinates(self._discrepancy_theta(theta))
            return np.hstack([zf, df]), np.hstack([zu, du])

        return ReducedBasis(
            force_mean=low.force_mean + delta.force_mean,
            force_basis=np.vstack([low.force_basis, delta.force_basis]),
            field_mean=carried(low.field_mean)[0] + delta.field_mean,
            field_basis=np.vstack([carried(low.field_basis), delta.field_basis]),
            steps=self.n_steps,
            nodes=self.n_nodes,
            coordinates=coordinates,
        )

    def training_gap(self, theta) -> np.ndarray:
        """The low-fidelity level's :meth:`FieldSurrogate.training_gap`.

        Its campaign covers the box; the discrepancy's few high-fidelity points are sparse by
        design (their GP says so in the bounds).

        Parameters
        ----------
        theta : array_like
            (n, p) points, kPa.

        Returns
        -------
        numpy.ndarray
            (n,) gaps in median training spacings.
        """
        return self.low.training_gap(theta)

    # ------------------------------------------------------------------ saving (no pickle): TwoLevelSurrogate
    @classmethod
    def _from_levels(
        cls, config: dict[str, Any], first: FieldSurrogate, second: FieldSurrogate
    ) -> MultiFidelitySurrogate:
        """The surrogate from its low level and its discrepancy GP; W rebuilt from their top nodes."""
        if not isinstance(second, GaussianProcessSurrogate):
            raise ValueError(f"the discrepancy model must be a 'gp' surrogate, not {second.kind!r}")
        # a file made before stick_mu learned the stick's discrepancy against the stick surrogate
        model = cls(first, **{"stick_mu": None, **config["hyperparameters"]})
        model.discrepancy = second
        model._set_box()
        model.interpolation = interpolation_matrix(first.top_xyz, second.top_xyz)
        return model
