"""The inverse fit of an experiment (paper 2.8.2): the workflow, its pieces and its result.

What a fit reads (:mod:`.inputs`), Levenberg-Marquardt and Gauss-Newton on any Predictor
(:mod:`.inverse_fit`), the workflow ``fit_experiment`` (:mod:`.workflow`), its friction path
(:mod:`.friction`), whether mu is identified (:mod:`.mu_reach`), the model-error parts a fit carries
(:mod:`.error_parts`), the FE confirmation that ends a fit on a surrogate (:mod:`.confirm_stage`),
a surrogate fitted to FE runs it was not trained on (:mod:`.run_refits`) and the result, fit.json
(:mod:`.result`). The names are exported by
:mod:`indentation_studio.inference`.
"""
