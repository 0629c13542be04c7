"""
A campaign and its surrogate
============================

A 5 x 5 grid of (c1, c5) simulated on the coarse mesh into a resumable campaign store, a held-out
Latin hypercube of 6 points, and a Gaussian-process surrogate trained on the grid and checked on
the held-out points (:doc:`../guide/campaign`, :doc:`../guide/surrogates`).
"""

import tempfile

import indentation_studio as ins

runs = tempfile.mkdtemp()
spec = ins.ModelSpec(mesh=ins.MeshChoice("coarse"), protocol=ins.Protocol(steps=4))
for name, grid in (("train", "c1=4:16:5,c5=150:500:5"), ("test", "lhs:6:1")):
    summary = ins.run_named_campaign(name, grid, spec, runs_dir=runs, jobs=2)
    print(name, summary["done"], "points,", summary["failed"], "failed")
train, test = ins.load_campaign("train", runs), ins.load_campaign("test", runs)

# %%
# The surrogate's force against the simulated force at the held-out points.
gp = ins.train_surrogate(train, "gp", test_campaign=test)
print({key: round(value, 4) for key, value in gp.meta["validation"]["test"].items()})
predicted = gp.predict(test.theta)
fig = ins.figures.parity_figure({"force (mN)": (test.force, predicted.force)})
