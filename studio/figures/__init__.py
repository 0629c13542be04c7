"""Figures of the studio, in the style of corner.py: each function returns a matplotlib Figure (shown
inline in a notebook); saving is the caller's (:func:`save_figure`), and the backend is chosen by
whoever runs them (the CLI's entry point sets Agg). The numerics come from the packages.

One module a family: :mod:`.design` (the objective's map, the design comparison),
:mod:`.posterior` (the corner plot), :mod:`.responses` (force, displacements, parity),
:mod:`.campaign` (a campaign's points, the mesh), :mod:`.validation` (the composite, the
verification study, the model-error budget) and :mod:`.saving`; every name is imported from here
(``studio.figures.corner_figure``) as it was when they were one module."""

from .campaign import campaign_figure, mesh_figure
from .design import certainty_ellipse, design_comparison_figure, objective_map_figure
from .posterior import corner_figure, posterior_corner_figure
from .responses import displacement_maps_figure, force_depth_figure, parity_figure
from .saving import save_figure
from .validation import (
    budget_map_figure,
    composite_comparison_figure,
    equibiaxial_figure,
    verification_figure,
)

__all__ = [
    "budget_map_figure",
    "campaign_figure",
    "certainty_ellipse",
    "composite_comparison_figure",
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
]
