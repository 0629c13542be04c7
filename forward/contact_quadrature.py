"""Where the indenter's penalty contact is evaluated on the block's top face.

A penalty contact (:mod:`forward.coulomb_contact`) computes the sphere's force at *contact
points*, each with its own anchor, status and penalty; this module maps those points to and from
the top nodes. Two placements:

* ``node``: one point per top node, its penalty the node's tributary area (node to surface);
* ``surface``: ``order`` x ``order`` Gauss points on every top face, interpolated from the face's
  four nodes with the bilinear shape functions, each with its Gauss weight x area (surface to
  surface, integrated over the faces as FEBio's sliding-elastic contact and mortar methods do).

Points are grouped in *cells* (a top node, or a top face) of ``k`` nodes and ``q`` points. The
force on the nodes is N^T f, the tangent's contact part N^T (df/dr) N, assembled cell by cell
into the CSR slots of the body's stiffness (every cell's nodes share an element, so the pattern
holds them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .block_mesh import BlockMesh
from .sparse_assembly import SparsePattern

__all__ = [
    "CONTACT_INTEGRATIONS",
    "ContactPoints",
    "cells_within",
    "contact_points",
    "top_faces",
    "tributary_areas",
]

#: The placements of :func:`contact_points`.
CONTACT_INTEGRATIONS = ("node", "surface")

#: The six faces of a hex8 element (FEBio's node order), each in a cyclic order of its corners.
_HEX8_FACES = np.array([[4, 5, 6, 7], [0, 1, 2, 3], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]])


def top_faces(mesh: BlockMesh, *, upward: bool = False) -> np.ndarray:
    """The top face's quads: the faces of hex8 elements whose four nodes all lie on the top.

    The one list of the top faces: the surface contact integrates over them
    (:func:`contact_points`) and the FEBio writer writes them as the contact surface
    (``upward=True``).

    Parameters
    ----------
    mesh : BlockMesh
        The block.
    upward : bool, default False
        Turn each quad whose normal (right-hand rule over its corners' order) points down so that
        every normal is +z, out of the block, as FEBio's contact surface needs; by default each
        quad keeps its element's order of corners.

    Returns
    -------
    ndarray, shape (nf, 4)
        Node indices (into the mesh) of each quad, in cyclic order, in element order.

    Raises
    ------
    ValueError
        If no element face lies on the top.
    """
    quads = _top_quads(mesh.n_nodes, mesh.elements, mesh.top)
    if len(quads) == 0:
        raise ValueError(f"mesh {mesh.source}: no element face lies on the top surface")
    if not upward:
        return quads
    x = mesh.nodes[quads]
    normal_z = np.cross(x[:, 1] - x[:, 0], x[:, 3] - x[:, 0])[:, 2]
    return np.where((normal_z > 0)[:, None], quads, quads[:, ::-1])


def _top_quads(n_nodes: int, elements: np.ndarray, top: np.ndarray) -> np.ndarray:
    """The faces of hex8 ``elements`` whose four nodes are all in ``top`` (nf, 4), in element order."""
    on_top = np.zeros(n_nodes, dtype=bool)
    on_top[top] = True
    quads = elements[:, _HEX8_FACES]  # (ne, 6, 4)
    element, face = np.nonzero(on_top[quads].all(axis=2))
    return quads[element, face]


def tributary_areas(nodes: np.ndarray, elements: np.ndarray, top: np.ndarray) -> np.ndarray:
    """Each top node's share of the top face: a quarter of the area of every top quad it is a corner of.

    Parameters
    ----------
    nodes : ndarray, shape (n, 3)
        Node coordinates, mm.
    elements : ndarray, shape (ne, 8)
        hex8 connectivity (node indices).
    top : ndarray, shape (nt,)
        The top nodes' indices.

    Returns
    -------
    ndarray, shape (nt,)
        Tributary areas, mm^2 (they sum to the top face's area).
    """
    quads = _top_quads(nodes.shape[0], elements, top)
    xy = nodes[quads][:, :, :2]
    shoelace = 0.5 * np.abs(
        np.einsum("ij,ij->i", xy[:, :, 0], np.roll(xy[:, :, 1], -1, axis=1))
        - np.einsum("ij,ij->i", xy[:, :, 1], np.roll(xy[:, :, 0], -1, axis=1))
    )
    area = np.zeros(nodes.shape[0])
    np.add.at(area, quads.ravel(), np.repeat(shoelace / 4.0, 4))
    return area[top]


@dataclass(frozen=True)
class ContactPoints:
    """Contact points on the top face, grouped in cells (module docstring).

    Attributes
    ----------
    integration : str
        ``"node"`` or ``"surface"``.
    cell_nodes : ndarray, shape (nc, k)
        Each cell's nodes, as indices into the mesh's top nodes.
    shape : ndarray, shape (nc, q, k)
        The value of each cell node's shape function at each of the cell's points.
    area : ndarray, shape (nc * q,)
        Each point's share of the top face, mm^2 (its penalty is ``penalty * area``).
    xyz0 : ndarray, shape (nc * q, 3)
        The points' reference positions.
    n_top : int
        The number of top nodes.
    """

    integration: str
    cell_nodes: np.ndarray
    shape: np.ndarray
    area: np.ndarray
    xyz0: np.ndarray
    n_top: int

    @property
    def n_points(self) -> int:
        """The number of contact points."""
        return int(self.area.size)

    @property
    def interpolation(self) -> sp.csr_matrix:
        """N (n_points, n_top): point values from top-node values."""
        nc, q, k = self.shape.shape
        rows = np.repeat(np.arange(nc * q), k)
        cols = np.repeat(self.cell_nodes, q, axis=0).ravel()
        return sp.csr_matrix((self.shape.ravel(), (rows, cols)), shape=(nc * q, self.n_top))

    def to_points(self, top_values: np.ndarray) -> np.ndarray:
        """Values at the points interpolated from values at the top nodes (N v).

        Parameters
        ----------
        top_values : ndarray, shape (n_top, ...)
            Values at the top nodes (displacements, their derivatives, ...).

        Returns
        -------
        ndarray, shape (n_points, ...)
        """
        nc, q, _ = self.shape.shape
        cell = top_values[self.cell_nodes]  # (nc, k, ...)
        return np.einsum("cqk,ck...->cq...", self.shape, cell).reshape(nc * q, *top_values.shape[1:])

    def to_nodes(self, point_values: np.ndarray) -> np.ndarray:
        """The work-conjugate node values N^T v of point values: the nodal forces of point forces.

        Parameters
        ----------
        point_values : ndarray, shape (n_points, ...)
            Values at the contact points.

        Returns
        -------
        ndarray, shape (n_top, ...)
        """
        nc, q, _ = self.shape.shape
        tail = point_values.shape[1:]
        per = np.einsum("cqk,cq...->ck...", self.shape, point_values.reshape(nc, q, *tail))
        out = np.zeros((self.n_top, *tail))
        np.add.at(out, self.cell_nodes, per)
        return out

    def any_per_node(self, flags: np.ndarray) -> np.ndarray:
        """The top nodes that carry a weight of at least one flagged point.

        Parameters
        ----------
        flags : ndarray of bool, shape (n_points,)
            A flag per contact point (in contact, slipping, ...).

        Returns
        -------
        ndarray of bool, shape (n_top,)
        """
        nc, q, _ = self.shape.shape
        hit = (flags.reshape(nc, q)[:, :, None] & (self.shape > 0.0)).any(axis=1)  # (nc, k)
        out = np.zeros(self.n_top, dtype=bool)
        np.logical_or.at(out, self.cell_nodes, hit)
        return out

    def cell_blocks(self, point_blocks: np.ndarray) -> np.ndarray:
        """The points' 3 x 3 blocks carried to the cells' nodes, N^T B N cell by cell.

        Parameters
        ----------
        point_blocks : ndarray, shape (n_points, 3, 3)
            A block per point (df/dr of the contact law).

        Returns
        -------
        ndarray, shape (nc, k, 3, k, 3)
        """
        nc, q, _ = self.shape.shape
        B = point_blocks.reshape(nc, q, 3, 3)
        return np.einsum("cqa,cqb,cqij->caibj", self.shape, self.shape, B)

    def cell_scale(self, eps: np.ndarray) -> np.ndarray:
        """Each cell's penalty: the sum of its points' (what a change of its block is measured against).

        Parameters
        ----------
        eps : ndarray, shape (n_points,)
            The points' penalties, mN/mm.

        Returns
        -------
        ndarray, shape (nc,)
            mN/mm.
        """
        nc, q, _ = self.shape.shape
        return eps.reshape(nc, q).sum(axis=1)

    def cell_dofs(self, top: np.ndarray) -> np.ndarray:
        """The global dofs of each cell's nodes.

        Parameters
        ----------
        top : ndarray, shape (n_top,)
            The mesh's top node indices.

        Returns
        -------
        ndarray, shape (nc, k, 3)
        """
        return 3 * top[self.cell_nodes][:, :, None] + np.arange(3)

    def slots(self, pattern: SparsePattern, top: np.ndarray) -> np.ndarray:
        """Positions in the CSR data of every entry of every cell block.

        Parameters
        ----------
        pattern : SparsePattern
            The body's stiffness pattern (every cell's nodes share an element, so it holds them).
        top : ndarray, shape (n_top,)
            The mesh's top node indices.

        Returns
        -------
        ndarray, shape (nc, k, 3, k, 3)

        Raises
        ------
        RuntimeError
            When the pattern lacks a cell's block (a contact cell whose nodes share no element).
        """
        dofs = self.cell_dofs(top)
        nc, k, _ = dofs.shape
        rows = np.broadcast_to(dofs[:, :, :, None, None], (nc, k, 3, k, 3)).astype(np.int64)
        cols = np.broadcast_to(dofs[:, None, None, :, :], (nc, k, 3, k, 3)).astype(np.int64)
        keys = pattern.row.astype(np.int64) * pattern.n_dofs + pattern.indices
        wanted = rows * pattern.n_dofs + cols
        slots = np.minimum(np.searchsorted(keys, wanted), keys.size - 1)
        if not np.array_equal(keys[slots], wanted):
            raise RuntimeError("the sparsity pattern lacks a contact cell's block")
        return slots


def contact_points(mesh: BlockMesh, integration: str = "node", *, order: int = 2) -> ContactPoints:
    """The contact points of ``mesh``'s top face.

    Parameters
    ----------
    mesh : BlockMesh
        The block.
    integration : {"node", "surface"}
        One point per top node, or ``order`` x ``order`` Gauss points per top face.
    order : int, optional
        Gauss points per face edge (surface only).

    Returns
    -------
    ContactPoints
        The points, their cells, shape functions and areas.

    Raises
    ------
    ValueError
        An unknown ``integration`` or an ``order`` below 1.
    """
    top = np.asarray(mesh.top)
    index = np.full(mesh.n_nodes, -1)
    index[top] = np.arange(top.size)
    if integration == "node":
        area = tributary_areas(mesh.nodes, mesh.elements, top)
        nt = top.size
        return ContactPoints(
            "node", np.arange(nt)[:, None], np.ones((nt, 1, 1)), area, mesh.nodes[top].copy(), nt
        )
    if integration != "surface":
        raise ValueError(f"unknown contact integration {integration!r}; use one of {CONTACT_INTEGRATIONS}")
    if int(order) != order or order < 1:
        raise ValueError(f"the surface contact's order must be a whole number >= 1, got {order!r}")
    quads = top_faces(mesh)
    xy = mesh.nodes[quads][:, :, :2]  # (nf, 4, 2)
    g, w = np.polynomial.legendre.leggauss(int(order))
    xi, eta = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    wq = np.outer(w, w).ravel()
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
    N = 0.25 * (1 + xi[:, None] * corners[:, 0]) * (1 + eta[:, None] * corners[:, 1])  # (q, 4)
    dN = np.stack(
        [
            0.25 * corners[:, 0] * (1 + eta[:, None] * corners[:, 1]),
            0.25 * corners[:, 1] * (1 + xi[:, None] * corners[:, 0]),
        ],
        axis=1,
    )  # (q, 2, 4)
    J = np.einsum("qak,fkb->fqab", dN, xy)  # (nf, q, 2, 2)
    detJ = np.abs(np.linalg.det(J))
    nf, q = quads.shape[0], xi.size
    shape = np.broadcast_to(N, (nf, q, 4)).copy()
    xyz0 = np.einsum("qk,fkj->fqj", N, mesh.nodes[quads]).reshape(nf * q, 3)
    return ContactPoints("surface", index[quads], shape, (detJ * wq).ravel(), xyz0, top.size)


def cells_within(cell_dofs: np.ndarray, columns: int) -> int:
    """How many of the cells, taken in order, hold at most ``columns`` distinct dofs together.

    Neighbouring contact cells share nodes, so a patch of cells needs far fewer columns of the
    factorisation's inverse than 3 per node of each cell: on a quad grid a patch of P cells has
    about P + 2 sqrt(P) + 1 nodes, not 4 P (the contact's correction,
    :meth:`forward.penalty_contact.PenaltyContact.correction`).

    Parameters
    ----------
    cell_dofs : ndarray of int, shape (m, k, 3)
        The global dofs of each cell's nodes, in the order the cells are wanted.
    columns : int
        How many distinct dofs may be held.

    Returns
    -------
    int
        The longest prefix of the cells within ``columns`` dofs (at least 1 where there is a cell).
    """
    m = cell_dofs.shape[0]
    if m == 0:
        return 0
    flat = cell_dofs.reshape(m, -1)
    _, first = np.unique(flat.ravel(), return_index=True)
    new_dofs = np.bincount(first // flat.shape[1], minlength=m)
    return max(1, int(np.searchsorted(np.cumsum(new_dofs), columns, side="right")))
