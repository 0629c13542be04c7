"""Error budgets against a verification study's high-fidelity level with its GCI carried
(inference.budgets.study_budget), what a fit reads of them (surrogate.error_budgets), and the fit's model
and objective (forward.mesh_presets.FIT_MESH, the ``fit`` reading)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from indentation_studio.design.nodal_weights import FIT_INNER_RADII
from indentation_studio.forward.convergence.mesh_family import contact_family
from indentation_studio.forward.fe_predictor import FESolverPredictor
from indentation_studio.forward.mesh_presets import FIT_MESH, HIGH_FIDELITY_MESH
from indentation_studio.forward.predictor import CachedPredictor
from indentation_studio.forward.result import SimulationResult
from indentation_studio.forward.spec import Contact, Indenter, MeshChoice, ModelSpec, Protocol
from indentation_studio.inference.budgets.budget_merge import merge_error_budgets
from indentation_studio.inference.budgets.error_budget import compute_error_budget
from indentation_studio.inference.budgets.finest_reference import (
    finest_reference_budget,
    reference_correction,
    with_finest_reference,
)
from indentation_studio.inference.budgets.model_error import ModelError
from indentation_studio.inference.budgets.study_budget import (
    FS_ASYMPTOTIC,
    FS_OUTSIDE,
    reference_uncertainty_pct,
    study_error_budget,
)
from indentation_studio.inference.budgets.study_files import merge_verification_studies
from indentation_studio.inference.budgets.verification_study import run_verification_study
from indentation_studio.studio.cli import app
from indentation_studio.surrogate.error_budgets import (
    budget_at,
    remaining_bias,
    shipped_budget,
    shipped_budgets_folder,
)


def test_reference_uncertainty_is_roaches_gci_with_the_order_limited():
    h = [1.0, 1.5, 2.25, 3.375]
    # exact second order with one triplet's worth of agreement: Fs 1.25 |e| / (1.5^2 - 1)
    f = [100.0 + 4.0 * x**2 for x in h]
    e = abs(f[0] - f[1]) / f[0]
    assert reference_uncertainty_pct(f, h, 0) == pytest.approx(100 * FS_ASYMPTOTIC * e / 1.25)
    # a fourth-order sequence is read at order 2 (levels that agree by chance give no small GCI)
    f4 = [100.0 + 0.5 * x**4 for x in h]
    e4 = abs(f4[0] - f4[1]) / f4[0]
    assert reference_uncertainty_pct(f4, h, 0) == pytest.approx(100 * FS_ASYMPTOTIC * e4 / 1.25)
    # first order on the finest triplet, second on the next: not asymptotic, Fs = 3, p = 1
    g = [100.0, 101.0, 102.5, 104.0]  # orders log(1.5)/log(1.5) = 1, then 0
    u = reference_uncertainty_pct(g, h, 0)
    assert u == pytest.approx(100 * FS_OUTSIDE * 0.01 / 0.5)
    # oscillating: order 2, Fs 3
    osc = [100.0, 98.0, 101.0, 99.0]
    assert reference_uncertainty_pct(osc, h, 0) == pytest.approx(100 * FS_OUTSIDE * 0.02 / 1.25)
    # the second level (index 1) reads its own triplet
    assert reference_uncertainty_pct(f, h, 1) == pytest.approx(
        100 * FS_OUTSIDE * abs(f[1] - f[2]) / f[1] / 1.25
    )
    # a level that agrees with the next coarser one but not with the finer one (R = 8 mm, {3, 330}
    # kPa, c5 on levels 4 to 1: 330, 322.5, 325.2, 355.6): never less than the finer level
    # measured, its distance to it plus that level's own uncertainty
    c5 = [330.0, 322.479, 325.24, 355.595]
    hh = [0.444, 0.667, 1.0, 1.5]
    below = reference_uncertainty_pct(c5[1:], hh[1:], 0)  # without level 4
    u4 = reference_uncertainty_pct(c5, hh, 0)
    u3 = reference_uncertainty_pct(c5, hh, 1)
    assert below < 100 * (330.0 - 322.479) / 322.479 < u3  # less than level 4 measured
    assert u3 == pytest.approx((100 * (330.0 - 322.479) + u4 * 330.0) / 322.479)
    assert u3 > 100 * (330.0 - 322.479) / 322.479 + u4 > 4.0
    with pytest.raises(ValueError, match="no coarser level"):
        reference_uncertainty_pct(f, h, 3)


def _budget_file(tmp_path, rows, gci_carried=True):
    path = tmp_path / "budget.json"
    reference = {
        "gci_carried": gci_carried,
        "model": ModelSpec(mesh=MeshChoice(HIGH_FIDELITY_MESH)).to_dict(),
    }
    path.write_text(json.dumps({"rows": rows, "reference": reference}))
    return path


def test_a_budget_adds_the_reference_gci_and_interpolates_between_its_points(tmp_path):
    rows = [
        {
            "model": FIT_MESH,
            "c1_true": c1,
            "c5_true": c5,
            "c1_bias_pct": 1.0,
            "c5_bias_pct": -5.0 if c5 < 300 else 3.0,
            "c1_reference_gci_pct": 0.5,
            "c5_reference_gci_pct": 2.0 if c1 < 10 else 1.0,
        }
        for c1 in (3.0, 19.0)
        for c5 in (120.0, 540.0)
    ]
    left = remaining_bias(_budget_file(tmp_path, rows), FIT_MESH)
    # at (3, 120): 5 % below the truth is 5.263 % of the fit, plus the level's 2 % GCI
    assert left["c5_pct"] == pytest.approx(100 * (1 / 0.95 - 1) + 2.0)
    assert left["c1_pct"] == pytest.approx(1.5)
    at_corner = budget_at(left, [19.0, 540.0])
    assert at_corner["source"]["where"] == "interpolated"
    assert at_corner["c5_pct"] == pytest.approx(4.0)
    between = budget_at(left, [np.sqrt(3 * 19), np.sqrt(120 * 540)])  # the middle in log space
    corners = [100 * (1 / 0.95 - 1) + 2, 5.0, 100 * (1 / 0.95 - 1) + 1, 4.0]
    assert min(corners) < between["c5_pct"] < max(corners)
    rows[0]["c5_reference_gci_pct"] = float("nan")
    with pytest.raises(ValueError, match="reference GCI of c5"):
        remaining_bias(_budget_file(tmp_path, rows), FIT_MESH)


@pytest.fixture(scope="module")
def small_study(tmp_path_factory):
    """Levels 0 to 2 of the contact family at R = 4.77 mm, 2 steps, two points, the fit's objective."""
    out = tmp_path_factory.mktemp("study")
    spec = ModelSpec(
        protocol=Protocol(step_size=0.5, steps=2), contact=Contact(integration="surface", order=1)
    )
    study = run_verification_study(
        spec, contact_family(4.77), (0, 1, 2), points=((4.0, 300.0), (12.0, 150.0)), radii=(4.77,),
        substeps=(1,), out_dir=out,
    )  # fmt: skip
    return out, study, spec


def test_study_budget_is_the_fit_of_the_model_plus_the_levels_gci(small_study, tmp_path):
    out, study, spec = small_study
    # contact-L0 fitted, and the reference level beside it (its own rows, below): one budget
    both = study_error_budget(out, ("contact-L0", "contact-L1"), reference_level=1, fe_steps=2)
    budget = replace(both, table=both.table[both.table["model"] == "contact-L0"].reset_index(drop=True))
    assert budget.reading == "fit" and budget.reference["gci_carried"] is True
    assert budget.reference["model"]["mesh"]["preset"] == "contact-L1"
    assert budget.reference["model"]["contact"] == {
        "friction": None,
        "penalty": 1e5,
        "integration": "surface",
        "order": 1,
    }
    rows = budget.table.to_dict(orient="records")
    assert [(r["c1_true"], r["c5_true"]) for r in rows] == [(4.0, 300.0), (12.0, 150.0)]
    for case, row in zip(study.cases, rows, strict=True):
        sizes = [lv["h_mm"] for lv in case["levels"]]
        c5 = case["quantities"]["fit c5"]["values"]
        assert row["c5_reference_gci_pct"] == pytest.approx(reference_uncertainty_pct(c5, sizes, 1))
        assert row["c5_reference_gci_pct"] > 0
    # the bias is compute_error_budget's of the contact-L0 preset fitted to level 1's runs
    results = [
        SimulationResult.load(out / "R4.77" / f"c1-{c1:g}_c5-{c5:g}" / "L1-s1.npz")
        for c1, c5 in ((4, 300), (12, 150))
    ]
    direct = compute_error_budget(
        results,
        {
            "contact-L0": CachedPredictor(
                FESolverPredictor(ModelSpec(mesh=MeshChoice("contact-L0"), protocol=spec.protocol))
            )
        },
        fe_steps=2,
    )
    np.testing.assert_allclose(budget.table["c5_bias_pct"], direct.table["c5_bias_pct"], rtol=1e-9)
    # the reference level beside it: no bias, its GCI all it leaves (what a multi-fidelity
    # surrogate on it carries), the half-widths the fitted model's
    own = both.table[both.table["model"] == "contact-L1"].to_dict(orient="records")
    assert len(own) == 2 and all(r["c1_bias_pct"] == 0.0 and r["c5_bias_pct"] == 0.0 for r in own)
    for r, fitted in zip(own, rows, strict=True):
        assert (
            r["c5_reference_gci_pct"] == fitted["c5_reference_gci_pct"] and r["half_width_of"] == "contact-L0"
        )
        assert (r["c1_fit"], r["c5_fit"]) == (r["c1_true"], r["c5_true"])
    budget_file = tmp_path / "b.json"
    budget_file.write_text(json.dumps(both.to_dict()))
    left = remaining_bias(budget_file, "contact-L1")
    assert left["c5_pct"] == pytest.approx(max(r["c5_reference_gci_pct"] for r in own))
    with pytest.raises(ValueError, match="needs a fitted model beside it"):
        study_error_budget(out, ("contact-L1",), reference_level=1)
    for level in (0, 5):  # the coarsest has no coarser level; 5 is not in the study
        with pytest.raises(ValueError, match=f"level {level} and a coarser one"):
            study_error_budget(out, ("contact-L0",), reference_level=level)
    with pytest.raises(ValueError, match="contact-L presets"):
        study_error_budget(out, ("default",), reference_level=1)
    with pytest.raises(ValueError, match="--reading paper"):
        study_error_budget(out, ("contact-L0",), reference_level=1, reading="paper")


def test_the_fit_model_and_objective_are_the_studios_decision():
    assert FIT_MESH == "contact-L1" and HIGH_FIDELITY_MESH == "contact-L3" and FIT_INNER_RADII == 1.5
    fit = ModelSpec(mesh=MeshChoice(FIT_MESH))
    assert fit.contact.describe() == "stick by penalty, surface-integrated (1x1 per face)"


@pytest.mark.parametrize("radius", [4.77, 8.0])
def test_a_fit_at_each_paper_radius_finds_its_budget_and_its_model(radius):
    """The shipped budgets of the fit's model (contact-L1 against contact-L3 with its GCI, the fit's
    objective) at both paper radii: found for the fit's model at that test, interpolated at a fit's
    theta, and not for another contact, another level or a frictional model."""
    spec = ModelSpec(mesh=MeshChoice(FIT_MESH), indenter=Indenter(radius))
    left = shipped_budget(spec)
    assert left is not None and left["source"]["model"] == FIT_MESH
    assert left["source"]["reference_mesh"] == HIGH_FIDELITY_MESH and left["source"]["reference_gci_carried"]
    assert left["source"]["file"] == f"indentation_studio/error_budgets/fit-model-R{radius:g}.json"
    payload = json.loads((shipped_budgets_folder() / f"fit-model-R{radius:g}.json").read_text())
    assert payload["reading"] == "fit" and len(payload["rows"]) == 18  # contact-L1's 9, contact-L3's 9
    l1_rows = [row for row in payload["rows"] if row["model"] == FIT_MESH]
    at = budget_at(left, [12.0, 250.0])
    values = np.array([[p["c1_pct"], p["c5_pct"]] for p in left["points"]])
    assert at["source"]["where"] == "interpolated"
    assert np.all(values.min(axis=0) <= [at["c1_pct"], at["c5_pct"]]) and np.all(
        [at["c1_pct"], at["c5_pct"]] <= values.max(axis=0)
    )
    # every point carries at least level 3's own uncertainty
    for row, point in zip(l1_rows, left["points"], strict=True):
        assert (
            point["c5_pct"] >= row["c5_reference_gci_pct"] > 0
            and point["c1_pct"] >= row["c1_reference_gci_pct"] > 0
        )
    # the high fidelity (what a multi-fidelity surrogate on it carries): level 4 was run at the nine
    # points at both radii, so level 3's fit is corrected to level 4's reference by issue 57's rule,
    # its reference's width (level 4's GCI) alone, and the fit's model carries that correction as an
    # error beside it
    high = shipped_budget(ModelSpec(mesh=MeshChoice(HIGH_FIDELITY_MESH), indenter=Indenter(radius)))
    assert high is not None and high["source"]["model"] == HIGH_FIDELITY_MESH
    l3_rows = [row for row in payload["rows"] if row["model"] == HIGH_FIDELITY_MESH]
    for row, point, l1 in zip(l3_rows, high["points"], l1_rows, strict=True):
        for p in ("c1", "c5"):
            assert point[f"{p}_pct"] == pytest.approx(row[f"{p}_reference_gci_pct"])
            assert point[f"{p}_correction_pct"] == row[f"{p}_correction_pct"] != 0.0
            assert l1[f"{p}_reference_gci_pct"] == pytest.approx(
                abs(row[f"{p}_correction_pct"]) + row[f"{p}_reference_gci_pct"]
            )
    assert high["source"].get("reference_level") == 4
    assert shipped_budget(ModelSpec(mesh=MeshChoice("contact-L2"), indenter=Indenter(radius))) is None
    assert (
        shipped_budget(
            ModelSpec(
                mesh=MeshChoice(FIT_MESH), indenter=Indenter(radius), contact=Contact(integration="node")
            )
        )
        is None
    )
    assert shipped_budget(spec.with_friction(0.3)) is None


@pytest.mark.parametrize("order", [1.0, 1.5, 2.0])
def test_a_monotone_finest_triplet_corrects_a_levels_fit_to_the_converged_value(order):
    # level k answers as the converged model at theta + d_k, d_k = C h_k^p; the study's values are
    # the finest level's fits of each level's response, f_k = theta + d_k - d_0 (verification_study)
    h, theta, C = [1.0, 1.5, 2.25, 3.375], 100.0, 2.0
    d = [C * x**order for x in h]
    f = [theta + dk - d[0] for dk in d]
    for k in (1, 2):
        rc = reference_correction(f, h, k, finest_level=4)
        assert rc.reference == "extrapolated"
        assert rc.reference_value == pytest.approx(theta - d[0])
        fitted = theta - d[k]  # what level k's model fits to a converged experiment
        assert fitted * (1 + rc.correction_pct / 100) == pytest.approx(theta, rel=1e-12)
        # the width is the finest level's GCI, and holds the finest level's own distance d_0
        assert rc.width_pct == pytest.approx(reference_uncertainty_pct(f, h, 0))
        assert rc.width_pct >= 100 * d[0] / (theta - d[0])


def test_an_oscillating_finest_triplet_corrects_to_the_finest_level():
    h = [1.0, 1.5, 2.25, 3.375]
    f = [100.0, 98.0, 101.0, 99.0]  # level 3's fit of level 4's response 2 % low, then 1 % high
    rc = reference_correction(f, h, 1, finest_level=4)
    assert rc.reference == "level 4" and rc.reference_value == 100.0
    # level 3 fits theta - d_3 = 102 to what level 4 reads as 100: corrected by -2 / 102
    assert rc.correction_pct == pytest.approx(-200.0 / 102.0)
    assert rc.width_pct == pytest.approx(reference_uncertainty_pct(f, h, 0))  # Fs 3, order 2
    assert rc.width_pct == pytest.approx(100 * FS_OUTSIDE * 0.02 / 1.25)


def test_a_budget_moved_to_the_studys_finest_level_follows_the_rule(small_study):
    out, _, _ = small_study
    payload = study_error_budget(out, ("contact-L0", "contact-L1"), reference_level=1, fe_steps=2).to_dict()
    loaded = json.loads((out / "study.json").read_text())
    moved = with_finest_reference(payload, loaded, {"contact-L1": 1, "contact-L0": 0})
    assert moved["reference"]["level"] == 2 and moved["reference"]["corrected"] is True
    for case in loaded["cases"]:
        sizes = [lv["h_mm"] for lv in case["levels"]]
        rows = {r["model"]: r for r in moved["rows"] if (r["c1_true"], r["c5_true"]) == tuple(case["theta"])}
        for p in ("c1", "c5"):
            v = case["quantities"][f"fit {p}"]["values"]
            triplet = case["quantities"][f"fit {p}"]["triplets"][0]
            expected = "level 2" if triplet["oscillatory"] else "extrapolated"
            assert rows["contact-L1"][f"{p}_reference"] == expected
            f_inf = v[0] if triplet["oscillatory"] else reference_correction(v, sizes, 1).reference_value
            assert rows["contact-L1"][f"{p}_correction_pct"] == pytest.approx(
                100 * (v[1] - f_inf) / (v[0] - v[1] + f_inf)
            )
            assert rows["contact-L1"][f"{p}_bias_pct"] == 0.0
            # the coarser model keeps its bias and carries level 1's correction as an error
            width = rows["contact-L1"][f"{p}_reference_gci_pct"]
            assert rows["contact-L0"][f"{p}_reference_gci_pct"] == pytest.approx(
                abs(rows["contact-L1"][f"{p}_correction_pct"]) + width
            )
            assert rows["contact-L0"][f"{p}_bias_pct"] != 0.0


def test_a_study_made_a_point_at_a_time_merges_into_the_whole_studys_budget(small_study, tmp_path):
    out, _, _ = small_study
    budget_file = tmp_path / "budget.json"
    budget = study_error_budget(out, ("contact-L0", "contact-L1"), reference_level=1, fe_steps=2)
    budget_file.write_text(json.dumps(budget.to_dict()))
    whole = json.loads((out / "study.json").read_text())
    parts = []
    for k, case in enumerate(whole["cases"]):  # each point as its own study, as on two machines
        part = dict(whole) | {"cases": [case], "wall_s": 10.0 + k}
        part["inputs"] = dict(whole["inputs"]) | {"points": [list(case["theta"])]}
        parts.append(tmp_path / f"study-{k}.json")
        parts[-1].write_text(json.dumps(part))
    merged = merge_verification_studies(parts)
    assert merged["cases"] == whole["cases"] and merged["wall_s"] == 21.0
    assert merged["inputs"] == whole["inputs"] and merged["merged_from"] == [str(p) for p in parts]
    from_parts = finest_reference_budget(budget_file, parts)
    from_whole = finest_reference_budget(budget_file, out / "study.json")
    assert from_parts["rows"] == from_whole["rows"]
    assert from_parts["reference"]["finest_study"] == f"{parts[0]}, {parts[1]}"
    # the same point twice, or studies of other levels, are named, not merged
    with pytest.raises(ValueError, match=r"R = 4.77 mm at \(4.0, 300.0\) is also in"):
        merge_verification_studies([parts[0], parts[0]])
    other = tmp_path / "other.json"
    other.write_text(json.dumps(json.loads(parts[1].read_text()) | {"levels": [1, 0]}))
    with pytest.raises(ValueError, match=r"other\.json: its levels differs"):
        merge_verification_studies([parts[0], other])
    other.write_text(
        json.dumps(json.loads(parts[1].read_text()) | {"inputs": whole["inputs"] | {"reading": "paper"}})
    )
    with pytest.raises(ValueError, match="its input 'reading' differs"):
        merge_verification_studies([parts[0], other])


def test_a_corrected_budget_moves_the_fit_and_never_narrows_outside_its_points(tmp_path):
    rows = [
        {
            "model": FIT_MESH,
            "c1_true": c1,
            "c5_true": c5,
            "c1_bias_pct": 0.0,
            "c5_bias_pct": 0.0,
            "c1_correction_pct": 2.0,
            "c5_correction_pct": -1.0 if c1 < 10 else -3.0,
            "c1_reference_gci_pct": 1.0,
            "c5_reference_gci_pct": 2.0,
        }
        for c1 in (3.0, 19.0)
        for c5 in (120.0, 540.0)
    ]
    path = tmp_path / "budget.json"
    path.write_text(
        json.dumps({"reference": {"gci_carried": True, "corrected": True, "level": 4}, "rows": rows})
    )
    left = remaining_bias(path, FIT_MESH)
    # held everywhere (no point read), a correction counts as an error again
    assert left["c5_pct"] == pytest.approx(5.0) and left["c1_pct"] == pytest.approx(3.0)
    mid = budget_at(left, [np.sqrt(3 * 19), 250.0])
    assert mid["source"]["where"] == "interpolated"
    assert mid["c5_pct"] == pytest.approx(2.0) and -3.0 < mid["c5_correction_pct"] < -1.0
    assert mid["c1_correction_pct"] == pytest.approx(2.0)
    # outside the points: the nearest point's correction, its width plus the nearest ones' spread
    soft = budget_at(left, [1.0, 600.0])
    assert soft["source"]["where"] == "outside" and soft["source"]["verified"] is False
    assert soft["c5_correction_pct"] == pytest.approx(-1.0)
    assert soft["c5_pct"] == pytest.approx(2.0 + 2.0) and soft["c5_pct"] >= mid["c5_pct"]
    error = ModelError(
        np.zeros(2),
        np.array([soft["c1_pct"], soft["c5_pct"]]),
        np.zeros((2, 2)),
        correction_pct=np.array([2.0, -1.0]),
    )
    assert error.corrected(np.array([10.0, 300.0, 0.5])) == pytest.approx([10.2, 297.0, 0.5])


def test_a_budget_map_reads_the_budget_as_a_fit_does(tmp_path):
    from indentation_studio.surrogate.error_budgets import budget_map

    rows = [
        {"model": FIT_MESH, "c1_true": c1, "c5_true": c5, "c1_bias_pct": 0.0, "c5_bias_pct": 0.0,
         "c1_reference_gci_pct": 1.0, "c5_reference_gci_pct": 2.0 if c1 < 10 else 4.0}
        for c1 in (3.0, 19.0) for c5 in (120.0, 540.0)
    ]  # fmt: skip
    path = tmp_path / "budget.json"
    path.write_text(json.dumps({"reference": {"gci_carried": True}, "rows": rows}))
    left = remaining_bias(path, FIT_MESH)
    noise = {"c1": [0.2] * 4, "c5": [1.5] * 4}
    m = budget_map(left, [1.0, 3.0, 19.0], [120.0, 540.0], noise_pct=noise)
    assert m["c5_pct"].shape == (2, 3) and m["points"].shape == (4, 2)
    np.testing.assert_allclose(m["c5_pct"][:, 1:], [[2.0, 4.0], [2.0, 4.0]])  # at the points: theirs
    np.testing.assert_allclose(m["total_c5_pct"][:, 1:], np.hypot([[2.0, 4.0], [2.0, 4.0]], 1.5))
    assert m["verified"][:, 1:].all() and not m["verified"][:, 0].any()  # c1 = 1 kPa: outside
    assert np.all(m["c5_pct"][:, 0] >= 2.0)  # never narrower than at the nearest point


def _split_budget(tmp_path, source):
    """The shipped R = 4.77 mm budget cut in two: the points with c1 = 19 kPa, and the rest."""
    payload = json.loads(source.read_text())
    corner = [r for r in payload["rows"] if r["c1_true"] == 19.0]
    rest = [r for r in payload["rows"] if r["c1_true"] != 19.0]
    a, b = tmp_path / "rest.json", tmp_path / "c1-19.json"
    a.write_text(json.dumps(payload | {"rows": rest}))
    b.write_text(json.dumps(payload | {"rows": corner}))
    return payload, a, b


def test_budgets_made_at_different_points_merge_into_the_whole(tmp_path):
    source = shipped_budgets_folder() / "fit-model-R4.77.json"
    payload, a, b = _split_budget(tmp_path, source)
    merged = merge_error_budgets([a, b])
    assert merged["reference"]["points"] == 9 and len(merged["rows"]) == len(payload["rows"])
    assert merged["summary"] == payload["summary"]  # the summary made again over the rows
    out = tmp_path / "merged.json"
    out.write_text(json.dumps(merged))
    whole, again = remaining_bias(source, "contact-L3"), remaining_bias(out, "contact-L3")
    again["source"] = whole["source"] = {k: whole["source"][k] for k in ("reference_gci_carried",)}
    for theta in ([5.0, 200.0], [15.0, 450.0], [1.5, 560.0]):  # inside the hull, and outside it
        x, y = budget_at(whole, theta), budget_at(again, theta)
        for key in ("c1_pct", "c5_pct", "c1_correction_pct", "c5_correction_pct"):
            assert x[key] == pytest.approx(y[key], rel=1e-12)
    # the half without c1 = 19 has its hull end at c1 = 11: there a fit at 15 kPa is outside
    alone = remaining_bias(a, "contact-L3")
    assert budget_at(alone, [15.0, 450.0])["source"]["where"] == "outside"


def test_budgets_of_other_settings_or_the_same_point_twice_do_not_merge(tmp_path):
    _, a, b = _split_budget(tmp_path, shipped_budgets_folder() / "fit-model-R4.77.json")
    with pytest.raises(ValueError, match="the same model at the same point"):
        merge_error_budgets([a, a])
    other = tmp_path / "weights.json"
    other.write_text(json.dumps(json.loads(b.read_text()) | {"weights": [0.5, 0.3, 0.2, 0.0]}))
    with pytest.raises(ValueError, match="weights"):
        merge_error_budgets([a, other])
    radius = json.loads(b.read_text())
    radius["reference"]["model"]["indenter"]["radius"] = 8.0
    (tmp_path / "r8.json").write_text(json.dumps(radius))
    with pytest.raises(ValueError, match="another test"):
        merge_error_budgets([a, tmp_path / "r8.json"])
    with pytest.raises(ValueError, match="two files or more"):
        merge_error_budgets([a])


def test_the_merge_command_writes_the_whole(tmp_path):
    _, a, b = _split_budget(tmp_path, shipped_budgets_folder() / "fit-model-R4.77.json")
    out = tmp_path / ("a-folder-whose-name-is-long-" * 3) / "m.json"  # the line is not broken
    out.parent.mkdir()
    r = CliRunner().invoke(
        app, ["design", "merge-budgets", "--budget", str(a), "--budget", str(b), "--out", str(out)]
    )
    assert r.exit_code == 0, r.output
    assert "9 points" in r.output and json.loads(out.read_text())["merged_from"] == [str(a), str(b)]
    bad = CliRunner().invoke(
        app, ["design", "merge-budgets", "--budget", str(a), "--budget", str(a), "--out", str(out)]
    )
    assert bad.exit_code != 0 and "the same model at the same point" in bad.output
