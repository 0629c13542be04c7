"""The fit's mu in one sentence, shared by the fit command's printout and the demo's report."""

from indentation_studio.studio.mu_wording import mu_statement


def test_mu_whose_interval_is_its_whole_range_is_not_identified():
    fr = {
        "mu": 1.58,
        "mu_interval": [0.1, 3.0],
        "mu_range": [0.1, 3.0],
        "mu_identified": False,
        "mu_statistical_pct": 40.0,
        "mu_model_pct": 1107.0,
        "mu_at_limit": None,
    }
    assert mu_statement(fr) == (
        "mu is not identified by these data: its 95 % interval (statistical +- 40 %, model +- 1.11e+03 %)"
        " is its whole range [0.1, 3] (the fit at 1.58)"
    )


def test_mu_whose_interval_reaches_an_end_is_not_identified_and_the_end_is_named():
    fr = {
        "mu": 2.7,
        "mu_interval": [1.9, 3.0],
        "mu_range": [0.1, 3.0],
        "mu_identified": False,
        "mu_reaches_range_end": {"lower": False, "upper": True},
        "mu_at_limit": "upper",
    }
    text = mu_statement(fr)
    assert text.startswith(
        "mu is not identified by these data: its 95 % interval [1.9, 3] reaches its range's end"
    )
    assert "(the fit at 2.7 (on its range's upper limit)" in text
    assert text.endswith("do not bound it at the range's upper end)")


def test_an_identified_mu_is_stated_with_its_interval_and_a_fit_without_mu_says_nothing():
    fr = {"mu": 0.52, "mu_interval": [0.45, 0.6], "mu_range": [0.1, 3.0], "mu_identified": True}
    assert mu_statement(fr) == "mu = 0.52, 95 % within [0.45, 0.6]"
    assert mu_statement(None) == "" and mu_statement({"mu": None}) == ""
