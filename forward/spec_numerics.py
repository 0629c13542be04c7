"""How a model spec is solved (:mod:`.spec`): the mesh, the contact between the sphere and the
block, and the solver's options."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from .mesh_presets import COMPOSITE_MESH_PRESETS, CONTACT_MESH_LEVELS, MESH_PRESETS
from .spec_checks import SpecError, finite_positive

__all__ = ["DEFAULT_CONTACT_PENALTY", "Contact", "MeshChoice", "SolverOptions"]


@dataclass(frozen=True)
class MeshChoice:
    """Which block mesh: a named preset, or the hex8 block of a FEBio file.

    Parameters
    ----------
    preset : str, optional
        A preset of :mod:`forward.mesh`, of the composite phantom (``COMPOSITE_MESH_PRESETS``), or
        one that follows the contact of the spec's indenter (``contact-L0`` to ``contact-L4``,
        ``CONTACT_MESH_LEVELS``: :func:`forward.convergence.mesh_family.contact_mesh`).
    feb_file : str or None, optional
        A FEBio file whose hex8 block is the mesh (then ``preset`` is not used).

    Raises
    ------
    SpecError
        An unknown preset.
    """

    preset: str = "default"
    feb_file: str | None = None

    def __post_init__(self) -> None:
        known = {**MESH_PRESETS, **COMPOSITE_MESH_PRESETS, **CONTACT_MESH_LEVELS}
        if self.feb_file is None and self.preset not in known:
            raise SpecError("mesh.preset", f"unknown preset {self.preset!r}; use {sorted(known)}")

    @property
    def is_composite(self) -> bool:
        """Whether the mesh is a composite phantom's preset."""
        return self.feb_file is None and self.preset in COMPOSITE_MESH_PRESETS

    @property
    def follows_contact(self) -> bool:
        """Whether the mesh follows the contact (its default contact is then the surface's).

        The levels ``contact-L0`` to ``-L4`` and the composite meshes whose core is theirs
        (``composite-contact``).
        """
        if self.feb_file is not None:
            return False
        composite = COMPOSITE_MESH_PRESETS.get(self.preset)
        return self.preset in CONTACT_MESH_LEVELS or (composite is not None and composite.follows_contact)


#: Penalty of the frictional contact (kPa per mm of penetration) unless the spec says otherwise;
#: why this value: README, "Friction".
DEFAULT_CONTACT_PENALTY = 1.0e5


@dataclass(frozen=True)
class Contact:
    """The indenter's contact with the top face.

    Parameters
    ----------
    friction : float or None, optional
        Coulomb's friction coefficient mu >= 0 (0: frictionless); None (the default): the
        paper's near-perfect stick.
    penalty : float, optional
        kPa per mm of penetration (and of elastic slip under stick) of a penalty contact.
    integration : {"node", "surface"} or None, optional
        Where the contact is evaluated (:mod:`forward.contact_quadrature`): node by node (the
        stick imposed exactly, :mod:`forward.stick_contact`, friction by a penalty), or at
        ``order`` x ``order`` Gauss points of every top face (stick and friction by a penalty,
        :mod:`forward.coulomb_contact`). None (the default): the mesh's own, which a
        :class:`ModelSpec` fills in (:meth:`Contact.on_mesh`): the surface contact with one point
        per face on the meshes that follow the contact (``contact-L0`` to ``contact-L4``, the
        fit's model, docs/validation/verification.md), node by node on every other mesh (the
        paper's reproduction, FEBio's mesh node for node).
    order : int or None, optional
        Gauss points per face edge of the surface contact (1 to 8); None: the mesh's own (1 on
        the ``contact-L`` meshes, 2 elsewhere).

    Raises
    ------
    SpecError
        A friction coefficient or penalty out of range, an unknown integration, an order out of
        range.
    """

    friction: float | None = None
    penalty: float = DEFAULT_CONTACT_PENALTY
    integration: str | None = None
    order: int | None = None

    def __post_init__(self) -> None:
        if self.friction is not None:
            try:
                mu = float(self.friction)
            except (TypeError, ValueError) as exc:
                raise SpecError(
                    "contact.friction", f"must be a number or None (stick), got {self.friction!r}"
                ) from exc
            if not math.isfinite(mu) or mu < 0.0:
                raise SpecError(
                    "contact.friction",
                    f"must be finite and >= 0 (0: frictionless; None: perfect stick), got {self.friction!r}",
                )
            object.__setattr__(self, "friction", mu)
        object.__setattr__(self, "penalty", finite_positive("contact.penalty", self.penalty))
        if self.integration not in ("node", "surface", None):
            raise SpecError(
                "contact.integration",
                f"must be 'node', 'surface' or None (the mesh's), got {self.integration!r}",
            )
        if self.order is not None:
            if int(self.order) != self.order or not 1 <= self.order <= 8:
                raise SpecError("contact.order", f"must be a whole number from 1 to 8, got {self.order!r}")
            object.__setattr__(self, "order", int(self.order))

    def on_mesh(self, mesh: MeshChoice) -> Contact:
        """This contact with what it leaves open (``integration``, ``order``) set to ``mesh``'s own.

        Parameters
        ----------
        mesh : MeshChoice
            The mesh the contact acts on.

        Returns
        -------
        Contact
            Fully specified: the surface contact with one point per face on the ``contact-L``
            meshes, node by node elsewhere, unless this contact says otherwise.
        """
        follows = mesh.follows_contact
        integration = self.integration or ("surface" if follows else "node")
        order = self.order or (1 if follows else 2)
        return replace(self, integration=integration, order=order)

    @property
    def penalised(self) -> bool:
        """Whether the contact is a penalty (friction, or any surface contact), not the exact stick."""
        return self.friction is not None or self.integration == "surface"

    def describe(self) -> str:
        """The contact in words ("perfect stick", "Coulomb friction mu = 0.3", ...).

        Returns
        -------
        str
        """
        if self.integration in (None, "node"):  # None: the mesh's own, told once in a spec
            where = ""
        else:
            order = self.order or 2
            where = f", surface-integrated ({order}x{order} per face)"
        if self.friction is None:
            return ("stick by penalty" if self.integration == "surface" else "perfect stick") + where
        law = "frictionless" if self.friction == 0 else f"Coulomb friction mu = {self.friction:g}"
        return law + where


@dataclass(frozen=True)
class SolverOptions:
    """Numerical controls of the embedded solver (forward.solver).

    Parameters
    ----------
    substeps : int, optional
        Increments per protocol step.
    residual_tol : float, optional
        Newton's residual on the free dofs relative to the reactions.
    max_newton : int, optional
        Newton iterations per solve at most.
    max_cutbacks : int, optional
        How many times an increment may be halved.
    max_contact_passes : int, optional
        Re-solves of an increment until its contact set settles, at most.
    fiber_stretch : {"gauss", "mean"}, optional
        Where the element evaluates the fiber term of eq. 3: at each of its Gauss points (FEBio's
        element, the default) or once at the element's mean isochoric I4 (as mean dilatation does
        for the volume: fibers far stiffer than the matrix lock a hex8 otherwise;
        :func:`forward.hex8_mean_dilatation.element_state_numpy`). Both converge to the same model.

    Raises
    ------
    SpecError
        A count that is not a whole number in range, a tolerance that is not positive, an unknown
        fiber stretch.
    """

    substeps: int = 1
    #: Newton's residual on the free dofs relative to the reactions (why 1e-4: README, "The forward
    #: model"); sensitivity checks against finite differences need tighter (the tests use 1e-11).
    residual_tol: float = 1e-4
    max_newton: int = 25
    max_cutbacks: int = 6
    max_contact_passes: int = 12
    fiber_stretch: str = "gauss"

    def __post_init__(self) -> None:
        if self.fiber_stretch not in ("gauss", "mean"):
            raise SpecError("solver.fiber_stretch", f"must be 'gauss' or 'mean', got {self.fiber_stretch!r}")
        for name in ("substeps", "max_newton", "max_contact_passes"):
            v = getattr(self, name)
            if int(v) != v or v < 1:
                raise SpecError(f"solver.{name}", f"must be a whole number >= 1, got {v!r}")
        if int(self.max_cutbacks) != self.max_cutbacks or self.max_cutbacks < 0:
            raise SpecError("solver.max_cutbacks", f"must be a whole number >= 0, got {self.max_cutbacks!r}")
        object.__setattr__(self, "residual_tol", finite_positive("solver.residual_tol", self.residual_tol))
