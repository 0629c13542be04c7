"""Scatter element vectors and matrices into global ones with a CSR pattern built once.

The pattern of a mesh never changes, so each element-matrix entry's slot in the CSR data array
is computed once; assembling is then one ``np.bincount`` over all entries.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


class SparsePattern:
    """CSR structure of the global stiffness for element dofs ``edofs`` (ne, nd)."""

    def __init__(self, edofs: np.ndarray, n_dofs: int) -> None:
        self.edofs = np.asarray(edofs, dtype=np.int64)
        self.n_dofs = int(n_dofs)
        nodes = _nodes_of(self.edofs, self.n_dofs)
        if nodes is None:
            self._dof_pattern()
        else:
            self._node_block_pattern(nodes)

    def _dof_pattern(self) -> None:
        """The pattern from every (row dof, column dof) pair of every element."""
        nd = self.edofs.shape[1]
        rows = np.repeat(self.edofs, nd, axis=1).ravel()
        cols = np.tile(self.edofs, (1, nd)).ravel()
        keys = rows * self.n_dofs + cols
        unique, self.slot = np.unique(keys, return_inverse=True)
        self.indices = (unique % self.n_dofs).astype(np.int32)
        row_of = unique // self.n_dofs
        self.indptr = np.searchsorted(row_of, np.arange(self.n_dofs + 1)).astype(np.int32)
        self.nnz = int(unique.size)
        self.row = row_of.astype(np.int64)

    def _node_block_pattern(self, nodes: np.ndarray) -> None:
        """The same pattern, slots and order as :meth:`_dof_pattern` from the (node, node) pairs
        (dofs 3n, 3n+1, 3n+2 of node n): nine times fewer keys to sort, the set-up's largest cost
        in a fresh process (about 0.06 s of it on FEBio's baseline mesh). Row 3a+i holds, for each
        node b coupled to a in increasing order, the columns 3b..3b+2: it starts at
        9 p(a) + 3 i d(a) (p: node a's first pair, d: its number of pairs)."""
        n_nodes, k = self.n_dofs // 3, nodes.shape[1]
        a = np.repeat(nodes, k, axis=1).ravel()
        b = np.tile(nodes, (1, k)).ravel()
        pairs, pair_of = np.unique(a * n_nodes + b, return_inverse=True)
        pa, pb = pairs // n_nodes, pairs % n_nodes
        first = np.searchsorted(pa, np.arange(n_nodes + 1))
        degree = np.diff(first)
        ij = np.arange(3)
        # the slot of dof pair (3a+i, 3b+j) of node pair q (the q-th pair, a's (q - first[a])-th)
        pair_start = 9 * first[pa] + 3 * (np.arange(pairs.size) - first[pa])
        dest = pair_start[:, None, None] + 3 * ij[None, :, None] * degree[pa][:, None, None] + ij
        self.nnz = 9 * int(pairs.size)
        self.indices = np.empty(self.nnz, dtype=np.int32)
        self.indices[dest] = 3 * pb[:, None, None] + ij
        self.row = np.empty(self.nnz, dtype=np.int64)
        self.row[dest] = 3 * pa[:, None, None] + ij[:, None]
        starts = 9 * first[:-1, None] + 3 * ij * degree[:, None]
        self.indptr = np.append(starts.ravel(), self.nnz).astype(np.int32)
        # element entry (3 la + i, 3 lb + j) of element e: local nodes la, lb; slot as above
        q = pair_of.reshape(nodes.shape[0], k, k)
        an = nodes[:, :, None]
        start = 9 * first[an] + 3 * (q - first[an])
        step = 3 * degree[an]
        slot = start[:, :, None, :, None] + step[:, :, None, :, None] * ij[:, None, None] + ij
        self.slot = slot.reshape(-1)

    def matrix(self, element_matrices: np.ndarray) -> sp.csr_matrix:
        data = np.bincount(self.slot, weights=element_matrices.ravel(), minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_dofs, self.n_dofs))

    def vector(self, element_vectors: np.ndarray) -> np.ndarray:
        return np.bincount(self.edofs.ravel(), weights=element_vectors.ravel(), minlength=self.n_dofs)


def _nodes_of(edofs: np.ndarray, n_dofs: int) -> np.ndarray | None:
    """The elements' nodes (ne, nd // 3) when every element's dofs are its nodes' three
    (3n, 3n+1, 3n+2, node after node), as the solver numbers them; else None."""
    ne, nd = edofs.shape
    if nd % 3 or n_dofs % 3 or not ne:
        return None
    blocks = edofs.reshape(ne, nd // 3, 3)
    nodes = blocks[:, :, 0] // 3
    return nodes if np.array_equal(blocks, 3 * nodes[:, :, None] + np.arange(3)) else None
