"""The numbers each notebook must print, against values computed here on their own.

Each notebook's last code cell prints one JSON line of what it computed; :func:`printed_numbers`
reads it from the executed notebook (so changing a notebook's number or parameter makes its check
fail) and ``CHECKS[stem]`` compares it with a direct simulation, the design functions called here
(with the other Hessian method), the truth of the synthetic experiment, or a closed form.

The notebooks are executed once per test run, by the documentation build (myst-nb, on small inputs,
``INDENT_STUDIO_SMALL=1``); ``tests/test_docs.py`` reads the executed notebooks from that build's
cache and applies these checks (``tests/test_notebooks.py`` checks the stored notebooks)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import indentation_studio as ins
from indentation_studio.campaign.designs import design_from_option
from indentation_studio.forward import PHANTOM

#: The figures each notebook shows inline (those it wrote as PNG files before the figures were returned).
FIGURES = {
    "01_forward_model": 2,  # force-depth, displacement maps
    "02_campaign_and_surrogates": 1,  # parity
    "03_experiment_design": 2,  # design comparison, Fig. 8
    "04_fitting_an_experiment": 1,  # corner
    "05_composite_phantom": 2,  # Fig. 14, Fig. 12/13
}


def printed_numbers(book) -> dict:
    """The JSON line the executed notebook's last code cell printed (its last line of output)."""
    last = [c for c in book.cells if c.cell_type == "code"][-1]
    text = "".join(o.get("text", "") for o in last.outputs if o.get("name") == "stdout").strip()
    assert text, "the notebook's last cell printed nothing: it must print its numbers as one JSON line"
    return json.loads(text.splitlines()[-1])


#: What the notebooks run on under INDENT_STUDIO_SMALL=1 (the test's own copy of their settings).
SMALL_SPEC = ins.ModelSpec(mesh=ins.MeshChoice("coarse"), protocol=ins.Protocol(step_size=0.5, steps=4))


def _check_forward_model(numbers: dict) -> None:
    """Notebook 01: the coarse mesh's force at every depth is that of a direct ``simulate`` of
    the same spec, and eq. 1a is ||F - F_ref|| / ||F_ref|| / steps of the printed forces."""
    direct = ins.simulate(SMALL_SPEC)
    np.testing.assert_allclose(numbers["depth_mm"], direct.depth, rtol=1e-12, err_msg="01: depths")
    force = np.array(numbers["force_mN"][numbers["mesh"]])
    np.testing.assert_allclose(
        force, direct.force, rtol=1e-6, err_msg="01: the notebook's coarse force against a direct simulate"
    )
    F, F_ref = force[1:], np.array(numbers["force_mN"]["default"])[1:]
    eq_1a = 100.0 * np.linalg.norm(F - F_ref) / np.linalg.norm(F_ref) / F.size
    assert numbers["E_f_pct"] == pytest.approx(eq_1a, rel=1e-9), "01: eq. 1a of the printed forces"
    # the default mesh within 8 % of the coarse one at every depth (measured: 4.1 % at 1 mm at most)
    np.testing.assert_allclose(F_ref, F, rtol=0.08, err_msg="01: the default mesh's force")


def _check_campaign_and_surrogates(numbers: dict) -> None:
    """Notebook 02: the held-out campaign's first point is the seeded Latin hypercube's, its
    stored force that of a direct ``simulate`` there, and both surrogates predict that force."""
    theta = design_from_option("lhs:6:1").points[0]
    np.testing.assert_allclose(numbers["test_theta"], theta, rtol=1e-12, err_msg="02: held-out point")
    direct = ins.simulate(SMALL_SPEC.with_material(c1=theta[0], c5=theta[1]))
    np.testing.assert_allclose(
        numbers["test_force_mN"], direct.force[1:], rtol=1e-6, err_msg="02: stored force against simulate"
    )
    for kind, force in numbers["surrogate_force_mN"].items():
        np.testing.assert_allclose(
            force, direct.force[1:], rtol=SURROGATE_RTOL, err_msg=f"02: the {kind} surrogate's force"
        )


#: How close the notebook's small surrogates come to the FE force at the held-out point.
SURROGATE_RTOL = 0.05  # measured: gp 1.3 %, mlp 1.1 % at the last step


#: Notebook 03's Table 1 and candidate tests: the paper's protocol on `default` at every scale.
PAPER_DESIGN_SPEC = ins.ModelSpec(mesh=ins.MeshChoice("default"), protocol=ins.Protocol(steps=28))


def _check_experiment_design(numbers: dict) -> None:
    """Notebook 03: Table 1's bounds at the paper's weights are eq. 6 (s = 0.05) of the exact
    Gauss-Newton term Hessians of the paper's protocol on `default` computed here; the rows that
    combine force and field agree with finite-difference Hessians of the FE model (the other method)
    to DESIGN_RTOL (the single-term rows are near singular: there the two methods differ by 3 to
    27 %); the bounds at theta* of the small map are those of the paper's weights on its spec."""
    exact = ins.fe_design_study(PAPER_DESIGN_SPEC, (10.0, 350.0), method="exact").term_hessians
    fd_paper = ins.fe_design_study(PAPER_DESIGN_SPEC, (10.0, 350.0), method="fd").term_hessians
    fd = ins.fe_design_study(SMALL_SPEC, (10.0, 350.0), method="fd").term_hessians
    rows = ins.compare_with_paper(fd_paper, 0.05)
    printed = numbers["table1"]
    assert [r[0] for r in printed] == [row.name for row in rows], "03: Table 1's rows"
    for (name, c1, c5), row in zip(printed, rows, strict=True):
        expected = ins.design.bounds_pct(ins.design.combine(exact, row.paper_weights), 0.05)
        np.testing.assert_allclose([c1, c5], expected, rtol=1e-6, err_msg=f"03: Table 1 row {name!r}")
        if row.paper_weights[0] > 0 and any(w > 0 for w in row.paper_weights[1:]):  # force and field
            np.testing.assert_allclose(
                [c1, c5],
                [row.c1_pct_at_paper_weights, row.c5_pct_at_paper_weights],
                rtol=DESIGN_RTOL,
                err_msg=f"03: Table 1 row {name!r}, exact against finite-difference Hessians",
            )
    at_paper = ins.design.bounds_pct(ins.design.combine(fd, ins.PAPER_WEIGHTS), 0.05)
    np.testing.assert_allclose(
        numbers["bounds_at_theta_star_pct"], at_paper, rtol=DESIGN_RTOL, err_msg="03: bounds at theta*"
    )


#: Exact Gauss-Newton against central-difference Hessians (step 0.02 of theta*): measured 0.14 % at most.
DESIGN_RTOL = 0.005


def _check_fitting_an_experiment(numbers: dict) -> None:
    """Notebook 04: the synthetic experiment's truth (12, 250) kPa lies within the fit's bounds,
    and those bounds are finite and narrower than MAX_FIT_BOUND_PCT (else holding it says little)."""
    truth = np.array([12.0, 250.0])
    np.testing.assert_array_equal(numbers["truth"], truth, err_msg="04: the synthetic experiment's truth")
    theta, half = np.array(numbers["theta"]), np.array(numbers["bounds_pct"])
    assert np.all(half < MAX_FIT_BOUND_PCT), f"04: bounds {half.tolist()} %"
    miss = 100.0 * np.abs(theta - truth) / theta
    assert np.all(miss <= half), (
        f"04: fit {theta.tolist()} misses the truth by {miss.tolist()} % > {half.tolist()} %"
    )


MAX_FIT_BOUND_PCT = 10.0  # measured: 0.45 % (c1), 2.1 % (c5)


def _check_composite_phantom(numbers: dict) -> None:
    """Notebook 05: eq. 11 in closed form for the paper's constituents (matrix mu = 19.4 kPa, fibers
    c1, c2 = -1227, 5945 kPa) at the phantom's fiber volume fraction computed here."""
    geometry = ins.ModelSpec.composite_phantom("composite-coarse").geometry
    fvf = PHANTOM.fiber_volume_fraction(2.0 * geometry.half_x, geometry.height)
    assert numbers["fiber_volume_fraction"] == pytest.approx(fvf, rel=1e-12), "05: fiber volume fraction"
    c1 = 19.4 / 2.0  # eq. 11a
    c5 = fvf * (-1227.0 + 5945.0) + (1.0 - fvf) * c1  # eq. 11b
    np.testing.assert_allclose(numbers["eq11"], [c1, c5], rtol=1e-9, err_msg="05: eq. 11")


CHECKS = {
    "01_forward_model": _check_forward_model,
    "02_campaign_and_surrogates": _check_campaign_and_surrogates,
    "03_experiment_design": _check_experiment_design,
    "04_fitting_an_experiment": _check_fitting_an_experiment,
    "05_composite_phantom": _check_composite_phantom,
}
