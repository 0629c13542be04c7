"""How much the FE mesh moves a fit: the parameter shift between the fit's mesh and a finer one at
theta_hat, and the discretisation uncertainty of the fit that follows from it.

The bounds of eq. 6 to 8 are statistical: they shrink with the number of DIC points, while the
error the mesh makes in the model does not. At theta_hat, with the residual vector r of eq. 4 and
5 and its Jacobian J on the fit's mesh, the finer mesh's response (interpolated at the same top
nodes) gives residuals r_fine, and the fit would move, to first order (one Gauss-Newton step), by

    delta = -(J^T J)^-1 J^T (r_fine - r).

Roache's grid convergence index turns that two-mesh difference into an uncertainty of the coarser
(fitted) mesh's result: U = Fs |delta| r_h^p / (r_h^p - 1), with r_h = (N_fine / N)^(1/3) the
refinement ratio from the node counts, p the order of convergence (1 by default: node-wise stick
contact converges at first order where the contact edge passes) and Fs = 3, Roache's safety factor
for a two-mesh estimate (P. J. Roache, J. Fluids Eng. 116 (1994) 405; ASME V&V 20-2009). It is
combined with the statistical 95 % half-width by root sum of squares, as V&V 20 combines
uncertainties.

The fit can also be carried to the finer mesh, theta_hat (1 + delta), whose own discretisation
uncertainty is the fine-grid GCI, Fs |delta| / (r_h^p - 1) (smaller by r_h^p). The posterior is
carried the same way (:func:`inference.posterior.sampling.carried_to_finer_mesh`): every sample shifted by
delta and spread by that GCI, read as a 95 % half-width of a normal error.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...design.certainty import bounds_pct, s_from_data
from ...design.objective import Objective, check_weights
from ...forward.convergence.mesh_study import top_field_interpolator
from ...forward.predictor import Prediction
from ...forward.result import SimulationResult
from ...forward.solver import simulate
from ...forward.spec import MeshChoice, ModelSpec


@dataclass(frozen=True)
class MeshCheck:
    """The fit's sensitivity to its mesh at ``theta`` (kPa); percentages are of theta.

    Attributes
    ----------
    theta : numpy.ndarray
        (p,) the fit, kPa.
    shift_pct : numpy.ndarray
        (p,) first-order change of the fit on the finer mesh.
    uncertainty_pct : numpy.ndarray
        (p,) GCI of the fit's mesh: Fs |shift| r^p / (r^p - 1).
    refinement_ratio : float
        r between the two meshes.
    order : float
        The order of convergence p assumed.
    safety : float
        The GCI's safety factor Fs.
    nodes : tuple of int
        (fit's mesh, finer mesh) node counts.
    hessian : numpy.ndarray
        Gauss-Newton 2 J^T J on the fit's mesh, in theta_bar = theta / theta_hat.
    s : float
        Eq. 8 from F(theta) on the fit's mesh.
    statistical_pct : numpy.ndarray
        (p,) eq. 6 half-width with that s.
    """

    theta: np.ndarray
    shift_pct: np.ndarray  # first-order change of the fit on the finer mesh
    uncertainty_pct: np.ndarray  # GCI of the fit's mesh: Fs |shift| r^p / (r^p - 1)
    refinement_ratio: float
    order: float
    safety: float
    nodes: tuple[int, int]  # (fit's mesh, finer mesh)
    hessian: np.ndarray  # Gauss-Newton 2 J^T J on the fit's mesh, in theta_bar = theta / theta_hat
    s: float  # eq. 8 from F(theta) on the fit's mesh
    statistical_pct: np.ndarray  # eq. 6 half-width with that s

    @property
    def combined_pct(self) -> np.ndarray:
        """Root sum of squares of the statistical half-width and the mesh's uncertainty."""
        return np.hypot(self.statistical_pct, self.uncertainty_pct)

    @property
    def corrected_theta(self) -> np.ndarray:
        """The fit carried to the finer mesh (to first order): theta_hat (1 + shift)."""
        return self.theta * (1.0 + self.shift_pct / 100.0)

    @property
    def corrected_uncertainty_pct(self) -> np.ndarray:
        """GCI of the finer mesh's result, Fs |delta| / (r^p - 1), percent.

        What is left of the discretisation error once the fit is carried there (Roache's GCI of
        the fine grid).
        """
        rp = self.refinement_ratio**self.order
        return self.safety * np.abs(self.shift_pct) / (rp - 1.0)

    @property
    def corrected_combined_pct(self) -> np.ndarray:
        """95 % half-width of the corrected fit: statistical and finer mesh's GCI, root sum of squares."""
        return np.hypot(self.statistical_pct, self.corrected_uncertainty_pct)

    def to_dict(self, check_mesh: str) -> dict:
        """The check as written to fit.json / confirm.json (read back by :func:`load_mesh_check`).

        Parameters
        ----------
        check_mesh : str
            The finer mesh preset.

        Returns
        -------
        dict
            The meshes, ratio, order, safety factor, shift, theta on both meshes, the
            uncertainties, statistical and combined half-widths (percent) and s.
        """
        return {
            "check_mesh": check_mesh,
            "nodes": list(self.nodes),
            "refinement_ratio": self.refinement_ratio,
            "order": self.order,
            "safety_factor": self.safety,
            "shift_pct": self.shift_pct.tolist(),
            "theta": self.theta.tolist(),
            "theta_on_finer_mesh": self.corrected_theta.tolist(),
            "uncertainty_pct": self.uncertainty_pct.tolist(),
            "statistical_pct": self.statistical_pct.tolist(),
            "combined_pct": self.combined_pct.tolist(),
            "corrected_uncertainty_pct": self.corrected_uncertainty_pct.tolist(),
            "corrected_combined_pct": self.corrected_combined_pct.tolist(),
            "s": self.s,
        }


def prediction_at_nodes(result: SimulationResult, top_xyz: np.ndarray) -> Prediction:
    """A simulation's response (steps without depth 0) at other top nodes ``top_xyz`` of the same
    block: the force as it is, the top displacement of every step interpolated at once
    (:func:`forward.convergence.mesh_study.top_field_interpolator`)."""
    field = np.moveaxis(result.displacement[1:], 0, 1)  # (nodes, steps, 3)
    u = np.moveaxis(top_field_interpolator(result.top_xyz, field)(top_xyz), 1, 0)
    return Prediction(result.force[None, 1:], u[None], result.depth[1:], np.asarray(top_xyz))


def mesh_check(
    objective: Objective,
    eta,
    model: SimulationResult,
    finer: SimulationResult,
    order: float = 1.0,
    safety: float = 3.0,
) -> MeshCheck:
    """The parameter shift and discretisation uncertainty of a fit whose objective is built on
    ``model``'s top nodes, from ``model`` (solved at theta_hat with sensitivities) and ``finer``
    (the same spec on a finer mesh)."""
    if model.force_sensitivity is None:
        raise ValueError("the fit's mesh must be solved with sensitivities (the Jacobian of eq. 4, 5)")
    if model.depth.shape != finer.depth.shape or not np.allclose(model.depth, finer.depth):
        raise ValueError("the two meshes must be solved for the same protocol (depths)")
    theta = np.array([model.spec["material"]["c1"], model.spec["material"]["c5"]], float)
    other = np.array([finer.spec["material"]["c1"], finer.spec["material"]["c5"]], float)
    if not np.allclose(theta, other):
        raise ValueError(f"the two meshes must be solved at the same parameters, got {theta} and {other}")
    n_model, n_fine = int(model.solver["mesh"]["nodes"]), int(finer.solver["mesh"]["nodes"])
    if n_fine <= n_model:
        raise ValueError(f"the check mesh ({n_fine} nodes) must be finer than the fit's ({n_model} nodes)")
    if not (order > 0 and safety >= 1):
        raise ValueError(f"order must be > 0 and the safety factor >= 1, got {order}, {safety}")
    e = check_weights(eta)
    coarse = Prediction.from_results([model], ("c1", "c5"))
    fine = prediction_at_nodes(finer, coarse.top_xyz)
    r = objective.residuals(coarse, e)[0]
    r_fine = objective.residuals(fine, e)[0]
    J = objective.jacobian(coarse, e)[0] * theta  # in theta_bar = theta / theta_hat
    delta, *_ = np.linalg.lstsq(J, -(r_fine - r), rcond=None)
    ratio = (n_fine / n_model) ** (1.0 / 3.0)
    rp = ratio**order
    shift = 100.0 * delta
    H = 2.0 * J.T @ J
    s = s_from_data(float(r @ r), objective.data_points(e), theta.size)
    return MeshCheck(
        theta=theta,
        shift_pct=shift,
        uncertainty_pct=safety * np.abs(shift) * rp / (rp - 1.0),
        refinement_ratio=float(ratio),
        order=float(order),
        safety=float(safety),
        nodes=(n_model, n_fine),
        hessian=H,
        s=s,
        statistical_pct=bounds_pct(H, s),
    )


def check_mesh_at(
    spec: ModelSpec,
    objective: Objective,
    eta,
    theta: np.ndarray,
    preset: str,
    say: Callable[[str], None] | None = None,
) -> tuple[MeshCheck, Prediction]:
    """Check a fit against a finer mesh: solve at ``theta`` on the fit's mesh and on ``preset``.

    The fit's mesh is solved with sensitivities.

    Parameters
    ----------
    spec : ModelSpec
        The FE model of the fit.
    objective : Objective
        The fit's objective.
    eta : array_like
        The weights of eq. 5.
    theta : numpy.ndarray
        (p,) the fit, kPa.
    preset : str
        The finer mesh preset.
    say : callable, optional
        Where progress messages go.

    Returns
    -------
    check : MeshCheck
        The fit's shift to the finer mesh and its uncertainty.
    prediction : Prediction
        The fit's-mesh prediction at ``theta`` (an FE confirmation).
    """
    at = spec.with_material(c1=float(theta[0]), c5=float(theta[1]))
    if say is not None:
        say(f"solving at {np.round(theta, 3).tolist()} kPa on the fit's mesh and on '{preset}' ...")
    coarse = simulate(at, sensitivities=True)
    check = mesh_check(objective, eta, coarse, simulate(replace(at, mesh=MeshChoice(preset))))
    return check, Prediction.from_results([coarse], ("c1", "c5"))


def load_mesh_check(path: str | Path, experiment: str | Path, theta_fit: np.ndarray) -> dict:
    """The mesh check stored in a fit.json or confirm.json, refused if it belongs to another
    experiment or lies more than 10 % from this fit (its shift is first-order, at its own theta)."""
    try:
        payload = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{path}: not a readable fit.json or confirm.json ({exc})") from exc
    check = payload.get("mesh_check")
    if not isinstance(check, dict) or "corrected_uncertainty_pct" not in check or "theta" not in check:
        raise ValueError(
            f"{path}: no mesh check in it; run 'indent-studio fit' or 'confirm' with --check-mesh PRESET"
        )
    where = (payload.get("inputs") or {}).get("experiment")
    if where is not None and Path(where).resolve() != Path(experiment).resolve():
        raise ValueError(f"{path}: the mesh check was made for experiment {where}, not {experiment}")
    theta = np.asarray(check["theta"], float)
    far = np.abs(theta / np.asarray(theta_fit, float) - 1.0)
    if np.any(far > 0.1):
        raise ValueError(
            f"{path}: the mesh check was made at {theta.round(4).tolist()} kPa, more than 10 % from this fit "
            f"{np.round(theta_fit, 4).tolist()}; confirm at the fit first"
        )
    return {
        "file": str(path),
        "check_mesh": check["check_mesh"],
        "nodes": check["nodes"],
        "theta": theta.tolist(),
        "shift_pct": check["shift_pct"],
        "corrected_uncertainty_pct": check["corrected_uncertainty_pct"],
    }
