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
#: c5, kappa and the fiber of the homogeneous tests (c1 = 10 kPa by position)
MODULI = {"c5": 350.0, "kappa": 1000.0, "fiber": FIBER}


@pytest.fixture(scope="module")
def setup():
    mesh = preset_mesh("coarse")
    geo = ReferenceGeometry.of(mesh)
    edofs = (3 * mesh.elements[:, :, None] + np.arange(3)).reshape(-1, 24)
    rng = np.random.default_rng(3)
    u = 0.05 * rng.standard_normal((mesh.n_nodes, 3))
    return mesh, geo, SparsePattern(edofs, 3 * mesh.n_nodes), u, rng


def _assert_force_and_tangent_are_derivatives(state_of, ue, elements, pattern, d, *, h, rel):
    """The assembled forces of ``state_of(ue)`` are the energy's derivative along the nodal
    direction ``d`` and its tangent the forces', to ``rel`` by central differences of step ``h``;
    the tangent is symmetric."""
    s, sp, sm = state_of(ue), state_of(ue + h * d[elements]), state_of(ue - h * d[elements])
    f, K = pattern.vector(s.force), pattern.matrix(s.stiffness)
    assert (sp.energy - sm.energy) / (2 * h) == pytest.approx(f @ d.ravel(), rel=rel)
    df = (pattern.vector(sp.force) - pattern.vector(sm.force)) / (2 * h)
    assert np.abs(df - K @ d.ravel()).max() < rel * np.abs(df).max()
    assert abs(K - K.T).max() < 1e-12 * abs(K).max()


def test_reference_volume_is_the_block(setup):
    _, geo, *_ = setup
    assert geo.volume.sum() == pytest.approx(50 * 50 * 60, rel=1e-12)


def test_forces_and_tangent_are_exact_derivatives(setup):
    mesh, geo, pattern, u, rng = setup
    _assert_force_and_tangent_are_derivatives(
        lambda ue: element_state(geo, ue, 10.0, 350.0, 1000.0, FIBER),
        u[mesh.elements],
        mesh.elements,
        pattern,
        rng.standard_normal(u.shape),
        h=1e-6,
        rel=1e-7,
    )


def test_compiled_kernel_equals_numpy_reference(setup):
    mesh, geo, _, u, _ = setup
    a = element_state(geo, u[mesh.elements], 10.0, **MODULI, tangent=True, parameter_derivatives=True)
    b = element_state_numpy(geo, u[mesh.elements], 10.0, **MODULI, tangent=True, parameter_derivatives=True)
    assert a.energy == pytest.approx(b.energy, rel=1e-12)
    for x, y in (
        (a.force, b.force),
        (a.stiffness, b.stiffness),
        (a.dforce_dtheta, b.dforce_dtheta),
    ):
        assert np.abs(x - y).max() < 1e-12 * np.abs(y).max()


def test_parameter_derivative_of_forces(setup):
    mesh, geo, _, u, _ = setup
    base = element_state(geo, u[mesh.elements], 10.0, **MODULI, tangent=False, parameter_derivatives=True)
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


def test_per_element_mooney_rivlin_kernel_equals_numpy_and_is_exact(setup):
    """Per-element moduli with the Mooney-Rivlin c2 term (a composite, 2.4.2): the compiled kernel
    equals the numpy reference, forces are the energy's gradient, the tangent the forces'."""
    mesh, geo, pattern, u, rng = setup
    ne = mesh.n_elements
    fiber = rng.random(ne) < 0.3
    c1 = np.where(fiber, -1227.0, 9.7)
    c2 = np.where(fiber, 5945.0, 0.0)
    c5 = np.where(fiber, 0.0, 350.0)
    kappa = np.where(fiber, 9.436e5, 1.94e4)
    ue = 0.02 * u[mesh.elements]
    a = element_state(
        geo, ue, c1, c5=c5, kappa=kappa, fiber=FIBER, tangent=True, parameter_derivatives=True, c2=c2
    )
    b = element_state_numpy(
        geo, ue, c1, c5=c5, kappa=kappa, fiber=FIBER, tangent=True, parameter_derivatives=True, c2=c2
    )
    # the fibers' energy c1 (I1~ - 3) + c2 (I2~ - 3) cancels ~1e4 kPa moduli: round-off of the sum
    scale = np.dot(np.abs(c1) + np.abs(c2), geo.volume) * 3.0
    assert abs(a.energy - b.energy) < 1e-13 * scale
    for x, y in ((a.force, b.force), (a.stiffness, b.stiffness), (a.dforce_dtheta, b.dforce_dtheta)):
        assert np.abs(x - y).max() < 1e-12 * np.abs(y).max()
    _assert_force_and_tangent_are_derivatives(
        lambda ue: element_state(geo, ue, c1, c5, kappa, FIBER, c2=c2),
        ue,
        mesh.elements,
        pattern,
        rng.standard_normal(u.shape),
        h=1e-7,
        rel=1e-6,
    )


def test_scalar_moduli_equal_per_element_arrays_bit_for_bit(setup):
    """The homogeneous model (scalars, c2 = 0) and the same moduli given per element agree to the last bit."""
    mesh, geo, _, u, _ = setup
    ne = mesh.n_elements
    a = element_state(geo, u[mesh.elements], 10.0, **MODULI, tangent=True, parameter_derivatives=True)
    b = element_state(
        geo,
        u[mesh.elements],
        np.full(ne, 10.0),
        c5=np.full(ne, 350.0),
        kappa=np.full(ne, 1000.0),
        fiber=FIBER,
        tangent=True,
        parameter_derivatives=True,
        c2=np.zeros(ne),
    )
    assert a.energy == b.energy
    assert np.array_equal(a.force, b.force) and np.array_equal(a.stiffness, b.stiffness)


@pytest.mark.parametrize(("name", "value"), [("c1", np.nan), ("kappa", [1.0, 2.0])])
def test_bad_moduli_are_refused_by_name(setup, name, value):
    mesh, geo, _, u, _ = setup
    args = {"c1": 10.0, "c5": 350.0, "kappa": 1000.0}
    args[name] = value
    with pytest.raises(ValueError, match=name):
        element_state(geo, u[mesh.elements], args["c1"], args["c5"], args["kappa"], FIBER)


def test_mean_fiber_stretch_kernel_equals_numpy_and_is_exact(setup):
    """The fiber term at each element's mean I4~ (fiber_mean): the compiled kernel equals the
    numpy closed form, forces and tangent are the energy's derivatives, d force / d c5 its own."""
    mesh, geo, pattern, u, rng = setup
    ue = u[mesh.elements]
    kw = dict(c5=350.0, kappa=1000.0, fiber=FIBER, tangent=True, parameter_derivatives=True, fiber_mean=True)
    a, b = element_state(geo, ue, 10.0, **kw), element_state_numpy(geo, ue, 10.0, **kw)
    plain = element_state(geo, ue, 10.0, **{**kw, "fiber_mean": False})
    assert a.energy == pytest.approx(b.energy, rel=1e-12)
    assert abs(a.energy - plain.energy) > 1e-6 * plain.energy  # the mean is not the Gauss points' sum
    for x, y in ((a.force, b.force), (a.stiffness, b.stiffness), (a.dforce_dtheta, b.dforce_dtheta)):
        assert np.abs(x - y).max() < 1e-12 * np.abs(y).max()
    _assert_force_and_tangent_are_derivatives(
        lambda v: element_state(geo, v, 10.0, c5=350.0, kappa=1000.0, fiber=FIBER, fiber_mean=True),
        ue,
        mesh.elements,
        pattern,
        rng.standard_normal(u.shape),
        h=1e-6,
        rel=1e-6,
    )
    up = element_state(geo, ue, 10.0, c5=351.0, kappa=1000.0, fiber=FIBER, tangent=False, fiber_mean=True)
    assert np.allclose(up.force - a.force, a.dforce_dtheta[:, 1], atol=1e-9)


def test_mean_fiber_stretch_equals_gauss_points_under_a_homogeneous_stretch(setup):
    """Where every Gauss point has the same I4~ (a homogeneous deformation), the element's mean
    is that value: both evaluations give the same energy and forces."""
    mesh, geo, *_ = setup
    F = np.array([[1.0, 0.02, 0.0], [0.0, 1.12, 0.0], [0.0, 0.0, 1.0 / 1.12]])
    ue = (mesh.nodes @ (F - np.eye(3)).T)[mesh.elements]
    kw = dict(c5=350.0, kappa=1000.0, fiber=FIBER, tangent=False)
    a = element_state(geo, ue, 10.0, **kw, fiber_mean=True)
    b = element_state(geo, ue, 10.0, **kw)
    assert b.energy > 0 and a.energy == pytest.approx(b.energy, rel=1e-12)
    assert np.abs(a.force - b.force).max() < 1e-10 * np.abs(b.force).max()


@pytest.mark.parametrize("fiber_mean", [False, True])
def test_the_kernel_marks_the_gauss_points_whose_fibers_are_taut(setup, fiber_mean):
    """``fiber_taut`` is eq. 3's kink: the isochoric fiber stretch sqrt(J^-2/3 I4) at least 1.
    A homogeneous isochoric stretch lam along y (the fiber): every point taut for lam = 1.05,
    none for 0.95; at the random state, each Gauss point as its own F says."""
    mesh, geo, _, u, _ = setup
    y = np.array([0.0, 1.0, 0.0])
    for lam, taut in ((1.05, True), (0.95, False)):
        F = np.diag([lam**-0.5, lam, lam**-0.5])
        ue = (mesh.nodes @ (F - np.eye(3)).T)[mesh.elements]
        st = element_state(geo, ue, 10.0, 350.0, 1000.0, y, fiber_mean=fiber_mean)
        assert st.fiber_taut.shape == (len(mesh.elements), 8) and np.all(st.fiber_taut == taut)
    if fiber_mean:
        return
    ue = u[mesh.elements]
    Fg = np.eye(3) + np.einsum("eai,egaj->egij", ue, geo.dNdX)
    stretch2 = np.linalg.det(Fg) ** (-2.0 / 3.0) * np.sum((Fg @ FIBER) ** 2, axis=-1)
    st = element_state(geo, ue, 10.0, 350.0, 1000.0, FIBER)
    assert 0 < st.fiber_taut.sum() < st.fiber_taut.size  # both sides of the kink at this state
    np.testing.assert_array_equal(st.fiber_taut, stretch2 >= 1.0)
