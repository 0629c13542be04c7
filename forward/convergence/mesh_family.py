"""Families of systematically refined quarter-block meshes for a verification study: one topology
and one grading, refined by a constant ratio in every direction.

Each axis maps a uniform parameter xi in [0, 1] to the coordinate by the continuous form of
geometric grading,

    x(xi) = L (exp(beta xi) - 1) / (exp(beta) - 1),

with beta set so that the base level's first cell (at the indentation point) is ``h0``. Level k has
n ratio^k cells along an axis of n base cells (rounded half up where it is not whole), the same
xi-spacing refined by ``ratio``, so every cell shrinks by the same ratio wherever it is (Roache's
systematic refinement), and the representative size h = (V / N)^(1/3) falls by ``ratio`` from level
to level (by the rounded counts' own ratio where a level was rounded).

A family may instead follow the contact (``core_xy`` > 0): along x and y the map is uniform over a
core of ``core_xy`` mm (the region the contact edge sweeps and the inner DIC field) on the first
``core_fraction`` of xi, then grows exponentially with a continuous cell size to the far face,

    x(xi) = core xi / xc                                   (xi <= xc)
    x(xi) = core + (core / xc) (exp(b (xi - xc)) - 1) / b   (xi > xc),

the same map at every level, so the refinement stays systematic.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import lazy_loader as lazy
import numpy as np

from ..block_mesh import BlockMesh, grid_block
from ..mesh_presets import CONTACT_CORE_PER_RADIUS, CONTACT_MESH_LEVELS
from ..spec import Geometry
from .gci import representative_size

# scipy.optimize loads on first use: a simulation's cold start does not pay for it (tests/test_cold_start.py)
optimize = lazy.load("scipy.optimize", suppress_warning=True)

__all__ = ["MeshFamily", "contact_family", "contact_mesh", "cored_coordinates", "graded_coordinates"]


def graded_coordinates(length: float, cells: int, beta: float) -> np.ndarray:
    """``cells + 1`` coordinates from 0 to ``length`` on the exponential map of rate ``beta``."""
    xi = np.linspace(0.0, 1.0, cells + 1)
    if abs(beta) < 1e-12:
        return length * xi
    x = length * np.expm1(beta * xi) / np.expm1(beta)
    x[-1] = length  # exactly: the far faces of every level coincide
    return x


def cored_coordinates(length: float, cells: int, core: float, fraction: float) -> np.ndarray:
    """``cells + 1`` coordinates from 0 to ``length``: uniform over ``core`` mm on the first
    ``fraction`` of xi, then exponential growth (module docstring)."""
    xi = np.linspace(0.0, 1.0, cells + 1)
    slope = core / fraction
    rest = length - core
    span = 1.0 - fraction
    if rest <= slope * span * (1.0 + 1e-9):
        raise ValueError(
            f"a core of {core:g} mm on {fraction:g} of the cells leaves too little to grow into over "
            f"{length:g} mm; make the core smaller or its fraction larger"
        )
    b = float(optimize.brentq(lambda b: slope * np.expm1(b * span) / b - rest, 1e-9, 200.0))
    x = np.where(xi <= fraction, slope * xi, core + slope * np.expm1(b * (xi - fraction)) / b)
    x[-1] = length
    return x


def _rate(length: float, cells: int, first: float) -> float:
    """beta such that the first of ``cells`` cells over ``length`` is ``first`` (0: uniform)."""
    if not 0 < first <= length / cells + 1e-12:
        raise ValueError(
            f"a first cell of {first:g} mm cannot start {cells} growing cells over {length:g} mm"
        )
    if abs(first - length / cells) < 1e-12:
        return 0.0
    return float(optimize.brentq(lambda b: length * np.expm1(b / cells) / np.expm1(b) - first, 1e-9, 200.0))


@dataclass(frozen=True)
class MeshFamily:
    """A family of refined meshes, level 0 the coarsest, refined by ``ratio`` per level.

    Level 0 has ``cells_xy`` and ``cells_z`` cells, its first cells ``h0_xy`` and ``h0_z`` at the
    indentation point.

    Parameters
    ----------
    cells_xy, cells_z : int
        Cells along x (and y) and along z at level 0.
    h0_xy, h0_z : float
        The size of level 0's cell at the indentation point along x (and y) and z, mm.
    ratio : float
        Refinement ratio between levels (Roache asks for at least 1.3).
    core_xy : float, optional
        A core of uniform cells this wide (mm) along x and y at the indentation point (0: none;
        ``h0_xy`` is then unused).
    core_fraction : float, optional
        The share of the cells along x and y inside the core.
    """

    cells_xy: int = 8
    cells_z: int = 8
    h0_xy: float = 1.2
    h0_z: float = 1.2
    ratio: float = 1.5
    core_xy: float = 0.0
    core_fraction: float = 0.5

    def __post_init__(self) -> None:
        if not self.ratio > 1.0:
            raise ValueError(f"the refinement ratio must be > 1, got {self.ratio!r}")
        if self.cells_xy < 1 or self.cells_z < 1:
            raise ValueError("a family needs at least one cell per axis")
        if self.core_xy < 0.0 or not 0.0 < self.core_fraction < 1.0:
            raise ValueError(
                f"core_xy must be >= 0 and core_fraction in (0, 1), got {self.core_xy!r}, {self.core_fraction!r}"
            )

    def cells(self, level: int) -> tuple[int, int]:
        """The cell counts at ``level``: n ratio^level, rounded half up where it is not whole.

        A rounded level is refined from the one before by a ratio a little off ``ratio`` (8 x 1.5^4
        = 40.5 becomes 41, 41 / 27 = 1.52 instead of 1.5); the map from xi to the coordinate is the
        same, so every cell still shrinks by that one ratio, and the observed order and the GCI use
        each level's own size (``size``), which is what Celik et al.'s procedure asks for when the
        ratio is not constant.

        Parameters
        ----------
        level : int
            0 the coarsest.

        Returns
        -------
        tuple of int
            (cells along x and y, cells along z).
        """
        return tuple(int(np.floor(n * self.ratio**level + 0.5 + 1e-9)) for n in (self.cells_xy, self.cells_z))

    def mesh(self, level: int, geometry: Geometry | None = None) -> BlockMesh:
        """The hex8 quarter block of ``level``.

        Parameters
        ----------
        level : int
            0 the coarsest.
        geometry : Geometry, optional
            The block; default ``Geometry()``.

        Returns
        -------
        BlockMesh
            The mesh.
        """
        g = geometry or Geometry()
        nxy, nz = self.cells(level)
        if self.core_xy > 0.0:
            x = cored_coordinates(g.half_x, nxy, self.core_xy, self.core_fraction)
            y = cored_coordinates(g.half_y, nxy, self.core_xy, self.core_fraction)
        else:
            x = graded_coordinates(g.half_x, nxy, _rate(g.half_x, self.cells_xy, self.h0_xy))
            y = graded_coordinates(g.half_y, nxy, _rate(g.half_y, self.cells_xy, self.h0_xy))
        bz = _rate(g.height, self.cells_z, self.h0_z)
        z = g.height - graded_coordinates(g.height, nz, bz)[::-1]
        return grid_block(x, y, z, f"family:{self.name}:L{level}")

    def size(self, level: int, geometry: Geometry | None = None) -> float:
        """The representative cell size h = (V / N)^(1/3) of ``level``, mm.

        Parameters
        ----------
        level : int
            0 the coarsest.
        geometry : Geometry, optional
            The block; default ``Geometry()``.

        Returns
        -------
        float
            h, mm.
        """
        g = geometry or Geometry()
        nxy, nz = self.cells(level)
        return representative_size(g.half_x * g.half_y * g.height, nxy * nxy * nz)

    def node_count(self, level: int) -> int:
        """The number of nodes at ``level``.

        Parameters
        ----------
        level : int
            0 the coarsest.

        Returns
        -------
        int
            (cells_xy + 1)^2 (cells_z + 1).
        """
        nxy, nz = self.cells(level)
        return (nxy + 1) ** 2 * (nz + 1)

    @property
    def name(self) -> str:
        """The family's name from its parameters, e.g. ``8x8-h1.2x1.2-r1.5``."""
        core = f"-core{self.core_xy:g}x{self.core_fraction:g}" if self.core_xy > 0.0 else ""
        return f"{self.cells_xy}x{self.cells_z}-h{self.h0_xy:g}x{self.h0_z:g}-r{self.ratio:g}{core}"

    def to_dict(self) -> dict:
        """The family's parameters as a dict (the core's only when there is one).

        Returns
        -------
        dict
            ``cells_xy``, ``cells_z``, ``h0_xy``, ``h0_z``, ``ratio`` [, ``core_xy``, ``core_fraction``].
        """
        d = {
            "cells_xy": self.cells_xy,
            "cells_z": self.cells_z,
            "h0_xy": self.h0_xy,
            "h0_z": self.h0_z,
            "ratio": self.ratio,
        }
        if self.core_xy > 0.0:  # families written before cores existed read the same
            d |= {"core_xy": self.core_xy, "core_fraction": self.core_fraction}
        return d


def contact_family(radius: float) -> MeshFamily:
    """The family of meshes that follow the contact of a sphere of ``radius``.

    8 x 8 cells at level 0, refined by 1.5, half of the in-plane cells in a uniform core
    ``CONTACT_CORE_PER_RADIUS`` R wide (rounded to whole mm; 8 mm at R = 4.77, 13 mm at R = 8:
    the families of the verification study, ``--family 8x8:1.2:1.5:core8`` and ``core13``).

    Parameters
    ----------
    radius : float
        The indenter's radius, mm.

    Returns
    -------
    MeshFamily
        The family.

    Raises
    ------
    ValueError
        If ``radius`` is not positive.

    Examples
    --------
    >>> from indentation_studio.forward.convergence.mesh_family import contact_family
    >>> contact_family(4.77).name, contact_family(8.0).node_count(3)
    ('8x8-h1.2x1.2-r1.5-core8x0.5', 21952)
    """
    if not radius > 0.0:
        raise ValueError(f"the indenter's radius must be > 0, got {radius!r}")
    core = max(1.0, float(round(CONTACT_CORE_PER_RADIUS * radius)))
    return MeshFamily(8, 8, 1.2, 1.2, 1.5, core_xy=core, core_fraction=0.5)


def contact_mesh(name: str, radius: float, geometry: Geometry | None = None) -> BlockMesh:
    """The radius-following preset ``name`` (``contact-L0`` to ``contact-L4``) for a sphere of ``radius``.

    Parameters
    ----------
    name : str
        A key of ``CONTACT_MESH_LEVELS``.
    radius : float
        The indenter's radius, mm.
    geometry : Geometry, optional
        The block; default ``Geometry()``.

    Returns
    -------
    BlockMesh
        Level ``CONTACT_MESH_LEVELS[name]`` of :func:`contact_family`, named ``contact-Lk@R<radius>``.

    Raises
    ------
    ValueError
        If ``name`` is not such a preset.
    """
    if name not in CONTACT_MESH_LEVELS:
        raise ValueError(f"unknown radius-following mesh {name!r}; use one of {sorted(CONTACT_MESH_LEVELS)}")
    mesh = contact_family(radius).mesh(CONTACT_MESH_LEVELS[name], geometry)
    return replace(mesh, source=f"preset:{name}@R{radius:g}")
