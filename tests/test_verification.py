"""The verification study's numerics against closed forms (Roache's GCI, Celik et al. 2008), the
mesh family's systematic refinement, and the study on a small family of real FE runs."""

import numpy as np
import pytest

from indentation_studio.forward.convergence.gci import observed_order, study_quantity
from indentation_studio.forward.convergence.mesh_family import MeshFamily, graded_coordinates


def test_constant_ratio_recovers_order_extrapolation_and_gci():
    h = np.array([1.0, 1.5, 2.25])
    f = 2.0 + 0.5 * h**2  # error C h^p with p = 2
    t = observed_order(f, h)
    assert t.order == pytest.approx(2.0, abs=1e-12)
    assert t.extrapolated == pytest.approx(2.0, abs=1e-12)
    assert not t.oscillatory
    # GCI_21 = 1.25 |e21 / f1| / (r^p - 1), in %
    assert t.gci_fine_pct == pytest.approx(100 * 1.25 * abs((f[1] - f[0]) / f[0]) / (1.5**2 - 1), rel=1e-12)
    assert t.asymptotic_ratio == pytest.approx(1.0, abs=1e-12)


def test_varying_ratio_is_solved_by_fixed_point_iteration():
    h = np.array([1.0, 1.3, 2.0])
    f = 5.0 - 0.8 * h**1.5
    t = observed_order(f, h)
    assert t.order == pytest.approx(1.5, abs=1e-8)
    assert t.extrapolated == pytest.approx(5.0, abs=1e-8)


def test_oscillatory_convergence_is_flagged_and_never_asymptotic():
    h = np.array([1.0, 1.5, 2.25, 3.375])
    f = 1.0 + 0.1 * (-1.0) ** np.arange(4) * h
    q = study_quantity("oscillating", f, h)
    assert all(t.oscillatory for t in q.triplets)
    assert not q.asymptotic


def test_four_levels_in_the_asymptotic_range_and_out_of_it():
    h = 0.5 * 1.5 ** np.arange(4)
    clean = study_quantity("clean", 10.0 + 0.3 * h, h)
    assert clean.asymptotic and clean.order_spread == pytest.approx(0.0, abs=1e-9)
    assert clean.orders[0] == pytest.approx(1.0, abs=1e-9)
    assert clean.extrapolated == pytest.approx(10.0, abs=1e-9)
    assert np.allclose(clean.error_pct, 100 * 0.3 * h / 10.0, rtol=1e-9)
    # the coarsest level outside the asymptotic range (its error twice what first order says)
    f = 10.0 + 0.3 * h
    f[-1] += 0.3 * h[-1]
    mixed = study_quantity("mixed", f, h)
    assert not mixed.asymptotic and mixed.order_spread > 0.5


def test_family_refines_every_cell_by_the_same_ratio():
    fam = MeshFamily(cells_xy=8, cells_z=8, h0_xy=1.2, h0_z=1.0, ratio=1.5)
    assert fam.cells(2) == (18, 18)
    assert fam.cells(4) == (41, 41)  # 40.5 rounded half up: the ratio from level 3 is 41 / 27
    assert fam.size(3) / fam.size(4) == pytest.approx(41 / 27, rel=1e-12)
    coarse, fine = fam.mesh(0), fam.mesh(2)
    xc, xf = np.unique(coarse.nodes[:, 0]), np.unique(fine.nodes[:, 0])
    assert xc[1] == pytest.approx(1.2, rel=1e-9) and xf[-1] == 50.0

    # the same map sampled 2.25 times as densely: the cell size at any point falls by the ratio^2
    def size_at(x, at):
        return np.interp(at, 0.5 * (x[1:] + x[:-1]), np.diff(x))

    for at in (5.0, 15.0, 35.0):
        assert size_at(xc, at) / size_at(xf, at) == pytest.approx(2.25, rel=0.05)
    assert fam.size(0) / fam.size(2) == pytest.approx(2.25, rel=1e-12)
    assert fine.n_nodes == fam.node_count(2) == 19 * 19 * 19
    assert np.all(np.diff(graded_coordinates(50.0, 12, 2.0)) > 0)


def test_a_family_with_a_core_keeps_its_cells_uniform_there_and_refines_systematically():
    from indentation_studio.studio.verification_cli import parse_family

    fam = parse_family("8x8:1.2:1.5:core8")
    assert (fam.core_xy, fam.core_fraction) == (8.0, 0.5) and "core8" in fam.name
    x0, x2 = (np.unique(fam.mesh(k).nodes[:, 0]) for k in (0, 2))
    assert np.allclose(np.diff(x0)[:4], 2.0) and np.allclose(np.diff(x2)[:9], 8.0 / 9.0)
    assert x2[-1] == 50.0 and np.all(np.diff(np.diff(x2)[8:]) > 0)  # grows beyond the core
    sizes = np.diff(x2)
    assert sizes[9] / sizes[8] < 1.2  # the cell size continuous across the core's edge (C1 map)
    # systematic: at any point the cells of level 2 are the ratio^2 smaller than level 0's
    for at in (3.0, 7.0, 20.0):  # (beyond, level 0's 20 mm cells sample the map too coarsely)
        ratio = np.interp(at, 0.5 * (x0[1:] + x0[:-1]), np.diff(x0)) / np.interp(
            at, 0.5 * (x2[1:] + x2[:-1]), sizes
        )
        assert ratio == pytest.approx(2.25, rel=0.05)
    assert "core_xy" in fam.to_dict() and "core_xy" not in MeshFamily().to_dict()
    with pytest.raises(ValueError, match="coreMM"):
        parse_family("8x8:1.2:1.5:ring8")
    with pytest.raises(ValueError, match="too little to grow"):
        MeshFamily(core_xy=45.0, core_fraction=0.5).mesh(0)


#: The small study's point, radius and substeps (its family and levels: :func:`small_study`).
SMALL_STUDY = dict(points=[(10.0, 350.0)], radii=[4.77], substeps=(1,))


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    from indentation_studio.forward.spec import ModelSpec, Protocol
    from indentation_studio.inference.budgets.verification_study import run_verification_study

    family = MeshFamily(cells_xy=8, cells_z=8, h0_xy=1.6, h0_z=1.6, ratio=1.5)  # 729, 2197, 6859 nodes
    out = tmp_path_factory.mktemp("verification")
    spec = ModelSpec(protocol=Protocol(steps=4))
    study = run_verification_study(
        spec,
        family,
        [0, 1, 2],
        **SMALL_STUDY,
        out_dir=out,
        reading="paper",
    )
    return study, out, spec, family


def test_observed_orders_of_the_fe_model_on_a_small_family(small_study):
    study, *_ = small_study
    case = study.cases[0]
    assert [lv["nodes"] for lv in case["levels"]] == [6859, 2197, 729]
    q = case["quantities"]
    # measured on this family (R = 4.77, 2 mm): uz at 2R converges at p = 2.6, the fit's c5 (the
    # paper's objective) at 1.7
    assert 2.0 < q["uz(2R)"]["orders"][0] < 3.2
    assert 1.2 < q["fit c5"]["orders"][0] < 2.2
    # the finest level fits its own response exactly; the coarser ones are biased, most the coarsest
    c5 = q["fit c5"]["values"]
    assert c5[0] == pytest.approx(350.0, rel=1e-9)
    assert abs(c5[2] - 350.0) > abs(c5[1] - 350.0) > 1.0
    assert q["fit c5"]["gci_pct"][0] < q["fit c5"]["gci_pct"][1]


def test_the_study_resumes_from_its_runs(small_study):
    from indentation_studio.inference.budgets.study_files import load_verification_study
    from indentation_studio.inference.budgets.verification_study import run_verification_study

    study, out, spec, family = small_study
    said = []
    again = run_verification_study(
        spec,
        family,
        [0, 1, 2],
        **SMALL_STUDY,
        out_dir=out,
        say=said.append,
        reading="paper",
    )
    assert len(said) == 3 and all("read back" in s for s in said)
    assert (
        again.cases[0]["quantities"]["fit c1"]["values"] == study.cases[0]["quantities"]["fit c1"]["values"]
    )
    stored = load_verification_study(out / "study.json")
    assert stored["family"]["ratio"] == 1.5 and stored["inputs"]["radii"] == [4.77]
    assert stored["inputs"]["reading"] == "paper"
    # another objective only refits: the runs are read back, the forces the same, the fits not
    said.clear()
    fit = run_verification_study(
        spec,
        family,
        [0, 1, 2],
        **SMALL_STUDY,
        out_dir=out,
        say=said.append,
    )
    assert len(said) == 3 and load_verification_study(out / "study.json")["inputs"]["reading"] == "fit"
    q_fit, q_paper = fit.cases[0]["quantities"], study.cases[0]["quantities"]
    assert q_fit["force(2mm)"]["values"] == q_paper["force(2mm)"]["values"]
    assert q_fit["fit c5"]["values"][0] == pytest.approx(350.0, rel=1e-9)  # the finest fits itself
    assert q_fit["fit c5"]["values"][2] != pytest.approx(q_paper["fit c5"]["values"][2], rel=1e-3)


def test_the_command_runs_the_study_and_prints_one_json_object(small_study):
    import json

    from typer.testing import CliRunner

    from indentation_studio.studio.cli import app

    study, out, *_ = small_study
    args = ["verification-study", "--family", "8x8:1.6:1.5", "--levels", "0,1,2", "--points", "10:350"]
    args += [
        "--radii",
        "4.77",
        "--steps",
        "4",
        "--substeps",
        "1",
        "--out-dir",
        str(out),
        "--reading",
        "paper",
        "--json",
    ]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    payload = json.loads(result.stdout)
    stored = study.cases[0]["quantities"]["fit c5"]["values"]
    assert payload["cases"][0]["quantities"]["fit c5"]["values"] == pytest.approx(list(stored), rel=1e-12)
    bad = CliRunner().invoke(app, ["verification-study", "--family", "8x8:1.6", "--json"])
    assert bad.exit_code == 1 and "CXYxCZ:H0:RATIO" in json.loads(bad.stdout)["error"]


def test_a_coarser_fitting_level_spares_the_finest_its_sensitivities(small_study):
    from indentation_studio.forward.result import SimulationResult
    from indentation_studio.inference.budgets.verification_study import run_verification_study

    study, out, spec, family = small_study
    kwargs = dict(SMALL_STUDY, out_dir=out, reading="paper")
    by_middle = run_verification_study(spec, family, [0, 1, 2], fitting_level=1, **kwargs)
    c5 = by_middle.cases[0]["quantities"]["fit c5"]["values"]
    finest = study.cases[0]["quantities"]["fit c5"]["values"]
    # the finest level still fits itself; the others move to second order only (the Jacobians'
    # difference times the response's): on this coarse family biases of 11 and 32 % move by 1.6 and
    # 0.8 % of themselves (measured)
    assert c5[0] == pytest.approx(350.0, rel=1e-9)
    for k in (1, 2):
        assert abs(c5[k] - 350.0) > 10.0
        assert c5[k] - 350.0 == pytest.approx(finest[k] - 350.0, rel=0.05)
        assert c5[k] != pytest.approx(finest[k], rel=1e-6)  # another Jacobian indeed
    assert by_middle.cases[0]["fitting_level"] == 1
    assert SimulationResult.load(out / "R4.77" / "c1-10_c5-350" / "L1-s1.npz").force_sensitivity is not None
    with pytest.raises(ValueError, match="fitting level 3 is not one of"):
        run_verification_study(spec, family, [0, 1, 2], fitting_level=3, **kwargs)
