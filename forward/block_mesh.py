"""The hex8 quarter-block mesh and its node sets (symmetry planes, bottom, top)."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class BlockMesh:
    """A hex8 mesh of the quarter block with the node sets the model needs.

    ``nodes`` (n, 3) reference coordinates, mm; ``elements`` (ne, 8) zero-based node indices in
    FEBio's hex8 order; ``node_ids`` (n,) external ids (FEBio's, 1-based); node sets are
    zero-based index arrays. ``top`` is ordered by node id.

    A composite mesh (paper 2.4.2) has element sets: ``element_material`` (ne,) the index of each
    element's material in ``material_names`` (the composite phantom: 0 matrix, 1 fibers); None
    for a homogeneous mesh.

    Attributes
    ----------
    nodes : numpy.ndarray
        (n, 3) reference coordinates, mm.
    elements : numpy.ndarray
        (ne, 8) zero-based node indices, FEBio's hex8 order.
    node_ids : numpy.ndarray
        (n,) external node ids (FEBio's, 1-based).
    xsym, ysym : numpy.ndarray
        Indices of the nodes on the symmetry planes x = 0 and y = 0.
    bottom : numpy.ndarray
        Indices of the bottom nodes.
    top : numpy.ndarray
        Indices of the top-surface nodes, ordered by node id.
    source : str
        Where the mesh came from (a preset, a file, a generator).
    element_material : numpy.ndarray or None
        (ne,) each element's material index in ``material_names``; None: homogeneous.
    material_names : tuple of str
        The materials of a composite mesh.
    """

    nodes: np.ndarray
    elements: np.ndarray
    node_ids: np.ndarray
    xsym: np.ndarray
    ysym: np.ndarray
    bottom: np.ndarray
    top: np.ndarray
    source: str
    element_material: np.ndarray | None = None
    material_names: tuple[str, ...] = ()

    @property
    def n_nodes(self) -> int:
        """The number of nodes."""
        return int(self.nodes.shape[0])

    @property
    def n_elements(self) -> int:
        """The number of elements."""
        return int(self.elements.shape[0])

    @property
    def top_xyz(self) -> np.ndarray:
        """(nt, 3) the top-surface nodes' coordinates, mm."""
        return self.nodes[self.top]

    def geometry_record(self) -> dict[str, Any]:
        """What identifies this mesh's geometry, so that a campaign store is never reused on a changed mesh.

        Its source, node and element counts, the node coordinates' extent and the sha256 of its
        coordinates (rounded to 1e-9 mm) and connectivity.

        Returns
        -------
        dict
            ``source``, ``nodes``, ``elements``, ``extent_mm`` and ``sha256``.
        """
        digest = hashlib.sha256()
        digest.update(np.ascontiguousarray(np.round(self.nodes, 9), dtype="<f8").tobytes())
        digest.update(np.ascontiguousarray(self.elements, dtype="<i8").tobytes())
        if self.element_material is not None:
            digest.update(np.ascontiguousarray(self.element_material, dtype="<i8").tobytes())
        return {
            "source": self.source,
            "nodes": self.n_nodes,
            "elements": self.n_elements,
            "extent_mm": [float(v) for v in self.nodes.max(axis=0) - self.nodes.min(axis=0)],
            "sha256": digest.hexdigest(),
        }

    def element_set(self, name: str) -> np.ndarray:
        """Zero-based indices of the elements of material ``name``.

        Parameters
        ----------
        name : str
            A material of ``material_names`` (the phantom: ``matrix``, ``fibers``).

        Returns
        -------
        numpy.ndarray
            The element indices.

        Raises
        ------
        KeyError
            If the mesh has no such element set.
        """
        if self.element_material is None or name not in self.material_names:
            raise KeyError(f"{self.source}: no element set {name!r} (sets: {list(self.material_names)})")
        return np.flatnonzero(self.element_material == self.material_names.index(name))

    @classmethod
    def from_arrays(
        cls,
        nodes: np.ndarray,
        elements: np.ndarray,
        node_ids: np.ndarray,
        source: str,
        element_material: np.ndarray | None = None,
        material_names: tuple[str, ...] = (),
    ) -> BlockMesh:
        """A mesh of a quarter block (x, y >= 0), its node sets derived from the coordinates.

        Parameters
        ----------
        nodes : numpy.ndarray
            (n, 3) coordinates, mm.
        elements : numpy.ndarray
            (ne, 8) zero-based node indices, FEBio's hex8 order.
        node_ids : numpy.ndarray
            (n,) external node ids.
        source : str
            Where the mesh came from.
        element_material : numpy.ndarray, optional
            (ne,) each element's material index (a composite).
        material_names : tuple of str, default ()
            The materials of a composite.

        Returns
        -------
        BlockMesh
            The mesh with its symmetry, bottom and top node sets.

        Raises
        ------
        ValueError
            If the block does not start at x = 0 and y = 0 (not a quarter block).
        """
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
        if element_material is not None:
            element_material = np.asarray(element_material, dtype=np.int64)
            if element_material.shape != (len(elements),):
                raise ValueError(f"{source}: element_material needs one entry per element")
            if element_material.min() < 0 or element_material.max() >= len(material_names):
                raise ValueError(f"{source}: element_material refers to materials outside {material_names}")
        return cls(
            nodes=nodes,
            elements=np.asarray(elements, dtype=np.int64),
            node_ids=np.asarray(node_ids, dtype=np.int64),
            source=source,
            element_material=element_material,
            material_names=tuple(material_names),
            **sets,
        )


def grid_block(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    source: str,
    element_material: np.ndarray | None = None,
    material_names: tuple[str, ...] = (),
) -> BlockMesh:
    """The structured hex8 mesh of the grid x[i], y[j], z[k].

    Node id = 1 + k + nz * (j + ny * i) (FEBio's baseline numbering); elements in the order of
    their (i, j, k) cells.

    Parameters
    ----------
    x, y, z : numpy.ndarray
        Ascending node coordinates along each axis, mm.
    source : str
        Where the mesh came from.
    element_material : numpy.ndarray, optional
        (ne,) each element's material index (a composite).
    material_names : tuple of str, default ()
        The materials of a composite.

    Returns
    -------
    BlockMesh
        The mesh and its node sets.

    Examples
    --------
    >>> import numpy as np
    >>> from indentation_studio.forward import grid_block
    >>> mesh = grid_block(np.linspace(0, 1, 3), np.linspace(0, 1, 3), np.linspace(0, 1, 2), "test")
    >>> mesh.n_nodes, len(mesh.elements)
    (18, 4)
    """
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
    return BlockMesh.from_arrays(
        nodes, elements, np.arange(1, len(nodes) + 1), source, element_material, material_names
    )
