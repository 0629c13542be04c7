"""How the difference between two levels' runs of the stick (force and top field, at the
surrogate's nodes) moves a plain fit to first order, with mu held and with mu free: the error
budget is measured with mu held, the plain fit frees mu (docs/validation/model-error.md, "Why the
local part still cannot land").

    .venv/bin/python benchmarks/probes/mu_free_moves.py EXPERIMENT_DIR L3.npz L4.npz

EXPERIMENT_DIR holds the plain fit (``indent-studio fit --experiment DIR --out DIR/fit``); L3 and
L4 are the coarse and the fine run of the same point. A fit with the coarse level's model of data
made by the fine level moves as its prediction moves by (coarse - fine).
"""

import json
import sys

import numpy as np

from indentation_studio.forward.result import SimulationResult
from indentation_studio.inference.budgets.fit_moves import fit_moves
from indentation_studio.inference.budgets.mesh_check import prediction_at_nodes
from indentation_studio.inference.fit.inputs import prepare_fit

experiment, coarse, fine = sys.argv[1:4]
fit = json.loads(open(f"{experiment}/fit/fit.json").read())
inputs = prepare_fit(experiment)
surrogate = inputs.surrogate
theta = np.array([fit["model_fit"]["c1"], fit["model_fit"]["c5"], fit["friction"]["mu"]])
at_coarse = prediction_at_nodes(SimulationResult.load(coarse), surrogate.top_xyz)
at_fine = prediction_at_nodes(SimulationResult.load(fine), surrogate.top_xyz)
moved = np.concatenate(
    [
        np.log(at_coarse.force[0]) - np.log(at_fine.force[0]),
        (at_coarse.displacement[0] - at_fine.displacement[0]).ravel(),
    ]
)[None]
for free in (2, 3):
    move = fit_moves(inputs.objective, inputs.eta, surrogate, theta, free, moved)[0]
    print(
        f"{'mu held' if free == 2 else 'mu free'}: d log theta = {np.round(100 * move, 2)} % at {np.round(theta, 3)}"
    )
