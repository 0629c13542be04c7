"""Inference: what is done after a test. Experiment data and its processing (eq. 9, registration,
DIC to nodes), synthetic experiments, the inverse fit (2.8.2), posteriors, the model-error (mesh)
check, the FE confirmation, the composite phantom as an experiment."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submodules=["lab"],
    submod_attrs={
        "experiment_data": ["ExperimentData", "ExperimentDataError", "load_experiment"],
        "experiment_processing": ["experiment_objective", "static_forces", "to_model_frame"],
        "synthetic_experiment": [
            "LAB_RECORDING",
            "Recording",
            "write_experiment_from_model",
            "write_synthetic_experiment",
        ],
        "inverse_fit": ["FitResult", "fit_parameters"],
        "fit_inputs": ["FitInputs", "prepare_fit"],
        "experiment_fit": ["ExperimentFit", "FE_STAGES", "default_friction", "fit_experiment"],
        "fit_confirmation": ["FitConfirmation", "confirm_fit"],
        "posterior": ["Posterior", "sample_posterior"],
        "model_error": [
            "ModelError",
            "combined_pct",
            "emulation_error_pct",
            "model_error_at",
            "model_error_scope",
            "with_emulation_error",
            "with_model_error",
            "with_processing_error",
        ],
        "processing_error": ["REGISTRATION_MM", "ProcessingError", "processing_error_at"],
        "experiment_posterior": ["ExperimentPosterior", "sample_posterior_for"],
        "confirmation": ["Confirmation", "confirm"],
        "mesh_check": ["MeshCheck", "check_mesh_at"],
        "lab.experiment_import": [
            "import_dic_csv",
            "import_duodic",
            "import_experiment",
            "import_load_frame",
            "import_matchid",
        ],
        "data_check": ["check_experiment"],
        "adequacy": ["CANNOT_EXPLAIN", "Adequacy", "NoiseModel", "chi_square_test", "noise_model"],
        "error_budget": [
            "CONVERGED_FRACTION",
            "ErrorBudget",
            "campaign_error_budget",
            "compute_error_budget",
            "noise_objective_value",
            "resolve_model",
        ],
        "verification_study": ["VerificationStudy", "parameter_bias", "run_verification_study"],
        "study_budget": ["reference_uncertainty_pct", "study_error_budget"],
        "febio_experiment": [
            "RecordedRun",
            "experiment_from_febio_run",
            "febio_contact",
            "febio_experiment_summary",
        ],
        "composite_experiment": [
            "CompositeComparison",
            "CompositeExperiment",
            "compare_with_fit",
            "compare_with_homogeneous",
            "composite_indentation",
            "experiment_from_composite",
            "fitted_model",
            "write_composite_experiment",
        ],
    },
)
