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

    def matrix(self, element_matrices: np.ndarray) -> sp.csr_matrix:
        data = np.bincount(self.slot, weights=element_matrices.ravel(), minlength=self.nnz)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n_dofs, self.n_dofs))

    def vector(self, element_vectors: np.ndarray) -> np.ndarray:
        return np.bincount(self.edofs.ravel(), weights=element_vectors.ravel(), minlength=self.n_dofs)
