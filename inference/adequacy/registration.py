"""What the registration and the interpolation do to the residuals, as the adequacy test sees them:
the data processed again about other indentation points within the declared registration
uncertainty, the field's gradients at the nodes, and the interpolation's own bias."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...forward.convergence.mesh_study import top_field_interpolator
from ..experiment.processing import (
    NodeInterpolation,
    RegisteredDIC,
    node_interpolation,
)

__all__ = ["PROFILE_DIRECTIONS", "PROFILE_RINGS", "operator_bias", "registration_alternatives"]


#: The indentation points the registration profile tries: rings at these fractions of the declared
#: registration uncertainty, in this many directions.
PROFILE_RINGS = (0.25, 0.5, 0.75, 1.0)
PROFILE_DIRECTIONS = 12


def registration_alternatives(
    objective, dic: RegisteredDIC, used_steps: np.ndarray, eta, registration_mm: float
) -> np.ndarray:
    """(a, residuals): how eq. 5's residual vector changes when the DIC points are registered about
    another indentation point within ``registration_mm`` (rings at :data:`PROFILE_RINGS` of it, in
    :data:`PROFILE_DIRECTIONS` directions).

    The data stay what they are; the whole processing runs again (the quarter's folding about the
    point, the nearest points, the planes), so what a misregistration does next to the symmetry
    planes and to which points a node sees is in it, which no gradient at the nodes holds. A node
    that has no plane about one of the points keeps its value.

    Parameters
    ----------
    objective : Objective
        The fit's objective (its data came from ``dic`` by the same processing).
    dic : RegisteredDIC
        The DIC data in the model frame.
    used_steps : numpy.ndarray
        The experiment's steps used (1..N).
    eta : array_like
        The weights of eq. 5.
    registration_mm : float
        The declared registration uncertainty, mm.

    Returns
    -------
    numpy.ndarray
        (rings x directions, residuals) the change of the residual vector for each point.
    """
    e = np.asarray(eta, float)
    s, measured = len(objective.steps), objective.measured
    node_xy = np.asarray(objective.top_xyz)[:, :2]
    steps = np.asarray(objective.steps, int)  # 0-based
    scale = objective.displacement_residual_scale()[measured]  # (m, 3)

    def nodes_of(shift: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        plan = node_interpolation(replace(dic, xyz=dic.xyz - shift), node_xy, used_steps=used_steps)
        u = np.nan_to_num(dic.u[steps][:, plan.points])
        values = np.stack([(plan.matrix(j) @ u[..., j].T).T for j in range(3)], axis=-1)
        return values[:, measured], plan.measured[measured]

    base = np.asarray(objective.displacement, float)[steps][:, measured]  # the same processing, unmoved
    out = []
    for ring in PROFILE_RINGS:
        for angle in np.arange(PROFILE_DIRECTIONS) * 2.0 * np.pi / PROFILE_DIRECTIONS:
            shift = ring * registration_mm * np.array([np.cos(angle), np.sin(angle), 0.0])
            moved, seen = nodes_of(shift)
            D = np.where(seen[None, :, None], moved - base, 0.0)  # (s, m, 3), mm
            dr = np.zeros(s + 3 * s * int(measured.sum()))
            for j in range(3):
                if e[j + 1] > 0:
                    part = -D[..., j] * np.sqrt(e[j + 1]) * scale[:, j][None, :]
                    dr[s + j * s * part.shape[1] : s + (j + 1) * s * part.shape[1]] = np.nan_to_num(
                        part
                    ).ravel()
            out.append(dr)
    return np.array(out)


def operator_bias(
    prediction, plan: NodeInterpolation, dic: RegisteredDIC, steps: np.ndarray, measured: np.ndarray
) -> np.ndarray:
    """(steps used, measured nodes, 3): the model's top field (``prediction``, one point) sampled
    at the DIC points (its quarter unfolded by symmetry, as the data are) and interpolated to the
    nodes by the planes the data went through, less its values at the nodes: what the
    interpolation itself makes of a curved field, which is no noise (without it data made by the
    fitted model itself fail the test where the field bends, next to the indenter)."""
    top = np.asarray(prediction.top_xyz, float)
    field = np.asarray(prediction.displacement[0], float)[np.asarray(steps, int) - 1]  # (s, nodes, 3)
    xy = dic.xyz[plan.points, :2]
    interp = top_field_interpolator(top, np.moveaxis(field, 0, 1))
    at = np.moveaxis(interp(np.minimum(np.abs(xy), top[:, :2].max(axis=0))), 0, 1)  # (s, points, 3)
    at[..., 0] *= np.sign(xy[:, 0])
    at[..., 1] *= np.sign(xy[:, 1])
    seen = np.stack([(plan.matrix(j) @ at[..., j].T).T for j in range(3)], axis=-1)  # (s, nodes, 3)
    return (seen - field)[:, measured]


def _gradients(
    plan: NodeInterpolation, dic: RegisteredDIC, steps: np.ndarray, measured: np.ndarray
) -> np.ndarray:
    """(steps, measured nodes, 3, 2): the in-plane gradient of the DIC field at the nodes (the
    interpolating planes' slopes), what a shift of the indentation point moves each value by."""
    n_ok = len(plan.points)
    u = np.nan_to_num(dic.u[np.asarray(steps, int) - 1][:, plan.points])  # (s, n_ok, 3)
    U = u[:, plan.neighbours % n_ok] * plan.signs[None]  # (s, nodes, k, 3)
    g = np.einsum("nak,snkd->snda", plan.planes[:, 1:, :], U)  # (s, nodes, 3, 2)
    return g[:, measured]
