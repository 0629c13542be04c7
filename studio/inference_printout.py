"""What ``indent-studio fit | posterior | confirm`` print (:mod:`studio.inference_cli`): the headline
numbers, the parts their bounds hold, the warnings that say when not to trust them, mu's statement,
the chain's convergence and the FE confirmation; the JSON files hold the same."""

from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.panel import Panel

from .. import inference  # lazy: only what a command ran
from .mu_wording import mu_statement
from .options import err

__all__ = ["loud_warnings", "print_confirmation", "print_fit", "print_posterior"]


def _surrogate_part(model_error: dict) -> str:
    """The surrogate's own error and the processing's among a fit's printed parts ('' when not carried)."""
    own, processing = model_error.get("surrogate_pct"), model_error.get("processing")
    text = "" if own is None else f", surrogate {own[0]:.2f} / {own[1]:.2f}"
    if processing is not None:
        pct = processing["processing_pct"]
        text += f", processing {pct[0]:.2f} / {pct[1]:.2f}"
    return text


def print_fit(result: inference.ExperimentFit, payload: dict, check_mesh: str | None) -> None:
    """Print a fit's (c1, c5) and bounds, its model error, adequacy and warnings, mu and the mesh check.

    Parameters
    ----------
    result : inference.ExperimentFit
        The fit.
    payload : dict
        What fit.json holds (``ExperimentFit.to_dict``).
    check_mesh : str or None
        The finer mesh the fit was checked on, if any.
    """
    if payload["excluded_steps"]:
        Console().print(f"steps left out of the fit: {payload['excluded_steps']}")
    final = result.fit
    Console().print(
        f"c1 = {payload['c1']:.3f} kPa +- {payload['c1_pct']:.1f} %, c5 = {payload['c5']:.1f} kPa +- "
        f"{payload['c5_pct']:.1f} %  (95 %; F = {final.F:.3g}, s = {final.s:.3g}, n = {final.n_residuals})"
    )
    correction = payload.get("correction")
    if correction is not None:
        model_fit = payload["model_fit"]
        Console().print(
            f"  corrected from the model's fit c1 = {model_fit['c1']:.3f}, c5 = {model_fit['c5']:.1f} kPa by "
            f"{correction['c1_pct']:+.2f} % / {correction['c5_pct']:+.2f} % ({correction['reference']})"
        )
    stat = payload["statistical_pct"]
    if payload["model_error"] is not None:
        m = payload["model_error"]
        Console().print(
            f"  statistical +- {stat[0]:.2f} % / {stat[1]:.2f} %; model error +- {m['model_pct'][0]:.2f} % / "
            f"{m['model_pct'][1]:.2f} % (discrepancy {m['discrepancy_pct'][0]:.2f} / {m['discrepancy_pct'][1]:.2f}, "
            f"error budget {m['error_budget_pct'][0]:.2f} / {m['error_budget_pct'][1]:.2f}"
            + _surrogate_part(m)
            + ")"
        )
    loud_warnings(payload)
    for warning in payload["warnings"]:
        err.print(f"[yellow]warning:[/yellow] {warning}")
    fr = payload["friction"]
    if "mu_pct" in fr:
        share = fr["mu_share_pct"]
        said = "  " + mu_statement(fr)
        Console().print(
            f"{said}; mu's share of the bounds "
            f"+- {share[0]:.2f} % / {share[1]:.2f} % (with mu known: +- {fr['conditional_pct'][0]:.2f} % / "
            f"{fr['conditional_pct'][1]:.2f} %)"
        )
        for side, note in fr["mu_reach_notes"].items():
            if note.startswith("taken as reached"):
                Console().print(f"  mu's {side} end {note}")
        if fr.get("mu_model_unmeasured"):
            Console().print(f"  mu not claimed: {fr['mu_model_unmeasured']}")
    Console().print(f"  bounds: {payload['bounds_include']}")
    confirmation = payload["fe_confirmation"]
    if confirmation is not None and confirmation["error"] is None:
        shift = ", ".join(
            f"{k} {v:+.2f} %"
            for k, v in zip(confirmation["parameters"], confirmation["gauss_newton_shift_pct"], strict=True)
        )
        Console().print(
            f"  FE confirmation ({confirmation['wall_s']:.1f} s): F = {confirmation['F_fe']:.4g} on the FE model "
            f"(surrogate {confirmation['F_surrogate']:.4g}); one Gauss-Newton step from it moves {shift}"
        )
    check = payload["mesh_check"]
    if check is not None:
        t, u = check["theta_on_finer_mesh"], check["corrected_combined_pct"]
        Console().print(
            f"carried to '{check_mesh}' ({check['nodes'][1]} nodes): c1 = {t[0]:.3f} kPa +- {u[0]:.1f} %, "
            f"c5 = {t[1]:.1f} kPa +- {u[1]:.1f} % (95 %, statistical and that mesh's GCI); on the fit's mesh "
            f"with its GCI: +- {check['combined_pct'][0]:.1f} %, +- {check['combined_pct'][1]:.1f} %"
        )


def loud_warnings(payload: dict) -> None:
    """Print the adequacy flag (red) and a budget that does not hold here (yellow) as panels.

    Under the headline numbers: they say the numbers above are not to be trusted as they stand
    (fit.json holds them under 'adequacy' and 'error_budget').

    Parameters
    ----------
    payload : dict
        What fit.json holds.
    """
    console = Console()
    adequacy = payload["adequacy"]
    if "flagged" not in adequacy:
        console.print(f"  model adequacy: not tested ({adequacy.get('note')})")
    elif adequacy["flagged"]:
        named = "".join(f"\n  {d['parameter']}: {d['reason']}" for d in adequacy["named_parameters"])
        terms = ", ".join(
            f"{k} {v['statistic']:.4g} / {v['n']}" for k, v in adequacy["terms"].items() if v["n"]
        )
        console.print(
            Panel(
                f"[bold]{inference.CANNOT_EXPLAIN}[/bold]\n"
                f"chi-square {adequacy['statistic']:.4g} on {adequacy['dof']} degrees of freedom "
                f"({adequacy['per_degree']:.3g} per degree), p = {adequacy['p_value']:.3g} < {adequacy['alpha']:g}"
                f"\nper term (statistic / points): {terms}"
                f"\nnoise: {_noise_words(adequacy['noise'])}{_field_error_words(adequacy)}"
                + (f"\nparameters named:{named}" if named else ""),
                title="[bold red]MODEL INADEQUATE[/bold red]",
                border_style="red",
            )
        )
    else:
        console.print(
            f"  model adequacy: chi-square {adequacy['statistic']:.4g} on {adequacy['dof']} degrees of freedom, "
            f"p = {adequacy['p_value']:.3g} (not flagged; noise: {_noise_words(adequacy['noise'])}"
            f"{_field_error_words(adequacy)})"
        )
        for d in adequacy["named_parameters"]:
            console.print(f"  [yellow]{d['parameter']}[/yellow]: {d['reason']}")
    budget = payload["error_budget"]
    if budget["warning"]:
        words = "ERROR BUDGET NOT MEASURED HERE" if budget["known"] else "NO ERROR BUDGET FOR THIS TEST"
        title = f"[bold yellow]{words}[/bold yellow]"
        console.print(Panel(budget["warning"], title=title, border_style="yellow"))


def _field_error_words(adequacy: dict) -> str:
    """The high fidelity's field error the test held, short ('' where none)."""
    fe = adequacy.get("field_error")
    if not fe:
        return ""
    return (
        f"; {fe['coarse_mesh']}'s field error against {fe['fine_mesh']} (measured at {fe['points']} "
        f"points, {fe['file']}) held"
    )


def _noise_words(noise: dict) -> str:
    """The noise levels an adequacy test used, short."""
    dic = ", ".join(f"{v:.3g}" for v in noise["dic_sd_mm"])
    reg = max(noise["registration_sd_mm"])
    return (
        f"force {noise['force_sd_pct_median']:.3g} % of f_inf per step (median; {noise['force_source']}); "
        f"DIC ({dic}) mm ({noise['dic_source']}); registration {reg:.2g} mm"
    )


def print_posterior(result: inference.ExperimentPosterior, payload: dict, png: Path) -> None:
    """Print each parameter's median, interval and sd, the chain's convergence and the mesh carry.

    Parameters
    ----------
    result : inference.ExperimentPosterior
        The posterior.
    payload : dict
        What posterior.json holds.
    png : pathlib.Path
        The corner plot's file.
    """
    for k, name in enumerate(result.posterior.parameters):
        lo, hi = payload["ci95"][k]
        if name in result.not_identified:
            Console().print(
                f"{name} is not identified by these data: its 95 % interval [{lo:.4g}, {hi:.4g}] reaches its "
                f"prior's end {list(result.mu_range)} (the model's own errors on it counted: "
                f"+- {payload['friction'].get('mu_model_pct') or 0:.3g} %)"
            )
            if payload["friction"].get("mu_model_unmeasured"):
                Console().print(
                    f"  its samples are its prior's: {payload['friction']['mu_model_unmeasured']}"
                )
            continue
        fit_lo, fit_hi = payload["fit_bounds"][k]
        Console().print(
            f"{name}: median {payload['median'][k]:.4g}, 95 % [{lo:.4g}, {hi:.4g}], sd {payload['std'][k]:.3g} "
            f"(the fit's 95 % bounds [{fit_lo:.4g}, {fit_hi:.4g}])"
        )
    Console().print(f"intervals: {payload['intervals_include']}")
    post = result.posterior
    colour = "green" if post.converged else "yellow"
    Console().print(
        f"[{colour}]{post.convergence_message}[/{colour}]; acceptance {post.acceptance_fraction:.2f}; {png}"
    )
    carried = result.carried
    if carried is not None:
        Console().print(
            f"carried to the '{carried['check_mesh']}' mesh ({carried['nodes'][1]} nodes): shifted by "
            f"{[round(v, 2) for v in carried['shift_pct']]} %, spread by its GCI "
            f"{[round(v, 2) for v in carried['corrected_uncertainty_pct']]} % (95 %)"
        )


def print_confirmation(payload: dict, solver: str) -> None:
    """Print F on the FE model beside the surrogate's, their difference, and the mesh check.

    Parameters
    ----------
    payload : dict
        What confirm.json holds.
    solver : str
        The FE solver that confirmed (embedded or febio).
    """
    Console().print(
        f"F(theta_hat) on {solver}: {payload['F_fe']:.4g} (surrogate {payload['F_surrogate']:.4g}); surrogate vs "
        f"FE: force {payload['force_diff_max_pct']:.2f} %, field {payload['displacement_diff_max_pct']:.2f} % of max |u|"
    )
    m = payload.get("mesh_check")
    if m is not None:
        Console().print(
            f"mesh check ({m['nodes'][0]} -> {m['nodes'][1]} nodes): the finer mesh moves c1 by "
            f"{m['shift_pct'][0]:+.2f} % and c5 by {m['shift_pct'][1]:+.2f} %; 95 % bounds c1 +-"
            f"{m['statistical_pct'][0]:.2f} % (statistical, eq. 6-8) -> +-{m['combined_pct'][0]:.2f} % with the "
            f"mesh's uncertainty, c5 +-{m['statistical_pct'][1]:.2f} % -> +-{m['combined_pct'][1]:.2f} %"
        )
        t, u = m["theta_on_finer_mesh"], m["corrected_combined_pct"]
        Console().print(
            f"carried to the finer mesh: c1 = {t[0]:.4g} kPa +- {u[0]:.2f} %, c5 = {t[1]:.4g} kPa +- {u[1]:.2f} % "
            f"(95 %, statistical and the finer mesh's GCI)"
        )
