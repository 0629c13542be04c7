"""The constrained sparse solves of the Newton iterations (forward.linear_solver): a factorisation
serves more constraints through its Schur complement exactly; single precision is what it says."""

from __future__ import annotations

import numpy as np
import pytest

from indentation_studio.forward.linear_solver import (
    ConstrainedSymmetricSolver,
    LowRankUpdate,
    default_backend,
)
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import MeshChoice, ModelSpec


@pytest.fixture(scope="module")
def system():
    solver = EmbeddedSolver(ModelSpec(mesh=MeshChoice("coarse")))
    _, K, _ = solver.assemble(np.zeros((solver.mesh.n_nodes, 3)))
    permanent = solver.bc_fixed.ravel()
    return solver.pattern, K, permanent


def _direct(pattern, K, permanent, mask, rhs, backend):
    direct = ConstrainedSymmetricSolver(pattern, backend, permanent=permanent)
    direct.factorize(K, mask)
    return direct.solve(rhs)


@pytest.mark.parametrize("backend", sorted({"superlu", default_backend()}))
def test_schur_complement_holds_extra_constraints_exactly(system, backend):
    pattern, K, permanent = system
    rng = np.random.default_rng(0)
    n = pattern.n_dofs
    base = permanent.copy()
    solver = ConstrainedSymmetricSolver(pattern, backend, permanent=permanent)
    solver.factorize(K, base)
    free = np.flatnonzero(~base)
    for count in (3, 12, 30):  # the contact set grows: W gains columns, the Schur factor is remade
        mask = base.copy()
        mask[rng.choice(free, count, replace=False)] = True
        assert solver.covers(mask)
        rhs = np.where(mask, 0.0, rng.standard_normal(n))
        x = solver.solve_constrained(rhs, mask)
        expected = _direct(pattern, K, permanent, mask, rhs, backend)
        assert np.all(x[mask] == 0.0)
        np.testing.assert_allclose(x, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    attached = base.copy()
    attached[free[:6]] = True
    solver.factorize(K, attached)
    released = attached.copy()
    released[free[0]] = False  # a dof the factorisation held is free again: a new one is needed
    assert solver.covers(attached) and not solver.covers(released)


@pytest.mark.parametrize("backend", sorted({"superlu", default_backend()}))
def test_low_rank_update_inverts_the_changed_matrix(system, backend):
    """Friction's tangent is its factorised symmetric part plus unsymmetric 3 x 3 changes at a few
    nodes (slip, nodes that came into contact): Woodbury gives its exact inverse."""
    pattern, K, permanent = system
    rng = np.random.default_rng(2)
    n = pattern.n_dofs
    solver = ConstrainedSymmetricSolver(pattern, backend, permanent=permanent)
    solver.factorize(K, permanent)
    free_nodes = np.flatnonzero(~permanent.reshape(-1, 3).any(axis=1))
    nodes = rng.choice(free_nodes, 7, replace=False)
    dofs = (3 * nodes[:, None] + np.arange(3)).ravel()
    scale = np.abs(K.diagonal()).max()
    D = np.zeros((dofs.size, dofs.size))
    for i in range(nodes.size):  # unsymmetric blocks as large as the penalty's
        D[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = scale * rng.standard_normal((3, 3))
    update = LowRankUpdate(solver, dofs, D)
    rhs = np.where(permanent, 0.0, rng.standard_normal(n))
    x = update.apply(solver.solve(rhs))
    changed = K.toarray()
    changed[np.ix_(dofs, dofs)] += D
    kept = ~permanent
    expected = np.zeros(n)
    expected[kept] = np.linalg.solve(changed[np.ix_(kept, kept)], rhs[kept])
    np.testing.assert_allclose(x, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    # the columns of A^-1 are kept: a second update on some of the same dofs solves no new ones
    width = solver._W.shape[1]
    LowRankUpdate(solver, dofs[:6], D[:6, :6])
    assert solver._W.shape[1] == width


@pytest.mark.skipif(default_backend() != "pardiso", reason="single precision is a PARDISO option")
def test_single_precision_factorisation(system):
    pattern, K, permanent = system
    rhs = np.where(permanent, 0.0, np.random.default_rng(1).standard_normal(pattern.n_dofs))
    single = ConstrainedSymmetricSolver(pattern, "pardiso", permanent=permanent, single_precision=True)
    single.factorize(K, permanent)
    assert single._matrix.dtype == np.float32
    x = single.solve(rhs)
    exact = _direct(pattern, K, permanent, permanent, rhs, "pardiso")
    err = np.linalg.norm(x - exact) / np.linalg.norm(exact)
    assert 1e-12 < err < 1e-3  # float32 round-off times the condition number, not float64's
