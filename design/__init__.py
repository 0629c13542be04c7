"""Design: what is decided before a test. Objectives (eq. 4, 5), Appendix B nodal weights, certainty
bounds (eq. 6 to 8), weight optimisation (Table 1), Fig. 8, which experiment to run, constituents and homogenisation (eq. 10, 11)."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submod_attrs={
        "objective": ["PAPER_WEIGHTS", "Objective", "check_weights"],
        "nodal_weights": ["FIT_INNER_RADII", "READINGS", "default_selection"],
        "reduced_objective": ["FieldObjective", "ReducedObjective", "objective_function"],
        "certainty": ["DESIGN_BOUNDS_INCLUDE", "bounds_pct", "combine", "s_from_data"],
        "study": [
            "DesignBounds",
            "DesignStudy",
            "design_bounds",
            "fe_design_study",
            "friction_design_bounds",
            "model_design_study",
        ],
        "weights_comparison": ["WeightsTable", "weights_table"],
        "friction_treatment": ["FixedParameter", "FrictionTreatment", "friction_bounds"],
        "weights": ["PAPER_HESSIAN", "compare_with_paper", "optimise_weights", "table1"],
        "objective_over_plane": ["ObjectiveMap", "campaign_objective_map", "objective_map"],
        "experiment_choice": [
            "DesignComparison",
            "candidate_grid",
            "compare_candidate_designs",
            "compare_designs",
        ],
        "constituents": [
            "Baseline",
            "baseline_from_constituents",
            "fit_equibiaxial",
            "parallel_fiber_stresses",
            "rule_of_mixtures",
        ],
        "composite_homogenisation": ["CompositeHomogenisation", "composite_equibiaxial_fit"],
    },
)
