"""Richardson extrapolation of two FE meshes: a Predictor of the mesh-converged response.

With responses Y_f on a fine mesh and Y_c on a coarser one (read at the fine mesh's top nodes),
a discretisation error that falls as h^p gives the extrapolated response

    Y_ext = Y_f + (Y_f - Y_c) / (r^p - 1),    r = (N_f / N_c)^(1/3)

(L. F. Richardson 1911; the estimate behind Roache's GCI), applied to log force per step and to
the top-surface field, and so to their Jacobians. Whether it is closer to a much finer mesh than
Y_f itself is what the error budget measures (``inference.budgets.error_budget``), not assumed.
"""

from __future__ import annotations

import numpy as np

from ..mesh import build_mesh
from ..predictor import Prediction
from .mesh_study import top_field_interpolator


class RichardsonPredictor:
    """A Predictor that extrapolates a fine and a coarse FE Predictor (Richardson) to order ``order``.

    The coarse top fields are read at the fine top nodes; the refinement ratio is the cube root
    of the meshes' node counts.

    Parameters
    ----------
    fine, coarse : FESolverPredictor
        The same test on two meshes, ``fine`` with more nodes.
    order : float, default 1.0
        The order of convergence (> 0).

    Raises
    ------
    ValueError
        If the order is not positive or the fine mesh has no more nodes than the coarse one.
    """

    def __init__(self, fine, coarse, order: float = 1.0) -> None:
        if not order > 0:
            raise ValueError(f"the order of convergence must be positive, got {order}")
        self.fine, self.coarse, self.order = fine, coarse, float(order)
        self.spec = fine.spec
        self.parameters = tuple(fine.parameters)
        mesh_f, mesh_c = build_mesh(fine.spec), build_mesh(coarse.spec)
        if mesh_f.n_nodes <= mesh_c.n_nodes:
            raise ValueError(
                f"the fine mesh ({mesh_f.n_nodes} nodes) must have more nodes than the coarse one"
            )
        self.top_xyz = mesh_f.nodes[mesh_f.top]
        self._coarse_top = mesh_c.nodes[mesh_c.top]
        self.ratio = (mesh_f.n_nodes / mesh_c.n_nodes) ** (1.0 / 3.0)
        self.factor = 1.0 / (self.ratio**self.order - 1.0)

    def _at_fine_nodes(self, values: np.ndarray) -> np.ndarray:
        """A coarse top field (n, steps, nodes, ...) read at the fine top nodes."""
        moved = np.moveaxis(values, 2, 0)  # (nodes, n, steps, ...)
        at = top_field_interpolator(self._coarse_top, moved)(self.top_xyz)
        return np.moveaxis(at, 0, 2)

    def predict(self, theta: np.ndarray, jacobian: bool = False) -> Prediction:
        """The extrapolated response: log force and the field, f + (f - f_coarse) / (r^order - 1).

        Parameters
        ----------
        theta : numpy.ndarray
            (n, p) points.
        jacobian : bool, default False
            Also the Jacobians, extrapolated alike.

        Returns
        -------
        Prediction
            On the fine mesh's top nodes.
        """
        pf = self.fine.predict(theta, jacobian=jacobian)
        pc = self.coarse.predict(theta, jacobian=jacobian)
        a = self.factor
        log_f = np.log(pf.force) + a * (np.log(pf.force) - np.log(pc.force))
        force = np.exp(log_f)
        field = pf.displacement + a * (pf.displacement - self._at_fine_nodes(pc.displacement))
        fj = dj = None
        if jacobian:
            dlog_f = pf.force_jacobian / pf.force[..., None]
            dlog_c = pc.force_jacobian / pc.force[..., None]
            fj = force[..., None] * (dlog_f + a * (dlog_f - dlog_c))
            dj = pf.displacement_jacobian + a * (
                pf.displacement_jacobian - self._at_fine_nodes(pc.displacement_jacobian)
            )
        return Prediction(force, field, pf.depth, self.top_xyz, self.parameters, fj, dj)
