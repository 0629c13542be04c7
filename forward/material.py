"""Uncoupled fiber-reinforced Mooney-Rivlin material (paper eq. 2, 3; Appendix A; 2.4.2).

FEBio's ``trans iso Mooney-Rivlin`` with lam_max = 1 (Appendix A, eq. A.3):

    W = c1 (I1~ - 3) + c2 (I2~ - 3) + W_f(lam~) + kappa/2 (ln J)^2,
    W_f = c5 (lam~ - 1) - c5 ln lam~  for lam~ > 1, else 0,       lam~^2 = I4~ = a0 . C~ a0,

with C~ = J^(-2/3) C, I2~ = J^(-4/3) I2. The homogeneous model of eq. 3 is c2 = 0; the composite
phantom's constituents (2.4.2) are the neo-Hookean matrix (c2 = c5 = 0) and the Mooney-Rivlin
fibers (c5 = 0), FEBio's uncoupled ``Mooney-Rivlin``. The moduli may be arrays broadcast over
the points' leading axes (one value per element: a composite). Everything is written in the total-Lagrangian pair (F, P = dW/dF,
A = d2W/dF dF), vectorised over any leading axes (elements, Gauss points). The volumetric term
is kept separate because the element applies it to the element's mean dilatation (three-field
hex8, :mod:`forward.hex8_mean_dilatation`).

Also the closed-form incompressible stress-stretch relations of eq. 2 (supplement S2; eq. 10a,
10b for equibiaxial stretch) used to check the solver and to fit constituent data.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .spec import Material

_I3 = np.eye(3)


@dataclass(frozen=True)
class DeviatoricResponse:
    """Isochoric part at each point: energy, PK1 stress, tangent d2W/dF dF and dP/d(c1, c5)."""

    energy: np.ndarray  # (...)
    P: np.ndarray  # (..., 3, 3)
    A: np.ndarray | None  # (..., 3, 3, 3, 3), A[i,J,k,L] = d2W / dF_iJ dF_kL
    dP_dtheta: np.ndarray | None  # (..., 2, 3, 3): dP/dc1, dP/dc5


def _isochoric_invariant(
    I: np.ndarray,
    G: np.ndarray,
    GG: np.ndarray | None,
    m: np.ndarray,
    H: np.ndarray,
    HH: np.ndarray | None,
    HxH: np.ndarray | None,
    a: float = -2.0 / 3.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """I~ = J^a I with its first and second derivatives with respect to F (a = -2/3 for I1 and
    I4, -4/3 for I2).

    ``G`` = dI/dF, ``GG`` = d2I/dF2, ``m`` = J^a, ``H`` = F^-T, ``HH`` = H_iJ H_kL,
    ``HxH`` = H_kJ H_iL (from d F^-T / dF).
    """
    It = m * I
    dIt = m[..., None, None] * (G + a * I[..., None, None] * H)
    if GG is None:
        return It, dIt, None
    HG = H[..., :, :, None, None] * G[..., None, None, :, :]
    GH = G[..., :, :, None, None] * H[..., None, None, :, :]
    I4 = I[..., None, None, None, None]
    d2 = GG + a * (HG + GH) + (a * a) * I4 * HH - a * I4 * HxH
    return It, dIt, m[..., None, None, None, None] * d2


def _per_point(value: np.ndarray | float, extra: int) -> np.ndarray:
    """A modulus (scalar or one per point) with ``extra`` trailing axes to broadcast with."""
    v = np.asarray(value, dtype=float)
    return v.reshape(v.shape + (1,) * extra)


class InvertedElementError(ArithmeticError):
    """A deformation with det F <= 0 (or not finite) at a Gauss point or over an element.

    The solver halves the increment that made it.

    Parameters
    ----------
    where : str, default "element"
        What inverted, for the message.
    """

    def __init__(self, where: str = "element") -> None:
        super().__init__(f"inverted or degenerate {where}: det F <= 0")


def deviatoric_response(
    F: np.ndarray,
    c1: np.ndarray | float,
    c5: np.ndarray | float,
    fiber: np.ndarray,
    tangent: bool = True,
    parameter_derivatives: bool = False,
    c2: np.ndarray | float = 0.0,
) -> DeviatoricResponse:
    """Isochoric part of eq. 3 (with the Mooney-Rivlin term c2 (I2~ - 3) where ``c2`` is not 0)
    at deformation gradients ``F`` (..., 3, 3); the moduli are scalars or arrays of F's leading
    shape (or broadcastable to it)."""
    F = np.asarray(F, dtype=float)
    a0 = np.asarray(fiber, dtype=float)
    J = np.linalg.det(F)
    if np.any(~np.isfinite(J)) or np.any(J <= 0.0):
        raise InvertedElementError()
    H = np.linalg.inv(F).swapaxes(-1, -2)
    m = J ** (-2.0 / 3.0)
    HH = HxH = None
    if tangent:
        HH = H[..., :, :, None, None] * H[..., None, None, :, :]
        HxH = np.einsum("...kJ,...iL->...iJkL", H, H)

    # I1 = F:F, dI1/dF = 2F, d2I1 = 2 delta_ik delta_JL
    I1 = np.einsum("...iJ,...iJ->...", F, F)
    GG1 = 2.0 * np.einsum("ik,JL->iJkL", _I3, _I3) if tangent else None
    I1t, dI1t, d2I1t = _isochoric_invariant(I1, 2.0 * F, GG1, m, H, HH, HxH)

    # I4 = |F a0|^2, dI4/dF = 2 (F a0) x a0, d2I4 = 2 delta_ik a0_J a0_L
    Fa = F @ a0
    I4 = np.einsum("...i,...i->...", Fa, Fa)
    G4 = 2.0 * Fa[..., :, None] * a0
    GG4 = 2.0 * np.einsum("ik,J,L->iJkL", _I3, a0, a0) if tangent else None
    I4t, dI4t, d2I4t = _isochoric_invariant(I4, G4, GG4, m, H, HH, HxH)

    # fiber energy as a function of I4~: h(I4~) = W_f(sqrt(I4~)), active in tension only
    lam = np.sqrt(I4t)
    on = lam > 1.0
    lam_on = np.where(on, lam, 1.0)
    h = np.where(on, lam_on - 1.0 - np.log(lam_on), 0.0)  # per unit c5
    dh = np.where(on, (lam_on - 1.0) / (2.0 * lam_on**2), 0.0)
    d2h = np.where(on, (2.0 - lam_on) / (4.0 * lam_on**4), 0.0)

    energy = c1 * (I1t - 3.0) + c5 * h
    P = _per_point(c1, 2) * dI1t + (c5 * dh)[..., None, None] * dI4t
    A = None
    if tangent:
        A = (
            _per_point(c1, 4) * d2I1t
            + (c5 * dh)[..., None, None, None, None] * d2I4t
            + (c5 * d2h)[..., None, None, None, None]
            * dI4t[..., :, :, None, None]
            * dI4t[..., None, None, :, :]
        )
    if np.any(np.asarray(c2) != 0.0):
        # I2 = (I1^2 - C:C) / 2, dI2/dF = 2 (I1 F - F C),
        # d2I2 = 2 [2 F_iJ F_kL + I1 d_ik d_JL - d_ik C_LJ - F_iL F_kJ - B_ik d_JL]
        C = np.swapaxes(F, -1, -2) @ F
        I2 = 0.5 * (I1**2 - np.einsum("...IJ,...IJ->...", C, C))
        G2 = 2.0 * (I1[..., None, None] * F - F @ C)
        GG2 = None
        if tangent:
            B = F @ np.swapaxes(F, -1, -2)
            GG2 = 2.0 * (
                2.0 * F[..., :, :, None, None] * F[..., None, None, :, :]
                + I1[..., None, None, None, None] * np.einsum("ik,JL->iJkL", _I3, _I3)
                - np.einsum("ik,...LJ->...iJkL", _I3, C)
                - np.einsum("...iL,...kJ->...iJkL", F, F)
                - np.einsum("...ik,JL->...iJkL", B, _I3)
            )
        I2t, dI2t, d2I2t = _isochoric_invariant(I2, G2, GG2, m * m, H, HH, HxH, a=-4.0 / 3.0)
        energy = energy + c2 * (I2t - 3.0)
        P = P + _per_point(c2, 2) * dI2t
        if tangent:
            A = A + _per_point(c2, 4) * d2I2t
    dP = None
    if parameter_derivatives:
        dP = np.stack([dI1t, dh[..., None, None] * dI4t], axis=-3)
    return DeviatoricResponse(energy, P, A, dP)


def volumetric_energy(J: np.ndarray | float, kappa: np.ndarray | float) -> np.ndarray:
    """U(J) = kappa/2 (ln J)^2 and its first two derivatives (U, U', U'')."""
    J = np.asarray(J, dtype=float)
    lnJ = np.log(J)
    return np.stack([0.5 * kappa * lnJ**2, kappa * lnJ / J, kappa * (1.0 - lnJ) / J**2])


def full_response(F: np.ndarray, material: Material) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Energy, PK1 stress and tangent of the whole of eq. 3 at a point (volumetric term at J).

    ``material`` is a :class:`Material` or anything with ``c1``, ``c5``, ``kappa`` and optionally
    ``c2`` and ``fiber`` (a composite's :class:`~forward.spec.Constituent`: c2, the fibers along y)."""
    c2 = getattr(material, "c2", 0.0)
    fiber = np.asarray(getattr(material, "fiber", (0.0, 1.0, 0.0)), dtype=float)
    dev = deviatoric_response(F, material.c1, material.c5, fiber, c2=c2)
    J = np.linalg.det(F)
    H = np.linalg.inv(F).swapaxes(-1, -2)
    U, dU, d2U = volumetric_energy(J, material.kappa)
    JH = J[..., None, None] * H
    P = dev.P + dU[..., None, None] * JH
    HH = H[..., :, :, None, None] * H[..., None, None, :, :]
    HxH = np.einsum("...kJ,...iL->...iJkL", H, H)
    A = (
        dev.A
        + (d2U * J**2)[..., None, None, None, None] * HH
        + (dU * J)[..., None, None, None, None] * (HH - HxH)
    )
    return dev.energy + U, P, A


def cauchy_stress(F: np.ndarray, material: Material) -> np.ndarray:
    """Cauchy stress sigma = P F^T / J of the whole of eq. 3, kPa."""
    _, P, _ = full_response(F, material)
    J = np.linalg.det(F)
    return P @ np.swapaxes(F, -1, -2) / J[..., None, None]


def equibiaxial_stress_incompressible(lam: np.ndarray, c1: float, c5: float) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 10a, 10b: Cauchy stresses along (sigma11) and across (sigma22) the fibers under
    incompressible equibiaxial stretch ``lam`` with the fibers along direction 1."""
    lam = np.asarray(lam, dtype=float)
    s22 = 2.0 * c1 * (lam**2 - lam**-4)
    s11 = s22 + c5 * np.where(lam > 1.0, lam - 1.0, 0.0)
    return s11, s22


def uniaxial_stress_incompressible(lam: np.ndarray, c1: float, c5: float, along_fiber: bool) -> np.ndarray:
    """Cauchy stress of eq. 2 under incompressible uniaxial stretch ``lam`` (supplement S2).

    Along the fibers: 2 c1 (lam^2 - 1/lam) + c5 (lam - 1) for lam > 1. Across the fibers the
    fibers shorten and carry nothing: 2 c1 (lam^2 - 1/lam) (the neo-Hookean relation; with
    c1 = mu / 2 this is the matrix fit of supplement S3).
    """
    lam = np.asarray(lam, dtype=float)
    s = 2.0 * c1 * (lam**2 - 1.0 / lam)
    if along_fiber:
        s = s + c5 * np.where(lam > 1.0, lam - 1.0, 0.0)
    return s


def uniaxial_stress_mooney_rivlin(lam: np.ndarray, c1: float, c2: float) -> np.ndarray:
    """Cauchy stress of the incompressible Mooney-Rivlin solid under uniaxial stretch ``lam``:
    2 (lam^2 - 1/lam)(c1 + c2/lam) (supplement S3; the phantom's fibers, 2.4.2)."""
    lam = np.asarray(lam, dtype=float)
    return 2.0 * (lam**2 - 1.0 / lam) * (c1 + c2 / lam)
