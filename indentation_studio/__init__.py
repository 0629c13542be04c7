"""Indentation Studio: identifiability-aware identification of soft-tissue parameters.

``import indentation_studio as ins`` reaches the everyday workflows (simulate, run a campaign, train a
surrogate, design bounds and weights, load an experiment, fit, posterior, confirm, figures); the
subpackages ``forward``, ``campaign``, ``surrogate``, ``design``, ``inference`` and ``studio`` hold
the rest. Names are imported on first use (lazy_loader), so importing the package is cheap.
"""

from importlib.metadata import PackageNotFoundError, version

import lazy_loader as lazy

from .thread_waits import brief_thread_waits

# before MKL, numba or torch loads an OpenMP runtime: waiting threads spin briefly, then sleep
brief_thread_waits()

try:
    __version__ = version("indentation-studio")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0.0.0+unknown"

__getattr__, __dir__, _all = lazy.attach(
    __name__,
    submodules=["campaign", "design", "forward", "inference", "studio", "surrogate"],
    submod_attrs={
        "forward": [
            "FESolverPredictor",
            "MeshChoice",
            "ModelSpec",
            "Protocol",
            "Indenter",
            "Material",
            "simulate",
        ],
        "campaign": ["StoredResponses", "load_campaign", "run_named_campaign"],
        "surrogate": [
            "load_surrogate",
            "save_surrogate",
            "shipped_budget",
            "train_multi_fidelity",
            "train_surrogate",
        ],
        "design": [
            "PAPER_WEIGHTS",
            "campaign_objective_map",
            "compare_designs",
            "compare_with_paper",
            "fe_design_study",
        ],
        "inference": [
            "campaign_error_budget",
            "confirm",
            "fit_experiment",
            "load_experiment",
            "sample_posterior_for",
            "write_synthetic_experiment",
        ],
        "studio": ["figures", "run_demo"],
    },
)
__all__ = ["__version__", *_all]
