"""Error budgets: every budget a fit's bounds carry, computed, checked and combined.

A budget computed from a reference campaign (:mod:`.error_budget`; its table :mod:`.budget_table`,
the models it fits :mod:`.budget_models`, the campaign's budget written and resumed
:mod:`.campaign_budget`) or from a verification study (:mod:`.verification_study`,
:mod:`.study_budget`), the mesh check at a fit (:mod:`.mesh_check`), whether a fit has a budget for
its model (:mod:`.check`), and the model error carried into the bounds (:mod:`.model_error`; its
parts and their sum :mod:`.model_error_parts`, an output change's move of the fit
:mod:`.fit_moves`, what freeing mu adds to the mesh's error :mod:`.freed_mu_moves`). The budgets a surrogate carries are read from their files by
:mod:`indentation_studio.surrogate.error_budgets`. The names are exported by
:mod:`indentation_studio.inference`.
"""
