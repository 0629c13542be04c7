"""A surrogate trained as the command line trains one: on a campaign (or a low-fidelity surrogate
corrected by a second campaign), with the error budget left for the campaign's mesh, saved beside
the campaign; the record ``surrogate train --json`` and ``surrogate train-mf --json`` print."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..campaign.loader import open_campaign
from .base import FieldSurrogate
from .error_budgets import remaining_bias
from .persistence import save_surrogate
from .training import train_multi_fidelity, train_surrogate

__all__ = ["TrainedSurrogate", "budget_for_campaign", "train_and_save", "train_and_save_multi_fidelity"]


@dataclass
class TrainedSurrogate:
    """A trained surrogate, its kind and the file it was saved to.

    Attributes
    ----------
    model : FieldSurrogate
        The trained surrogate.
    kind : {"gp", "mlp", "mf"}
        Its kind.
    model_file : pathlib.Path
        The file it was saved to.
    """

    model: FieldSurrogate
    kind: str
    model_file: Path

    @property
    def error_budget(self) -> dict | None:
        """What the error budget leaves for the model's mesh (None: no budget known)."""
        return self.model.meta.get("error_budget")

    def to_dict(self) -> dict[str, Any]:
        """The training's record as the command line prints it.

        Returns
        -------
        dict
            The model file, its kind and error budget; a multi-fidelity model's validation and
            discrepancy folds, another's fit time, components and errors per data set.
        """
        meta = self.model.meta
        if self.kind == "mf":
            return {
                "model_file": str(self.model_file),
                "kind": "mf",
                "validation": meta["validation"],
                "discrepancy_kfold": meta.get("discrepancy_kfold"),
                "error_budget": meta.get("error_budget"),
            }
        return {
            "model_file": str(self.model_file),
            "kind": self.kind,
            "error_budget": meta.get("error_budget"),
            "fit_s": meta["fit_s"],
            "force_components": meta["force_components"],
            "field_components": meta["field_components"],
            **{f"{name}_errors": e for name, e in meta["validation"].items()},
        }


def budget_for_campaign(
    error_budget: str | Path | None, budget_model: str | None, campaign: str, runs_dir: str | Path = "runs"
) -> dict | None:
    """What ``error_budget`` leaves for the campaign's mesh.

    Parameters
    ----------
    error_budget : str or Path or None
        An error-budget.json; None: no file (the training then takes the shipped budget for that
        mesh, if any).
    budget_model : str or None
        The mesh's name in that budget (default: the campaign's mesh preset or .feb file).
    campaign : str
        The campaign (name under ``runs_dir``, or its folder).
    runs_dir : str or Path
        Where campaigns live.

    Returns
    -------
    dict or None
        The remaining bias (:func:`surrogate.error_budgets.remaining_bias`), or None.
    """
    if error_budget is None:
        return None
    mesh = open_campaign(campaign, runs_dir).spec.model.mesh
    return remaining_bias(error_budget, budget_model or mesh.preset or str(mesh.feb_file))


def train_and_save(
    campaign: str,
    kind: str = "gp",
    *,
    input_scale: str = "log",
    pca_tol: float = 1e-3,
    test_campaign: str | None = None,
    kfold: int = 0,
    seed: int = 0,
    out: str | Path | None = None,
    error_budget: str | Path | None = None,
    budget_model: str | None = None,
    runs_dir: str | Path = "runs",
    say: Callable[[str], None] | None = None,
    stick: str | Path | None = None,
) -> TrainedSurrogate:
    """Train a ``kind`` surrogate on ``campaign`` and save it.

    Training is :func:`surrogate.training.train_surrogate`.

    Parameters
    ----------
    campaign : str
        The training campaign.
    kind : str
        'gp', 'mlp' or 'slip'.
    input_scale, pca_tol, test_campaign, kfold, seed, runs_dir, stick
        As :func:`surrogate.training.train_surrogate`.
    out : str or Path, optional
        The model file (default ``<runs_dir>/<campaign>/surrogate-<kind>.safetensors``).
    error_budget, budget_model
        As :func:`budget_for_campaign`.
    say : callable, optional
        Progress messages.

    Returns
    -------
    TrainedSurrogate
        The model and its file.
    """
    if say is not None:
        say(f"training a {kind} surrogate on {campaign!r} ({kfold}-fold cross-validation) ...")
    budget = budget_for_campaign(error_budget, budget_model, campaign, runs_dir)
    model = train_surrogate(
        campaign,
        kind,
        input_scale=input_scale,
        pca_tol=pca_tol,
        test_campaign=test_campaign,
        kfold=kfold,
        seed=seed,
        runs_dir=runs_dir,
        error_budget=budget,
        stick=stick,
        say=say,
    )
    name = model.meta["campaign"].get("name", campaign)
    path = save_surrogate(model, out or Path(runs_dir) / name / f"surrogate-{kind}.safetensors")
    return TrainedSurrogate(model, kind, path)


def train_and_save_multi_fidelity(
    low: str | Path,
    campaign: str | Sequence[str],
    *,
    stick_mu: float | None = None,
    test_campaign: str | None = None,
    seed: int = 0,
    out: str | Path | None = None,
    error_budget: str | Path | None = None,
    budget_model: str | None = None,
    runs_dir: str | Path = "runs",
    say: Callable[[str], None] | None = None,
) -> TrainedSurrogate:
    """Correct the surrogate ``low`` by the high-fidelity ``campaign`` and save it.

    Training is :func:`surrogate.training.train_multi_fidelity`.

    Parameters
    ----------
    low : str or Path
        The low-fidelity surrogate file.
    campaign : str or sequence of str
        The high-fidelity campaign, or several of one mesh merged (a stick one and one with a mu
        axis: ``stick_mu`` then).
    stick_mu, test_campaign, seed, runs_dir
        As :func:`surrogate.training.train_multi_fidelity`.
    out : str or Path, optional
        The model file (default ``<runs_dir>/<first campaign>/surrogate-mf.safetensors``).
    error_budget, budget_model
        As :func:`budget_for_campaign`.
    say : callable, optional
        Progress messages.

    Returns
    -------
    TrainedSurrogate
        The model and its file.
    """
    campaigns = [campaign] if isinstance(campaign, str) else list(campaign)
    budget = budget_for_campaign(error_budget, budget_model, campaigns[0], runs_dir)
    if say is not None:
        say(f"training a multi-fidelity surrogate: {low} corrected by {' + '.join(campaigns)} ...")
    model = train_multi_fidelity(
        low,
        campaigns[0] if len(campaigns) == 1 else campaigns,
        test_campaign=test_campaign,
        seed=seed,
        runs_dir=runs_dir,
        error_budget=budget,
        stick_mu=stick_mu,
    )
    folder = open_campaign(campaigns[0], runs_dir).root if len(campaigns) > 1 else None
    name = model.meta["campaign"].get("name", campaigns[0])
    path = save_surrogate(model, out or (folder or Path(runs_dir) / name) / "surrogate-mf.safetensors")
    return TrainedSurrogate(model, "mf", path)
