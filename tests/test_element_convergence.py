"""The element's order of convergence, fitted on a manufactured solution (scikit-fem's style):
the hex8 three-field element of :mod:`forward.hex8_mean_dilatation` in its linear-elastic limit
(its exact tangent at zero displacement, c5 = 0: shear modulus 2 c1, bulk modulus kappa, the
volumetric term at each element's mean dilatation) solves the unit cube clamped on every face
under the body force of a known smooth displacement field. On four uniform meshes the L2 error
of the displacement and the H1 (energy) error of its gradient fall as h^2 and h^1, the orders of
the trilinear hex8; each fitted rate must lie within RATE_TOL of its order.

Measured (n = 4, 8, 12, 16 elements a side): L2 rate 2.026, H1 rate 1.014 (printed with -s), in
about 3 s. With the manufactured field's shear modulus 10 % off the element's, the rates fall to
0.07 and 0.77: the test fails."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from indentation_studio.forward.block_mesh import grid_block
from indentation_studio.forward.hex8_mean_dilatation import (
    HEX8_NODES,
    ReferenceGeometry,
    element_state,
    shape_gradients,
)
from indentation_studio.forward.sparse_assembly import SparsePattern

#: The linear-elastic limit's moduli (kPa): shear 2 c1, bulk kappa (c5 = 0: no fiber term).
C1, KAPPA = 1.0, 5.0
MU = 2.0 * C1
LAMBDA = KAPPA - 2.0 * MU / 3.0
#: The amplitude of the manufactured field along x, y, z (mm): not divergence-free, so that the
#: volumetric term is tested as well as the shear.
AMPLITUDE = np.array([1.0, 0.5, -0.75]) * 1e-2
#: Elements a side of the four meshes.
SIDES = (4, 8, 12, 16)
#: How far a fitted rate may lie from its order (scikit-fem's convergence tests allow about 0.1).
RATE_TOL = 0.1

_G3 = np.sqrt(0.6)
#: The 3x3x3 Gauss rule (exact for the error integrals of these smooth fields to well below the
#: errors measured): points (27, 3), weights (27,).
_P1, _W1 = np.array([-_G3, 0.0, _G3]), np.array([5.0, 8.0, 5.0]) / 9.0
GAUSS27 = np.stack(np.meshgrid(_P1, _P1, _P1, indexing="ij"), axis=-1).reshape(-1, 3)
WEIGHTS27 = np.einsum("i,j,k->ijk", _W1, _W1, _W1).ravel()


def exact(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The manufactured field u = A sin(pi x) sin(pi y) sin(pi z) at points ``x`` (..., 3): the
    displacement (..., 3), its gradient du_i/dx_j (..., 3, 3) and the body force that holds it in
    equilibrium, f = -div sigma = -(mu lap u + (lambda + mu) grad div u) (..., 3)."""
    s, c = np.sin(np.pi * x), np.cos(np.pi * x)
    phi = s[..., 0] * s[..., 1] * s[..., 2]
    dphi = np.pi * np.stack(
        [
            c[..., 0] * s[..., 1] * s[..., 2],
            s[..., 0] * c[..., 1] * s[..., 2],
            s[..., 0] * s[..., 1] * c[..., 2],
        ],
        axis=-1,
    )
    hess = np.empty((*x.shape[:-1], 3, 3))
    for i in range(3):
        for j in range(3):
            if i == j:
                hess[..., i, j] = -(np.pi**2) * phi
            else:
                k = 3 - i - j
                hess[..., i, j] = np.pi**2 * c[..., i] * c[..., j] * s[..., k]
    u = AMPLITUDE * phi[..., None]
    grad = AMPLITUDE[:, None] * dphi[..., None, :]
    force = 3.0 * np.pi**2 * MU * u - (LAMBDA + MU) * hess @ AMPLITUDE
    return u, grad, force


def _shape_values(xi: np.ndarray) -> np.ndarray:
    """N_a of the trilinear hex8 at natural points ``xi`` (g, 3) -> (g, 8)."""
    return np.prod(1.0 + HEX8_NODES[None, :, :] * xi[:, None, :], axis=-1) / 8.0


def errors_on_cube(n: int) -> tuple[float, float, float]:
    """Solve the clamped unit cube with ``n`` elements a side; (h, L2 error, H1 seminorm error)."""
    grid = np.linspace(0.0, 1.0, n + 1)
    mesh = grid_block(grid, grid, grid, f"unit cube {n}^3")
    geo = ReferenceGeometry.of(mesh)
    edofs = (3 * mesh.elements[:, :, None] + np.arange(3)).reshape(-1, 24)
    pattern = SparsePattern(edofs, 3 * mesh.n_nodes)
    zero = np.zeros((len(mesh.elements), 8, 3))
    state = element_state(geo, zero, C1, 0.0, KAPPA, np.array([0.0, 1.0, 0.0]))
    K = pattern.matrix(state.stiffness)
    # the element's geometry at the 27 points: positions, dN/dX and w detJ
    X = mesh.nodes[mesh.elements]  # (ne, 8, 3)
    N = _shape_values(GAUSS27)  # (g, 8)
    J0 = np.einsum("eaI,gaj->egIj", X, shape_gradients(GAUSS27))
    dNdX = np.einsum("gaj,egjI->egaI", shape_gradients(GAUSS27), np.linalg.inv(J0))
    wdet = np.linalg.det(J0) * WEIGHTS27
    x = np.einsum("ga,eaI->egI", N, X)
    u_x, grad_x, f_x = exact(x)
    load = pattern.vector(np.einsum("eg,ga,egi->eai", wdet, N, f_x).reshape(-1, 24))
    on_face = np.any((mesh.nodes < 1e-12) | (mesh.nodes > 1.0 - 1e-12), axis=1)
    free = np.flatnonzero(~np.repeat(on_face, 3))
    u = np.zeros(3 * mesh.n_nodes)
    u[free] = spla.spsolve(K[free][:, free].tocsc(), load[free])
    ue = u.reshape(-1, 3)[mesh.elements]  # (ne, 8, 3)
    err = np.einsum("ga,eai->egi", N, ue) - u_x
    err_grad = np.einsum("egaJ,eai->egiJ", dNdX, ue) - grad_x
    l2 = np.sqrt(np.einsum("eg,egi->", wdet, err**2))
    h1 = np.sqrt(np.einsum("eg,egiJ->", wdet, err_grad**2))
    return 1.0 / n, float(l2), float(h1)


@pytest.fixture(scope="module")
def rates():
    table = np.array([errors_on_cube(n) for n in SIDES])
    h, l2, h1 = table.T
    l2_rate = np.polyfit(np.log(h), np.log(l2), 1)[0]
    h1_rate = np.polyfit(np.log(h), np.log(h1), 1)[0]
    print(f"\nh {h.round(4).tolist()}\nL2 {l2.tolist()}\nH1 {h1.tolist()}")
    print(f"fitted rates: L2 {l2_rate:.3f}, H1 {h1_rate:.3f}")
    return table, l2_rate, h1_rate


def test_l2_error_falls_as_h_squared(rates):
    table, l2_rate, _ = rates
    assert np.all(np.diff(table[:, 1]) < 0)  # every refinement closer
    assert abs(l2_rate - 2.0) < RATE_TOL, f"L2 rate {l2_rate:.3f}, trilinear hex8: 2"


def test_h1_error_falls_as_h(rates):
    table, _, h1_rate = rates
    assert np.all(np.diff(table[:, 2]) < 0)
    assert abs(h1_rate - 1.0) < RATE_TOL, f"H1 rate {h1_rate:.3f}, trilinear hex8: 1"
