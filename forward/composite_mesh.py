"""The composite phantom's geometry and its conforming hex8 quarter mesh (paper 2.4.2, supplement S1).

S1: the 100 x 100 x 60 mm block is cast in a mold of stacked layers, each 4.17 mm high with 12
uniformly spaced fibers of 1.6 x 1.6 mm cross-section running the block's full length along y;
a bottom plate brings the mold to 60 mm. The layout chosen here (S1 does not give every detail):

- 14 layers (168 fibers / 12), stacked on the bottom plate: the layers fill the top
  14 x 4.17 = 58.38 mm and the lowest 1.62 mm is matrix only;
- each fiber sits at the centre of its layer (its centre 2.085 mm above the layer's bottom);
- across x the 12 fibers are at the centres of 12 equal cells of the block's width (pitch
  100 / 12 = 8.33 mm, outermost fiber centres 4.17 mm from the faces), so that the layout is
  symmetric about the block's centre plane x = 0 and no fiber lies on it: the quarter
  (x >= 0) holds 6 whole fibers per layer, 84 in all; the fibers are aligned from layer to layer;
- the fiber volume fraction is 168 x 1.6^2 / (100 x 60) = 7.17 % (the block's cross-section).

The mesh is a structured grid whose x and z lines include every fiber boundary, so each element
is either matrix or fiber (``BlockMesh.element_material``: 0 matrix, 1 fibers). Between fiber
boundaries cells are sized ``h0 + growth * t`` with t the distance from the indenter's axis
(x, y) or from the top face (z), graded toward the indenter like the homogeneous meshes
(:mod:`forward.mesh`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .block_mesh import BlockMesh, grid_block
from .hex8_mean_dilatation import ReferenceGeometry
from .mesh_presets import COMPOSITE_MESH_PRESETS, CONTACT_CORE_PER_RADIUS, CompositeMeshPreset
from .spec import Geometry

#: Element-set names of a composite mesh, in the order of ``BlockMesh.element_material``.
COMPOSITE_SETS: tuple[str, str] = ("matrix", "fibers")
MATRIX, FIBERS = 0, 1


@dataclass(frozen=True)
class PhantomLayout:
    """The fibers of the composite phantom (supplement S1), mm.

    Parameters
    ----------
    fiber_size : float, default 1.6
        The square fibers' side, mm.
    layer_height : float, default 4.17
        The height of a layer, mm (more than ``fiber_size``).
    layers : int, default 14
        Layers of fibers.
    fibers_per_layer : int, default 12
        Fibers in a layer across the full block.

    Raises
    ------
    ValueError
        If a size is not positive, a count not a whole number >= 1, or a fiber not thinner than
        its layer.
    """

    fiber_size: float = 1.6
    layer_height: float = 4.17
    layers: int = 14
    fibers_per_layer: int = 12

    def __post_init__(self) -> None:
        for f in ("fiber_size", "layer_height"):
            v = getattr(self, f)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"PhantomLayout.{f} must be a positive number, got {v!r}")
        for f in ("layers", "fibers_per_layer"):
            if int(getattr(self, f)) != getattr(self, f) or getattr(self, f) < 1:
                raise ValueError(f"PhantomLayout.{f} must be a whole number >= 1, got {getattr(self, f)!r}")
        if self.fiber_size >= self.layer_height:
            raise ValueError("PhantomLayout: a fiber must be thinner than its layer")

    @property
    def fibers(self) -> int:
        """Fibers in the full block."""
        return self.layers * self.fibers_per_layer

    def x_centres(self, width: float) -> np.ndarray:
        """Fiber centres across the full block, x in [-width/2, width/2].

        Parameters
        ----------
        width : float
            The full block's width, mm.

        Returns
        -------
        numpy.ndarray
            (fibers_per_layer,) centres, mm.

        Raises
        ------
        ValueError
            If the fibers do not fit in the width.
        """
        pitch = width / self.fibers_per_layer
        if self.fiber_size >= pitch:
            raise ValueError(
                f"{self.fibers_per_layer} fibers of {self.fiber_size} mm do not fit in {width} mm"
            )
        return -width / 2 + pitch * (np.arange(self.fibers_per_layer) + 0.5)

    def z_centres(self, height: float) -> np.ndarray:
        """Fiber centres from the bottom (z = 0): one per layer, the layers on the bottom plate.

        Parameters
        ----------
        height : float
            The block's height, mm.

        Returns
        -------
        numpy.ndarray
            (layers,) centres, mm.
        """
        plate = self.bottom_plate(height)
        return plate + self.layer_height * (np.arange(self.layers) + 0.5)

    def bottom_plate(self, height: float) -> float:
        """The matrix below the lowest layer (S1's bottom plate), mm.

        Parameters
        ----------
        height : float
            The block's height, mm.

        Returns
        -------
        float
            The plate's thickness, mm.

        Raises
        ------
        ValueError
            If the layers do not fit in the block.
        """
        plate = height - self.layers * self.layer_height
        if plate < -1e-9:
            raise ValueError(
                f"{self.layers} layers of {self.layer_height} mm do not fit in a {height} mm block"
            )
        return max(plate, 0.0)

    def fiber_volume_fraction(self, width: float, height: float) -> float:
        """The fibers' share of the block's volume (they run its full length).

        Parameters
        ----------
        width, height : float
            The full block's width and height, mm.

        Returns
        -------
        float
            FVF.

        Examples
        --------
        >>> from indentation_studio.forward import PHANTOM
        >>> round(PHANTOM.fiber_volume_fraction(100.0, 60.0), 3)  # the phantom's 100 x 60 mm section
        0.072
        """
        return self.fibers * self.fiber_size**2 / (width * height)


#: The paper's phantom (S1).
PHANTOM = PhantomLayout()


def _intervals(centres: np.ndarray, size: float, length: float) -> list[tuple[float, float]]:
    """The fibers' [lo, hi] along an axis of the quarter, clipped to [0, length]."""
    out = []
    for c in centres:
        lo, hi = max(c - size / 2, 0.0), min(c + size / 2, length)
        if hi > lo:
            out.append((lo, hi))
    return out


def conforming_axis(
    length: float,
    fibers: list[tuple[float, float]],
    fiber_cells: int,
    h0: float,
    growth: float,
    from_end: bool = False,
    core: float = 0.0,
) -> np.ndarray:
    """Node coordinates on [0, length] through every fiber boundary: ``fiber_cells`` equal cells
    across each fiber, and between them cells of about h(t) = h0 + growth max(t - core, 0), t the
    distance from 0 (or from ``length`` with ``from_end``), spaced so that 1/h is integrated
    equally (cells grow smoothly within a gap; uniform over the first ``core`` mm)."""
    if h0 <= 0 or growth < 0 or fiber_cells < 1 or core < 0:
        raise ValueError("conforming_axis: h0 > 0, growth >= 0, fiber_cells >= 1 and core >= 0 are needed")
    breaks = sorted({0.0, length, *(v for f in fibers for v in f)})
    inside = {(round(lo, 12), round(hi, 12)) for lo, hi in fibers}

    def grown(s: np.ndarray) -> np.ndarray:  # integral of 1/h over s mm past the core
        return s / h0 if growth == 0 else np.log1p(growth * s / h0) / growth

    def phi(t: np.ndarray) -> np.ndarray:  # integral of 1/h from 0 to t
        return np.minimum(t, core) / h0 + grown(np.maximum(t - core, 0.0))

    def phi_inv(p: np.ndarray) -> np.ndarray:
        past = np.maximum(p - core / h0, 0.0)
        s = past * h0 if growth == 0 else h0 * np.expm1(growth * past) / growth
        return np.minimum(p * h0, core) + s

    coords = [0.0]
    for a, b in itertools.pairwise(breaks):
        if (round(a, 12), round(b, 12)) in inside:
            pts = np.linspace(a, b, fiber_cells + 1)[1:]
        else:
            ta, tb = (length - a, length - b) if from_end else (a, b)
            pa, pb = phi(np.asarray(ta)), phi(np.asarray(tb))
            n = max(1, math.ceil(abs(pb - pa) - 1e-9))
            t = phi_inv(pa + (pb - pa) * np.arange(1, n + 1) / n)
            pts = length - t if from_end else t
            pts[-1] = b
        coords.extend(pts.tolist())
    return np.asarray(coords)


def phantom_mesh(
    geometry: Geometry,
    preset: CompositeMeshPreset,
    layout: PhantomLayout = PHANTOM,
    name: str = "custom",
    *,
    radius: float | None = None,
) -> BlockMesh:
    """The conforming hex8 mesh of the phantom's quarter block with its element sets (module docstring).

    x, y >= 0 from the block's centre axis, the indenter at the top centre.

    Parameters
    ----------
    geometry : Geometry
        The block, mm.
    preset : CompositeMeshPreset
        Cells across a fiber, first cell size and growth, along x/z and y.
    layout : PhantomLayout, default PHANTOM
        The fibers.
    name : str, default "custom"
        The mesh's name (its source is ``composite:<name>``).
    radius : float, optional
        The indenter's radius, mm: needed when the preset follows the contact (its core is
        ``CONTACT_CORE_PER_RADIUS`` R, whole mm, as :func:`forward.convergence.mesh_family.contact_family`'s).

    Returns
    -------
    BlockMesh
        The mesh, element sets ``matrix`` and ``fibers``.

    Raises
    ------
    ValueError
        If the preset follows the contact and no positive radius is given.
    """
    core = 0.0
    if preset.follows_contact:
        if radius is None or not radius > 0.0:
            raise ValueError(
                f"a composite mesh that follows the contact needs the indenter's radius, got {radius!r}"
            )
        core = max(1.0, float(round(CONTACT_CORE_PER_RADIUS * radius)))
        name = f"{name}-core{core:g}"
    xf = _intervals(layout.x_centres(2 * geometry.half_x), layout.fiber_size, geometry.half_x)
    zf = _intervals(layout.z_centres(geometry.height), layout.fiber_size, geometry.height)
    x = conforming_axis(geometry.half_x, xf, preset.fiber_cells, preset.h0, preset.growth, core=core)
    z = conforming_axis(geometry.height, zf, preset.fiber_cells, preset.h0, preset.growth, from_end=True)
    y = conforming_axis(geometry.half_y, [], 1, preset.h0_y, preset.growth_y, core=core)
    xc, zc = 0.5 * (x[1:] + x[:-1]), 0.5 * (z[1:] + z[:-1])
    in_x = np.zeros(xc.size, bool)
    for lo, hi in xf:
        in_x |= (xc > lo) & (xc < hi)
    in_z = np.zeros(zc.size, bool)
    for lo, hi in zf:
        in_z |= (zc > lo) & (zc < hi)
    # cells in grid_block's order: i (x) slowest, then j (y), then k (z)
    fiber = in_x[:, None, None] & np.ones(y.size - 1, bool)[None, :, None] & in_z[None, None, :]
    material = np.where(fiber.ravel(), FIBERS, MATRIX)
    return grid_block(x, y, z, f"composite:{name}", material, COMPOSITE_SETS)


def composite_mesh(name: str, geometry: Geometry | None = None, *, radius: float | None = None) -> BlockMesh:
    """The named composite phantom mesh of :data:`COMPOSITE_MESH_PRESETS` (``radius``, mm, for
    the one that follows the contact)."""
    if name not in COMPOSITE_MESH_PRESETS:
        raise ValueError(
            f"unknown composite mesh preset {name!r}; use one of {sorted(COMPOSITE_MESH_PRESETS)}"
        )
    return phantom_mesh(geometry or Geometry(), COMPOSITE_MESH_PRESETS[name], name=name, radius=radius)


def fiber_volume_fraction(mesh: BlockMesh) -> float:
    """The fiber volume fraction of a composite mesh: its fiber elements' volume over its volume.

    Parameters
    ----------
    mesh : BlockMesh
        A composite mesh (with element sets).

    Returns
    -------
    float
        FVF.

    Raises
    ------
    ValueError
        If the mesh has no element sets.
    """

    if mesh.element_material is None:
        raise ValueError(f"{mesh.source}: not a composite mesh (no element sets)")
    vol = ReferenceGeometry.of(mesh).volume
    return float(vol[mesh.element_material == FIBERS].sum() / vol.sum())
