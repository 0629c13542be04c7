"""``indent-studio surrogate train | evaluate | convert``: emulators of the forward model from a campaign."""

from __future__ import annotations

import time
from collections.abc import Callable
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from .. import inference, surrogate  # lazy: the command imports what it runs
from ..atomic_write import strict_json
from .options import JSON, RUNS_DIR, SEED, err, fail

surrogate_app = typer.Typer(
    help="Gaussian-process and MLP emulators of the forward model, trained on a campaign."
)

CAMPAIGN = Annotated[str, typer.Option(help="campaign name under --runs-dir (or its folder)")]


class Kind(StrEnum):
    gp = "gp"
    mlp = "mlp"
    slip = "slip"


def _errors_table(title: str, rows: dict[str, dict]) -> None:
    table = Table(title=title)
    for col in ("data", "points", "force RMS %", "force max %", "u RMS %", "u max %"):
        table.add_column(col)
    for name, e in rows.items():
        table.add_row(
            name,
            str(e["points"]),
            f"{e['force_rms_pct']:.3f}",
            f"{e['force_max_pct']:.3f}",
            f"{e['displacement_rms_pct']:.3f}",
            f"{e['displacement_max_pct']:.3f}",
        )
    Console(width=120).print(table)


def _refits_table(title: str, refits: dict) -> None:
    rows = refits["refits"]
    names = [k for k in ("c1", "c5", "mu") if any(f"{k}_fit" in r for r in rows)]
    table = Table(title=title)
    for name in names:
        table.add_column(f"{name} run")
        table.add_column(f"{name} fit")
        table.add_column(f"{name} error %")
    table.add_column("F")
    for r in rows:
        cells = []
        for name in names:
            cells.append(f"{r[name + '_true']:.4g}" if name + "_true" in r else "-")
            cells.append(f"{r[name + '_fit']:.4g}")
            cells.append(f"{r[name + '_error_pct']:+.2f}" if name + "_error_pct" in r else "-")
        table.add_row(*cells, f"{r['F']:.3g}")
    Console(width=140).print(table)
    for name in names:
        s = refits["summary"].get(name)
        if s:
            Console().print(
                f"{name}: |error| largest {s['max_abs_pct']:.2f} %, 95th percentile {s['p95_abs_pct']:.2f} %, "
                f"mean {s['mean_pct']:+.2f} % over {refits['summary']['runs']} runs",
                highlight=False,
            )


def _train_and_say(
    train: Callable[[], surrogate.TrainedSurrogate],
    as_json: bool,
    title: str,
    what: str,
    absent: str,
) -> None:
    """Train and save a surrogate (``train``), then print its JSON, or its validation table, its
    file and the error budget its fits carry (``what``: the mesh the budget is of; ``absent``:
    what the fits carry when there is none)."""
    try:
        trained = train()
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json(trained.to_dict()))
        return
    meta = trained.model.meta
    _errors_table(title, meta["validation"])
    fit_s = f" (fit {meta['fit_s']:.1f} s)" if "fit_s" in meta else ""
    Console().print(f"saved {trained.model_file}{fit_s}")
    budget = trained.error_budget
    if budget is None:
        Console().print(f"no error budget known for {what}: {absent}")
    else:
        Console().print(
            f"error budget left for {what}: c1 {budget['c1_pct']:.2f} %, c5 {budget['c5_pct']:.2f} % "
            f"(from {budget['source']['file']}): fits carry it in their bounds"
        )


ERROR_BUDGET = Annotated[
    Path | None,
    typer.Option(
        help="an error-budget.json: what it leaves for the mesh joins every fit's bounds "
        "(default: the studio's shipped budget for that mesh and test, if any)"
    ),
]
BUDGET_MODEL = Annotated[
    str | None, typer.Option(help="the mesh's name in that budget (default: its mesh preset)")
]


KIND = Annotated[
    Kind,
    typer.Option(
        help="gp (scikit-learn), mlp (torch) or slip (a perfect-stick surrogate, --stick, plus an MLP of "
        "what slip changes, on a campaign with a mu axis)"
    ),
]
INPUT_SCALE = Annotated[str, typer.Option(help="linear or log scaling of the parameters")]
PCA_TOL = Annotated[float, typer.Option(help="PCA reconstruction tolerance (relative)")]
TEST_CAMPAIGN = Annotated[str | None, typer.Option(help="a campaign of points to test on")]
KFOLD = Annotated[int, typer.Option(help="k-fold cross-validation on the training campaign (0: none)")]
MODEL_OUT = Annotated[
    Path | None, typer.Option(help="model file (default runs/<campaign>/surrogate-<kind>.safetensors)")
]
MF_OUT = Annotated[
    Path | None, typer.Option(help="model file (default runs/<campaign>/surrogate-mf.safetensors)")
]


@surrogate_app.command("train-mf")
def train_mf(
    low: Annotated[
        Path,
        typer.Option(
            help="the low-fidelity surrogate file (trained on a large campaign); a multi-fidelity one gives its low level"
        ),
    ],
    campaign: Annotated[
        list[str],
        typer.Option(
            help="the high-fidelity campaign (tens of points on a finer mesh); given again, campaigns of "
            "that mesh merged over (c1, c5, mu), e.g. one at the stick and one with a mu axis"
        ),
    ],
    stick_mu: Annotated[
        float | None,
        typer.Option(
            help="with several campaigns: the mu a stick campaign's points are taken as; default "
            "the low level's mu range end (where nothing slips)"
        ),
    ] = None,
    error_budget: ERROR_BUDGET = None,
    budget_model: BUDGET_MODEL = None,
    test_campaign: Annotated[
        str | None, typer.Option(help="a high-fidelity campaign of points to test on")
    ] = None,
    seed: SEED = 0,
    out: MF_OUT = None,
    runs_dir: RUNS_DIR = Path("runs"),
    as_json: JSON = False,
) -> None:
    """Train a multi-fidelity surrogate: the low-fidelity surrogate corrected by a GP of its
    discrepancy from the high-fidelity campaign; fits on it refine on the high-fidelity mesh and carry
    the discrepancy's uncertainty (and the error budget's remaining bias) in their bounds."""
    _train_and_say(
        lambda: surrogate.train_and_save_multi_fidelity(
            low,
            campaign[0] if len(campaign) == 1 else campaign,
            stick_mu=stick_mu,
            test_campaign=test_campaign,
            seed=seed,
            out=out,
            error_budget=error_budget,
            budget_model=budget_model,
            runs_dir=runs_dir,
            say=err.print,
        ),
        as_json,
        "multi-fidelity surrogate: errors (percent)",
        "the high-fidelity mesh",
        "fits will carry the discrepancy's uncertainty only",
    )


@surrogate_app.command("train")
def train(
    campaign: CAMPAIGN,
    kind: KIND = Kind.gp,
    input_scale: INPUT_SCALE = "log",
    pca_tol: PCA_TOL = 1e-3,
    test_campaign: TEST_CAMPAIGN = None,
    kfold: KFOLD = 0,
    seed: SEED = 0,
    out: MODEL_OUT = None,
    error_budget: ERROR_BUDGET = None,
    budget_model: BUDGET_MODEL = None,
    runs_dir: RUNS_DIR = Path("runs"),
    stick: Annotated[
        Path | None,
        typer.Option(help="--kind slip: the perfect-stick surrogate file the campaign with mu corrects"),
    ] = None,
    as_json: JSON = False,
) -> None:
    """Train a surrogate on a campaign, validate it, and save it next to the campaign."""
    _train_and_say(
        lambda: surrogate.train_and_save(
            campaign,
            kind.value,
            input_scale=input_scale,
            pca_tol=pca_tol,
            test_campaign=test_campaign,
            kfold=kfold,
            seed=seed,
            out=out,
            error_budget=error_budget,
            budget_model=budget_model,
            runs_dir=runs_dir,
            say=err.print,
            stick=stick,
        ),
        as_json,
        f"{kind.value} surrogate of {campaign!r}: errors (percent)",
        "its mesh and test",
        "fits will say their bounds hold no model error",
    )


@surrogate_app.command("evaluate")
def evaluate(
    model_file: Annotated[Path, typer.Option("--model", help="a trained surrogate file")],
    campaign: Annotated[str | None, typer.Option(help="campaign to compare with")] = None,
    timing: Annotated[int, typer.Option(help="also time a prediction of this many random points")] = 0,
    refits: Annotated[
        bool,
        typer.Option(
            help="also fit each run of --campaign on the surrogate as a noise-free experiment (mu free "
            "where the surrogate has it): its error in c1, c5 (and mu)"
        ),
    ] = False,
    runs_dir: RUNS_DIR = Path("runs"),
    as_json: JSON = False,
) -> None:
    """Errors of a saved surrogate on a campaign, and the time to predict many points."""
    import numpy as np

    payload: dict = {}
    try:
        model = surrogate.load_surrogate(model_file)
        payload["kind"] = model.kind
        if campaign:
            payload["errors"] = surrogate.prediction_errors(
                model, surrogate.training_data(campaign, runs_dir)
            )
        if campaign and refits:
            payload["refits"] = inference.refit_campaign(
                model,
                campaign,
                runs_dir,
                progress=lambda k, n: err.print(f"refit {k} of {n}", highlight=False),
            )
        if timing:
            rng = np.random.default_rng(0)
            theta = model.scaler.lo + rng.random((timing, len(model.parameters))) * (
                model.scaler.hi - model.scaler.lo
            )
            t0 = time.perf_counter()
            model.predict(theta)
            payload["timing"] = {"points": timing, "wall_s": time.perf_counter() - t0}
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json(payload))
        return
    if "errors" in payload:
        _errors_table(f"{model.kind} surrogate on {campaign!r} (percent)", {campaign: payload["errors"]})
    if "refits" in payload:
        _refits_table(f"{model.kind} surrogate fitted to the runs of {campaign!r}", payload["refits"])
    if "timing" in payload:
        t = payload["timing"]
        Console().print(f"prediction of {t['points']} points: {t['wall_s']:.3f} s")


@surrogate_app.command("convert")
def convert(
    model_file: Annotated[
        Path, typer.Option("--model", help="an old pickle (joblib) surrogate file that you trust")
    ],
    out: Annotated[Path, typer.Option(help="the new file (e.g. surrogate-gp.safetensors)")],
    as_json: JSON = False,
) -> None:
    """Convert an old pickle (joblib) surrogate file to the safe format, once.

    WARNING: this UNPICKLES the old file, which runs any code it holds. Convert only files you
    made yourself or trust; the new file runs nothing when it is loaded."""
    try:
        path = surrogate.convert_pickled_surrogate(model_file, out)
    except (ValueError, OSError) as exc:
        fail(str(exc), as_json)
    if as_json:
        print(strict_json({"model_file": str(path), "converted_from": str(model_file)}))
        return
    Console().print(f"converted {model_file} -> {path}")
