"""The model spec: everything that defines one indentation simulation (paper 2.4, 2.5).

A :class:`ModelSpec` is a frozen, validated record of geometry, indenter, protocol, material,
mesh and solver options. Every result file stores it (``to_dict``) so a run can be traced and
repeated. Invalid input raises :class:`SpecError`, whose message names the offending field.

Units everywhere: mm, kPa, mN, s.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Any

from .mesh_presets import COMPOSITE_MESH_PRESETS, CONTACT_MESH_LEVELS, MESH_PRESETS

#: Indenter radii of the paper's two spheres (9.5 mm and 16 mm diameter), mm.
INDENTER_PRESETS: dict[str, float] = {"small": 4.77, "large": 8.0}

#: Deepest indentation accepted, as a fraction of the block height.
MAX_DEPTH_FRACTION = 0.5


class SpecError(ValueError):
    """A model spec field holds a value the model cannot take; the message names the field.

    Parameters
    ----------
    field_name : str
        The field, dotted (``"material.c1"``); kept as :attr:`field`.
    message : str
        What is wrong with it.
    """

    def __init__(self, field_name: str, message: str) -> None:
        self.field = field_name
        super().__init__(f"{field_name}: {message}")


def _finite(name: str, value: float) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise SpecError(name, f"must be a number, got {value!r}") from exc
    if not math.isfinite(v):
        raise SpecError(name, f"must be finite, got {value!r}")
    return v


def _finite_positive(name: str, value: float) -> float:
    v = _finite(name, value)
    if v <= 0.0:
        raise SpecError(name, f"must be positive, got {value!r}")
    return v


@dataclass(frozen=True)
class Geometry:
    """The quarter block: x in [0, half_x], y in [0, half_y], z in [0, height], mm.

    The full specimen is 100 x 100 x 60 mm; symmetry planes x = 0 and y = 0 cut it to a quarter.

    Parameters
    ----------
    half_x, half_y : float, optional
        Half the specimen's width along x and y, mm.
    height : float, optional
        The specimen's height, mm.

    Raises
    ------
    SpecError
        A size that is not finite and positive.
    """

    half_x: float = 50.0
    half_y: float = 50.0
    height: float = 60.0

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, _finite_positive(f"geometry.{f.name}", getattr(self, f.name)))


@dataclass(frozen=True)
class Indenter:
    """A rigid sphere, lowest point touching the top face at (0, 0, height) at depth 0.

    Parameters
    ----------
    radius : float, optional
        mm (the paper's spheres: 4.77 and 8).

    Raises
    ------
    SpecError
        A radius that is not finite and positive.
    """

    radius: float = INDENTER_PRESETS["small"]

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _finite_positive("indenter.radius", self.radius))

    @classmethod
    def preset(cls, name: str) -> Indenter:
        """One of the paper's two spheres by name.

        Parameters
        ----------
        name : {"small", "large"}
            4.77 or 8 mm.

        Returns
        -------
        Indenter

        Raises
        ------
        SpecError
            An unknown name.
        """
        if name not in INDENTER_PRESETS:
            raise SpecError("indenter.radius", f"unknown preset {name!r}; use {sorted(INDENTER_PRESETS)}")
        return cls(INDENTER_PRESETS[name])


@dataclass(frozen=True)
class Protocol:
    """Quasi-static indentation in equal steps (paper 2.7: 28 steps of 0.5 mm).

    Parameters
    ----------
    step_size : float, optional
        Depth per step, mm.
    steps : int, optional
        Number of steps.

    Raises
    ------
    SpecError
        A step size that is not finite and positive, or steps not a whole number >= 1.
    """

    step_size: float = 0.5
    steps: int = 28

    def __post_init__(self) -> None:
        object.__setattr__(self, "step_size", _finite_positive("protocol.step_size", self.step_size))
        if isinstance(self.steps, bool) or int(self.steps) != self.steps or self.steps < 1:
            raise SpecError("protocol.steps", f"must be a whole number >= 1, got {self.steps!r}")
        object.__setattr__(self, "steps", int(self.steps))

    @property
    def max_depth(self) -> float:
        """The deepest indentation, mm."""
        return self.step_size * self.steps

    @property
    def depths(self) -> list[float]:
        """Depths at the end of each step, mm (depth 0 excluded)."""
        return [self.step_size * (k + 1) for k in range(self.steps)]


@dataclass(frozen=True)
class Material:
    """Uncoupled fiber-reinforced neo-Hookean (eq. 3).

    FEBio's trans iso Mooney-Rivlin with c2 = 0 and lam_max = 1.

    Parameters
    ----------
    c1 : float, optional
        The matrix's modulus, kPa (> 0).
    c5 : float, optional
        The fibers' modulus, kPa (>= 0; 0 is isotropic).
    kappa : float, optional
        The bulk-like modulus, kPa.
    fiber : tuple of float, optional
        The reference fiber direction (normalised; the paper's +y).

    Raises
    ------
    SpecError
        A modulus out of range or a fiber that is not a finite non-zero 3-vector.
    """

    c1: float = 10.0
    c5: float = 350.0
    kappa: float = 1000.0
    fiber: tuple[float, float, float] = (0.0, 1.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "c1", _finite_positive("material.c1", self.c1))
        object.__setattr__(self, "kappa", _finite_positive("material.kappa", self.kappa))
        try:
            c5 = float(self.c5)
        except (TypeError, ValueError) as exc:
            raise SpecError("material.c5", f"must be a number, got {self.c5!r}") from exc
        if not math.isfinite(c5) or c5 < 0.0:
            raise SpecError("material.c5", f"must be finite and >= 0 (0: isotropic), got {self.c5!r}")
        object.__setattr__(self, "c5", c5)
        try:
            a = tuple(float(v) for v in self.fiber)
        except (TypeError, ValueError) as exc:
            raise SpecError("material.fiber", f"must be three numbers, got {self.fiber!r}") from exc
        norm = math.sqrt(sum(v * v for v in a)) if len(a) == 3 else 0.0
        if len(a) != 3 or not all(math.isfinite(v) for v in a) or norm == 0.0:
            raise SpecError("material.fiber", f"must be a finite non-zero 3-vector, got {self.fiber!r}")
        object.__setattr__(self, "fiber", tuple(v / norm for v in a))

    @property
    def theta(self) -> dict[str, float]:
        """The identified parameters theta = (c1, c5)."""
        return {"c1": self.c1, "c5": self.c5}


#: Bulk modulus of a composite's constituent, as a multiple of its initial shear modulus
#: 2 (c1 + c2), unless the spec gives kappa: the ratio of the paper's homogeneous model
#: (kappa = 1000 kPa, mu = 2 c1 = 20 kPa; Poisson's ratio 0.49), so that the composite and the
#: model fitted to it are equally compressible.
BULK_TO_SHEAR = 50.0


@dataclass(frozen=True)
class Constituent:
    """One material of the composite phantom (paper 2.4.2, 3.1).

    FEBio's uncoupled Mooney-Rivlin, W = c1 (I1~ - 3) + c2 (I2~ - 3) + kappa/2 (ln J)^2, plus
    eq. 2's fiber term c5 along ``Material.fiber`` where c5 > 0. A neo-Hookean solid of shear
    modulus mu is c1 = mu / 2, c2 = 0.

    Parameters
    ----------
    name : str
        A plain word (``"matrix"``, ``"fibers"``).
    c1, c2 : float
        kPa; c1 may be negative (the TPU fibers' c1 = -1227 kPa) as long as the initial shear
        modulus 2 (c1 + c2) is positive.
    c5 : float, optional
        The fiber term's modulus, kPa (>= 0).
    kappa : float or None, optional
        kPa; None: ``BULK_TO_SHEAR`` x 2 (c1 + c2).

    Raises
    ------
    SpecError
        A name that is not a plain word, a modulus out of range.
    """

    name: str
    c1: float
    c2: float = 0.0
    c5: float = 0.0
    kappa: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise SpecError("composite.name", f"a constituent's name must be a plain word, got {self.name!r}")
        for f in ("c1", "c2", "c5"):
            object.__setattr__(self, f, _finite(f"composite.{self.name}.{f}", getattr(self, f)))
        if self.c5 < 0.0:
            raise SpecError(f"composite.{self.name}.c5", f"must be >= 0, got {self.c5!r}")
        if not self.shear_modulus > 0.0:
            raise SpecError(
                f"composite.{self.name}.c1",
                f"the initial shear modulus 2 (c1 + c2) must be positive, got 2 ({self.c1!r} + {self.c2!r})",
            )
        kappa = BULK_TO_SHEAR * self.shear_modulus if self.kappa is None else self.kappa
        object.__setattr__(self, "kappa", _finite_positive(f"composite.{self.name}.kappa", kappa))

    @property
    def shear_modulus(self) -> float:
        """Initial shear modulus 2 (c1 + c2), kPa."""
        return 2.0 * (self.c1 + self.c2)


#: The phantom's constituents (paper 3.1, supplement S3): the Ecoflex matrix, neo-Hookean with
#: mu = 19.4 kPa, and the TPU fibers, Mooney-Rivlin with {c1, c2} = {-1227, 5945} kPa.
PHANTOM_MATRIX = Constituent("matrix", 9.7)
PHANTOM_FIBERS = Constituent("fibers", -1227.0, 5945.0)


@dataclass(frozen=True)
class CompositeMaterial:
    """The composite phantom's two materials (2.4.2).

    Element set 0 is the matrix, set 1 the fibers (:mod:`forward.composite_mesh`).

    Parameters
    ----------
    matrix, fibers : Constituent or dict, optional
        The constituents (the phantom's Ecoflex and TPU by default); a dict is a Constituent's
        fields.

    Raises
    ------
    SpecError
        A constituent that is not one, or two with the same name.
    """

    matrix: Constituent = PHANTOM_MATRIX
    fibers: Constituent = PHANTOM_FIBERS

    def __post_init__(self) -> None:
        for f in ("matrix", "fibers"):
            c = getattr(self, f)
            if isinstance(c, dict):
                c = Constituent(**{"name": f, **c})
                object.__setattr__(self, f, c)
            if not isinstance(c, Constituent):
                raise SpecError(f"composite.{f}", f"must be a Constituent, got {c!r}")
        if self.matrix.name == self.fibers.name:
            raise SpecError(
                "composite.fibers.name", f"the two constituents share the name {self.matrix.name!r}"
            )

    @property
    def constituents(self) -> tuple[Constituent, Constituent]:
        """(matrix, fibers), in element-set order."""
        return (self.matrix, self.fibers)


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
        object.__setattr__(self, "penalty", _finite_positive("contact.penalty", self.penalty))
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
        object.__setattr__(self, "residual_tol", _finite_positive("solver.residual_tol", self.residual_tol))


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
