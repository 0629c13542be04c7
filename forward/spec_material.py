"""The materials a model spec takes (:mod:`.spec`): the anisotropic Mooney-Rivlin model of eq. 3
(paper 2.5) and the phantom's composite of two constituents. Units: kPa."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .spec_checks import SpecError, finite, finite_positive

__all__ = [
    "BULK_TO_SHEAR",
    "PHANTOM_FIBERS",
    "PHANTOM_MATRIX",
    "CompositeMaterial",
    "Constituent",
    "Material",
]


@dataclass(frozen=True)
class Material:
    """Uncoupled fiber-reinforced neo-Hookean (eq. 3).

    FEBio's trans iso Mooney-Rivlin with c2 = 0 and lam_max = 1.

    Parameters
    ----------
    c1 : float, optional
        The matrix's modulus, kPa (> 0).
    c5 : float, optional
        The fibers' modulus, kPa (>= 0; 0 is isotropic).
    kappa : float, optional
        The bulk-like modulus, kPa.
    fiber : tuple of float, optional
        The reference fiber direction (normalised; the paper's +y).

    Raises
    ------
    SpecError
        A modulus out of range or a fiber that is not a finite non-zero 3-vector.
    """

    c1: float = 10.0
    c5: float = 350.0
    kappa: float = 1000.0
    fiber: tuple[float, float, float] = (0.0, 1.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "c1", finite_positive("material.c1", self.c1))
        object.__setattr__(self, "kappa", finite_positive("material.kappa", self.kappa))
        try:
            c5 = float(self.c5)
        except (TypeError, ValueError) as exc:
            raise SpecError("material.c5", f"must be a number, got {self.c5!r}") from exc
        if not math.isfinite(c5) or c5 < 0.0:
            raise SpecError("material.c5", f"must be finite and >= 0 (0: isotropic), got {self.c5!r}")
        object.__setattr__(self, "c5", c5)
        try:
            a = tuple(float(v) for v in self.fiber)
        except (TypeError, ValueError) as exc:
            raise SpecError("material.fiber", f"must be three numbers, got {self.fiber!r}") from exc
        norm = math.sqrt(sum(v * v for v in a)) if len(a) == 3 else 0.0
        if len(a) != 3 or not all(math.isfinite(v) for v in a) or norm == 0.0:
            raise SpecError("material.fiber", f"must be a finite non-zero 3-vector, got {self.fiber!r}")
        object.__setattr__(self, "fiber", tuple(v / norm for v in a))

    @property
    def theta(self) -> dict[str, float]:
        """The identified parameters theta = (c1, c5)."""
        return {"c1": self.c1, "c5": self.c5}


#: Bulk modulus of a composite's constituent, as a multiple of its initial shear modulus
#: 2 (c1 + c2), unless the spec gives kappa: the ratio of the paper's homogeneous model
#: (kappa = 1000 kPa, mu = 2 c1 = 20 kPa; Poisson's ratio 0.49), so that the composite and the
#: model fitted to it are equally compressible.
BULK_TO_SHEAR = 50.0


@dataclass(frozen=True)
class Constituent:
    """One material of the composite phantom (paper 2.4.2, 3.1).

    FEBio's uncoupled Mooney-Rivlin, W = c1 (I1~ - 3) + c2 (I2~ - 3) + kappa/2 (ln J)^2, plus
    eq. 2's fiber term c5 along ``Material.fiber`` where c5 > 0. A neo-Hookean solid of shear
    modulus mu is c1 = mu / 2, c2 = 0.

    Parameters
    ----------
    name : str
        A plain word (``"matrix"``, ``"fibers"``).
    c1, c2 : float
        kPa; c1 may be negative (the TPU fibers' c1 = -1227 kPa) as long as the initial shear
        modulus 2 (c1 + c2) is positive.
    c5 : float, optional
        The fiber term's modulus, kPa (>= 0).
    kappa : float or None, optional
        kPa; None: ``BULK_TO_SHEAR`` x 2 (c1 + c2).

    Raises
    ------
    SpecError
        A name that is not a plain word, a modulus out of range.
    """

    name: str
    c1: float
    c2: float = 0.0
    c5: float = 0.0
    kappa: float | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.isidentifier():
            raise SpecError("composite.name", f"a constituent's name must be a plain word, got {self.name!r}")
        for f in ("c1", "c2", "c5"):
            object.__setattr__(self, f, finite(f"composite.{self.name}.{f}", getattr(self, f)))
        if self.c5 < 0.0:
            raise SpecError(f"composite.{self.name}.c5", f"must be >= 0, got {self.c5!r}")
        if not self.shear_modulus > 0.0:
            raise SpecError(
                f"composite.{self.name}.c1",
                f"the initial shear modulus 2 (c1 + c2) must be positive, got 2 ({self.c1!r} + {self.c2!r})",
            )
        kappa = BULK_TO_SHEAR * self.shear_modulus if self.kappa is None else self.kappa
        object.__setattr__(self, "kappa", finite_positive(f"composite.{self.name}.kappa", kappa))

    @property
    def shear_modulus(self) -> float:
        """Initial shear modulus 2 (c1 + c2), kPa."""
        return 2.0 * (self.c1 + self.c2)


#: The phantom's constituents (paper 3.1, supplement S3): the Ecoflex matrix, neo-Hookean with
#: mu = 19.4 kPa, and the TPU fibers, Mooney-Rivlin with {c1, c2} = {-1227, 5945} kPa.
PHANTOM_MATRIX = Constituent("matrix", 9.7)


PHANTOM_FIBERS = Constituent("fibers", -1227.0, 5945.0)


@dataclass(frozen=True)
class CompositeMaterial:
    """The composite phantom's two materials (2.4.2).

    Element set 0 is the matrix, set 1 the fibers (:mod:`forward.composite_mesh`).

    Parameters
    ----------
    matrix, fibers : Constituent or dict, optional
        The constituents (the phantom's Ecoflex and TPU by default); a dict is a Constituent's
        fields.

    Raises
    ------
    SpecError
        A constituent that is not one, or two with the same name.
    """

    matrix: Constituent = PHANTOM_MATRIX
    fibers: Constituent = PHANTOM_FIBERS

    def __post_init__(self) -> None:
        for f in ("matrix", "fibers"):
            c = getattr(self, f)
            if isinstance(c, dict):
                c = Constituent(**{"name": f, **c})
                object.__setattr__(self, f, c)
            if not isinstance(c, Constituent):
                raise SpecError(f"composite.{f}", f"must be a Constituent, got {c!r}")
        if self.matrix.name == self.fibers.name:
            raise SpecError(
                "composite.fibers.name", f"the two constituents share the name {self.matrix.name!r}"
            )

    @property
    def constituents(self) -> tuple[Constituent, Constituent]:
        """(matrix, fibers), in element-set order."""
        return (self.matrix, self.fibers)
