"""Posteriors: the sampler of theta given a measurement, and the workflow for an experiment.

The emcee sampler and its checks (:mod:`.sampling`), the posterior of a measured experiment on
its surrogate (:mod:`.workflow`) and what it returns and writes (:mod:`.experiment_posterior`). The names are exported by :mod:`indentation_studio.inference`.
"""
