"""The forward model: one indentation simulation (model spec, meshes, material, element, contact,
the embedded solver and its sensitivities, the FEBio backend, result files, the Predictor seam).

Names are imported on first use (lazy_loader), so ``import indentation_studio.forward`` is cheap."""

import lazy_loader as lazy

from .numba_cache import ensure_numba_cache_dir

ensure_numba_cache_dir()  # before numba is imported: a read-only install still finds a cache folder

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submodules=["febio"],
    submod_attrs={
        "spec": [
            "CompositeMaterial",
            "Constituent",
            "Contact",
            "Geometry",
            "Indenter",
            "Material",
            "MeshChoice",
            "ModelSpec",
            "Protocol",
            "SolverOptions",
            "SpecError",
        ],
        "mesh": ["MESH_PRESETS", "BlockMesh", "build_mesh", "grid_block", "preset_mesh", "structured_block"],
        "composite_mesh": [
            "PHANTOM",
            "PhantomLayout",
            "fiber_volume_fraction",
            "phantom_mesh",
        ],
        "element_moduli": ["ElementModuli", "composite_moduli"],
        "block_stretch": [
            "BlockStretchResult",
            "StretchError",
            "equibiaxial_phantom_mesh",
            "equibiaxial_stretch",
            "stretch_block",
        ],
        "coulomb_law": ["contact_response"],
        "coulomb_contact": ["FrictionContactState"],
        "contact_quadrature": [
            "CONTACT_INTEGRATIONS",
            "ContactPoints",
            "contact_points",
            "top_faces",
            "tributary_areas",
        ],
        "solver": ["EmbeddedSolver", "SimulationError", "simulate"],
        "protocol_step": ["ProtocolSteps"],
        "checkpoint": ["CheckpointMismatch"],
        "indenter_contact": ["IndenterContact"],
        "node_stick": ["NodeStickContact"],
        "penalty_contact": ["PenaltyContact"],
        "penalty_newton": ["PenaltyNewton"],
        "run_records": ["IncrementState", "RunRecords"],
        "newton": ["Equilibrium", "IncrementFailed", "NewtonSystem"],
        "linear_steps": ["LinearSteps"],
        "sensitivity_solves": ["SensitivitySolves"],
        "threads": ["busy_cores", "solver_threads", "thread_limits"],
        "convergence.mesh_family": ["MeshFamily", "contact_family", "contact_mesh"],
        "mesh_presets": ["FIT_MESH", "HIGH_FIDELITY_MESH"],
        "convergence.gci": ["ConvergenceOfQuantity", "GridTriplet", "observed_order", "study_quantity"],
        "material": ["InvertedElementError"],
        "result": ["SimulationResult"],
        "fe_predictor": ["FESolverPredictor"],
        "predictor": [
            "CachedPredictor",
            "Prediction",
            "Predictor",
            "ReducedBasis",
            "ReducedPredictor",
        ],
        "convergence.richardson": ["RichardsonPredictor"],
        "febio.writer": ["FebSettings", "write_feb"],
        "febio.runner": ["FebioSolver", "find_febio"],
        "convergence.mesh_study": ["MeshErrors", "convergence_study", "mesh_errors"],
        "vtu_export": ["write_vtu_series"],
        "simulation_run": [
            "SimulationRun",
            "default_result_file",
            "feb_beside_log",
            "run_simulation",
            "termination_as_interrupt",
        ],
    },
)
