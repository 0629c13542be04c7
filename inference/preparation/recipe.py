"""What a prepared test is made of: the test (indenter, protocol, specimen, contact) and its plan."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from ...forward.mesh_presets import CONTACT_MESH_LEVELS, FIT_MESH, HIGH_FIDELITY_MESH
from ...forward.spec import MeshChoice, ModelSpec

__all__ = ["TestRecipe"]

#: The shipped tests' budget points (c1 x c5, kPa) and levels: what a recipe with less says so.
SHIPPED_BUDGET_POINTS = 9
SHIPPED_BUDGET_FINEST = 4


@dataclass(frozen=True)
class TestRecipe:
    """A test and the plan that prepares it, as the shipped tests were prepared.

    Parameters
    ----------
    spec : ModelSpec
        The test: indenter, protocol (steps, step size), specimen (``geometry``), kappa, contact;
        its mesh and (c1, c5) are the plan's.
    low_mesh, high_mesh : str
        The fit's model and its high fidelity (``contact-L`` presets).
    stick_grid, test_grid, mu_grid, high_grid : str
        The campaigns' grids (``campaign run --grid``): the low level's stick, its held-out stick
        points, its (c1, c5, mu) points, and the high level's stick over the box.
    budget_points : tuple of (float, float)
        The verification study's points (c1, c5), kPa.
    budget_levels : tuple of int
        The study's levels of the contact family (the high level among them, a coarser one too).
    field_of_view_mm : float
        The DIC field of view the budget's fits read, mm.
    kfold : int
        Folds of the slip surrogate's held-out errors.
    """

    __test__ = False  # not a pytest class, whatever its name

    spec: ModelSpec = field(default_factory=ModelSpec)
    low_mesh: str = FIT_MESH
    high_mesh: str = HIGH_FIDELITY_MESH
    stick_grid: str = "c1=1:21:9:log,c5=82.5:578:9"
    test_grid: str = "lhs:32:5"
    mu_grid: str = "sobol:512:1,mu=0.1:3:log"
    high_grid: str = "c1=1:21:3:log,c5=82.5:578:3:log"
    budget_points: tuple[tuple[float, float], ...] = (
        (3.0, 120.0),
        (3.0, 540.0),
        (11.0, 330.0),
        (19.0, 120.0),
        (19.0, 540.0),
    )
    budget_levels: tuple[int, ...] = (0, 1, 2, 3)
    field_of_view_mm: float = 25.0
    kfold: int = 5

    def __post_init__(self) -> None:
        for mesh in (self.low_mesh, self.high_mesh):
            if mesh not in CONTACT_MESH_LEVELS:
                raise ValueError(
                    f"{mesh!r}: a prepared test's models are contact-L presets (its budget's family)"
                )
        high = CONTACT_MESH_LEVELS[self.high_mesh]
        levels = sorted(set(self.budget_levels))
        if high not in levels or levels.index(high) == 0 or len(levels) < 3:
            raise ValueError(
                f"budget levels {list(self.budget_levels)}: three or more, with the high level {high} and a coarser one"
            )
        if not self.budget_points:
            raise ValueError("a prepared test needs budget points")

    @property
    def name(self) -> str:
        """The test's name: ``test-R<R>-<N>x<h>-<W>x<D>x<T>``."""
        s, g = self.spec, self.spec.geometry
        return (
            f"test-R{s.indenter.radius:g}-{s.protocol.steps}x{s.protocol.step_size:g}-"
            f"{2 * g.half_x:g}x{2 * g.half_y:g}x{g.height:g}"
        )

    @property
    def high_level(self) -> int:
        """The high fidelity's level in the contact family."""
        return CONTACT_MESH_LEVELS[self.high_mesh]

    def model(self, mesh: str) -> ModelSpec:
        """The test's spec on ``mesh``, its contact the mesh's own where the test leaves it unsaid.

        Parameters
        ----------
        mesh : str
            A mesh preset.

        Returns
        -------
        ModelSpec
            The spec.
        """
        spec = replace(self.spec, mesh=MeshChoice(mesh))
        return ModelSpec.from_dict(spec.to_dict())

    def choices(self) -> list[str]:
        """What this plan does with less than the shipped tests' study, in words (the manifest keeps them)."""
        out = []
        finest = max(self.budget_levels)
        if len(self.budget_points) < SHIPPED_BUDGET_POINTS:
            out.append(
                f"the error budget is measured at {len(self.budget_points)} points (the shipped tests: "
                f"{SHIPPED_BUDGET_POINTS}); outside their hull a fit reads the largest of the nearest points' "
                "budget and says it lies outside the verified region"
            )
        if finest < SHIPPED_BUDGET_FINEST:
            out.append(
                f"the study's finest level is {finest} (the shipped R = 8 mm test: level {SHIPPED_BUDGET_FINEST}): "
                f"level {self.high_level}'s fit is not corrected, its own GCI is carried by the study's rule "
                "(factor of safety 3 outside the asymptotic range, the order held to [1, 2]), so the bounds are "
                "never narrower for it"
            )
        return out

    def to_dict(self) -> dict[str, Any]:
        """The recipe as recipe.json keeps it."""
        return {
            "spec": self.spec.to_dict(),
            "low_mesh": self.low_mesh,
            "high_mesh": self.high_mesh,
            "stick_grid": self.stick_grid,
            "test_grid": self.test_grid,
            "mu_grid": self.mu_grid,
            "high_grid": self.high_grid,
            "budget_points": [list(p) for p in self.budget_points],
            "budget_levels": list(self.budget_levels),
            "field_of_view_mm": self.field_of_view_mm,
            "kfold": self.kfold,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TestRecipe:
        """A recipe from :meth:`to_dict`.

        Parameters
        ----------
        data : dict
            What :meth:`to_dict` wrote.

        Returns
        -------
        TestRecipe
            The recipe.
        """
        values = dict(data) | {
            "spec": ModelSpec.from_dict(data["spec"]),
            "budget_points": tuple(tuple(float(v) for v in p) for p in data["budget_points"]),
            "budget_levels": tuple(int(v) for v in data["budget_levels"]),
        }
        return cls(**values)
