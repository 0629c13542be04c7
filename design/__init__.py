"""Design: what is decided before a test. Objectives (eq. 4, 5), Appendix B nodal weights, certainty
bounds (eq. 6 to 8), weight optimisation (Table 1), Fig. 8, which experiment to run, the error
budget of a model, constituents and homogenisation (eq. 10, 11)."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submod_attrs={
        "objective": ["PAPER_WEIGHTS", "Objective", "check_weights"],
        "reduced_objective": ["FieldObjective", "ReducedObjective", "objective_function"],
        "certainty": ["bounds_pct", "combine", "s_from_data"],
        "study": ["DesignStudy", "fe_design_study", "friction_design_bounds"],
        "weights": ["PAPER_HESSIAN", "compare_with_paper", "optimise_weights", "table1"],
        "objective_over_plane": ["ObjectiveMap", "campaign_objective_map", "objective_map"],
        "experiment_choice": ["candidate_grid", "compare_designs"],
        "constituents": ["fit_equibiaxial", "parallel_fiber_stresses", "rule_of_mixtures"],
        "composite_homogenisation": ["CompositeHomogenisation", "composite_equibiaxial_fit"],
        "error_budget": [
            "ErrorBudget",
            "campaign_error_budget",
            "compute_error_budget",
            "remaining_bias",
            "resolve_model",
            "shipped_budget",
            "surrogate_error_budget",
        ],
    },
)
