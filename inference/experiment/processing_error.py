"""What the experiment's processing does to a fit, measured at the fit itself (issue 45).

Between the DIC points and the objective stand two steps the statistical bounds know nothing of:

* **DIC points to nodes** (:func:`inference.experiment.processing.dic_to_nodes`): each node's value
  is a weighted least-squares plane through its neighbouring points, exact for a field that varies
  linearly; where the field bends (next to the indenter) it is biased, and the bias moves the fit.
  It is measured by a replay: the model's own field at the fit, read at the experiment's own DIC
  points (as the camera would have seen it, without noise, with the same points missing), taken
  to the nodes by the same planes, is what a perfect model would be fitted to; its difference from
  the model's nodal field moves the fit, to first order, by d log theta = -(J^T J)^-1 J^T dr.
* **Registration**: the indentation point (the model frame's origin) comes from the indenter's
  tracked points; an error of ``registration_mm`` in it moves the replayed data and the fit; the
  part is the largest move over :data:`REGISTRATION_DIRECTIONS` directions in the top face, per
  parameter (the field is not linear in the point's position over a tenth of a millimetre).

Both are systematic half-widths in percent of theta_hat, combined with the other parts of the
bounds by root sum of squares (``inference.budgets.model_error``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ...design.objective import Objective, check_weights
from ...forward.convergence.mesh_study import top_field_interpolator
from .processing import RegisteredDIC, dic_to_nodes

__all__ = ["REGISTRATION_MM", "ProcessingError", "processing_error_at"]

#: Directions in the top face in which the indentation point is moved by ``registration_mm``.
REGISTRATION_DIRECTIONS = 8

#: The registration's uncertainty a fit carries by default, mm: how far the indentation point found
#: from the indenter's tracked points may lie from the true one (a lab's camera-to-indenter
#: calibration; the synthetic lab recording's misregistration, ``LAB_RECORDING``).
REGISTRATION_MM = 0.1


@dataclass(frozen=True)
class ProcessingError:
    """The processing's parts of a fit's 95 % half-width, percent of theta_hat.

    Attributes
    ----------
    interpolation_pct : numpy.ndarray
        (p,) |shift| of the fit by the DIC-points-to-nodes planes (the replay at the fit).
    registration_pct : numpy.ndarray
        (p,) the largest |shift| by an error of ``registration_mm`` in the indentation point.
    registration_mm : float
        The registration's uncertainty carried, mm.
    interpolation_shift_pct : numpy.ndarray or None
        (p,) the planes' shift of the fit with its sign (fit minus a perfect processing's).
    """

    interpolation_pct: np.ndarray
    registration_pct: np.ndarray
    registration_mm: float
    interpolation_shift_pct: np.ndarray | None = None  # signed: where the planes move the fit

    @property
    def half_width_pct(self) -> np.ndarray:
        """(p,) both parts' root sum of squares, percent."""
        return np.hypot(self.interpolation_pct, self.registration_pct)

    def padded(self, p: int) -> ProcessingError:
        """The parts over ``p`` parameters, those beyond its own at 0 (mu sampled beside them).

        Parameters
        ----------
        p : int
            The number of parameters.

        Returns
        -------
        ProcessingError
            The padded parts.
        """

        def pad(a: np.ndarray | None) -> np.ndarray | None:
            return None if a is None else np.append(a, np.zeros(p - len(a)))

        return replace(
            self,
            interpolation_pct=pad(self.interpolation_pct),
            registration_pct=pad(self.registration_pct),
            interpolation_shift_pct=pad(self.interpolation_shift_pct),
        )

    def describe(self) -> str:
        """What the part holds, in words."""
        return f"the processing's (DIC points to nodes, and the indentation point within {self.registration_mm:g} mm)"

    def to_dict(self) -> dict:
        """JSON-ready parts."""
        return {
            "interpolation_pct": self.interpolation_pct.tolist(),
            "interpolation_shift_pct": None
            if self.interpolation_shift_pct is None
            else self.interpolation_shift_pct.tolist(),
            "registration_pct": self.registration_pct.tolist(),
            "registration_mm": self.registration_mm,
            "processing_pct": self.half_width_pct.tolist(),
        }


def _field_at_points(top_xyz: np.ndarray, field: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(steps, points, 3): the quarter model's nodal field (steps, nodes, 3) at points (points, 2)
    anywhere on the surface, by the mesh's own interpolation and the symmetry planes."""
    at = top_field_interpolator(top_xyz, np.moveaxis(field, 0, 1))
    half = np.asarray(top_xyz)[:, :2].max(axis=0)
    u = np.moveaxis(at(np.minimum(np.abs(xy), half)), 0, 1)  # (steps, points, 3)
    u[..., 0] *= np.where(xy[:, 0] < 0, -1.0, 1.0)
    u[..., 1] *= np.where(xy[:, 1] < 0, -1.0, 1.0)
    return u


def _replayed(
    objective: Objective, dic: RegisteredDIC, force: np.ndarray, field: np.ndarray, used_steps, origin
):
    """The objective a perfect model's data would give: ``field`` read at the DIC points (the same
    points missing), its origin moved by ``origin`` (2,), taken to the nodes as the data are."""
    top = np.asarray(objective.top_xyz)
    xy = dic.xyz[:, :2]
    u = _field_at_points(top, field, xy + np.asarray(origin))  # the points see the field moved
    u = np.where(np.isfinite(dic.u), u, np.nan)
    nodes, measured = dic_to_nodes(replace(dic, u=u), top[:, :2], used_steps=used_steps)
    return replace(objective, force=force, displacement=nodes, mask=measured)


def processing_error_at(
    objective: Objective,
    dic: RegisteredDIC,
    predictor,
    theta: np.ndarray,
    eta,
    *,
    used_steps,
    registration_mm: float = REGISTRATION_MM,
    free: int | None = None,
) -> ProcessingError:
    """The processing's parts of a fit's bounds at ``theta`` (module docstring).

    Parameters
    ----------
    objective : Objective
        The fit's objective against the experiment's data.
    dic : RegisteredDIC
        The experiment's DIC data in the model frame (``FitInputs.dic``).
    predictor : Predictor
        The model (usually the fit's surrogate) whose field at ``theta`` is replayed.
    theta : numpy.ndarray
        (p,) the fit.
    eta : array_like
        The weights of eq. 5.
    used_steps : array_like
        The experiment's steps used (1..N).
    registration_mm : float, default REGISTRATION_MM
        The indentation point's uncertainty, mm.
    free : int, optional
        Only the first ``free`` parameters move (the rest held, as mu of a fit with friction).

    Returns
    -------
    ProcessingError
        The two parts, percent.
    """
    e = check_weights(eta)
    theta = np.asarray(theta, float)
    free = len(theta) if free is None else free
    pred = predictor.predict(theta[None, :], jacobian=True)
    force, field = pred.force[0], pred.displacement[0]
    J = (objective.jacobian(pred, e)[0] * theta)[:, :free]
    A = np.linalg.solve(J.T @ J, J.T)

    def move(origin) -> np.ndarray:
        replay = _replayed(objective, dic, force, field, used_steps, origin)
        return -A @ replay.residuals(pred, e)[0]  # the replay's residual at theta: the processing's alone

    at_origin = move((0.0, 0.0))
    angles = np.linspace(0.0, 2.0 * np.pi, REGISTRATION_DIRECTIONS, endpoint=False)
    moved = [move(registration_mm * np.array([np.cos(a), np.sin(a)])) - at_origin for a in angles]
    registration = np.max(np.abs(moved), axis=0)  # (free,) the largest over the directions
    return ProcessingError(
        interpolation_pct=100.0 * np.expm1(np.abs(at_origin)),
        registration_pct=100.0 * np.expm1(registration),
        registration_mm=float(registration_mm),
        interpolation_shift_pct=100.0 * np.expm1(at_origin),
    )
