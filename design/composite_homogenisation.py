"""The composite phantom's homogeneous (c1, c5) from its equibiaxial stretch (paper 2.9, 3.3.2):
the FE composite stretched equibiaxially, eq. 10 fitted to its volume-averaged true stresses, and
eq. 11's rule of mixtures beside it (Fig. 14)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from ..forward.block_mesh import BlockMesh
from ..forward.block_stretch import BlockStretchResult, equibiaxial_phantom_mesh, equibiaxial_stretch
from ..forward.composite_mesh import PHANTOM
from ..forward.spec import CompositeMaterial, Constituent, ModelSpec
from .constituents import Fit, fit_equibiaxial, parallel_fiber_stresses, rule_of_mixtures

__all__ = ["CompositeHomogenisation", "composite_equibiaxial_fit"]


@dataclass
class CompositeHomogenisation:
    """The phantom's equibiaxial stretch, its eq. 10 fit and eq. 11 at the phantom's FVF.

    Attributes
    ----------
    composite : CompositeMaterial
        The constituents.
    mesh : BlockMesh
        The y-invariant phantom mesh stretched.
    stretch : BlockStretchResult
        The stretch and its stresses.
    fit : Fit
        Eq. 10 fitted to the stresses (standard errors, not 95 % bounds).
    eq11 : tuple of float
        (c1, c5) of eq. 11 at the phantom's fiber volume fraction, kPa.
    fiber_volume_fraction : float
        The phantom's FVF.
    wall_s : float
        Wall time of the stretch, s.
    """

    composite: CompositeMaterial
    mesh: BlockMesh
    stretch: BlockStretchResult
    fit: Fit
    eq11: tuple[float, float]
    fiber_volume_fraction: float
    wall_s: float

    def parallel_fibers(self) -> dict:
        """The parallel-fiber rule of mixtures at this stretch and FVF beside the FE, with eq. 10 fitted.

        The stresses of :func:`design.constituents.parallel_fiber_stresses`, their largest
        relative gap to the FE's along the fibers, and eq. 10 fitted to them: what an FE composite
        of continuous bonded fibers should give (and why eq. 11b's c5 is low).

        Returns
        -------
        dict
            ``sigma_fiber_kPa``, ``sigma_transverse_kPa``, ``fe_fiber_stress_max_rel_gap``,
            ``eq10_fit`` and ``small_strain_c5``.
        """
        m, f = self.composite.matrix, self.composite.fibers
        lam = self.stretch.stretch_x[1:]
        s11, s22 = parallel_fiber_stresses(lam, m.shear_modulus, f.c1, f.c2, self.fiber_volume_fraction)
        fe11 = self.stretch.sigma_fiber[1:]
        fit = fit_equibiaxial(lam, s11, s22) if lam.size >= 2 else None
        return {
            "sigma_fiber_kPa": s11.tolist(),
            "sigma_transverse_kPa": s22.tolist(),
            "fe_fiber_stress_max_rel_gap": float(np.max(np.abs(fe11 / s11 - 1.0))),
            "eq10_fit": fit.values if fit is not None else None,
            "small_strain_c5": float(
                self.fiber_volume_fraction * (6.0 * (f.c1 + f.c2) - 6.0 * m.shear_modulus)
            ),
        }

    def to_dict(self) -> dict:
        """The homogenisation as ``composite equibiaxial --json`` prints it.

        Returns
        -------
        dict
            The stretch's record, the eq. 10 fit (with what its standard errors include), eq. 11
            and the FVF, the mesh, :meth:`parallel_fibers`, the constituents' kappa and the wall
            time.
        """
        return {
            **self.stretch.to_dict(),
            "fit": {
                "values": self.fit.values,
                "std_errors": self.fit.std_errors,
                "rms_kPa": self.fit.rms_kPa,
                "n_points": self.fit.n_points,
                "std_errors_include": (
                    "1 sd of eq. 10's least-squares fit to these FE stresses (its misfit only); not a "
                    "95 % bound, nor the mesh's discretisation or the bulk moduli's effect (README)"
                ),
            },
            "eq11": {
                "c1": self.eq11[0],
                "c5": self.eq11[1],
                "fiber_volume_fraction": self.fiber_volume_fraction,
            },
            "mesh": {
                "nodes": self.mesh.n_nodes,
                "elements": self.mesh.n_elements,
                "source": self.mesh.source,
            },
            "parallel_fibers": self.parallel_fibers(),
            "kappa_kPa": {c.name: c.kappa for c in self.composite.constituents},
            "wall_s": self.wall_s,
        }


def composite_equibiaxial_fit(
    max_stretch: float = 1.3,
    steps: int = 30,
    cell: float = 0.8,
    bulk_to_shear: float | None = None,
    composite: CompositeMaterial | None = None,
) -> CompositeHomogenisation:
    """Stretch the composite phantom equibiaxially and fit eq. 10 to its stresses; eq. 11 beside.

    The phantom is stretched on its y-invariant mesh; eq. 10 is fitted to the stresses along and
    across the fibers, and eq. 11 given at the phantom's fiber volume fraction.

    Parameters
    ----------
    max_stretch : float, default 1.3
        The final stretch.
    steps : int, default 30
        Load steps.
    cell : float, default 0.8
        Mesh size, mm (two cells across each fiber).
    bulk_to_shear : float, optional
        Sets kappa = that x 2 (c1 + c2) of both constituents.
    composite : CompositeMaterial, optional
        The constituents; default the paper's.

    Returns
    -------
    CompositeHomogenisation
        The stretch, its fit and eq. 11.
    """
    composite = composite or CompositeMaterial()
    if bulk_to_shear is not None:
        composite = CompositeMaterial(
            *(
                Constituent(c.name, c.c1, c.c2, c.c5, bulk_to_shear * c.shear_modulus)
                for c in composite.constituents
            )
        )
    spec = ModelSpec.composite_phantom("composite-coarse", composite=composite)
    mesh = equibiaxial_phantom_mesh(spec, cell)
    t = time.perf_counter()
    result = equibiaxial_stretch(spec, max_stretch, steps, mesh=mesh)
    wall = time.perf_counter() - t
    fit = fit_equibiaxial(result.stretch_x[1:], result.sigma_fiber[1:], result.sigma_transverse[1:])
    fvf = PHANTOM.fiber_volume_fraction(2 * spec.geometry.half_x, spec.geometry.height)
    eq11 = rule_of_mixtures(composite.matrix.shear_modulus, composite.fibers.c1, composite.fibers.c2, fvf)
    return CompositeHomogenisation(composite, mesh, result, fit, eq11, fvf, wall)
