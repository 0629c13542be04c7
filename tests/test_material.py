"""Eq. 3 material: stress and tangent against finite differences; homogeneous states against the
closed forms of eq. 10 (supplement S2)."""

import numpy as np
import pytest
from scipy.optimize import brentq

from indentation_studio.forward.material import (
    cauchy_stress,
    equibiaxial_stress_incompressible,
    full_response,
    uniaxial_stress_incompressible,
)
from indentation_studio.forward.spec import Material


@pytest.fixture
def deformations() -> np.ndarray:
    rng = np.random.default_rng(7)
    F = np.eye(3) + 0.25 * rng.standard_normal((6, 3, 3))
    F[np.linalg.det(F) < 0] *= -1.0
    return F


def test_stress_and_tangent_match_finite_differences(deformations):
    mat = Material(c1=10.0, c5=350.0, kappa=1000.0, fiber=(0.3, 1.0, 0.2))
    _, P, A = full_response(deformations, mat)
    h = 1e-6
    P_fd = np.zeros_like(P)
    A_fd = np.zeros_like(A)
    for k in range(3):
        for L in range(3):
            Fp, Fm = deformations.copy(), deformations.copy()
            Fp[:, k, L] += h
            Fm[:, k, L] -= h
            Wp, Pp, _ = full_response(Fp, mat)
            Wm, Pm, _ = full_response(Fm, mat)
            P_fd[:, k, L] = (Wp - Wm) / (2 * h)
            A_fd[..., k, L] = (Pp - Pm) / (2 * h)
    assert np.abs(P - P_fd).max() < 1e-7 * np.abs(P).max()
    assert np.abs(A - A_fd).max() < 1e-7 * np.abs(A).max()
    assert np.allclose(A, A.transpose(0, 3, 4, 1, 2), atol=1e-9 * np.abs(A).max())


def test_fibers_carry_nothing_in_compression():
    mat = Material(c1=10.0, c5=350.0, fiber=(1.0, 0.0, 0.0))
    iso = Material(c1=10.0, c5=0.0, fiber=(1.0, 0.0, 0.0))
    F = np.diag([0.9, 1.0 / np.sqrt(0.9), 1.0 / np.sqrt(0.9)])
    assert np.allclose(cauchy_stress(F, mat), cauchy_stress(F, iso), atol=1e-12)


def _equibiaxial_cauchy(lam: float, mat: Material) -> np.ndarray:
    """Cauchy stress of eq. 3 under equibiaxial stretch with a traction-free third direction."""

    def s33(l3: float) -> float:
        return cauchy_stress(np.diag([lam, lam, l3]), mat)[2, 2]

    l3 = brentq(s33, 0.2 / lam**2, 5.0 / lam**2, xtol=1e-15, rtol=1e-15)
    return cauchy_stress(np.diag([lam, lam, l3]), mat)


@pytest.mark.parametrize("lam", [1.05, 1.2, 1.5])
def test_equibiaxial_tends_to_eq10_when_nearly_incompressible(lam):
    c1, c5 = 10.0, 350.0
    mat = Material(c1=c1, c5=c5, kappa=1000.0 * 1000.0, fiber=(1.0, 0.0, 0.0))
    sigma = _equibiaxial_cauchy(lam, mat)
    s11, s22 = equibiaxial_stress_incompressible(lam, c1, c5)
    assert sigma[0, 0] == pytest.approx(s11, rel=1e-3)
    assert sigma[1, 1] == pytest.approx(s22, rel=1e-3)


def test_uniaxial_closed_form_along_and_across_fibers():
    lam = np.array([1.0, 1.5, 2.0])
    assert np.allclose(uniaxial_stress_incompressible(lam, 10.0, 0.0, True), 20.0 * (lam**2 - 1 / lam))
    along = uniaxial_stress_incompressible(lam, 10.0, 350.0, True)
    across = uniaxial_stress_incompressible(lam, 10.0, 350.0, False)
    assert np.allclose(along - across, 350.0 * (lam - 1.0))
