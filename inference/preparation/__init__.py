"""Your own test: one command prepares what a shipped test has (docs/guide/own-test.md).

The fit's model's stick and mu campaigns, the high fidelity's campaign over the box, the error
budget's verification study and budget, the multi-fidelity surrogate, and a manifest (recipe,
versions, sha256) that ``fit``, ``posterior`` and ``confirm`` check before they use it."""

from .cost import PER_RUN_S, CostEstimate, estimate_cost
from .recipe import TestRecipe
from .workflow import PreparedTest, prepare_test

__all__ = ["PER_RUN_S", "CostEstimate", "PreparedTest", "TestRecipe", "estimate_cost", "prepare_test"]
