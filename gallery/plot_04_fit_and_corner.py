"""
A fit and its corner plot
=========================

A synthetic experiment at the truth (12, 250) kPa, a GP surrogate of a small campaign, the inverse
fit (Levenberg-Marquardt on the surrogate, then on the FE model with the friction coefficient mu
marginalised) and the posterior of (c1, c5) sampled with emcee on the surrogate. Everything is on
the coarse mesh with 4 steps, so the data and the fit share their mesh and only the noise separates
them (:doc:`../guide/fit-and-posterior`).
"""

import tempfile

import numpy as np

import indentation_studio as ins

spec = ins.ModelSpec(mesh=ins.MeshChoice("coarse"), protocol=ins.Protocol(steps=4))
truth = np.array([12.0, 250.0])
experiment = ins.write_synthetic_experiment(
    ins.FESolverPredictor(spec), truth, tempfile.mkdtemp(), radius=4.77, step_size=0.5
)
runs = tempfile.mkdtemp()
ins.run_named_campaign("fit", "c1=6:18:4,c5=120:480:4", spec, runs_dir=runs, jobs=2)
gp = ins.train_surrogate("fit", "gp", runs_dir=runs)

# %%
# The fit: theta, its 95 % bounds (eq. 6 to 8) and what they assume about the contact.
result = ins.fit_experiment(experiment, gp)
print("theta", result.theta.round(3), "kPa; bounds +-", result.bounds_pct.round(2), "%;", result.contact)
print("mu 95 % interval:", result.to_dict()["friction"]["mu_interval"])

# %%
# The posterior on the surrogate, with the fit and the truth marked.
posterior = ins.sample_posterior_for(experiment, gp, walkers=16, steps=300, fit=result.surrogate_fit)
print("95 % intervals:", posterior.to_dict()["ci95"])
fig = ins.figures.corner_figure(posterior.posterior, result.theta, truth=truth)
