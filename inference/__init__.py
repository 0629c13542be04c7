"""Inference: what is done after a test.

Subpackages by concept: the experiment data, its processing (eq. 9, registration, DIC to nodes),
checks and the experiments the studio makes (``experiment``; a lab's files: ``lab``), the inverse
fit (2.8.2) with its friction path and result (``fit``), every error budget and the model error
(``budgets``), the adequacy test (``adequacy``), posteriors (``posterior``), and the FE
confirmation of a fit (the module ``confirmation``)."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submodules=["lab"],
    submod_attrs={
        "experiment.data": ["ExperimentData", "ExperimentDataError", "load_experiment"],
        "experiment.processing": ["experiment_objective", "static_forces", "to_model_frame"],
        "experiment.synthetic": [
            "LAB_RECORDING",
            "Recording",
            "write_experiment_from_model",
            "write_synthetic_experiment",
        ],
        "fit.inverse_fit": ["FitResult", "fit_parameters"],
        "fit.inputs": ["FitInputs", "prepare_fit"],
        "fit.result": ["ExperimentFit"],
        "fit.workflow": ["FE_STAGES", "fit_experiment"],
        "fit.friction": ["default_friction"],
        "fit.mu_reach": ["interval_is_whole_range", "mu_is_identified"],
        "fit.confirm_stage": ["FitConfirmation", "confirm_fit"],
        "fit.run_refits": ["RunRefit", "refit_campaign", "refit_runs", "refit_summary"],
        "posterior.sampling": ["Posterior", "sample_posterior"],
        "budgets.model_error_parts": ["ModelError", "combined_pct", "model_error_scope"],
        "budgets.fit_moves": ["emulation_error_pct", "emulation_moves"],
        "budgets.freed_mu_moves": ["freed_mu_moves", "with_freed_mu"],
        "budgets.mesh_difference_runs": ["mesh_differences_from_runs"],
        "budgets.model_error": [
            "budget_correction",
            "model_error_at",
            "with_emulation_error",
            "with_model_error",
            "with_processing_error",
        ],
        "experiment.processing_error": ["REGISTRATION_MM", "ProcessingError", "processing_error_at"],
        "posterior.experiment_posterior": ["ExperimentPosterior"],
        "posterior.workflow": ["sample_posterior_for"],
        "confirmation": ["Confirmation", "confirm"],
        "budgets.mesh_check": ["MeshCheck", "check_mesh_at"],
        "lab.experiment_import": [
            "import_dic_csv",
            "import_duodic",
            "import_experiment",
            "import_load_frame",
            "import_matchid",
        ],
        "experiment.data_check": ["check_experiment"],
        "adequacy.chi_square": ["CANNOT_EXPLAIN", "Adequacy", "chi_square_test"],
        "adequacy.noise": ["NoiseModel", "noise_model"],
        "adequacy.field_error": ["field_error_table", "field_variance", "shipped_field_error"],
        "budgets.error_budget": ["compute_error_budget", "noise_objective_value"],
        "budgets.budget_table": ["CONVERGED_FRACTION", "ErrorBudget"],
        "budgets.budget_models": ["resolve_model"],
        "budgets.campaign_budget": ["campaign_error_budget"],
        "budgets.verification_study": ["VerificationStudy", "run_verification_study"],
        "budgets.study_quantities": ["parameter_bias"],
        "budgets.study_files": ["load_verification_study", "merge_verification_studies"],
        "preparation": ["CostEstimate", "PreparedTest", "TestRecipe", "estimate_cost", "prepare_test"],
        "budgets.study_budget": ["reference_uncertainty_pct", "study_error_budget"],
        "budgets.budget_merge": ["merge_error_budgets"],
        "budgets.finest_reference": [
            "ReferenceCorrection",
            "finest_reference_budget",
            "reference_correction",
            "with_finest_reference",
        ],
        "experiment.febio": [
            "RecordedRun",
            "experiment_from_febio_run",
            "febio_contact",
            "febio_experiment_summary",
        ],
        "experiment.composite": [
            "CompositeExperiment",
            "composite_indentation",
            "experiment_from_composite",
            "write_composite_experiment",
        ],
        "experiment.composite_comparison": [
            "CompositeComparison",
            "compare_with_fit",
            "compare_with_homogeneous",
            "fitted_model",
        ],
    },
)
