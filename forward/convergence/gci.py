"""Grid convergence as the V&V literature measures it: the observed order of accuracy, Richardson's
extrapolated value and Roache's grid convergence index (GCI) from a family of systematically
refined solutions.

For three solutions f1 (finest), f2, f3 of one quantity on meshes of representative cell sizes
h1 < h2 < h3 with ratios r21 = h2 / h1 and r32 = h3 / h2 (Celik et al., J. Fluids Eng. 130 (2008)
078001, the ASME procedure; P. J. Roache, *Verification and Validation in Computational Science
and Engineering*, 1998; ASME V&V 20-2009):

    e21 = f2 - f1,  e32 = f3 - f2,  s = sign(e32 / e21)
    p = | ln|e32 / e21| + q(p) | / ln r21,   q(p) = ln((r21^p - s) / (r32^p - s))
    f_ext = (r21^p f1 - f2) / (r21^p - 1)
    GCI_21 = Fs |(f1 - f2) / f1| / (r21^p - 1),   Fs = 1.25 (three or more meshes)

q is 0 when the ratio is constant, and p is then found in closed form; otherwise by fixed-point
iteration. s < 0 is oscillatory convergence, where p and the GCI are not to be trusted. The
levels are in the asymptotic range when two observed orders from overlapping triplets agree
(this module's :func:`study_quantity` reports both and their difference).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

__all__ = [
    "ConvergenceOfQuantity",
    "GridTriplet",
    "observed_order",
    "representative_size",
    "study_quantity",
]

#: Roache's safety factor of the GCI for three or more meshes (1.25) and for two (3).
SAFETY_THREE_MESHES = 1.25
SAFETY_TWO_MESHES = 3.0


def representative_size(volume: float, elements: int) -> float:
    """The representative cell size h = (V / N)^(1/3) of a 3D mesh of ``elements`` cells (mm)."""
    if not (volume > 0 and elements > 0):
        raise ValueError(f"volume and element count must be positive, got {volume!r}, {elements!r}")
    return float((volume / elements) ** (1.0 / 3.0))


@dataclass(frozen=True)
class GridTriplet:
    """The convergence of one quantity over three meshes (f1 finest).

    Attributes
    ----------
    values : tuple of float
        (f1, f2, f3).
    sizes : tuple of float
        (h1, h2, h3), mm.
    order : float
        The observed order p (nan where the differences vanish).
    oscillatory : bool
        The differences change sign (s < 0).
    extrapolated : float
        The extrapolated value.
    gci_fine_pct : float
        GCI_21 of the finest mesh, % of f1.
    gci_coarse_pct : float
        GCI_32 of the middle mesh, % of f2.
    asymptotic_ratio : float
        GCI_32 / (r21^p GCI_21): 1 in the asymptotic range.
    """

    values: tuple[float, float, float]
    sizes: tuple[float, float, float]
    order: float  # observed order p (nan where the differences vanish)
    oscillatory: bool  # s < 0
    extrapolated: float
    gci_fine_pct: float  # GCI_21 of the finest mesh, % of f1
    gci_coarse_pct: float  # GCI_32 of the middle mesh, % of f2
    asymptotic_ratio: float  # GCI_32 / (r21^p GCI_21): 1 in the asymptotic range


def observed_order(
    values: Sequence[float],
    sizes: Sequence[float],
    *,
    max_order: float = 20.0,
    iterations: int = 100,
) -> GridTriplet:
    """Observed order, extrapolated value and GCI of three solutions (Celik et al. 2008).

    Parameters
    ----------
    values : three numbers
        The quantity on the finest, middle and coarsest mesh.
    sizes : three numbers
        Their representative cell sizes, h1 < h2 < h3.
    max_order : float, optional
        Orders are clipped here (a near-zero e21 makes p huge).
    iterations : int, optional
        Fixed-point iterations for a ratio that is not constant.

    Returns
    -------
    GridTriplet
        The order, extrapolated value and GCIs.

    Raises
    ------
    ValueError
        If the sizes do not grow from the finest mesh.

    Examples
    --------
    >>> from indentation_studio.forward import observed_order
    >>> round(observed_order([1.01, 1.04, 1.16], [1.0, 2.0, 4.0]).order, 3)
    2.0
    """
    f1, f2, f3 = (float(v) for v in values)
    h1, h2, h3 = (float(h) for h in sizes)
    if not (0 < h1 < h2 < h3):
        raise ValueError(f"sizes must grow from the finest mesh: got {h1:g}, {h2:g}, {h3:g}")
    r21, r32 = h2 / h1, h3 / h2
    e21, e32 = f2 - f1, f3 - f2
    nan = float("nan")
    if e21 == 0.0 or e32 == 0.0 or not np.isfinite(e21 * e32):
        return GridTriplet(
            (f1, f2, f3),
            (h1, h2, h3),
            order=nan,
            oscillatory=False,
            extrapolated=f1,
            gci_fine_pct=0.0 if e21 == 0 else nan,
            gci_coarse_pct=nan,
            asymptotic_ratio=nan,
        )
    s = float(np.sign(e32 / e21))
    p = abs(np.log(abs(e32 / e21))) / np.log(r21)
    for _ in range(iterations):
        if abs(r21 - r32) < 1e-12:
            break
        q = np.log((r21**p - s) / (r32**p - s)) if (r32**p - s) > 0 and (r21**p - s) > 0 else 0.0
        p_new = abs(np.log(abs(e32 / e21)) + q) / np.log(r21)
        if abs(p_new - p) < 1e-12:
            p = p_new
            break
        p = p_new
    p = float(min(p, max_order))
    rp21, rp32 = r21**p, r32**p
    extrapolated = (rp21 * f1 - f2) / (rp21 - 1.0) if rp21 > 1 else nan
    gci21 = SAFETY_THREE_MESHES * abs(e21 / f1) / (rp21 - 1.0) if f1 != 0 and rp21 > 1 else nan
    gci32 = SAFETY_THREE_MESHES * abs(e32 / f2) / (rp32 - 1.0) if f2 != 0 and rp32 > 1 else nan
    ratio = gci32 / (rp21 * gci21) * abs(f2 / f1) if gci21 and np.isfinite(gci21) and f1 != 0 else nan
    return GridTriplet(
        (f1, f2, f3),
        (h1, h2, h3),
        order=p,
        oscillatory=s < 0,
        extrapolated=float(extrapolated),
        gci_fine_pct=100.0 * float(gci21),
        gci_coarse_pct=100.0 * float(gci32),
        asymptotic_ratio=float(ratio),
    )


@dataclass(frozen=True)
class ConvergenceOfQuantity:
    """The convergence of one quantity over a family of meshes (finest first).

    Every level's value, the observed orders of the overlapping triplets, and, for each level,
    its error against the extrapolated value of the finest triplet and its GCI (% of its own
    value) with that triplet's order.

    Attributes
    ----------
    name : str
        The quantity.
    sizes : tuple of float
        The representative cell size of each level, finest first, mm.
    values : tuple of float
        The quantity on each level.
    triplets : tuple of GridTriplet
        The overlapping triplets (1, 2, 3), (2, 3, 4), ...
    orders : tuple of float
        Their observed orders.
    order_spread : float
        |p_123 - p_234| (nan with three levels).
    asymptotic : bool
        Every triplet monotone and the two finest orders agree within the tolerance.
    extrapolated : float
        The finest triplet's extrapolated value.
    error_pct : tuple of float
        100 (f_k - f_ext) / f_ext per level.
    gci_pct : tuple of float
        Per level, % of its value: its GCI with the next coarser level.
    """

    name: str
    sizes: tuple[float, ...]
    values: tuple[float, ...]
    triplets: tuple[GridTriplet, ...]  # (1, 2, 3), (2, 3, 4), ...
    orders: tuple[float, ...]
    order_spread: float  # |p_123 - p_234| (nan with three levels)
    asymptotic: bool  # every triplet monotone and the two finest orders agree within the tolerance
    extrapolated: float
    error_pct: tuple[float, ...]  # 100 (f_k - f_ext) / f_ext per level
    gci_pct: tuple[float, ...]  # per level, % of its value: its GCI with the next coarser level

    def to_dict(self) -> dict:
        """The convergence as a JSON-ready dict (the triplets as dicts too).

        Returns
        -------
        dict
            Every field.
        """
        d = asdict(self)
        d["triplets"] = [asdict(t) for t in self.triplets]
        return d


def study_quantity(
    name: str,
    values: Sequence[float],
    sizes: Sequence[float],
    *,
    order_tolerance: float = 0.5,
) -> ConvergenceOfQuantity:
    """The convergence of one quantity over a family of three or more meshes, finest first.

    Parameters
    ----------
    name : str
        What the quantity is (for tables).
    values, sizes : sequences of the same length >= 3
        The quantity and the representative cell size on each mesh, finest first.
    order_tolerance : float, optional
        The two finest triplets' orders must agree within this for the asymptotic range (0.5).

    Returns
    -------
    ConvergenceOfQuantity
        The GCI of level k uses the next coarser level and the finest triplet's order,
        Fs |f_k - f_{k+1}| / |f_k| / (r^p - 1) (% of f_k; the finest level's is GCI_21); the
        coarsest level's is Roache's coarse-grid GCI with the next finer, Fs |e| r^p / (r^p - 1).

    Raises
    ------
    ValueError
        If there are fewer than three levels or values and sizes differ in length.
    """
    v = [float(x) for x in values]
    h = [float(x) for x in sizes]
    if len(v) != len(h) or len(v) < 3:
        raise ValueError(f"need three or more levels with one size each, got {len(v)} values, {len(h)} sizes")
    triplets = tuple(observed_order(v[k : k + 3], h[k : k + 3]) for k in range(len(v) - 2))
    orders = tuple(t.order for t in triplets)
    spread = abs(orders[0] - orders[1]) if len(orders) > 1 else float("nan")
    monotone = not any(t.oscillatory for t in triplets[:2])
    asymptotic = bool(
        monotone and len(orders) > 1 and np.isfinite(spread) and spread <= order_tolerance and orders[0] > 0
    )
    finest = triplets[0]
    ext = finest.extrapolated
    error = tuple(100.0 * (x - ext) / ext if ext else float("nan") for x in v)
    p = finest.order
    gci = []
    for k in range(len(v)):
        pair, fine_grid = (k + 1, True) if k + 1 < len(v) else (k - 1, False)
        r = max(h[k], h[pair]) / min(h[k], h[pair])
        rp = r**p if np.isfinite(p) else float("nan")
        factor = 1.0 if fine_grid else rp  # Roache's coarse-grid GCI carries r^p
        gci.append(
            100.0 * SAFETY_THREE_MESHES * factor * abs(v[k] - v[pair]) / abs(v[k]) / (rp - 1.0)
            if v[k] != 0 and rp > 1
            else float("nan")
        )
    return ConvergenceOfQuantity(
        name,
        tuple(h),
        values=tuple(v),
        triplets=triplets,
        orders=orders,
        order_spread=spread,
        asymptotic=asymptotic,
        extrapolated=ext,
        error_pct=error,
        gci_pct=tuple(gci),
    )
