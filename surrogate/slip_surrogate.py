"""A surrogate over (c1, c5, mu) built as the perfect stick plus the slip: a surrogate trained on a
stick campaign over (c1, c5) corrected by an MLP of what slip changes, learned from a campaign with
a mu axis on the same mesh and test.

With F_st, u_st the STICK SURROGATE's predictions at (c1, c5) (so the correction also absorbs its
own error), the prediction at (c1, c5, mu) is

    log F(c1, c5, mu) = log F_st(c1, c5) + delta_f(c1, c5, mu)                          (1a)
    u(c1, c5, mu)     = u_st(c1, c5)     + delta_u(c1, c5, mu)                          (1b)

delta is an :class:`surrogate.mlp.MLPSurrogate` trained on D_i = [F_i / F_st(theta_i),
u_i - u_st(theta_i)] (its "force" is the ratio, learned in log). Where nothing slips (mu above
about 1) delta is small, and an error that is a fraction of delta is a far smaller fraction of the
response than the same fraction of a plain surrogate over (c1, c5, mu) (docs/validation/surrogates.md,
"A surrogate with mu"). The Jacobians follow from (1) through both parts, d/dmu from delta alone;
the reduced basis stacks the two parts' bases. It is the multi-fidelity idea of
:mod:`surrogate.multi_fidelity` with the stick as the low level and slip as the discrepancy, but on
one mesh: a fit on it has no high-fidelity level and no discrepancy variance to carry.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from ..forward.predictor import Prediction, ReducedBasis
from .base import FieldSurrogate, TrainingData, padded_jacobian
from .mlp import MLPSurrogate
from .two_level import TwoLevelSurrogate

__all__ = ["SlipSurrogate"]


class SlipSurrogate(TwoLevelSurrogate):
    """A perfect-stick surrogate over (c1, c5) plus an MLP of the slip's change over (c1, c5, mu).

    See the module docstring (eq. 1a, 1b). A Predictor over ``stick.parameters + ("mu",)`` with
    Jacobians and a reduced basis like the single-level surrogates; :meth:`fit` takes the campaign
    with the mu axis.

    Parameters
    ----------
    stick : FieldSurrogate
        The trained perfect-stick surrogate, over (c1, c5).
    input_scale : {"log", "linear"}, default "log"
        Scaling of the slip MLP's inputs over the campaign's box.
    pca_tol : float, default 1e-3
        PCA tolerance of the slip's change.
    max_components : int, default 40
        At most this many PCA components per part of it.
    **mlp_options
        Options of :class:`surrogate.mlp.MLPSurrogate` (width, layers, epochs).
    """

    kind = "slip"
    levels = ("stick", "slip")
    first_meta_key = "stick"

    def __init__(
        self,
        stick: FieldSurrogate,
        input_scale: str = "log",
        pca_tol: float = 1e-3,
        max_components: int = 40,
        **mlp_options: Any,
    ) -> None:
        self.stick = stick
        self.mlp_options = dict(mlp_options)
        self.slip: MLPSurrogate | None = None
        super().__init__(input_scale, pca_tol, max_components)

    def hyperparameters(self) -> dict[str, Any]:
        """The constructor's arguments (the stick surrogate apart).

        Returns
        -------
        dict
            Input scale, PCA tolerance, components and the MLP's options.
        """
        return {**super().hyperparameters(), **self.mlp_options}

    def _slip_model(self) -> MLPSurrogate:
        return MLPSurrogate(
            input_scale=self.input_scale,
            pca_tol=self.pca_tol,
            max_components=self.max_components,
            **self.mlp_options,
        )

    # ------------------------------------------------------------------ training
    def _check_compatible(self, data: TrainingData) -> None:
        stick = self.stick
        problems = []
        if tuple(data.parameters) != (*stick.parameters, "mu"):
            problems.append(
                f"parameters: {tuple(data.parameters)} (campaign), need the stick surrogate's "
                f"{stick.parameters} then 'mu'"
            )
        problems += self._same_test_problems(data, ("stick", "campaign"))
        top = np.asarray(data.top_xyz, float)
        if top.shape != stick.top_xyz.shape or not np.allclose(top, stick.top_xyz, rtol=0, atol=1e-9):
            problems.append(f"top nodes: {len(stick.top_xyz)} (stick) vs {len(top)} (campaign): not one mesh")
        stick_model = (stick.meta.get("campaign") or {}).get("model")
        model = (data.source or {}).get("model")
        if stick_model is not None and model is not None and stick_model.get("mesh") != model.get("mesh"):
            problems.append(f"mesh: {stick_model.get('mesh')} (stick) vs {model.get('mesh')} (campaign)")
        if problems:
            raise ValueError(
                "the campaign with mu does not describe the stick surrogate's test: " + "; ".join(problems)
            )
        outside = ~stick.inside_box(data.theta[:, :-1])
        if outside.any():
            raise ValueError(
                f"{int(outside.sum())} points (e.g. {data.theta[outside][0].tolist()}) lie outside the stick "
                f"surrogate's training box {stick.scaler.lo.tolist()} .. {stick.scaler.hi.tolist()}"
            )

    def slip_data(self, data: TrainingData) -> TrainingData:
        """What slip changes at the campaign's points: F / F_st and u - u_st (module eq. 1a, 1b).

        Parameters
        ----------
        data : TrainingData
            The campaign over (c1, c5, mu).

        Returns
        -------
        TrainingData
            The changes at the same points (its 'force' is the ratio).
        """
        stick = self.stick.predict(data.theta[:, :-1])
        return self._correction_data(data, stick.force, stick.displacement)

    def fit(self, data: TrainingData, seed: int = 0) -> SlipSurrogate:
        """Learn the slip's change from the campaign with mu, ``data``.

        Parameters
        ----------
        data : TrainingData
            Over the stick surrogate's parameters and mu (last), same mesh and test.
        seed : int, default 0
            Seed of the MLP's training.

        Returns
        -------
        SlipSurrogate
            ``self``, trained.

        Raises
        ------
        ValueError
            If the campaign is not over the stick's parameters and mu, or its mesh, depths or test
            differ from the stick surrogate's, or a point lies outside the stick's training box.
        """
        t0 = time.perf_counter()
        self._check_compatible(data)
        self.parameters = tuple(data.parameters)
        self.depth = np.asarray(data.depth, float)
        self.top_xyz = np.asarray(data.top_xyz, float)
        self.n_steps, self.n_nodes = data.displacement.shape[1], data.displacement.shape[2]
        self.slip = self._slip_model().fit(self.slip_data(data), seed=seed)
        self._share_slip_arrays()
        s = self.slip.meta
        self.meta.update(
            {
                "kind": self.kind,
                "input_scale": self.input_scale,
                "training_points": int(data.n),
                "force_components": s["force_components"],
                "field_components": s["field_components"],
                "pca_tol": self.pca_tol,
                "box": s["box"],
                "slip": {k: s[k] for k in ("force_pca_error", "field_pca_error", "fit_s")},
                "campaign": data.source,
                "stick": self.stick.meta,
                "fit_s": time.perf_counter() - t0,
            }
        )
        return self

    def _share_slip_arrays(self) -> None:
        """The box and the training points are the slip MLP's (over all parameters)."""
        self.scaler = self.slip.scaler
        self.training_theta = self.slip.training_theta

    # ------------------------------------------------------------------ prediction
    def predict(self, theta, jacobian: bool = False) -> Prediction:
        """Force curves and fields at ``theta`` (module eq. 1a, 1b).

        Parameters
        ----------
        theta : array_like
            (n, p) points: (c1, c5) kPa and mu.
        jacobian : bool, default False
            Also their Jacobians, through both parts (d/dmu from the slip's alone).

        Returns
        -------
        Prediction
            Forces (mN), top-surface displacements (mm) and, if asked, their Jacobians.
        """
        theta = self._checked_theta(theta)
        stick = self.stick.predict(theta[:, :-1], jacobian)
        slip = self.slip.predict(theta, jacobian)  # force: the ratio exp(delta_f)
        force = stick.force * slip.force
        disp = stick.displacement + slip.displacement
        fj = dj = None
        if jacobian:
            p = theta.shape[1]  # d/dmu of the stick: 0
            fj = (
                padded_jacobian(stick.force_jacobian, p) * slip.force[..., None]
                + stick.force[..., None] * slip.force_jacobian
            )
            dj = padded_jacobian(stick.displacement_jacobian, p) + slip.displacement_jacobian
        return Prediction(force, disp, self.depth, self.top_xyz, self.parameters, fj, dj)

    def reduced_basis(self) -> ReducedBasis:
        """The stick's basis stacked with the slip's; the coordinates both parts' scores side by side.

        Returns
        -------
        ReducedBasis
            The stacked basis (eq. 1 is affine in the scores).
        """
        stick, slip = self.stick.reduced_basis(), self.slip.reduced_basis()

        def coordinates(theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            theta = self._checked_theta(theta)
            (zf, zu), (df, du) = stick.coordinates(theta[:, :-1]), slip.coordinates(theta)
            return np.hstack([zf, df]), np.hstack([zu, du])

        return ReducedBasis(
            force_mean=stick.force_mean + slip.force_mean,
            force_basis=np.vstack([stick.force_basis, slip.force_basis]),
            field_mean=stick.field_mean + slip.field_mean,
            field_basis=np.vstack([stick.field_basis, slip.field_basis]),
            steps=self.n_steps,
            nodes=self.n_nodes,
            coordinates=coordinates,
        )

    @classmethod
    def _from_levels(
        cls, config: dict[str, Any], first: FieldSurrogate, second: FieldSurrogate
    ) -> SlipSurrogate:
        """The surrogate from its stick surrogate and its slip MLP."""
        if not isinstance(second, MLPSurrogate):
            raise ValueError(f"the slip model must be an 'mlp' surrogate, not {second.kind!r}")
        model = cls(first, **config["hyperparameters"])
        model.slip = second
        model._share_slip_arrays()
        return model
