"""The demo's report as a page a person reads: tables that fit the page, missing values in words,
each section linked to the docs page that explains it."""

from __future__ import annotations

import html
import re

import pandas as pd

from indentation_studio.studio.report import fit_warnings_html, write_report


def _results() -> dict:
    row = {"name": "force only", "paper_weights": [1.0, 0.0, 0.0, 0.0], "paper_c1_pct": 22.5}
    row |= {"paper_c5_pct": 210.2, "c1_pct_at_paper_weights": 4.31, "c5_pct_at_paper_weights": 33.2}
    row |= {"weights": [1.0, 0.0, 0.0, 0.0], "c1_pct": 4.31, "c5_pct": float("nan")}
    errors = {"points": 16, "force_rms_pct": 0.36, "force_max_pct": 1.46}
    errors |= {"displacement_rms_pct": 0.033, "displacement_max_pct": 0.95}
    fit = {"theta": [11.7, 299.3], "bounds_pct": [3.24, 31.96], "statistical_pct": [0.49, 2.94], "F": 0.047}
    fit |= {"s": 0.0103, "truth": [12.0, 250.0], "bounds_include": "statistical and the mesh's budget"}
    post = {"median": [11.7, 300.0], "ci95": [[11.3, 12.1], [220.0, 412.0]], "acceptance_fraction": 0.71}
    post |= {"autocorrelation_steps": [27.7, 28.4]}
    return {
        "wall_s": 842.0,
        "table1": [row],
        "hessian_at_paper_weights": [[19.5, 2.27], [2.27, 0.469]],
        "paper_hessian": [[2.07, -0.12], [-0.12, 0.07]],
        "surrogate_test_errors": {"gp": errors},
        "fit": fit,
        "posterior": post,
        "confirmation": {"F_fe": 0.047},
    }


def test_report_tables_fit_the_page_and_say_what_is_missing(tmp_path):
    rows = [
        {"radius_mm": 4.77, "max_depth_mm": 14.0, "steps": 28, "every": 1, "fov_mm": float("nan"), "s": 0.05},
        {"radius_mm": 8.0, "max_depth_mm": 14.0, "steps": 28, "every": 1, "fov_mm": 15.0, "s": 0.05},
    ]
    pd.DataFrame([r | {"c1_pct": 2.4, "c5_pct": 15.6} for r in rows]).to_csv(
        tmp_path / "design-comparison.csv", index=False
    )
    page = write_report(tmp_path, _results(), []).read_text()
    assert "nan" not in page.lower().replace("nanosecond", "")
    assert page.count("whole top") == 1 and "<td>15</td>" in page  # the missing field of view, in words
    assert "<td>not computed</td>" in page  # a value the table has no number for
    # every table sits in a box that scrolls inside the page rather than running off its edge
    assert page.count("<table>") == page.count("<div class='table'><table>") == 3
    assert "overflow-x: auto" in page
    links = re.findall(r"href='([^']+)'", page)
    # the links lead to the built site's pages (site/, Sphinx), never to the Markdown sources
    assert any(link.endswith("site/guide/design.html") for link in links)
    assert not any(link.endswith(".md") for link in links)
    assert any("fit-and-posterior" in link for link in links)


def test_a_flagged_fit_never_says_its_bounds_hold(tmp_path):
    """The report's example section: an adequate fit says what its bounds hold; one the adequacy test
    flags says what they do not hold, and the words 'These bounds hold' appear nowhere on its page."""
    results = _results()
    adequate = {"flagged": False, "statistic": 1210.0, "dof": 1200, "p_value": 0.41, "alpha": 0.01}
    results["fit"]["adequacy"] = adequate
    page = write_report(tmp_path / "ok", results, []).read_text()
    assert (
        "These bounds hold: statistical and the mesh&#x27;s budget." in page
        and "Model inadequate" not in page
    )
    results["fit"]["adequacy"] = adequate | {
        "flagged": True,
        "statistic": 7212.0,
        "per_degree": 6.01,
        "p_value": 0.0,
    }
    page = write_report(tmp_path / "flagged", results, []).read_text()
    assert "Model inadequate" in page and "These bounds hold" not in page
    assert "These bounds do not hold the truth's distance from this fit" in page


def test_the_reports_fit_says_what_it_found_of_mu():
    """The example's paragraph states the fit's mu beside the posterior's (issue 57): not identified
    where its interval reaches the range's end, with the reason it is not claimed; identified with
    its interval; nothing without mu."""
    from indentation_studio.studio.report import fit_mu_sentence

    unmeasured = "mu's model error at the high fidelity is not measured"
    fit = {
        "friction": {
            "mu": 1.58,
            "mu_interval": [0.1004, 2.996],
            "mu_identified": False,
            "mu_model_unmeasured": unmeasured,
        }
    }
    text = fit_mu_sentence(fit)
    assert text.startswith("The fit: mu is not identified by these data: its 95 % interval [0.1, 3]")
    assert "(the fit at 1.58)" in text and f"mu not claimed: {html.escape(unmeasured)}." in text
    fit["friction"].update(mu_identified=True, mu_interval=[0.41, 0.62], mu=0.5, mu_model_unmeasured=None)
    assert fit_mu_sentence(fit) == "The fit: mu = 0.5, 95 % within [0.41, 0.62]."
    assert fit_mu_sentence({"friction": None}) == "" and fit_mu_sentence({}) == ""


def test_the_report_names_the_field_error_its_adequacy_test_held():
    """Where the test's covariance held the high fidelity's field error (issue 57), the report says
    which, flagged or not; where it did not, nothing is said of it."""
    held = {"file": "indentation_studio/error_budgets/field-error-R4.77.json", "points": 3}
    held |= {"coarse_mesh": "contact-L3", "fine_mesh": "contact-L4"}
    adequacy = {"flagged": False, "statistic": 1210.0, "dof": 1200, "p_value": 0.41, "alpha": 1e-3}
    words = "held contact-L3's field error against contact-L4 (measured at 3 points"
    assert words in fit_warnings_html({"adequacy": adequacy | {"field_error": held}})
    flagged = adequacy | {"flagged": True, "per_degree": 1.09, "p_value": 1e-12, "field_error": held}
    assert words in fit_warnings_html({"adequacy": flagged})
    assert "field error" not in fit_warnings_html({"adequacy": adequacy | {"field_error": None}})


def test_a_corrected_fit_says_from_what_and_by_how_much(tmp_path):
    """Where the error budget corrected the fit (issue 57's rule), the report gives the model's own
    fit and the correction, as the fit command prints them; an uncorrected fit says nothing of it."""
    results = _results()
    results["fit"] |= {"theta": [12.314909, 243.844429], "model_fit": [11.965410, 246.092414, 1.5]}
    results["fit"]["correction"] = {"c1_pct": 2.920913, "c5_pct": -0.913472, "reference": "level 4"}
    page = write_report(tmp_path, results, []).read_text()
    assert "Corrected from the model's fit c1 = 11.965, c5 = 246.1 kPa by +2.92 % / -0.91 %" in page
    plain = write_report(tmp_path / "plain", _results(), []).read_text()
    assert "Corrected from" not in plain
