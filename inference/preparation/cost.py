"""What preparing a test costs, from measured per-run costs, before it starts."""

from __future__ import annotations

from dataclasses import dataclass, field

from ...campaign.designs import design_from_option
from ...forward.mesh_presets import CONTACT_MESH_LEVELS
from .recipe import TestRecipe

__all__ = ["PER_RUN_S", "CostEstimate", "estimate_cost"]

#: Seconds of one run on one core at the paper's test (28 steps of 0.5 mm), by contact-family level,
#: with the stick: contact-L1 measured again after issue 58's solver changes (2026-11-29, CPU
#: seconds with sensitivities, R = 4.77 mm, the (c1, c5) of the shipped mu campaign's first 24
#: Sobol points: 6.2 s a point, 3.9 to 8.7 s; the shipped campaigns had taken 12.1 and 17.4 s at
#: R = 8 and 4.77 mm, indentation_studio/surrogates/manifest.json); the finer levels as measured
#: before those changes, which made them cheaper (contact-L3 522 and 566 s in the shipped
#: surrogates' campaigns; the verification study at R = 8 mm,
#: docs/validation/data/verification-contact-L4-R8.json: levels 0 to 4 2.0, 8.4, 51, 994 and
#: 4,178 s at {3, 120} kPa, the soft corner; about a quarter of that at c1 = 11 kPa).
#: The soft corner costs far more at the fine levels: contact-L3 over the paper's box at R = 4.77 mm
#: (docs/validation/data/campaigns/high-box-R4.77, 2026-11-29) took 3,300 to 6,900 s a run at
#: c1 = 1 kPa and 90 to 200 s at c1 >= 4.6 kPa (the printout says so; not in the estimate).
PER_RUN_S = {0: 2.0, 1: 6.5, 2: 51.0, 3: 550.0, 4: 2500.0}
#: A run with friction against the stick at the same level: contact-L1, the same 24 points with
#: their mu (0.1 to 3, log-uniform), 13.0 s a point against 6.2 s (2026-11-29; 1.5 times at the
#: median point, up to 9.9 times where mu is 0.1 to 0.25 and most of the contact slips).
FRICTION_FACTOR = 2.1
#: A run with sensitivities against one without (a verification study's fitting level).
SENSITIVITY_FACTOR = 1.8


@dataclass(frozen=True)
class CostEstimate:
    """Runs and CPU seconds of each stage of a preparation, and the wall time on some cores.

    Attributes
    ----------
    stages : dict
        Stage name to ``(runs, cpu_s)``.
    cores : int
        The cores (or dask workers) the wall time is for.
    """

    stages: dict[str, tuple[int, float]] = field(default_factory=dict)
    cores: int = 2

    @property
    def cpu_s(self) -> float:
        """Every stage's CPU seconds."""
        return float(sum(s for _, s in self.stages.values()))

    @property
    def wall_s(self) -> float:
        """The wall time: the campaigns over ``cores``, the study's runs one after another."""
        study = sum(s for name, (_, s) in self.stages.items() if name.startswith("study"))
        return float((self.cpu_s - study) / max(self.cores, 1) + study)

    def describe(self) -> str:
        """The estimate in words, as the command prints it before it starts."""
        parts = ", ".join(f"{name} {n} runs {s / 3600:.1f} h" for name, (n, s) in self.stages.items())
        return (
            f"estimated cost: {self.cpu_s / 3600:.1f} CPU hours ({parts}); about {self.wall_s / 3600:.1f} h of wall "
            f"time on {self.cores} cores (from measured per-run costs at the paper's test, scaled by the steps; "
            "a soft material's run costs more: at level 3, c1 = 1 kPa 6 to 13 times the average)"
        )

    def to_dict(self) -> dict:
        """The estimate as the manifest keeps it."""
        return {
            "stages": {k: {"runs": n, "cpu_s": s} for k, (n, s) in self.stages.items()},
            "cpu_s": self.cpu_s,
            "wall_s": self.wall_s,
            "cores": self.cores,
        }


def estimate_cost(recipe: TestRecipe, *, cores: int = 2) -> CostEstimate:
    """The cost of preparing ``recipe``'s test, from :data:`PER_RUN_S`.

    Parameters
    ----------
    recipe : TestRecipe
        The test and its plan.
    cores : int, default 2
        Cores (or dask workers) the campaigns run on.

    Returns
    -------
    CostEstimate
        Runs and CPU seconds by stage.

    Examples
    --------
    >>> from indentation_studio.inference.preparation import TestRecipe, estimate_cost
    >>> cost = estimate_cost(TestRecipe())
    >>> cost.stages["mu campaign"]
    (512, 6988.8)
    """
    scale = recipe.spec.protocol.steps / 28.0
    low, high = CONTACT_MESH_LEVELS[recipe.low_mesh], CONTACT_MESH_LEVELS[recipe.high_mesh]

    def runs(grid: str) -> int:
        return len(design_from_option(grid).points)

    stages = {
        "stick campaign": (runs(recipe.stick_grid), PER_RUN_S[low]),
        "held-out campaign": (runs(recipe.test_grid), PER_RUN_S[low]),
        "mu campaign": (runs(recipe.mu_grid), FRICTION_FACTOR * PER_RUN_S[low]),
        "high campaign": (runs(recipe.high_grid), PER_RUN_S[high]),
    }
    out = {name: (n, n * each * scale) for name, (n, each) in stages.items()}
    points = len(recipe.budget_points)
    for level in sorted(recipe.budget_levels):
        each = PER_RUN_S[level] * (SENSITIVITY_FACTOR if level == max(recipe.budget_levels) else 1.0)
        out[f"study level {level}"] = (points, points * each * scale)
    return CostEstimate(out, int(cores))
