"""The test a model spec describes (:mod:`.spec`): the block, the indenter and the protocol of
steps. Units: mm."""

from __future__ import annotations

from dataclasses import dataclass, fields

from .spec_checks import SpecError, finite_positive

__all__ = ["INDENTER_PRESETS", "MAX_DEPTH_FRACTION", "Geometry", "Indenter", "Protocol"]


#: Indenter radii of the paper's two spheres (9.5 mm and 16 mm diameter), mm.
INDENTER_PRESETS: dict[str, float] = {"small": 4.77, "large": 8.0}


#: Deepest indentation accepted, as a fraction of the block height.
MAX_DEPTH_FRACTION = 0.5


@dataclass(frozen=True)
class Geometry:
    """The quarter block: x in [0, half_x], y in [0, half_y], z in [0, height], mm.

    The full specimen is 100 x 100 x 60 mm; symmetry planes x = 0 and y = 0 cut it to a quarter.

    Parameters
    ----------
    half_x, half_y : float, optional
        Half the specimen's width along x and y, mm.
    height : float, optional
        The specimen's height, mm.

    Raises
    ------
    SpecError
        A size that is not finite and positive.
    """

    half_x: float = 50.0
    half_y: float = 50.0
    height: float = 60.0

    def __post_init__(self) -> None:
        for f in fields(self):
            object.__setattr__(self, f.name, finite_positive(f"geometry.{f.name}", getattr(self, f.name)))


@dataclass(frozen=True)
class Indenter:
    """A rigid sphere, lowest point touching the top face at (0, 0, height) at depth 0.

    Parameters
    ----------
    radius : float, optional
        mm (the paper's spheres: 4.77 and 8).

    Raises
    ------
    SpecError
        A radius that is not finite and positive.
    """

    radius: float = INDENTER_PRESETS["small"]

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", finite_positive("indenter.radius", self.radius))

    @classmethod
    def preset(cls, name: str) -> Indenter:
        """One of the paper's two spheres by name.

        Parameters
        ----------
        name : {"small", "large"}
            4.77 or 8 mm.

        Returns
        -------
        Indenter

        Raises
        ------
        SpecError
            An unknown name.
        """
        if name not in INDENTER_PRESETS:
            raise SpecError("indenter.radius", f"unknown preset {name!r}; use {sorted(INDENTER_PRESETS)}")
        return cls(INDENTER_PRESETS[name])


@dataclass(frozen=True)
class Protocol:
    """Quasi-static indentation in equal steps (paper 2.7: 28 steps of 0.5 mm).

    Parameters
    ----------
    step_size : float, optional
        Depth per step, mm.
    steps : int, optional
        Number of steps.

    Raises
    ------
    SpecError
        A step size that is not finite and positive, or steps not a whole number >= 1.
    """

    step_size: float = 0.5
    steps: int = 28

    def __post_init__(self) -> None:
        object.__setattr__(self, "step_size", finite_positive("protocol.step_size", self.step_size))
        if isinstance(self.steps, bool) or int(self.steps) != self.steps or self.steps < 1:
            raise SpecError("protocol.steps", f"must be a whole number >= 1, got {self.steps!r}")
        object.__setattr__(self, "steps", int(self.steps))

    @property
    def max_depth(self) -> float:
        """The deepest indentation, mm."""
        return self.step_size * self.steps

    @property
    def depths(self) -> list[float]:
        """Depths at the end of each step, mm (depth 0 excluded)."""
        return [self.step_size * (k + 1) for k in range(self.steps)]
