"""The moduli of every element of a spec's mesh: one material everywhere (eq. 3) or the composite
phantom's two (paper 2.4.2), as the per-element arrays the hex8 kernel takes."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .block_mesh import BlockMesh
from .hex8_mean_dilatation import ElementState, ReferenceGeometry
from .hex8_mean_dilatation import element_state as _element_state
from .spec import CompositeMaterial, ModelSpec


@dataclass(frozen=True)
class ElementModuli:
    """The material moduli per element: scalars (homogeneous) or (ne,) arrays (a composite).

    Attributes
    ----------
    c1, c2, c5, kappa : float or numpy.ndarray
        The moduli of eq. 3 (c2 of the Mooney-Rivlin matrix), kPa.
    fiber : numpy.ndarray
        The unit reference fiber direction of the c5 term.
    """

    c1: float | np.ndarray
    c2: float | np.ndarray
    c5: float | np.ndarray
    kappa: float | np.ndarray
    fiber: np.ndarray

    @property
    def homogeneous(self) -> bool:
        """Whether the moduli are scalars (one material)."""
        return np.ndim(self.c1) == 0

    def element_state(
        self,
        geometry: ReferenceGeometry,
        u_e: np.ndarray,
        *,
        tangent: bool = True,
        parameter_derivatives: bool = False,
        fiber_mean: bool = False,
    ) -> ElementState:
        """Energy, forces and tangent of every element with these moduli.

        The compiled kernel, :func:`forward.hex8_mean_dilatation.element_state`.

        Parameters
        ----------
        geometry : ReferenceGeometry
            The mesh's reference geometry.
        u_e : numpy.ndarray
            (ne, 8, 3) element displacements, mm.
        tangent, parameter_derivatives, fiber_mean : bool, optional
            As :func:`forward.hex8_mean_dilatation.element_state`.

        Returns
        -------
        ElementState
            The elements' state.
        """
        return _element_state(
            geometry,
            u_e,
            self.c1,
            c5=self.c5,
            kappa=self.kappa,
            fiber=self.fiber,
            tangent=tangent,
            parameter_derivatives=parameter_derivatives,
            c2=self.c2,
            fiber_mean=fiber_mean,
        )


def composite_moduli(composite: CompositeMaterial, mesh: BlockMesh, fiber: np.ndarray) -> ElementModuli:
    """Per-element moduli of ``composite`` on a mesh with element sets named after its constituents.

    Parameters
    ----------
    composite : CompositeMaterial
        The constituents (``matrix``, ``fibers``).
    mesh : BlockMesh
        A mesh with element sets of the same names.
    fiber : numpy.ndarray
        The unit reference fiber direction.

    Returns
    -------
    ElementModuli
        (ne,) arrays of c1, c2, c5 and kappa, kPa.

    Raises
    ------
    ValueError
        If the mesh has no element sets, or sets and constituents do not match.
    """
    if mesh.element_material is None:
        raise ValueError(f"{mesh.source}: a composite needs a mesh with element sets (matrix, fibers)")
    table = np.zeros((len(mesh.material_names), 4))
    for c in composite.constituents:
        if c.name not in mesh.material_names:
            raise ValueError(f"{mesh.source}: no element set {c.name!r} for that constituent")
        table[mesh.material_names.index(c.name)] = (c.c1, c.c2, c.c5, c.kappa)
    missing = set(mesh.material_names) - {c.name for c in composite.constituents}
    if missing:
        raise ValueError(f"{mesh.source}: element sets {sorted(missing)} have no constituent")
    per = table[mesh.element_material]
    return ElementModuli(*(np.ascontiguousarray(per[:, k]) for k in range(4)), fiber=np.asarray(fiber, float))


def element_moduli(spec: ModelSpec, mesh: BlockMesh) -> ElementModuli:
    """The moduli of ``spec`` on ``mesh``: the homogeneous material (c2 = 0) or the composite's."""
    fiber = np.asarray(spec.material.fiber, dtype=float)
    if spec.composite is not None:
        return composite_moduli(spec.composite, mesh, fiber)
    m = spec.material
    return ElementModuli(m.c1, 0.0, m.c5, m.kappa, fiber)
