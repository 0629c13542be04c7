"""The composite phantom beside the homogeneous model (paper 3.3.1): the homogeneous model (eq. 3)
at a fitted (c1, c5), run with the composite's indenter and protocol, its force against depth and
its top-surface field at the composite's top nodes, where the fibers show
(:func:`compare_with_homogeneous`, :func:`compare_with_fit`). The composite experiment itself is
:mod:`~indentation_studio.inference.experiment.composite`'s."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...forward.composite_mesh import PHANTOM
from ...forward.convergence.mesh_study import top_field_interpolator
from ...forward.result import SimulationResult
from ...forward.solver import EmbeddedSolver
from ...forward.spec import Contact, Material, MeshChoice, ModelSpec

__all__ = [
    "CompositeComparison",
    "compare_with_fit",
    "compare_with_homogeneous",
    "fitted_model",
    "top_fiber_bands",
]


def top_fiber_bands(result: SimulationResult) -> list[tuple[float, float]]:
    """x-intervals (mm, quarter model) of the fibers in the top layer, which imprint the surface."""
    spec = ModelSpec.from_dict(result.spec)
    g = spec.geometry
    centres = PHANTOM.x_centres(2 * g.half_x)
    h = PHANTOM.fiber_size / 2
    return [(float(c - h), float(c + h)) for c in centres if c > 0]


@dataclass
class CompositeComparison:
    """The composite's force and top field beside the homogeneous model's at ``theta``.

    Attributes
    ----------
    theta : tuple of float
        The homogeneous model's (c1, c5), kPa.
    depth : numpy.ndarray
        (steps,) depths, mm.
    force_composite, force_homogeneous : numpy.ndarray
        (steps,) the two forces, mN.
    top_xyz : numpy.ndarray
        (n_top, 3) the composite's top nodes, mm.
    field_composite, field_homogeneous : numpy.ndarray
        (steps, n_top, 3) the two top fields at the composite's top nodes, mm.
    homogeneous_mesh : str
        The homogeneous model's mesh preset.
    fiber_bands : list of (float, float)
        The top fibers' bands across x, mm.
    homogeneous_contact : dict
        The homogeneous model's contact.
    radius : float
        The indenter's radius, mm.
    """

    theta: tuple[float, float]
    depth: np.ndarray
    force_composite: np.ndarray
    force_homogeneous: np.ndarray
    top_xyz: np.ndarray
    field_composite: np.ndarray
    field_homogeneous: np.ndarray
    homogeneous_mesh: str
    fiber_bands: list[tuple[float, float]]
    homogeneous_contact: dict
    radius: float

    @property
    def field_difference(self) -> np.ndarray:
        """Composite minus homogeneous, (steps, n_top, 3) mm, at the composite's top nodes."""
        return self.field_composite - self.field_homogeneous

    def to_dict(self, within_mm: float = 25.0) -> dict:
        """The comparison as JSON: forces, their relative gap, and the field gap at the last step.

        Parameters
        ----------
        within_mm : float, default 25.0
            The field gap is taken within this of the axis and outside the indenter's shadow
            (what DIC sees), mm.

        Returns
        -------
        dict
            theta, the force table and gap, the field gap, the homogeneous mesh and contact and
            the top fibers' bands.
        """
        r = np.hypot(self.top_xyz[:, 0], self.top_xyz[:, 1])
        near = (r <= within_mm) & (r > self.radius)
        diff = self.field_difference[-1][near]
        f_c, f_h = self.force_composite, self.force_homogeneous
        rel = np.divide(f_h - f_c, f_c, out=np.zeros_like(f_c), where=f_c != 0)
        return {
            "theta": {"c1": self.theta[0], "c5": self.theta[1]},
            "depth_mm": self.depth.tolist(),
            "force_composite_mN": f_c.tolist(),
            "force_homogeneous_mN": f_h.tolist(),
            "force_rel_gap_max": float(np.max(np.abs(rel[1:]))),
            "force_rel_gap_last": float(rel[-1]),
            "field_rms_gap_mm": {a: float(np.sqrt(np.mean(diff[:, j] ** 2))) for j, a in enumerate("xyz")},
            "field_max_gap_mm": {a: float(np.max(np.abs(diff[:, j]))) for j, a in enumerate("xyz")},
            "field_within_mm": within_mm,
            "field_outside_mm": self.radius,
            "homogeneous_mesh": self.homogeneous_mesh,
            "homogeneous_contact": self.homogeneous_contact,
            "top_fiber_bands_x_mm": self.fiber_bands,
        }


def fitted_model(fit: str | Path | dict) -> tuple[tuple[float, float], float | None]:
    """The homogeneous model a fit found: its (c1, c5) and its mu.

    Parameters
    ----------
    fit : str, pathlib.Path or dict
        A fit.json, or that dict.

    Returns
    -------
    theta : tuple of float
        (c1, c5), kPa.
    mu : float or None
        mu held, identified or marginalised; None where the surrogate's contact was assumed.

    Raises
    ------
    ValueError
        If the fit has no c1 or c5.
    """
    values = json.loads(Path(fit).read_text()) if not isinstance(fit, dict) else fit
    try:
        theta = (float(values["c1"]), float(values["c5"]))
    except KeyError as exc:
        raise ValueError(f"{fit if not isinstance(fit, dict) else 'the fit'}: no {exc} in it") from exc
    friction = values.get("friction") or {}
    mu = friction.get("mu") if friction.get("treatment") != "assumed" else None
    return theta, None if mu is None else float(mu)


def compare_with_fit(
    result: SimulationResult | str | Path,
    *,
    c1: float | None = None,
    c5: float | None = None,
    fit: str | Path | dict | None = None,
    mesh: str = "default",
    friction: float | None = None,
    progress: Callable[[int, int, float], None] | None = None,
) -> CompositeComparison:
    """Compare the composite with the homogeneous model at (c1, c5) given, or at a fit's.

    :func:`compare_with_homogeneous` at the values given, or a fit's (:func:`fitted_model`; a value
    given overrides the fit's).

    Parameters
    ----------
    result : SimulationResult, str or Path
        The composite's result.
    c1, c5 : float, optional
        The homogeneous model's moduli, kPa (default: the fit's).
    fit : str, Path or dict, optional
        A fit.json (or its dict) whose (c1, c5) and mu to use.
    mesh : str
        The homogeneous model's mesh preset.
    friction : float, optional
        The homogeneous model's Coulomb mu (default: the fit's mu, else the composite's contact).
    progress : callable, optional
        The homogeneous run's progress.

    Returns
    -------
    CompositeComparison
        The two models side by side.

    Raises
    ------
    ValueError
        Neither (c1, c5) nor a fit given.
    """
    if fit is not None:
        (c1_fit, c5_fit), mu_fit = fitted_model(fit)
        c1 = c1_fit if c1 is None else c1
        c5 = c5_fit if c5 is None else c5
        friction = mu_fit if friction is None else friction  # the model the fit found
    if c1 is None or c5 is None:
        raise ValueError("give --c1 and --c5, or --fit")
    contact = "composite" if friction is None else friction
    return compare_with_homogeneous(result, (c1, c5), mesh, progress=progress, friction=contact)


def compare_with_homogeneous(
    result: SimulationResult | str | Path,
    theta,
    mesh: str = "default",
    progress: Callable[[int, int, float], None] | None = None,
    friction: float | str | None = "composite",
) -> CompositeComparison:
    """Run the homogeneous model (eq. 3) at ``theta`` and put it beside the composite.

    The homogeneous model has the composite result's indenter and protocol; its top field is
    interpolated at the composite's top nodes.

    Parameters
    ----------
    result : SimulationResult, str or pathlib.Path
        The composite's result (or its .npz).
    theta : array_like
        (c1, c5), kPa.
    mesh : str, default "default"
        The homogeneous model's mesh preset.
    progress : callable, optional
        The homogeneous run's progress.
    friction : float, str or None, default "composite"
        The homogeneous model's contact: ``"composite"`` the composite's, a number Coulomb's mu
        (a fit's mu), None the stick.

    Returns
    -------
    CompositeComparison
        The forces and top fields side by side.
    """
    if not isinstance(result, SimulationResult):
        result = SimulationResult.load(result)
    c1, c5 = (float(v) for v in np.ravel(theta))
    comp = ModelSpec.from_dict(result.spec)
    spec = ModelSpec(
        geometry=comp.geometry,
        indenter=comp.indenter,
        protocol=comp.protocol,
        material=Material(c1=c1, c5=c5),
        mesh=MeshChoice(preset=mesh),
        contact=comp.contact if friction == "composite" else Contact(friction=friction),
    )
    hom = EmbeddedSolver(spec).run(progress=progress)
    interp = top_field_interpolator(hom.top_xyz, np.moveaxis(hom.displacement, 0, 1))
    field_h = np.moveaxis(interp(result.top_xyz), 0, 1)
    return CompositeComparison(
        theta=(c1, c5),
        depth=result.depth,
        force_composite=result.force,
        force_homogeneous=hom.force,
        top_xyz=result.top_xyz,
        field_composite=result.displacement,
        field_homogeneous=field_h,
        homogeneous_mesh=mesh,
        fiber_bands=top_fiber_bands(result),
        homogeneous_contact={"friction": spec.contact.friction},
        radius=comp.indenter.radius,
    )
