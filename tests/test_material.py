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


def test_mooney_rivlin_stress_and_tangent_match_finite_differences(deformations):
    """The c2 (I2~ - 3) term (the composite's fibers, 2.4.2), with a fiber term and per-point moduli."""
    from types import SimpleNamespace

    c1 = np.array([-1227.0, 9.7, 3.0, -2.0, 10.0, 0.5])
    c2 = np.array([5945.0, 0.0, 4.0, 6.0, 0.0, 1.0])
    mat = SimpleNamespace(c1=c1, c2=c2, c5=50.0, kappa=2.0e4, fiber=(0.3, 1.0, 0.2))
    _, P, A = full_response(deformations, mat)
    h = 1e-6
    for k, L in ((0, 0), (1, 2), (2, 1)):
        Fp, Fm = deformations.copy(), deformations.copy()
        Fp[:, k, L] += h
        Fm[:, k, L] -= h
        Wp, Pp, _ = full_response(Fp, mat)
        Wm, Pm, _ = full_response(Fm, mat)
        assert np.abs(P[:, k, L] - (Wp - Wm) / (2 * h)).max() < 1e-6 * np.abs(P).max()
        assert np.abs(A[..., k, L] - (Pp - Pm) / (2 * h)).max() < 1e-6 * np.abs(A).max()
    assert np.allclose(A, A.transpose(0, 3, 4, 1, 2), atol=1e-9 * np.abs(A).max())


@pytest.mark.parametrize("lam", [0.8, 1.1, 1.3, 1.6])
def test_mooney_rivlin_uniaxial_against_its_closed_form(lam):
    """sigma = 2 (lam^2 - 1/lam)(c1 + c2/lam), incompressible; the fibers' constants (S3)."""
    from indentation_studio.forward.material import uniaxial_stress_mooney_rivlin
    from indentation_studio.forward.spec import Constituent

    fibers = Constituent("fibers", -1227.0, 5945.0, kappa=1.0e6 * 9436.0)

    def s22(lt: float) -> float:
        return cauchy_stress(np.diag([lam, lt, lt]), fibers)[1, 1]

    lt = brentq(s22, 0.5 / np.sqrt(lam), 2.0 / np.sqrt(lam), xtol=1e-15, rtol=1e-15)
    sigma = cauchy_stress(np.diag([lam, lt, lt]), fibers)
    expected = uniaxial_stress_mooney_rivlin(lam, -1227.0, 5945.0)
    assert sigma[0, 0] == pytest.approx(expected, rel=1e-5)
    assert lt**2 * lam == pytest.approx(1.0, abs=1e-5)
