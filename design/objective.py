"""The objective of the paper (eq. 4a, 4b, 5): force and per-direction displacement errors against a
measured (or baseline) response, their weighted sum, and the residual vector whose squared sum it is.

Readings (the paper as printed, or the authors' public code), chosen with ``reading``:

* ``paper`` (default): eq. 4a sums over all steps the force error relative to that step's
  measured force; eq. 4b sums over all steps the displacement errors over max |u_j,exp| with the
  normalised B.1 to B.3 weights, nodes within the sphere's radius of the axis obscured.
* ``fit``: as ``paper``, with the rings from R to 1.5 R left out too
  (:data:`~indentation_studio.design.nodal_weights.FIT_INNER_RADII`): the studio's fits, error
  budgets and design advice (docs/validation/verification.md, "What a decision on R = 8 mm can
  choose from").
* ``authors``: one step (``step``, default the deepest); force error over max |f_exp|;
  displacement errors over max |u_j,exp| at the last step; the 1.2 R to 5.5 R ring; unnormalised
  inverse-distance weights.

F_k(theta) = sum r_k^2 for each term k in (force, ux, uy, uz); F = sum eta_k F_k (eq. 5) with eta on
the simplex; the residual vector is the concatenation of sqrt(eta_k) r_k.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .nodal_weights import default_selection, nodal_weights

TERMS = ("force", "ux", "uy", "uz")

#: The paper's combined weights (eq. 13, Table 1's last row): force, ux, uy, uz.
PAPER_WEIGHTS = (0.45, 0.35, 0.2, 0.0)


def check_weights(eta) -> np.ndarray:
    """The weights ``eta`` (4,) as an array, refused unless on the simplex of eq. 5.

    Parameters
    ----------
    eta : array_like
        Weights of the force, ux, uy and uz objectives.

    Returns
    -------
    numpy.ndarray
        (4,) the weights, clipped to [0, 1].

    Raises
    ------
    ValueError
        If they are not 4 finite numbers, each in [0, 1], summing to 1 (eq. 5).

    Examples
    --------
    >>> from indentation_studio.design import check_weights
    >>> check_weights([0.45, 0.35, 0.2, 0.0])  # eq. 13
    array([0.45, 0.35, 0.2 , 0.  ])
    """
    e = np.asarray(eta, dtype=float).ravel()
    if e.shape != (4,) or not np.all(np.isfinite(e)):
        raise ValueError(f"objective weights must be 4 finite numbers (force, ux, uy, uz), got {eta!r}")
    if np.any(e < -1e-12) or abs(e.sum() - 1.0) > 1e-9:
        raise ValueError(
            f"objective weights must lie on the simplex (each in [0, 1], sum 1), got {e.tolist()}"
        )
    return np.clip(e, 0.0, 1.0)


@dataclass
class Objective:
    """The objectives of eq. 4a, 4b and their combination (eq. 5) against a target response.

    Parameters
    ----------
    force : numpy.ndarray
        (steps,) the measured (or baseline) force, mN.
    displacement : numpy.ndarray
        (steps, nodes, 3) the measured (or baseline) displacements, mm.
    top_xyz : numpy.ndarray
        (nodes, 3) the top-surface nodes, mm.
    radius : float
        The indenter's radius, mm.
    reading : {"paper", "fit", "authors"}, default "paper"
        How eq. 4 is read (module docstring).
    step : int, optional
        Compare this step only (index from 0); default all (``paper``) or the deepest
        (``authors``).
    mask : numpy.ndarray, optional
        (nodes,) True at nodes with data (default: see the readings).
    excluded_steps : tuple of int, default ()
        Step numbers counting from 1, as in experiment.json, left out of eq. 4a and 4b; their
        targets may be NaN.

    Raises
    ------
    ValueError
        If the shapes disagree, every step is excluded, or the target force is zero at a step used.
    """

    force: np.ndarray
    displacement: np.ndarray
    top_xyz: np.ndarray
    radius: float
    reading: str = "paper"
    step: int | None = None
    mask: np.ndarray | None = None
    excluded_steps: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        self.force = np.asarray(self.force, float)
        self.displacement = np.asarray(self.displacement, float)
        if self.displacement.shape != (len(self.force), len(self.top_xyz), 3):
            raise ValueError(
                f"displacement must be (steps, nodes, 3) = ({len(self.force)}, {len(self.top_xyz)}, 3), "
                f"got {self.displacement.shape}"
            )
        used = np.setdiff1d(np.arange(len(self.force)), np.asarray(self.excluded_steps, int) - 1)
        if not used.size:
            raise ValueError("every step is excluded: nothing to compare")
        if not (np.all(np.isfinite(self.force[used])) and np.all(np.isfinite(self.displacement[used]))):
            raise ValueError("the target force or displacement holds NaN or infinite values")
        selection = default_selection(self.radius, self.reading, self.mask)
        self.measured = selection.measured(np.asarray(self.top_xyz)[:, :2])
        self.weights = nodal_weights(np.asarray(self.top_xyz)[:, :2], self.measured, self.reading)
        if self.reading == "authors":
            k = len(self.force) - 1 if self.step is None else self.step
            if k not in used:
                raise ValueError(f"the authors' reading compares step {k + 1}, which is excluded")
            self.steps = np.array([k])
            self.force_scale = np.full(1, np.max(np.abs(self.force)))
            u_norm = np.max(np.abs(self.displacement[-1][self.measured]), axis=0)
        else:
            self.steps = used if self.step is None else np.array([self.step])
            self.force_scale = self.force[self.steps]
            u_norm = np.max(np.abs(self.displacement[used][:, self.measured]), axis=(0, 1))
        if np.any(np.abs(self.force_scale) <= 0.0):
            raise ValueError("the target force is zero at a step the objective uses (eq. 4a divides by it)")
        if np.any(u_norm <= 0.0):
            raise ValueError("a displacement direction is zero at every measured node (eq. 4b divides by it)")
        self.u_norm = u_norm
        self._sqrt_w = np.stack([np.sqrt(self.weights[t]) for t in TERMS[1:]], axis=-1)  # (nodes, 3)

    @classmethod
    def from_prediction(cls, target, index: int = 0, **kwargs) -> Objective:
        """The objective against point ``index`` of a Prediction (e.g. the response at theta*).

        Parameters
        ----------
        target : Prediction
            The target responses.
        index : int, default 0
            The point.
        **kwargs
            The other fields of :class:`Objective` (``radius``, ``reading``, ...).

        Returns
        -------
        Objective
            The objective.
        """
        return cls(target.force[index], target.displacement[index], target.top_xyz, **kwargs)

    # --------------------------------------------------------------- residuals
    def displacement_residual_scale(self) -> np.ndarray:
        """What eq. 4b multiplies a displacement error by at each node and direction.

        Returns
        -------
        numpy.ndarray
            (nodes, 3) sqrt(w_j^(i)) / max |u_j,exp| (0 where a node has no weight).
        """
        return self._sqrt_w / self.u_norm

    def term_residuals(self, force: np.ndarray, displacement: np.ndarray) -> list[np.ndarray]:
        """Residuals r_k per term for a batch (eq. 4a, 4b).

        Parameters
        ----------
        force : numpy.ndarray
            (n, steps) forces, mN.
        displacement : numpy.ndarray
            (n, steps, nodes, 3) displacements, mm.

        Returns
        -------
        list of numpy.ndarray
            Force (n, s), ux (n, s * m), uy, uz, with m the measured nodes.
        """
        f = np.asarray(force)[:, self.steps]
        r_f = (f - self.force[self.steps]) / self.force_scale
        du = (
            np.asarray(displacement)[:, self.steps][:, :, self.measured]
            - self.displacement[self.steps][:, self.measured]
        )
        du = du * self.displacement_residual_scale()[self.measured]
        n = du.shape[0]
        return [r_f, *(du[..., j].reshape(n, -1) for j in range(3))]

    def term_jacobians(self, force_jac: np.ndarray, displacement_jac: np.ndarray) -> list[np.ndarray]:
        """d r_k / d theta per term for a batch.

        Parameters
        ----------
        force_jac : numpy.ndarray
            (n, steps, p) d force / d theta.
        displacement_jac : numpy.ndarray
            (n, steps, nodes, 3, p) d u / d theta.

        Returns
        -------
        list of numpy.ndarray
            Force (n, s, p), ux, uy, uz (n, s * m, p), m the measured nodes.
        """
        jf = np.asarray(force_jac)[:, self.steps] / self.force_scale[:, None]
        ju = np.asarray(displacement_jac)[:, self.steps][:, :, self.measured]
        ju = ju * (self._sqrt_w[self.measured] / self.u_norm)[..., None]
        n, p = ju.shape[0], ju.shape[-1]
        return [jf, *(ju[..., j, :].reshape(n, -1, p) for j in range(3))]

    def data_points(self, eta) -> int:
        """n of eq. 8: the residuals of the terms that have weight.

        Force steps; measured nodes x steps per displacement direction.

        Parameters
        ----------
        eta : array_like
            The four weights.

        Returns
        -------
        int
            n.
        """
        e = check_weights(eta)
        sizes = [len(self.steps)] + [len(self.steps) * int(self.measured.sum())] * 3
        return int(sum(k for k, w in zip(sizes, e, strict=True) if w > 0))

    def terms(self, prediction) -> np.ndarray:
        """The four objectives F_k: force, ux, uy, uz (eq. 4a, 4b).

        Parameters
        ----------
        prediction : Prediction
            The model's responses.

        Returns
        -------
        numpy.ndarray
            (n, 4).
        """
        return np.stack(
            [np.sum(r**2, axis=1) for r in self.term_residuals(prediction.force, prediction.displacement)],
            axis=1,
        )

    def value(self, prediction, eta) -> np.ndarray:
        """The combined objective F of eq. 5.

        Parameters
        ----------
        prediction : Prediction
            The model's responses.
        eta : array_like
            The four weights.

        Returns
        -------
        numpy.ndarray
            (n,) F.
        """
        return self.terms(prediction) @ check_weights(eta)

    def residuals(self, prediction, eta) -> np.ndarray:
        """The residual vector whose squared sum is F: sqrt(eta_k) r_k concatenated.

        Parameters
        ----------
        prediction : Prediction
            The model's responses.
        eta : array_like
            The four weights.

        Returns
        -------
        numpy.ndarray
            (n, m).
        """
        e = check_weights(eta)
        parts = self.term_residuals(prediction.force, prediction.displacement)
        return np.concatenate([np.sqrt(w) * r for w, r in zip(e, parts, strict=True)], axis=1)

    def jacobian(self, prediction, eta) -> np.ndarray:
        """d residuals / d theta from a Prediction carrying its Jacobians.

        Parameters
        ----------
        prediction : Prediction
            With ``force_jacobian`` and ``displacement_jacobian``.
        eta : array_like
            The four weights.

        Returns
        -------
        numpy.ndarray
            (n, m, p).

        Raises
        ------
        ValueError
            If the prediction carries no Jacobian.
        """
        if prediction.force_jacobian is None:
            raise ValueError(
                "this prediction carries no Jacobian (ask the embedded solver for sensitivities)"
            )
        e = check_weights(eta)
        parts = self.term_jacobians(prediction.force_jacobian, prediction.displacement_jacobian)
        return np.concatenate([np.sqrt(w) * j for w, j in zip(e, parts, strict=True)], axis=1)
