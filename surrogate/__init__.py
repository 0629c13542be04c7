"""Emulators of the forward model trained on a campaign: Gaussian process (scikit-learn) and MLP
(torch), the multi-fidelity correction of one by a second campaign, the perfect stick plus slip over
(c1, c5, mu), their training, validation and files."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submod_attrs={
        "base": ["FieldSurrogate"],
        "training_set": ["TrainingData", "merged_training_data"],
        "gaussian_process": ["GaussianProcessSurrogate"],
        "mlp": ["MLPSurrogate"],
        "multi_fidelity": ["MultiFidelitySurrogate"],
        "slip_surrogate": ["SlipSurrogate"],
        "two_level": ["TwoLevelSurrogate"],
        "training": [
            "SURROGATE_KINDS",
            "make_surrogate",
            "train_multi_fidelity",
            "train_surrogate",
            "training_data",
        ],
        "persistence": ["SurrogateFileError", "load_surrogate", "save_surrogate"],
        "trained": [
            "TrainedSurrogate",
            "budget_for_campaign",
            "train_and_save",
            "train_and_save_multi_fidelity",
        ],
        "pickle_conversion": ["convert_pickled_surrogate"],
        "validation": ["k_fold_errors", "prediction_errors"],
        "emulation_error": ["EMULATION_ENERGY", "EmulationError", "held_out_errors"],
        "error_budgets": [
            "budget_at",
            "budget_map",
            "indentation_test_of",
            "remaining_bias",
            "shipped_budget",
            "shipped_budgets_folder",
            "surrogate_error_budget",
        ],
        "mesh_differences": ["MeshDifferences", "shipped_mesh_differences", "surrogate_mesh_differences"],
        "registry": ["SAVED_KINDS", "surrogate_class"],
        "shipped": [
            "ShippedSurrogate",
            "load_shipped",
            "recipe_for_test",
            "shipped_for_test",
            "shipped_surrogates",
            "shipped_surrogates_folder",
        ],
    },
)
