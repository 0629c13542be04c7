"""The model spec: everything that defines one indentation simulation (paper 2.4, 2.5).

A :class:`ModelSpec` is a frozen, validated record of geometry, indenter, protocol, material,
mesh and solver options. Every result file stores it (``to_dict``) so a run can be traced and
repeated. Invalid input raises :class:`SpecError`, whose message names the offending field.

Units everywhere: mm, kPa, mN, s.

The spec's parts live in :mod:`.spec_test` (geometry, indenter, protocol), :mod:`.spec_material`
(materials), :mod:`.spec_numerics` (mesh, contact, solver) and :mod:`.spec_checks` (the error);
every name is imported from here as before."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

from .mesh_presets import COMPOSITE_MESH_PRESETS
from .spec_checks import SpecError
from .spec_material import BULK_TO_SHEAR as BULK_TO_SHEAR  # X as X: re-exported, as every part's name
from .spec_material import PHANTOM_FIBERS as PHANTOM_FIBERS
from .spec_material import PHANTOM_MATRIX as PHANTOM_MATRIX
from .spec_material import CompositeMaterial, Material
from .spec_material import Constituent as Constituent
from .spec_numerics import DEFAULT_CONTACT_PENALTY as DEFAULT_CONTACT_PENALTY
from .spec_numerics import Contact, MeshChoice, SolverOptions
from .spec_test import INDENTER_PRESETS as INDENTER_PRESETS
from .spec_test import MAX_DEPTH_FRACTION, Geometry, Indenter, Protocol


@dataclass(frozen=True)
class ModelSpec:
    """One indentation simulation: geometry, indenter, protocol, material, mesh, solver, contact.

    Parameters
    ----------
    geometry, indenter, protocol, material, mesh, solver, contact : optional
        The parts (their defaults: the paper's baseline test).
    composite : CompositeMaterial or None, optional
        The composite phantom's two materials (2.4.2) on a composite mesh; None: the
        homogeneous ``material`` everywhere.

    Raises
    ------
    SpecError
        A composite mesh without a composite material or the reverse, or a protocol deeper than
        half the block.
    """

    geometry: Geometry = field(default_factory=Geometry)
    indenter: Indenter = field(default_factory=Indenter)
    protocol: Protocol = field(default_factory=Protocol)
    material: Material = field(default_factory=Material)
    mesh: MeshChoice = field(default_factory=MeshChoice)
    solver: SolverOptions = field(default_factory=SolverOptions)
    contact: Contact = field(default_factory=Contact)
    #: the composite phantom's two materials (2.4.2) on a composite mesh; None: the homogeneous
    #: ``material`` everywhere
    composite: CompositeMaterial | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "contact", self.contact.on_mesh(self.mesh))
        if self.composite is None and self.mesh.is_composite:
            raise SpecError(
                "mesh.preset",
                f"the composite mesh {self.mesh.preset!r} needs a composite material (composite=...)",
            )
        if self.composite is not None and not (self.mesh.is_composite or self.mesh.feb_file):
            raise SpecError(
                "mesh.preset",
                f"a composite needs a composite mesh ({sorted(COMPOSITE_MESH_PRESETS)}) or a .feb file "
                f"with its element sets, got {self.mesh.preset!r}",
            )
        limit = MAX_DEPTH_FRACTION * self.geometry.height
        if self.protocol.max_depth > limit:
            raise SpecError(
                "protocol.steps",
                f"maximum depth {self.protocol.max_depth:g} mm (steps x step_size) exceeds what the "
                f"{self.geometry.height:g} mm block can take ({limit:g} mm)",
            )

    def with_material(self, **changes: float) -> ModelSpec:
        """The same spec with some material fields changed.

        Parameters
        ----------
        **changes : float
            Material fields and their values (e.g. ``c1=12``).

        Returns
        -------
        ModelSpec
        """
        return replace(self, material=replace(self.material, **changes))

    def with_parameters(self, **values: float) -> ModelSpec:
        """The same spec with some identified parameters changed.

        A campaign's or a predictor's parameter point goes through here, so that mu can be an
        axis too.

        Parameters
        ----------
        **values : float
            Material fields by name (``c1``, ``c5``, ``kappa``) and ``mu``, the contact's
            friction coefficient.

        Returns
        -------
        ModelSpec

        Raises
        ------
        SpecError
            An unknown parameter.
        """
        material = {k: v for k, v in values.items() if k != "mu"}
        scalar = {f.name for f in fields(Material)} - {"fiber"}  # a direction is no parameter
        unknown = sorted(set(material) - scalar)
        if unknown:
            raise SpecError(
                "parameters", f"unknown parameter(s) {unknown}; use material fields (c1, c5, kappa) or mu"
            )
        spec = self.with_material(**material) if material else self
        return spec.with_friction(float(values["mu"])) if "mu" in values else spec

    def with_friction(self, friction: float | None) -> ModelSpec:
        """The same spec with another friction coefficient.

        Parameters
        ----------
        friction : float or None
            mu (None: stick).

        Returns
        -------
        ModelSpec
        """
        return replace(self, contact=replace(self.contact, friction=friction))

    def to_dict(self) -> dict[str, Any]:
        """The spec as plain data (what every result file stores).

        On a mesh that does not follow the contact, the contact is left out when it is the default
        (perfect stick, node by node) and a node-wise contact keeps only its friction and penalty,
        so that specs, campaigns and result files written before friction or the surface contact
        existed compare equal to today's; on the ``contact-L`` meshes, whose default contact is
        the surface one, it is always written whole. The solver's fiber stretch is left out when
        it is the Gauss points'.

        Returns
        -------
        dict
        """
        d = asdict(self)
        d["material"]["fiber"] = list(self.material.fiber)
        if self.mesh.follows_contact:
            pass  # its default is the surface contact: written whole
        elif self.contact == Contact().on_mesh(self.mesh):
            del d["contact"]
        elif self.contact.integration == "node":  # as written before surface contact existed
            del d["contact"]["integration"], d["contact"]["order"]
        if self.composite is None:
            del d["composite"]
        if self.solver.fiber_stretch == "gauss":  # as written before the element-mean fiber existed
            del d["solver"]["fiber_stretch"]
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> ModelSpec:
        """The spec of :meth:`to_dict`'s plain data.

        Parameters
        ----------
        d : dict
            As written by :meth:`to_dict` (missing parts take their defaults).

        Returns
        -------
        ModelSpec
        """
        material = dict(d.get("material", {}))
        if "fiber" in material:
            material["fiber"] = tuple(material["fiber"])
        return cls(
            geometry=Geometry(**d.get("geometry", {})),
            indenter=Indenter(**d.get("indenter", {})),
            protocol=Protocol(**d.get("protocol", {})),
            material=Material(**material),
            mesh=MeshChoice(**d.get("mesh", {})),
            solver=SolverOptions(**d.get("solver", {})),
            contact=Contact(**(d.get("contact") or {})),
            composite=CompositeMaterial(**d["composite"]) if d.get("composite") else None,
        )

    @classmethod
    def composite_phantom(cls, preset: str = "composite", **fields_: Any) -> ModelSpec:
        """The composite phantom's spec (2.4.2): its constituents on a composite mesh.

        Parameters
        ----------
        preset : str, optional
            A composite mesh preset.
        **fields_ : Any
            Other fields (indenter, protocol, contact, composite, ...).

        Returns
        -------
        ModelSpec
        """
        composite = fields_.pop("composite", CompositeMaterial())
        return cls(mesh=MeshChoice(preset=preset), composite=composite, **fields_)
