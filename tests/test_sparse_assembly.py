"""forward.sparse_assembly: the CSR pattern built from node pairs (the solver's numbering) is the
pattern built from every dof pair, array for array; a numbering that is not node after node
takes the dof-pair path; both assemble what a dense scatter does."""

from __future__ import annotations

import numpy as np
import pytest

from indentation_studio.forward.mesh import build_mesh
from indentation_studio.forward.sparse_assembly import SparsePattern
from indentation_studio.forward.spec import MeshChoice, ModelSpec


def _by_dof_pairs(edofs: np.ndarray, n_dofs: int) -> SparsePattern:
    pattern = SparsePattern.__new__(SparsePattern)
    pattern.edofs, pattern.n_dofs = np.asarray(edofs, dtype=np.int64), n_dofs
    pattern._dof_pattern()
    return pattern


def _dense(edofs: np.ndarray, n_dofs: int, ke: np.ndarray) -> np.ndarray:
    K = np.zeros((n_dofs, n_dofs))
    for dofs, k in zip(edofs, ke, strict=True):
        K[np.ix_(dofs, dofs)] += k
    return K


@pytest.mark.parametrize("preset", ["coarse", "default"])
def test_node_pairs_give_the_dof_pairs_pattern(preset):
    mesh = build_mesh(ModelSpec(mesh=MeshChoice(preset)))
    edofs = (3 * mesh.elements[:, :, None] + np.arange(3)).reshape(-1, 24)
    fast, reference = SparsePattern(edofs, 3 * mesh.n_nodes), _by_dof_pairs(edofs, 3 * mesh.n_nodes)
    assert fast.nnz == reference.nnz
    for name in ("indices", "indptr", "slot", "row"):
        got, want = getattr(fast, name), getattr(reference, name)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want, err_msg=name)


def test_any_numbering_assembles_the_dense_matrix():
    rng = np.random.default_rng(3)
    mesh = build_mesh(ModelSpec(mesh=MeshChoice("coarse")))
    node_blocks = (3 * mesh.elements[:, :, None] + np.arange(3)).reshape(-1, 24)
    shuffled = node_blocks[:, rng.permutation(24)]  # not node after node: the dof-pair path
    n_dofs = 3 * mesh.n_nodes
    ke = rng.standard_normal((len(node_blocks), 24, 24))
    for edofs in (node_blocks, shuffled):
        K = SparsePattern(edofs, n_dofs).matrix(ke)
        K.check_format(full_check=True)
        np.testing.assert_allclose(K.toarray(), _dense(edofs, n_dofs, ke), rtol=1e-13, atol=1e-12)
