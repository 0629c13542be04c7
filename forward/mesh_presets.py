"""Gradings of the structured quarter-block meshes (paper 2.4.1): cells of ``h0`` in a core around
the indentation point, then geometric growth to the far faces. Plain data: the model spec
validates a preset name against :data:`MESH_PRESETS` (and the radius-following
:data:`CONTACT_MESH_LEVELS`), :mod:`forward.mesh` builds the mesh."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class GradedAxis:
    """Cells along one axis from the indentation point outward: ``n_core`` cells of ``h0``, then
    ``n_graded`` cells growing geometrically (first one ``h0``) to fill the rest."""

    h0: float
    n_core: int
    n_graded: int


@dataclass(frozen=True)
class MeshPreset:
    """Grading of the in-plane (x and y) and through-thickness axes."""

    xy: GradedAxis
    z: GradedAxis

    def node_count(self) -> int:
        n_xy = self.xy.n_core + self.xy.n_graded + 1
        return n_xy * n_xy * (self.z.n_core + self.z.n_graded + 1)


#: Named meshes. ``default`` is the smallest that meets the paper's mesh-convergence criterion
#: (E_f < 1 %, E_u < 1 % against ``reference``; see ``indent-studio mesh-study`` and the README).
MESH_PRESETS: dict[str, MeshPreset] = {
    "coarse": MeshPreset(GradedAxis(1.0, 3, 4), GradedAxis(1.0, 3, 5)),
    "default": MeshPreset(GradedAxis(0.6, 0, 10), GradedAxis(0.6, 0, 11)),
    "fine": MeshPreset(GradedAxis(0.4, 10, 10), GradedAxis(0.4, 10, 12)),
    "reference": MeshPreset(GradedAxis(0.35, 12, 20), GradedAxis(0.35, 8, 18)),
}


@dataclass(frozen=True)
class CompositeMeshPreset:
    """Grading of a composite phantom mesh (:mod:`forward.composite_mesh`): cell size
    ``h0 + growth * t`` at distance t from the indenter's axis (x, y) or from the top (z), mm;
    ``fiber_cells`` cells across each fiber in x and z. With ``follows_contact`` the cells along
    x and y are uniform (``h0``, ``h0_y``) over the core of the meshes that follow the contact
    (``CONTACT_CORE_PER_RADIUS`` R, whole mm) and grow from its edge: the mesh depends on the
    indenter's radius."""

    h0: float
    growth: float
    fiber_cells: int
    h0_y: float
    growth_y: float
    follows_contact: bool = False


#: Composite phantom meshes: ``composite`` near the paper's 86,400 hex8 (2.4.2), ``composite-medium``
#: a third of it (its mesh-convergence partner: 1 mm cells at the indenter, 1 to 1.6 mm along the
#: fibers), ``composite-coarse`` a few thousand nodes for tests. Two cells across each fiber: with one, the equibiaxial stretch
#: locks (transverse stress at lambda = 1.03 twice that of finer meshes, and kappa-dependent).
#: ``composite-contact`` follows the contact as ``contact-L2`` does (uniform 0.8 mm cells over the
#: same core, two across a fiber), with the surface contact by default.
COMPOSITE_MESH_PRESETS: dict[str, CompositeMeshPreset] = {
    "composite-coarse": CompositeMeshPreset(2.0, 0.15, 2, 4.0, 0.5),
    "composite-medium": CompositeMeshPreset(1.0, 0.06, 2, 1.0, 0.15),
    "composite": CompositeMeshPreset(0.7, 0.03, 2, 0.5, 0.07),
    "composite-contact": CompositeMeshPreset(0.8, 0.08, 2, 0.8, 0.15, follows_contact=True),
}


#: Meshes that follow the contact, whose grading depends on the indenter's radius: level k of the
#: verification family whose uniform core, ``CONTACT_CORE_PER_RADIUS`` R wide along x and y, holds
#: every material point the sphere touches (measured at 14 mm: r = 1.36 R at R = 4.77 mm and
#: 1.21 R at R = 8 mm, docs/validation/verification.md) with margin, and grows beyond
#: (:func:`forward.convergence.mesh_family.contact_family`). The levels are those of the verification study's
#: tables: ``contact-L3`` at R = 4.77 mm is its core-8 family's level 3 (21,952 nodes).
CONTACT_MESH_LEVELS: dict[str, int] = {f"contact-L{k}": k for k in range(5)}

#: The model of the studio's fits, the surrogates they use, their error budgets and the design
#: advice for a new test: the low level of the meshes that follow the contact (with their default,
#: surface-integrated contact). ``default`` (FEBio's mesh node for node, node-wise stick) stays
#: what reproduces the paper (its 775-point campaign, Table 1, Fig. 8) and what is compared with
#: FEBio. Why level 1: docs/validation/verification.md ("The fit's model").
FIT_MESH = "contact-L1"

#: The high-fidelity level the fit's model is judged and corrected against (error budgets, the
#: multi-fidelity discrepancy), its own GCI carried in the budgets.
HIGH_FIDELITY_MESH = "contact-L3"

#: The uniform core's width per indenter radius (rounded to whole mm: 8 mm at R = 4.77, 13 at R = 8,
#: the cores the verification study measured).
CONTACT_CORE_PER_RADIUS = 1.65
