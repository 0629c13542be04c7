"""Posteriors: the sampler of theta given a measurement, and the workflow for an experiment.

The emcee sampler and its checks (:mod:`.sampling`) and the posterior of a measured experiment on
its surrogate (:mod:`.workflow`). The names are exported by :mod:`indentation_studio.inference`.
"""
