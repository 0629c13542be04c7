"""The studio: the ``indent-studio`` command line, figures (functions that return matplotlib
Figures), the HTML report and the demo."""

import lazy_loader as lazy

__getattr__, __dir__, __all__ = lazy.attach(
    __name__,
    submodules=["figures"],
    submod_attrs={
        "figures": [
            "campaign_figure",
            "budget_map_figure",
            "corner_figure",
            "design_comparison_figure",
            "displacement_maps_figure",
            "equibiaxial_figure",
            "force_depth_figure",
            "mesh_figure",
            "objective_map_figure",
            "parity_figure",
            "posterior_corner_figure",
            "save_figure",
            "verification_figure",
        ],
        "demo": ["run_demo"],
    },
)
