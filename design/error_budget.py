"""Moved (0.2): computing an error budget (fits of a reference campaign) is
:mod:`indentation_studio.inference.error_budget`'s, reading a measured one
:mod:`indentation_studio.surrogate.error_budgets`'s. This path is kept for one version: its names
are fetched from there when asked for, with a ``DeprecationWarning``, so that the design layer
imports nothing above it (docs/architecture.md, "Layers")."""

from ..moved_names import moved_getattr

_READING = ("remaining_bias", "shipped_budget", "shipped_budgets_folder", "surrogate_error_budget")
_COMPUTING = (
    "CONVERGED_FRACTION",
    "ErrorBudget",
    "campaign_error_budget",
    "compute_error_budget",
    "noise_objective_value",
    "resolve_model",
)
MOVED = {name: "indentation_studio.surrogate.error_budgets" for name in _READING} | {
    name: "indentation_studio.inference.error_budget" for name in _COMPUTING
}


def _missing(name: str):
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__getattr__ = moved_getattr(__name__, MOVED, _missing)
