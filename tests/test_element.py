"""Three-field hex8: forces are the gradient of the energy, the tangent the gradient of the
forces, the compiled kernel equals the numpy reference, and mean dilatation removes locking."""

import numpy as np
import pytest

from indentation_studio.forward.hex8_mean_dilatation import (
    ReferenceGeometry,
    element_state,
    element_state_numpy,
)
from indentation_studio.forward.material import InvertedElementError
from indentation_studio.forward.mesh import preset_mesh
from indentation_studio.forward.sparse_assembly import SparsePattern

FIBER = np.array([0.2, 1.0, 0.1]) / np.linalg.norm([0.2, 1.0, 0.1])


@pytest.fixture(scope="module")
def setup():
    mesh = preset_mesh("coarse")
    geo = ReferenceGeometry.of(mesh)
    edofs = (3 * mesh.elements[:, :, None] + np.arange(3)).reshape(-1, 24)
    rng = np.random.default_rng(3)
    u = 0.05 * rng.standard_normal((mesh.n_nodes, 3))
    return mesh, geo, SparsePattern(edofs, 3 * mesh.n_nodes), u, rng


def test_reference_volume_is_the_block(setup):
    _, geo, *_ = setup
    assert geo.volume.sum() == pytest.approx(50 * 50 * 60, rel=1e-12)


def test_forces_and_tangent_are_exact_derivatives(setup):
    mesh, geo, pattern, u, rng = setup
    s = element_state(geo, u[mesh.elements], 10.0, 350.0, 1000.0, FIBER)
    f, K = pattern.vector(s.force), pattern.matrix(s.stiffness)
    d = rng.standard_normal(u.shape)
    h = 1e-6
    sp = element_state(geo, (u + h * d)[mesh.elements], 10.0, 350.0, 1000.0, FIBER)
    sm = element_state(geo, (u - h * d)[mesh.elements], 10.0, 350.0, 1000.0, FIBER)
    assert (sp.energy - sm.energy) / (2 * h) == pytest.approx(f @ d.ravel(), rel=1e-7)
    df = (pattern.vector(sp.force) - pattern.vector(sm.force)) / (2 * h)
    assert np.abs(df - K @ d.ravel()).max() < 1e-7 * np.abs(df).max()
    assert abs(K - K.T).max() < 1e-12 * abs(K).max()


def test_compiled_kernel_equals_numpy_reference(setup):
    mesh, geo, _, u, _ = setup
    a = element_state(geo, u[mesh.elements], 10.0, 350.0, 1000.0, FIBER, True, True)
    b = element_state_numpy(geo, u[mesh.elements], 10.0, 350.0, 1000.0, FIBER, True, True)
    assert a.energy == pytest.approx(b.energy, rel=1e-12)
    for x, y in (
        (a.force, b.force),
        (a.stiffness, b.stiffness),
        (a.dforce_dtheta, b.dforce_dtheta),
    ):
        assert np.abs(x - y).max() < 1e-12 * np.abs(y).max()


def test_parameter_derivative_of_forces(setup):
    mesh, geo, _, u, _ = setup
    base = element_state(geo, u[mesh.elements], 10.0, 350.0, 1000.0, FIBER, False, True)
    for k, (c1, c5) in enumerate(((11.0, 350.0), (10.0, 351.0))):
        other = element_state(geo, u[mesh.elements], c1, c5, 1000.0, FIBER, False)
        assert np.allclose(other.force - base.force, base.dforce_dtheta[:, k], atol=1e-9)


def test_inverted_element_is_refused(setup):
    mesh, geo, *_ = setup
    u = np.zeros((mesh.n_nodes, 3))
    u[mesh.top, 2] = -70.0  # pushes the top below the bottom
    with pytest.raises(InvertedElementError, match="det F"):
        element_state(geo, u[mesh.elements], 10.0, 350.0, 1000.0, FIBER)


def test_linear_solver_backends_agree(setup):
    from indentation_studio.forward.linear_solver import ConstrainedSymmetricSolver

    mesh, geo, pattern, u, rng = setup
    K = pattern.matrix(element_state(geo, 0.01 * u[mesh.elements], 10.0, 350.0, 1000.0, FIBER).stiffness)
    permanent = np.zeros(pattern.n_dofs, bool)
    permanent[3 * mesh.bottom[:, None] + np.arange(3)] = True
    constrained = permanent.copy()
    constrained[3 * mesh.top[:3] + 2] = True
    b = np.where(constrained, 0.0, rng.standard_normal(pattern.n_dofs))
    xs = []
    for backend in ("superlu", "pardiso"):
        lin = ConstrainedSymmetricSolver(pattern, backend, permanent=permanent)
        lin.factorize(K, constrained)
        xs.append(lin.solve(b))
    free = ~constrained
    assert np.abs((K @ xs[0])[free] - b[free]).max() < 1e-9 * np.abs(b).max()
    assert np.allclose(xs[0], xs[1], rtol=0, atol=1e-10 * np.abs(xs[0]).max())
    assert np.all(xs[0][constrained] == 0.0)
