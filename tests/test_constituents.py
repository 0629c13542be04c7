"""Baseline theta* from the constituents: eq. 11 with the paper's S3 values, and the S3 / eq. 10 fits
recovering known parameters from noisy synthetic stress-stretch data."""

import numpy as np
import pytest

from indentation_studio.design.constituents import (
    fit_equibiaxial,
    fit_mooney_rivlin_uniaxial,
    fit_neo_hookean_uniaxial,
    rule_of_mixtures,
)
from indentation_studio.forward.material import equibiaxial_stress_incompressible


def test_eq11_gives_about_10_and_350_from_the_paper_constituents():
    # paper 3.1: mu_m = 19.4 kPa, fibers {c1_f, c2_f} = {-1227, 5945} kPa, FVF = 7 %
    c1, c5 = rule_of_mixtures(19.4, -1227.0, 5945.0, 0.07)
    assert c1 == pytest.approx(9.7)
    assert c5 == pytest.approx(0.07 * 4718.0 + 0.93 * 9.7)  # 339.3 kPa
    assert c1 == pytest.approx(10.0, rel=0.05) and c5 == pytest.approx(350.0, rel=0.05)


@pytest.mark.parametrize("args", [(-1.0, 1.0, 1.0, 0.1), (1.0, 1.0, 1.0, 1.5), (1.0, -5.0, 1.0, 0.1)])
def test_eq11_refuses_impossible_constituents(args):
    with pytest.raises(ValueError):
        rule_of_mixtures(*args)


def test_uniaxial_fits_recover_known_constants():
    rng = np.random.default_rng(3)
    lam = np.linspace(1.05, 2.0, 30)
    mu = 19.4
    s = mu * (lam**2 - 1 / lam)
    fit = fit_neo_hookean_uniaxial(lam, s * (1 + 0.01 * rng.standard_normal(lam.size)))
    assert fit.values["mu"] == pytest.approx(mu, rel=0.01)
    assert 0 < fit.std_errors["mu"] < 0.2
    nominal = fit_neo_hookean_uniaxial(lam, s / lam, nominal=True)  # force over reference area
    assert nominal.values["mu"] == pytest.approx(mu, rel=1e-9)
    c1, c2 = -1227.0, 5945.0
    s = 2 * (c1 + c2 / lam) * (lam**2 - 1 / lam)
    fit = fit_mooney_rivlin_uniaxial(lam, s)
    assert (fit.values["c1"], fit.values["c2"]) == pytest.approx((c1, c2), rel=1e-6)


def test_equibiaxial_fit_recovers_c1_c5_from_eq10():
    rng = np.random.default_rng(5)
    lam = np.linspace(1.02, 1.4, 25)
    s11, s22 = equibiaxial_stress_incompressible(lam, 11.61, 273.0)
    noisy = [s * (1 + 0.02 * rng.standard_normal(lam.size)) for s in (s11, s22)]
    fit = fit_equibiaxial(lam, *noisy)
    assert fit.values["c1"] == pytest.approx(11.61, rel=0.03)
    assert fit.values["c5"] == pytest.approx(273.0, rel=0.05)
    assert fit.n_points == 50


def test_fits_name_bad_data():
    with pytest.raises(ValueError, match="NaN"):
        fit_neo_hookean_uniaxial([1.1, 1.2, np.nan], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="positive"):
        fit_neo_hookean_uniaxial([1.1, -1.2], [1.0, 2.0])
    with pytest.raises(ValueError, match="same number"):
        fit_equibiaxial([1.1, 1.2], [1.0, 2.0], [1.0])


def test_design_baseline_cli_eq11_and_equibiaxial_csv(tmp_path):
    import json

    import pandas as pd
    from typer.testing import CliRunner

    from indentation_studio.studio.cli import app

    lam = np.linspace(1.02, 1.3, 12)
    s11, s22 = equibiaxial_stress_incompressible(lam, 10.0, 350.0)
    pd.DataFrame({"stretch": lam, "sigma_fiber": s11, "sigma_transverse": s22}).to_csv(
        tmp_path / "eb.csv", index=False
    )
    res = CliRunner().invoke(app, ["design", "baseline", "--equibiaxial", str(tmp_path / "eb.csv"), "--json"])
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert out["c1"] == pytest.approx(9.7) and out["c5"] == pytest.approx(339.281)
    assert out["equibiaxial_fit"]["values"]["c5"] == pytest.approx(350.0, rel=1e-6)
    pd.DataFrame({"stretch": lam}).to_csv(tmp_path / "bad.csv", index=False)
    res = CliRunner().invoke(
        app, ["design", "baseline", "--equibiaxial", str(tmp_path / "bad.csv"), "--json"]
    )
    assert res.exit_code == 1 and "sigma_fiber" in json.loads(res.stdout)["error"]
