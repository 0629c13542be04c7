"""Block stretch without an indenter (paper 2.9): a homogeneous block reproduces eq. 10 (to the
solver's tolerance, through the exact compressible relation), the eq. 10 fit recovers (c1, c5), and
a two-material laminate stretched along its interface deforms uniformly with each material's
stress at its closed form (a patch test of per-element materials)."""

import numpy as np
import pytest
from scipy.optimize import brentq

from indentation_studio.design.constituents import fit_equibiaxial
from indentation_studio.forward.block_mesh import grid_block
from indentation_studio.forward.block_stretch import equibiaxial_stretch, stretch_block
from indentation_studio.forward.element_moduli import composite_moduli
from indentation_studio.forward.material import (
    cauchy_stress,
    equibiaxial_stress_incompressible,
    uniaxial_stress_mooney_rivlin,
)
from indentation_studio.forward.spec import CompositeMaterial, Constituent, Material, ModelSpec


def _box(nx: int = 3, ny: int = 3, nz: int = 3, **kwargs):
    return grid_block(np.linspace(0, 10, nx), np.linspace(0, 10, ny), np.linspace(0, 6, nz), "box", **kwargs)


def test_homogeneous_block_reproduces_eq10_exactly():
    material = Material(c1=10.0, c5=350.0, kappa=1.0e5)
    result = equibiaxial_stretch(ModelSpec(material=material), 1.3, 3, mesh=_box())
    for k, lam in enumerate(result.stretch_x[1:], start=1):
        # the compressible relation of eq. 3: sigma_zz = 0 at the lateral stretch l3
        l3 = brentq(
            lambda l3, lam=lam: cauchy_stress(np.diag([lam, lam, l3]), material)[2, 2], 0.2, 2.0, xtol=1e-15
        )
        exact = cauchy_stress(np.diag([lam, lam, l3]), material)
        assert np.allclose(result.stress[k], exact, rtol=0, atol=1e-8 * np.abs(exact).max())
        assert result.mean_stretch[k, 2] == pytest.approx(l3, rel=1e-10)
        # eq. 10 (incompressible): fibers along y are sigma_yy (10a), sigma_xx is 10b
        s_fiber, s_trans = equibiaxial_stress_incompressible(lam, 10.0, 350.0)
        assert result.sigma_fiber[k] == pytest.approx(s_fiber, rel=2e-3)
        assert result.sigma_transverse[k] == pytest.approx(s_trans, rel=2e-3)


def test_eq10_fit_recovers_c1_c5_from_a_homogeneous_block():
    material = Material(c1=10.0, c5=350.0, kappa=1.0e6)
    r = equibiaxial_stretch(ModelSpec(material=material), 1.3, 6, mesh=_box(2, 2, 2))
    fit = fit_equibiaxial(r.stretch_x[1:], r.sigma_fiber[1:], r.sigma_transverse[1:])
    assert fit.values["c1"] == pytest.approx(10.0, rel=1e-3)
    assert fit.values["c5"] == pytest.approx(350.0, rel=1e-3)
    assert fit.std_errors["c1"] < 0.01 and fit.std_errors["c5"] < 0.5


def test_two_material_laminate_stretched_along_its_interface_is_a_patch_test():
    """Two nearly incompressible layers (z < 3: neo-Hookean matrix; z > 3: Mooney-Rivlin fibers'
    constants) stretched along y with the x faces and the top free: both contract alike, so the
    displacement is linear and each layer's stress is its own uniaxial closed form."""
    mesh0 = _box(3, 4, 5)
    centroid_z = mesh0.nodes[mesh0.elements, 2].mean(axis=1)
    mesh = _box(3, 4, 5, element_material=(centroid_z > 3.0).astype(int), material_names=("matrix", "fibers"))
    big = 1.0e6  # bulk-to-shear ratio: the closed forms are incompressible
    comp = CompositeMaterial(
        Constituent("matrix", 9.7, kappa=big * 19.4),
        Constituent("fibers", -1227.0, 5945.0, kappa=big * 9436.0),
    )
    moduli = composite_moduli(comp, mesh, np.array([0.0, 1.0, 0.0]))
    lam = np.array([1.1, 1.2])
    r = stretch_block(mesh, moduli, None, lam)
    u, X = r.displacement, mesh.nodes
    F = np.diag([lam[-1] ** -0.5, lam[-1], lam[-1] ** -0.5])
    assert np.abs(u - X @ (F - np.eye(3)).T).max() < 1e-6
    s_matrix = r.stress_by_set[0, -1]
    s_fiber = r.stress_by_set[1, -1]
    assert s_matrix[1, 1] == pytest.approx(uniaxial_stress_mooney_rivlin(lam[-1], 9.7, 0.0), rel=1e-5)
    assert s_fiber[1, 1] == pytest.approx(uniaxial_stress_mooney_rivlin(lam[-1], -1227.0, 5945.0), rel=1e-5)
    for s in (s_matrix, s_fiber):
        off = np.abs(s - np.diag(np.diag(s))).max()
        assert (
            off < 1e-6 * abs(s[1, 1])
            and abs(s[0, 0]) < 1e-5 * abs(s[1, 1])
            and abs(s[2, 2]) < 1e-5 * abs(s[1, 1])
        )


def test_bad_stretches_are_refused_by_name():
    with pytest.raises(ValueError, match="stretch_y"):
        stretch_block(_box(2, 2, 2), composite_moduli_or_skip(), None, [1.1, float("nan")])


def composite_moduli_or_skip():
    from indentation_studio.forward.element_moduli import ElementModuli

    return ElementModuli(10.0, 0.0, 0.0, 1000.0, np.array([0.0, 1.0, 0.0]))


def test_composite_phantom_equibiaxial_on_its_y_invariant_mesh():
    """Paper 2.9 on the phantom (2 mm cells, two across each fiber, one along y): the fibers
    carry the stress along y (their Mooney-Rivlin uniaxial stress times the fiber volume
    fraction, within 10 %), the transverse stress is stiffer than the matrix alone, the top is
    traction free. Measured on this mesh (4,292 nodes): sigma_yy = 41.79, sigma_xx = 3.072 kPa at 1.02."""
    from indentation_studio.forward.block_stretch import equibiaxial_phantom_mesh

    spec = ModelSpec.composite_phantom("composite-coarse")
    mesh = equibiaxial_phantom_mesh(spec, cell=2.0)
    assert np.unique(mesh.nodes[:, 1]).size == 2
    r = equibiaxial_stretch(spec, 1.02, 2, mesh=mesh)
    lam, fvf = 1.02, 168 * 1.6**2 / 6000.0
    fibers_alone = fvf * uniaxial_stress_mooney_rivlin(lam, -1227.0, 5945.0)
    matrix_alone = equibiaxial_stress_incompressible(lam, 9.7, 0.0)[1]
    assert r.sigma_fiber[-1] == pytest.approx(fibers_alone + (1 - fvf) * matrix_alone, rel=0.1)
    assert matrix_alone < r.sigma_transverse[-1] < 2 * matrix_alone
    assert np.abs(r.stress[:, 2, 2]).max() < 1e-6 * r.sigma_fiber[-1]
    assert (r.sigma_fiber[-1], r.sigma_transverse[-1]) == pytest.approx((41.79, 3.072), rel=1e-3)
