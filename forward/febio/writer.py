"""Write a model spec as a FEBio 4.0 input file (``.feb``) that real FEBio runs to the end.

The model is the paper's (2.4, 2.5): the quarter block of hex8 elements with FEBio's ``trans iso
Mooney-Rivlin`` (eq. 3: c2 = 0, lam_max = 1) or, for the composite phantom (2.4.2), one hex8 part,
solid domain and uncoupled ``Mooney-Rivlin`` material per element set (matrix, fibers), symmetry and bottom boundary conditions, the
quarter-sphere indenter as rigid tri3 shells driven down by a load curve, and sliding-elastic
contact with a very large friction coefficient (near-perfect stick). The settings that real
FEBio 4 needed (README, "FEBio backend") are the defaults of :class:`FebSettings`:

- ``c3`` must not be 0: with c3 = c4 = 0 this FEBio computes c3 = c5/c4 exp(...) and gives NaN;
  1e-9 with lam_max = 1 leaves the fiber stress c5 (lam~ - 1) of eq. 2.
- the default contact penalty is too soft (the sphere sinks 0.13 mm at 0.5 mm depth and the
  force comes out 20% low): auto penalty with scale 100.
- friction 1e8 with 0.5 mm increments fails near 12 mm: the increment is capped at half a step
  (``late_max_increment``) from ``late_from_depth`` on.

:meth:`FebSettings.tightened` gives the settings of the one rerun the runner makes when FEBio
accepted steps off equilibrium (:mod:`forward.febio.equilibrium`).

Time is measured in steps (one time unit per indentation step), so the must points, where the
log records the results that the parser keeps, fall on the whole times 1, 2, ..., steps.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from ... import __version__
from ...atomic_write import atomic_write
from ..contact_quadrature import top_faces
from ..mesh import BlockMesh, build_mesh
from ..spec import ModelSpec

#: Names shared by the writer, the log parser and the runner.
TOP_DATA = "top_disp"
INDENTER_DATA = "indenter"
BOTTOM_DATA = "bottom_reaction"
BLOCK_MATERIAL_ID = 1
INDENTER_MATERIAL_ID = 2


@dataclass(frozen=True)
class FebSettings:
    """FEBio settings that are not part of the model spec (numerics of FEBio's solution).

    Attributes
    ----------
    c3 : float, default 1e-9
        The material's c3, kPa (> 0: FEBio gives NaN for c3 = c4 = 0).
    fric_coeff : float, default 1e8
        The contact's friction coefficient when the spec's contact has none (a stick).
    penalty : float, default 100.0
        The contact penalty.
    auto_penalty : bool, default True
        FEBio's automatic penalty.
    search_radius, search_tol : float
        The contact search's radius and tolerance.
    contact_tolerance : float, default 0.2
        The contact's augmentation tolerance.
    sphere_divisions : int, default 12
        Divisions of the indenter's sphere surface (>= 2).
    shell_thickness : float, default 0.01
        The indenter shell's thickness, mm.
    max_retries, opt_iter : int
        FEBio's time stepper: retries and optimal iterations.
    dtmin : float, default 0.001
        The smallest time increment.
    late_from_depth : float, default 10.0
        From this depth (mm) on the increment is capped at ``late_max_increment``.
    max_increment : float, default 1.0
        The largest time increment before ``late_from_depth``, steps.
    late_max_increment : float, default 0.5
        ... and from ``late_from_depth`` on, steps.
    dtol, etol, rtol : float
        FEBio's displacement, energy and residual tolerances.
    max_refs : int, default 50
        Stiffness reformations at most.
    linear_solver : str or None
        e.g. ``"pardiso"``; None: FEBio's default.
    """

    c3: float = 1e-9
    fric_coeff: float = 1e8
    penalty: float = 100.0
    auto_penalty: bool = True
    search_radius: float = 1.0
    search_tol: float = 0.01
    contact_tolerance: float = 0.2
    sphere_divisions: int = 12
    shell_thickness: float = 0.01
    max_retries: int = 10
    opt_iter: int = 15
    dtmin: float = 0.001
    late_from_depth: float = 10.0  # mm: from here on the increment is capped at late_max_increment
    max_increment: float = 1.0  # steps: the largest time increment before late_from_depth
    late_max_increment: float = 0.5  # steps: ... and from late_from_depth on
    dtol: float = 0.001
    etol: float = 0.01
    rtol: float = 0.0
    max_refs: int = 50
    linear_solver: str | None = None  # e.g. "pardiso"; None: FEBio's default

    def __post_init__(self) -> None:
        if not self.c3 > 0.0:
            raise ValueError("FebSettings.c3 must be > 0 (FEBio gives NaN for c3 = c4 = 0)")
        if self.sphere_divisions < 2:
            raise ValueError("FebSettings.sphere_divisions must be >= 2")
        for name in ("max_increment", "late_max_increment"):
            if not 0.0 < getattr(self, name) <= 1.0:
                raise ValueError(f"FebSettings.{name} must be in (0, 1] steps, got {getattr(self, name)!r}")

    def tightened(self) -> FebSettings:
        """The settings of the rerun after FEBio accepted steps off equilibrium.

        - increments capped at half of the present caps (0.5 step, and 0.25 from
          ``late_from_depth``): FEBio's bad steps start from a huge first residual (1.8e16 at
          12.5 mm in the baseline, where a contact predictor pushed nodes deep into the
          sphere); smaller increments keep that predictor, and the residual, small;
        - ``dtol`` and ``etol`` ten times smaller: the baseline's 12.5 mm step was accepted with
          its displacement norm at 0.4 of the required one; FEBio compares squared norms, so the
          new requirement is 100 times stricter on it;
        - ``rtol`` 1e-6 (was 0, FEBio's residual check off): FEBio then also wants the squared
          residual at 1e-6 of the increment's first one (the residual norm at 1e-3). The
          baseline accepted two increments whose residual had grown (100 and 4e4 times; 8.98
          and 10.50 time units); its clean increments end between 1e-15 and 1e-7. rtol alone
          would not have refused 12.5 mm (3e-14 of a huge first residual), hence the two above.

        Everything else (model, contact, penalty) stays, so both runs solve the same model.
        """
        return replace(
            self,
            max_increment=self.max_increment / 2,
            late_max_increment=self.late_max_increment / 2,
            dtol=self.dtol / 10,
            etol=self.etol / 10,
            rtol=self.rtol / 10 if self.rtol > 0 else 1e-6,
        )


def _num(v: float) -> str:
    return f"{float(v):.10g}"


def _vec(v: Any) -> str:
    return ",".join(_num(x) for x in v)


def _ids(ids: np.ndarray) -> str:
    return ",".join(str(int(i)) for i in ids)


def indenter_surface(radius: float, center: np.ndarray, divisions: int) -> tuple[np.ndarray, np.ndarray]:
    """The quarter sphere (x >= 0, y >= 0) as tri3 facets with outward normals.

    Each octant is the octahedron face x + y + z = 1 cut into ``divisions``^2 triangles and
    projected onto the sphere; the lower octant (the one that indents) comes first, then the
    upper one, which shares its equator. Returns node coordinates (n, 3) and zero-based
    triangles (m, 3).
    """
    n = divisions
    lower: dict[tuple[int, int], int] = {}
    pts: list[np.ndarray] = []
    for j in range(n + 1):
        for k in range(n + 1 - j):
            lower[j, k] = len(pts)
            v = np.array([n - j - k, j, -k], float)
            pts.append(center + radius * v / np.linalg.norm(v))
    upper: dict[tuple[int, int], int] = {}
    for j in range(n + 1):
        upper[j, 0] = lower[j, 0]
        for k in range(1, n + 1 - j):
            upper[j, k] = len(pts)
            v = np.array([n - j - k, j, k], float)
            pts.append(center + radius * v / np.linalg.norm(v))
    tris: list[tuple[int, int, int]] = []
    for idx, flip in ((lower, False), (upper, True)):
        for j in range(n):
            for k in range(n - j):
                a, b, c = idx[j, k], idx[j, k + 1], idx[j + 1, k]
                tris.append((a, c, b) if flip else (a, b, c))
                if k < n - j - 1:
                    d = idx[j + 1, k + 1]
                    tris.append((c, d, b) if flip else (c, b, d))
    return np.array(pts), np.array(tris, dtype=np.int64)


def _sub(parent: ET.Element, tag: str, text: Any = None, **attrib: Any) -> ET.Element:
    el = ET.SubElement(parent, tag, {k: str(v) for k, v in attrib.items()})
    if text is not None:
        el.text = text if isinstance(text, str) else _num(text)
    return el


def _params(parent: ET.Element, values: dict[str, Any]) -> None:
    for k, v in values.items():
        _sub(parent, k, v if isinstance(v, str) else _num(v))


def _solid_parts(spec: ModelSpec, mesh: BlockMesh) -> list[tuple[str, np.ndarray]]:
    """The hex8 parts (name, element indices): one "Block", or one per element set of a composite
    (named after its constituent; FEBio's element ids run through the parts in this order)."""
    if spec.composite is None:
        return [("Block", np.arange(mesh.n_elements))]
    if mesh.element_material is None:
        raise ValueError(f"{mesh.source}: a composite spec needs a mesh with element sets")
    return [(c.name, mesh.element_set(c.name)) for c in spec.composite.constituents]


def check_material_ids(root: ET.Element) -> None:
    """FEBio 4's rule for the Material section: ids 1, 2, ..., n in the order listed, each name
    once, and every domain's ``mat`` and rigid body's ``rb`` naming a material that is there."""
    mats = root.findall("Material/material")
    ids = [int(m.get("id")) for m in mats]
    if ids != list(range(1, len(ids) + 1)):
        raise ValueError(f"FEBio needs materials listed with ids 1..{len(ids)} in order, got {ids}")
    names = [m.get("name") for m in mats]
    if len(set(names)) != len(names):
        raise ValueError(f"material names repeat: {names}")
    for d in root.iterfind("MeshDomains/*"):
        if d.get("mat") not in names:
            raise ValueError(f"domain {d.get('name')} names material {d.get('mat')!r}, not one of {names}")
    for rb in root.iter("rb"):
        if int(rb.text) not in ids or mats[int(rb.text) - 1].get("type") != "rigid body":
            raise ValueError(f"rigid body {rb.text} is not the id of a rigid material")


def build_feb(
    spec: ModelSpec, mesh: BlockMesh, logfile: str = "model.log", settings: FebSettings | None = None
) -> ET.ElementTree:
    """The FEBio 4.0 document of ``spec`` on ``mesh`` (see the module docstring)."""
    s = settings or FebSettings()
    steps = spec.protocol.steps
    radius = spec.indenter.radius
    height = spec.geometry.height
    center = np.array([0.0, 0.0, height + radius])
    root = ET.Element("febio_spec", version="4.0")
    _sub(root, "Module", type="solid")

    control = _sub(root, "Control")
    _params(
        control,
        {
            "analysis": "STATIC",
            "time_steps": str(steps),
            "step_size": 1.0,
            "plot_level": "PLOT_MAJOR_ITRS",
            "output_level": "OUTPUT_MAJOR_ITRS",
        },
    )
    stepper = _sub(control, "time_stepper", type="default")
    _params(stepper, {"max_retries": str(s.max_retries), "opt_iter": str(s.opt_iter), "dtmin": s.dtmin})
    _sub(stepper, "dtmax", 1.0, lc=2)
    _params(stepper, {"aggressiveness": "1", "cutback": 0.5})
    solver = _sub(control, "solver", type="solid")
    _params(
        solver,
        {
            "symmetric_stiffness": "symmetric",
            "max_refs": str(s.max_refs),
            "diverge_reform": "1",
            "reform_each_time_step": "1",
            "dtol": s.dtol,
            "etol": s.etol,
            "rtol": s.rtol,
            "lstol": 0.9,
            "min_residual": 1e-20,
        },
    )
    _params(_sub(solver, "qn_method", type="BFGS"), {"max_ups": "0"})
    if s.linear_solver:
        _sub(control, "linear_solver", type=s.linear_solver)

    mat = spec.material
    materials = _sub(root, "Material")
    solid_parts = _solid_parts(spec, mesh)
    if spec.composite is None:
        block = _sub(
            materials, "material", id=BLOCK_MATERIAL_ID, name="Block", type="trans iso Mooney-Rivlin"
        )
        _params(
            block,
            {"density": 1.0, "k": mat.kappa, "c1": mat.c1, "c2": 0.0, "c3": s.c3, "c4": 0.0, "c5": mat.c5},
        )
        _params(block, {"lam_max": 1.0})
        _sub(_sub(block, "fiber", type="vector"), "vector", _vec(mat.fiber))
    rigid = _sub(materials, "material", id=INDENTER_MATERIAL_ID, name="Indenter", type="rigid body")
    _params(rigid, {"density": 1.0, "E": 1.0, "v": 0.0, "center_of_mass": _vec(center)})
    if spec.composite is not None:
        # the composite's constituents (2.4.2): FEBio's uncoupled Mooney-Rivlin (neo-Hookean: c2 = 0);
        # ids 1, 3, ... so that the indenter keeps id 2 (the log's rigid body)
        for k, c in enumerate(spec.composite.constituents):
            if c.c5 != 0.0:
                raise ValueError(
                    f"composite.{c.name}.c5: the FEBio export writes Mooney-Rivlin constituents (c5 = 0)"
                )
            cid = BLOCK_MATERIAL_ID if k == 0 else INDENTER_MATERIAL_ID + k
            m_el = _sub(materials, "material", id=cid, name=c.name, type="Mooney-Rivlin")
            _params(m_el, {"density": 1.0, "c1": c.c1, "c2": c.c2, "k": c.kappa})
    # FEBio 4 reads materials in the order of their ids ("invalid value for attribute id" when the
    # rigid indenter's id 2 comes before the matrix's 1): listed 1, 2, 3, ...
    materials[:] = sorted(materials, key=lambda m: int(m.get("id")))

    ids = mesh.node_ids
    sphere_xyz, sphere_tri = indenter_surface(radius, center, s.sphere_divisions)
    sphere_ids = ids.max() + 1 + np.arange(len(sphere_xyz))
    geo = _sub(root, "Mesh")
    nodes_el = _sub(geo, "Nodes", name="BlockNodes")
    for i, x in zip(ids, mesh.nodes, strict=True):
        _sub(nodes_el, "node", _vec(x), id=int(i))
    nodes_el = _sub(geo, "Nodes", name="IndenterNodes")
    for i, x in zip(sphere_ids, sphere_xyz, strict=True):
        _sub(nodes_el, "node", _vec(x), id=int(i))
    e_id = 1
    for part, members in solid_parts:
        elems = _sub(geo, "Elements", type="hex8", name=part)
        for conn in mesh.elements[members]:
            _sub(elems, "elem", _ids(ids[conn]), id=e_id)
            e_id += 1
    elems = _sub(geo, "Elements", type="tri3", name="Indenter")
    n_hex = mesh.n_elements
    for e, tri in enumerate(sphere_tri):
        _sub(elems, "elem", _ids(sphere_ids[tri]), id=n_hex + e + 1)
    for name in ("bottom", "xsym", "ysym", "top"):
        _sub(geo, "NodeSet", _ids(np.sort(ids[getattr(mesh, name)])), name=name)
    surf = _sub(geo, "Surface", name="BlockTop")
    for f, quad in enumerate(top_faces(mesh, upward=True)):
        _sub(surf, "quad4", _ids(ids[quad]), id=f + 1)
    surf = _sub(geo, "Surface", name="IndenterSurface")
    for f, tri in enumerate(sphere_tri):
        _sub(surf, "tri3", _ids(sphere_ids[tri]), id=f + 1)
    pair = _sub(geo, "SurfacePair", name="IndentPair")
    _sub(pair, "primary", "BlockTop")
    _sub(pair, "secondary", "IndenterSurface")

    domains = _sub(root, "MeshDomains")
    for part, _ in solid_parts:
        _sub(domains, "SolidDomain", name=part, mat=part)
    _sub(_sub(domains, "ShellDomain", name="Indenter", mat="Indenter"), "shell_thickness", s.shell_thickness)

    boundary = _sub(root, "Boundary")
    for name, nset, dofs in (
        ("FixBottomXY", "bottom", (1, 1, 0)),
        ("SymX", "xsym", (1, 0, 0)),
        ("SymY", "ysym", (0, 1, 0)),
    ):
        bc = _sub(boundary, "bc", name=name, type="zero displacement", node_set=nset)
        _params(bc, {f"{d}_dof": str(v) for d, v in zip("xyz", dofs, strict=True)})
        if name == "FixBottomXY":
            bz = _sub(boundary, "bc", name="FixBottomZ", type="prescribed displacement", node_set="bottom")
            _params(bz, {"dof": "z", "value": 0.0, "relative": "0"})

    rigid_el = _sub(root, "Rigid")
    fixed = _sub(rigid_el, "rigid_bc", name="IndenterFixed", type="rigid_fixed")
    _params(fixed, {"rb": str(INDENTER_MATERIAL_ID)})
    _params(fixed, {f"{d}_dof": "0" if d == "Rz" else "1" for d in ("Rx", "Ry", "Rz", "Ru", "Rv", "Rw")})
    move = _sub(rigid_el, "rigid_bc", name="IndenterZ", type="rigid_displacement")
    _params(move, {"rb": str(INDENTER_MATERIAL_ID), "dof": "z"})
    _sub(move, "value", -spec.protocol.max_depth, lc=1)
    _params(move, {"relative": "0"})

    contact = _sub(
        _sub(root, "Contact"),
        "contact",
        name="Indentation",
        type="sliding-elastic",
        surface_pair="IndentPair",
    )
    _params(
        contact,
        {
            "laugon": "0",
            "tolerance": s.contact_tolerance,
            "gaptol": 0.0,
            "penalty": s.penalty,
            "auto_penalty": str(int(s.auto_penalty)),
            "update_penalty": "0",
            "two_pass": "0",
            "search_tol": s.search_tol,
            "symmetric_stiffness": "1",
            "search_radius": s.search_radius,
            "seg_up": "0",
            "tension": "0",
            "minaug": "0",
            "maxaug": "10",
            # the spec's Coulomb coefficient when it has one (0: frictionless), else the paper's
            # near-perfect stick
            "fric_coeff": s.fric_coeff if spec.contact.friction is None else spec.contact.friction,
        },
    )

    load = _sub(root, "LoadData")
    depth_curve = _sub(load, "load_controller", id=1, name="DepthCurve", type="loadcurve")
    _params(depth_curve, {"interpolate": "LINEAR", "extend": "CONSTANT"})
    pts = _sub(depth_curve, "points")
    _sub(pts, "pt", "0,0")
    _sub(pts, "pt", f"{steps},1")
    must = _sub(load, "load_controller", id=2, name="MustPoints", type="loadcurve")
    _params(must, {"interpolate": "STEP", "extend": "CONSTANT"})
    pts = _sub(must, "points")
    late_step = int(np.ceil(s.late_from_depth / spec.protocol.step_size - 1e-9))
    for k in range(steps + 1):
        cap = s.late_max_increment if k >= late_step else s.max_increment
        _sub(pts, "pt", f"{k},{_num(cap)}")

    output = _sub(root, "Output")
    plot = _sub(output, "plotfile", type="febio")
    for var in ("displacement", "stress", "contact pressure", "contact gap"):
        _sub(plot, "var", type=var)
    log = _sub(output, "logfile", file=logfile)
    _sub(log, "node_data", name=TOP_DATA, data="ux;uy;uz", node_set="top", delim=" ")
    _sub(log, "rigid_body_data", str(INDENTER_MATERIAL_ID), name=INDENTER_DATA, data="z;Fx;Fy;Fz", delim=" ")
    _sub(log, "node_data", name=BOTTOM_DATA, data="Rz", node_set="bottom", delim=" ")
    check_material_ids(root)
    return ET.ElementTree(root)


def write_feb(
    spec: ModelSpec,
    path: str | Path,
    mesh: BlockMesh | None = None,
    settings: FebSettings | None = None,
) -> Path:
    """Write ``spec`` as a FEBio 4.0 ``.feb`` at ``path``; its logfile is ``<stem>.log`` beside it.

    Parameters
    ----------
    spec : ModelSpec
        The model.
    path : str or pathlib.Path
        The ``.feb`` file to write (atomically).
    mesh : BlockMesh, optional
        Default the mesh the spec names (a preset or the hex8 block of a ``.feb``).
    settings : FebSettings, optional
        FEBio's numerics; default ``FebSettings()``.

    Returns
    -------
    pathlib.Path
        The file written.

    Raises
    ------
    ValueError
        If the spec asks for the element-mean fiber stretch, which FEBio's element does not have.
    """
    if spec.solver.fiber_stretch != "gauss":
        raise ValueError(
            f"solver.fiber_stretch = {spec.solver.fiber_stretch!r}: FEBio evaluates the fiber term at the "
            "Gauss points only; write the model with fiber_stretch 'gauss'"
        )
    path = Path(path)
    mesh = mesh if mesh is not None else build_mesh(spec)
    settings = settings or FebSettings()
    tree = build_feb(spec, mesh, logfile=path.with_suffix(".log").name, settings=settings)
    comment = ET.Comment(
        f" written by indentation-studio {__version__}; spec: {spec.to_dict()}; settings: {asdict(settings)} "
    )
    tree.getroot().insert(0, comment)
    ET.indent(tree, space="\t")
    return atomic_write(path, lambda tmp: tree.write(tmp, encoding="ISO-8859-1", xml_declaration=True))
