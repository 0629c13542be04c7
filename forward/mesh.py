"""Structured hex8 quarter-block meshes graded toward the indentation point (paper 2.4.1).

The block spans x in [0, half_x], y in [0, half_y], z in [0, height]; the indenter touches
(0, 0, height). Cells are uniform (size ``h0``) in a core around the indentation point and
then grow geometrically to the far faces. Node numbering follows the FEBio files of
``../shared/febio`` (id = 1 + k + nz * (j + ny * i) for grid x[i], y[j], z[k]), so that node ids
of our meshes and of FEBio's coincide when the grids do.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .spec import Geometry


@dataclass(frozen=True)
class GradedAxis:
    """Cells along one axis from the indentation point outward: ``n_core`` cells of ``h0``, then
    ``n_graded`` cells growing geometrically (first one ``h0``) to fill the rest."""

    h0: float
    n_core: int
    n_graded: int

    def coordinates(self, length: float) -> np.ndarray:
        """Node coordinates from 0 (the fine end) to ``length``."""
        core = self.h0 * self.n_core
        rest = length - core
        if rest <= 0:
            raise ValueError(f"core {core:g} mm does not fit in {length:g} mm")
        sizes = [self.h0] * self.n_core
        if self.n_graded > 0:
            n = self.n_graded
            if rest <= self.h0 * n:  # would need shrinking cells: fall back to uniform
                sizes += [rest / n] * n
            else:
                r = brentq(lambda r: self.h0 * (r**n - 1.0) / (r - 1.0) - rest, 1.0 + 1e-12, 10.0)
                sizes += list(self.h0 * r ** np.arange(n))
        coords = np.concatenate([[0.0], np.cumsum(sizes)])
        coords[-1] = length
        return coords


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
class BlockMesh:
    """A hex8 mesh of the quarter block with the node sets the model needs.

    ``nodes`` (n, 3) reference coordinates, mm; ``elements`` (ne, 8) zero-based node indices in
    FEBio's hex8 order; ``node_ids`` (n,) external ids (FEBio's, 1-based); node sets are
    zero-based index arrays. ``top`` is ordered by node id.
    """

    nodes: np.ndarray
    elements: np.ndarray
    node_ids: np.ndarray
    xsym: np.ndarray
    ysym: np.ndarray
    bottom: np.ndarray
    top: np.ndarray
    source: str

    @property
    def n_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def n_elements(self) -> int:
        return int(self.elements.shape[0])

    @property
    def top_xyz(self) -> np.ndarray:
        return self.nodes[self.top]

    @classmethod
    def from_arrays(
        cls, nodes: np.ndarray, elements: np.ndarray, node_ids: np.ndarray, source: str
    ) -> BlockMesh:
        """Derive the node sets from the coordinates of a quarter block (x, y >= 0)."""
        nodes = np.asarray(nodes, dtype=float)
        lo, hi = nodes.min(axis=0), nodes.max(axis=0)
        tol = 1e-6 * float(np.max(hi - lo))
        if abs(lo[0]) > tol or abs(lo[1]) > tol:
            raise ValueError(
                f"{source}: the block is not a quarter block with symmetry planes x = 0 and y = 0 "
                f"(min x = {lo[0]:g}, min y = {lo[1]:g})"
            )
        sets = {
            "xsym": np.flatnonzero(np.abs(nodes[:, 0]) <= tol),
            "ysym": np.flatnonzero(np.abs(nodes[:, 1]) <= tol),
            "bottom": np.flatnonzero(np.abs(nodes[:, 2] - lo[2]) <= tol),
            "top": np.flatnonzero(np.abs(nodes[:, 2] - hi[2]) <= tol),
        }
        order = np.argsort(node_ids[sets["top"]], kind="stable")
        sets["top"] = sets["top"][order]
        return cls(
            nodes=nodes,
            elements=np.asarray(elements, dtype=np.int64),
            node_ids=np.asarray(node_ids, dtype=np.int64),
            source=source,
            **sets,
        )


def structured_block(geometry: Geometry, preset: MeshPreset, name: str = "custom") -> BlockMesh:
    """The graded structured hex8 mesh of the quarter block for ``preset``."""
    x = preset.xy.coordinates(geometry.half_x)
    y = preset.xy.coordinates(geometry.half_y)
    z = geometry.height - preset.z.coordinates(geometry.height)[::-1]
    nx, ny, nz = len(x), len(y), len(z)
    ii, jj, kk = np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij")
    nodes = np.stack([x[ii], y[jj], z[kk]], axis=-1).reshape(-1, 3)  # index = k + nz*(j + ny*i)

    def idx(i: np.ndarray, j: np.ndarray, k: np.ndarray) -> np.ndarray:
        return k + nz * (j + ny * i)

    ci, cj, ck = (
        a.ravel() for a in np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), np.arange(nz - 1), indexing="ij")
    )
    elements = np.stack(
        [
            idx(ci, cj, ck),
            idx(ci + 1, cj, ck),
            idx(ci + 1, cj + 1, ck),
            idx(ci, cj + 1, ck),
            idx(ci, cj, ck + 1),
            idx(ci + 1, cj, ck + 1),
            idx(ci + 1, cj + 1, ck + 1),
            idx(ci, cj + 1, ck + 1),
        ],
        axis=1,
    )
    return BlockMesh.from_arrays(nodes, elements, np.arange(1, len(nodes) + 1), f"preset:{name}")


def preset_mesh(name: str, geometry: Geometry | None = None) -> BlockMesh:
    """The named preset mesh of :data:`MESH_PRESETS`."""
    if name not in MESH_PRESETS:
        raise ValueError(f"unknown mesh preset {name!r}; use one of {sorted(MESH_PRESETS)}")
    return structured_block(geometry or Geometry(), MESH_PRESETS[name], name)
