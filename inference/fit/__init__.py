"""The inverse fit of an experiment (paper 2.8.2): the workflow, its pieces and its result.

What a fit reads (:mod:`.inputs`), Levenberg-Marquardt and Gauss-Newton on any Predictor
(:mod:`.inverse_fit`), the FE confirmation that ends a fit on a surrogate (:mod:`.confirm_stage`),
and the fit of an experiment. The names are exported by :mod:`indentation_studio.inference`.
"""
