"""The inverse fit of a measured experiment (paper 2.8.2): Levenberg-Marquardt on the surrogate,
then on the FE solver with its exact sensitivities, bounds from eq. 6 to 8; optionally the mesh check
at the fit (:mod:`inference.budgets.mesh_check`) and the fit carried to the finer mesh. With mu known,
identified or marginalised the fit takes the friction path (:mod:`.friction`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from threadpoolctl import threadpool_limits

from ...design.friction_treatment import FrictionTreatment
from ...design.objective import PAPER_WEIGHTS
from ...surrogate.base import FieldSurrogate
from ..adequacy.of_fit import fit_adequacy
from ..budgets.mesh_check import check_mesh_at
from ..budgets.model_error import has_high_fidelity_level, model_error_at
from ..experiment.data import ExperimentData
from ..experiment.processing_error import REGISTRATION_MM
from .error_parts import with_processing_part
from .friction import _fit_with_friction, default_friction
from .inputs import prepare_fit
from .inverse_fit import PAPER_F_STOP, _told, fit_parameters, gauss_newton_refine
from .result import ExperimentFit, _confirm

__all__ = ["FE_STAGES", "fit_experiment", "resolved_fe_stage"]

#: What follows the fit on the surrogate (``fit_experiment(fe_stage=...)``): ``confirm``, one FE run
#: at the fit and the Gauss-Newton step it points to (:mod:`inference.fit.confirm_stage`); ``fit``,
#: Levenberg-Marquardt on the FE model (paper 2.8.2; minutes with mu); ``none``; ``auto``,
#: ``confirm`` on a surrogate trained with mu and ``fit`` on one without (its FE stage is what
#: brings mu in, or refines the stick's fit).
FE_STAGES = ("auto", "confirm", "fit", "none")


@threadpool_limits.wrap(limits=1, user_api="blas")  # OpenBLAS spins: see forward.threads
def fit_experiment(
    experiment: str | Path | ExperimentData,
    surrogate: str | Path | FieldSurrogate | None = None,
    *,
    weights=PAPER_WEIGHTS,
    refine: bool = True,
    paper_stop: bool = False,
    check_mesh: str | None = None,
    exclude_steps=(),
    say: Callable[[str], None] | None = None,
    friction: FrictionTreatment | str | float | None = None,
    force_noise: float | None = None,
    dic_noise: float | None = None,
    fe_stage: str = "auto",
    reading: str = "fit",
    registration_mm: float = REGISTRATION_MM,
    tests: str | Path | None = None,
) -> ExperimentFit:
    """Fit (c1, c5) to a measured experiment: on the surrogate, then on its FE model (paper 2.8.2).

    LM from {6, 300} kPa on the surrogate, then the FE stage on the FE model the surrogate was
    trained on (``fe_stage``, :data:`FE_STAGES`): one confirming run with the Gauss-Newton step it
    points to, or LM with its exact sensitivities; eq. 6 to 8 bounds with s from the data. On a
    surrogate trained with mu as a parameter (a campaign with a mu axis) the surrogate stage fits
    or holds mu too, and by default the FE model confirms the fit (seconds); on one without, that
    stage fits (c1, c5) with its contact as a start, and the FE fit (needed then) brings mu in. Every fit is tested for model adequacy
    (:mod:`inference.adequacy.of_fit`: its residuals against the data's noise) and says whether its test
    has an error budget (:mod:`inference.budgets.check`).

    Parameters
    ----------
    experiment : str, pathlib.Path or ExperimentData
        The experiment (folder or loaded).
    surrogate : str, pathlib.Path, FieldSurrogate or None
        The surrogate (file or loaded); None (default): the one shipped for the experiment's test
        (:func:`~indentation_studio.inference.fit.inputs.prepare_fit`), said in ``say``.
    weights : array_like, default PAPER_WEIGHTS
        The weights of eq. 5.
    refine : bool, default True
        Run the FE stage at all (False: ``fe_stage="none"``).
    paper_stop : bool, default False
        Stop as soon as F < 3e-2 (the paper's rule).
    check_mesh : str, optional
        A finer mesh preset: adds the mesh check at the fit (the fit carried to that mesh with
        bounds that hold its discretisation uncertainty).
    exclude_steps : sequence of int, default ()
        Steps (1..N) left out of the fit beside those the experiment excludes; the result lists
        them all.
    say : callable, optional
        Where progress messages go.
    friction : FrictionTreatment, str or float, optional
        How the fit treats the indenter's friction coefficient mu: a value, ``identify``,
        ``marginalise[:LO:HI]``, ``assumed``; default (None) as :func:`default_friction` says.
    force_noise : float, optional
        Declared force noise (relative, per reading) for the adequacy test; default measured.
    dic_noise : float, optional
        Declared DIC noise (mm) for the adequacy test; default measured.
    fe_stage : {"auto", "confirm", "fit", "none"}, default "auto"
        What follows the surrogate's fit (:data:`FE_STAGES`).
    reading : str, default "fit"
        The objective (eq. 4's reading): the fit's, without the DIC rings from R to 1.5 R
        (docs/explanation/model-error.md), or ``paper``.
    registration_mm : float, default REGISTRATION_MM
        How far the indentation point found from the indenter's tracked points may lie from the
        true one, mm: the bounds carry its effect and that of the DIC-points-to-nodes planes,
        measured at the fit (``inference.experiment.processing_error``).

    tests : str or pathlib.Path, optional
        A prepared test's folder (``indent-studio test prepare``) read before the shipped surrogates
        (:func:`~indentation_studio.surrogate.shipped.find_test`).
    Returns
    -------
    ExperimentFit
        Both stages, the bounds and the checks.

    Raises
    ------
    ValueError
        If ``fe_stage`` is none of :data:`FE_STAGES`, or the friction treatment needs an FE fit
        that is not asked for.

    Examples
    --------
    >>> import indentation_studio as ins
    >>> fit = ins.fit_experiment("runs/experiments/synthetic", "surrogate-gp.safetensors")  # doctest: +SKIP
    >>> fit.fit.theta, fit.fit.bounds_pct  # doctest: +SKIP
    """
    say = say or (lambda message: None)
    inputs = prepare_fit(experiment, surrogate, weights, exclude_steps, reading=reading, tests=tests)
    if surrogate is None:
        say(f"surrogate: {inputs.sources['surrogate']}")
    stage = resolved_fe_stage(fe_stage, inputs.surrogate, refine=refine)
    treatment = (
        default_friction(inputs.surrogate, stage == "fit" and check_mesh is None)
        if friction is None
        else FrictionTreatment.parse(friction)
    )
    f_stop = PAPER_F_STOP if paper_stop else None
    if treatment.mode != "assumed" or "mu" in inputs.surrogate.parameters:
        result = _fit_with_friction(inputs, treatment, stage, f_stop, check_mesh, say, registration_mm)
        result.adequacy, result.adequacy_note = fit_adequacy(
            result, force_noise=force_noise, dic_noise=dic_noise, registration_mm=registration_mm
        )
        return result
    say(f"fitting on the {inputs.surrogate.kind} surrogate ...")
    first = fit_parameters(inputs.objective, inputs.surrogate, inputs.eta, f_stop=f_stop)
    final = first
    two_level = has_high_fidelity_level(inputs.surrogate)
    if stage == "fit":
        fe = inputs.fe_model()
        if (
            two_level and not paper_stop
        ):  # the surrogate already emulates this FE model: confirm by Gauss-Newton
            say(
                f"refining by Gauss-Newton on {inputs.fe_stage_words()} from {first.theta.round(3).tolist()} kPa ..."
            )
            final = gauss_newton_refine(inputs.objective, fe, inputs.eta, first.theta)
        else:
            say(f"refining on the FE solver from {first.theta.round(3).tolist()} kPa ...")
            final = fit_parameters(
                inputs.objective, fe, inputs.eta, theta0=first.theta, f_stop=f_stop, progress=_told(say)
            )
    check = None
    if check_mesh is not None:
        check, _ = check_mesh_at(inputs.spec, inputs.objective, inputs.eta, final.theta, check_mesh, say)
    if two_level:
        say("the model error at the fit (discrepancy and error budget) ...")
    model_error = model_error_at(
        inputs.objective, inputs.eta, inputs.surrogate, final.theta, on_surrogate=stage != "fit"
    )
    model_error = with_processing_part(
        model_error, inputs, final.theta, inputs.spec.contact.describe(), registration_mm, say
    )
    result = ExperimentFit(inputs, first, final, stage == "fit", check, check_mesh, model_error)
    if stage == "confirm":
        say(f"confirming on the FE solver at {first.theta.round(3).tolist()} kPa ...")
        result.confirmation = _confirm(result, inputs.fe_model(), None)
    result.adequacy, result.adequacy_note = fit_adequacy(
        result, force_noise=force_noise, dic_noise=dic_noise, registration_mm=registration_mm
    )
    return result


def resolved_fe_stage(fe_stage: str, surrogate, *, refine: bool = True) -> str:
    """The FE stage a fit runs (:data:`FE_STAGES`): ``auto`` made ``confirm`` on a surrogate trained
    with mu, ``fit`` on one without; ``none`` whenever ``refine`` is False.

    Parameters
    ----------
    fe_stage : str
        One of :data:`FE_STAGES`.
    surrogate : FieldSurrogate
        The surrogate the fit starts on.
    refine : bool, default True
        False: no FE stage at all.

    Returns
    -------
    str
        ``confirm``, ``fit`` or ``none``.

    Raises
    ------
    ValueError
        If ``fe_stage`` is none of :data:`FE_STAGES`.
    """
    if fe_stage not in FE_STAGES:
        raise ValueError(f"fe_stage {fe_stage!r}: use one of {', '.join(FE_STAGES)}")
    if not refine:
        return "none"
    if fe_stage == "auto":
        return "confirm" if "mu" in surrogate.parameters else "fit"
    return fe_stage
