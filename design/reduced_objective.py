"""The objective of eq. 5 evaluated in a Predictor's reduced space, without rebuilding its fields.

A surrogate predicts the top-surface field as an affine map of a few PCA scores,
u(theta) = mean + z(theta) @ C (forward.predictor.ReducedBasis). The displacement residuals of
eq. 4b are affine in u, hence in z: stacking the weighted residuals of the three directions (each
scaled by sqrt(eta_j w_j^(i)) / max |u_j,exp|, as in eq. 5 and 4b),

    sum_j eta_j F_uj(theta) = || B z - r0 ||^2,   B = A C^T,   r0 = A (u_exp - mean),

with A the diagonal of those scales over the steps and measured nodes the objective uses. With
the thin SVD B = U S V^T, r0 splits into its part in B's column space, U q with q = U^T r0, and
the rest, whose squared norm does not depend on theta:

    sum_j eta_j F_uj(theta) = || (S V^T) z - q ||^2 + || r0 - U q ||^2            (exact)

so each evaluation costs a k x k product (k = the field's components) instead of rebuilding
steps x nodes x 3 values. Written as a sum of two squares, nothing cancels (expanding into
z^T B^T B z - 2 z^T B^T r0 + r0^T r0 would lose digits where F is small next to ||r0||^2).

The force term of eq. 4a divides the force error by the measured force, f / f_exp - 1, and the
surrogate regresses log force: that term is not affine in the scores and is evaluated as it is,
exp(log force) at the steps the objective uses (at most N_s values per point, cheap).
"""

from __future__ import annotations

import numpy as np

from ..forward.predictor import ReducedBasis, ReducedPredictor
from .objective import Objective, check_weights


class ReducedObjective:
    """F(theta) of eq. 5 in one Predictor's reduced basis, for one objective and one set of weights.

    Equal to ``objective.value(predictor.predict(theta), eta)`` up to rounding, without building
    the fields.

    Parameters
    ----------
    objective : Objective
        The target response (eq. 4a, 4b); its field must have the basis's (steps, nodes, 3).
    basis : ReducedBasis
        The predictor's reduced basis (``ReducedPredictor.reduced_basis()``).
    eta : array_like
        The four weights of eq. 5.

    Raises
    ------
    ValueError
        If the objective's field and the basis describe different models.
    """

    def __init__(self, objective: Objective, basis: ReducedBasis, eta) -> None:
        self.eta = check_weights(eta)
        self.coordinates = basis.coordinates
        steps, measured = objective.steps, objective.measured
        field_shape = (basis.steps, basis.nodes, 3)
        if objective.displacement.shape != field_shape:
            raise ValueError(
                f"the objective's field is {objective.displacement.shape} but the predictor's basis is "
                f"{field_shape} (steps, nodes, 3): they describe different models"
            )  # the Objective holds as many force steps as field steps
        # eq. 4a: only the steps the objective uses, in log force
        self.force_weight = float(self.eta[0])
        self.log_force_mean = np.asarray(basis.force_mean, float)[steps]
        self.log_force_basis = np.asarray(basis.force_basis, float)[:, steps]
        self.force_target = objective.force[steps]
        self.force_scale = objective.force_scale
        # eq. 4b and 5: sqrt(eta_j) sqrt(w_j) / max |u_j,exp| per step, measured node and direction
        scale = np.sqrt(self.eta[1:]) * objective.displacement_residual_scale()[measured]  # (m, 3)
        a = np.zeros(field_shape)
        a[np.ix_(steps, np.flatnonzero(measured), np.arange(3))] = scale[None]
        keep = np.flatnonzero(a.ravel())  # no weight, no residual (a direction with eta_j = 0)
        a = a.ravel()[keep]
        B = np.asarray(basis.field_basis, float)[:, keep].T * a[:, None]  # (residuals, k)
        r0 = a * (objective.displacement.ravel()[keep] - np.asarray(basis.field_mean, float)[keep])
        if len(keep):
            U, S, Vt = np.linalg.svd(B, full_matrices=False)
        else:  # no displacement term: F is the force term alone
            U, S, Vt = np.zeros((0, 0)), np.zeros(0), np.zeros((0, B.shape[1]))
        self.field_map = S[:, None] * Vt  # (r, k): z -> the residual's coordinates in U
        self.field_target = U.T @ r0
        self.field_floor = float(np.sum((r0 - U @ self.field_target) ** 2))
        self.field_residuals = len(keep)

    def value(self, theta: np.ndarray) -> np.ndarray:
        """F of eq. 5 at theta, in the reduced space.

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) points, kPa.

        Returns
        -------
        numpy.ndarray
            (n,) F.
        """
        z_force, z_field = self.coordinates(np.atleast_2d(np.asarray(theta, float)))
        d = z_field @ self.field_map.T - self.field_target
        F = np.einsum("nk,nk->n", d, d) + self.field_floor
        if self.force_weight > 0.0:
            force = np.exp(z_force @ self.log_force_basis + self.log_force_mean)
            r = (force - self.force_target) / self.force_scale
            F += self.force_weight * np.einsum("ns,ns->n", r, r)
        return F


class FieldObjective:
    """F (n,) of eq. 5 from a Predictor's full fields: ``objective.value(predictor.predict(theta))``.

    Parameters
    ----------
    objective : Objective
        The target response (eq. 4a, 4b).
    predictor : Predictor
        Any predictor (e.g. an FE solver).
    eta : array_like
        The four weights of eq. 5.
    """

    def __init__(self, objective: Objective, predictor, eta) -> None:
        self.objective, self.predictor, self.eta = objective, predictor, check_weights(eta)

    def value(self, theta: np.ndarray) -> np.ndarray:
        """F of eq. 5 at theta, from the predicted fields.

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) points, kPa.

        Returns
        -------
        numpy.ndarray
            (n,) F.
        """
        return self.objective.value(self.predictor.predict(theta), self.eta)


def objective_function(
    objective: Objective, predictor, eta, reduced: bool | None = None
) -> ReducedObjective | FieldObjective:
    """F of eq. 5 against ``objective``, as an object with ``value(theta (n, p)) -> F (n,)``.

    Parameters
    ----------
    objective : Objective
        The target response.
    predictor : Predictor
        The model.
    eta : array_like
        The four weights of eq. 5.
    reduced : bool, optional
        None: in the predictor's reduced space when it offers one (:class:`ReducedPredictor`),
        else from its predicted fields (the FE solvers); False: from the fields; True: insist on
        the reduced space.

    Returns
    -------
    ReducedObjective or FieldObjective
        The objective function.

    Raises
    ------
    ValueError
        If ``reduced`` is True and the predictor has no reduced basis.
    """
    has_basis = isinstance(predictor, ReducedPredictor)
    if reduced and not has_basis:
        raise ValueError(f"{type(predictor).__name__} has no reduced basis to evaluate F in")
    if has_basis and reduced is not False:
        return ReducedObjective(objective, predictor.reduced_basis(), eta)
    return FieldObjective(objective, predictor, eta)
