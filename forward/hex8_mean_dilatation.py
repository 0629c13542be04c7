"""Hex8 with 2x2x2 Gauss points and the mean-dilatation (three-field u-p-J) volumetric term.

This is FEBio's default element for uncoupled materials on hex8 (FE3FieldElasticSolidDomain):
the isochoric energy of eq. 3 is integrated at the Gauss points, the volumetric energy
U(J) = kappa/2 (ln J)^2 is evaluated once per element at the element's dilatation
J_bar = v_e / V_e (current over reference volume), and the pressure is p = U'(J_bar). In energy
form (Simo, Taylor & Pister 1985):

    Pi(u) = sum_e [ sum_g w_g detJ0_g W_dev(F_g) + V_e U(v_e / V_e) ].

Internal forces and the exact tangent are the first and second derivatives of Pi; the tangent
is symmetric. Plain hex8 (U at every Gauss point) locks for kappa / c1 = 100.

The moduli (c1, c2, c5, kappa) are scalars (the homogeneous model, eq. 3) or arrays with one
value per element (the composite phantom's element sets, 2.4.2); c2 is the Mooney-Rivlin
modulus of FEBio's uncoupled Mooney-Rivlin, 0 in eq. 3.

Everything is vectorised over elements and Gauss points; there is no loop over elements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .block_mesh import BlockMesh
from .hex8_kernel_numba import hex8_three_field_kernel
from .material import InvertedElementError, volumetric_energy

_G = 1.0 / np.sqrt(3.0)
#: Natural coordinates of the hex8 nodes in FEBio's order.
HEX8_NODES = np.array(
    [
        [-1, -1, -1],
        [1, -1, -1],
        [1, 1, -1],
        [-1, 1, -1],
        [-1, -1, 1],
        [1, -1, 1],
        [1, 1, 1],
        [-1, 1, 1],
    ],
    dtype=float,
)
GAUSS_POINTS = HEX8_NODES * _G
GAUSS_WEIGHTS = np.ones(8)


def shape_gradients(xi: np.ndarray) -> np.ndarray:
    """dN_a/dxi_j of the trilinear hex8 at natural points ``xi`` (g, 3) -> (g, 8, 3)."""
    s = HEX8_NODES[None, :, :]
    t = 1.0 + s * xi[:, None, :]  # (g, 8, 3)
    d = np.empty_like(t)
    d[..., 0] = s[..., 0] * t[..., 1] * t[..., 2]
    d[..., 1] = t[..., 0] * s[..., 1] * t[..., 2]
    d[..., 2] = t[..., 0] * t[..., 1] * s[..., 2]
    return d / 8.0


@dataclass(frozen=True)
class ReferenceGeometry:
    """Per element and Gauss point: dN/dX (ne, g, 8, 3), w detJ0 (ne, g), volumes V_e (ne,)."""

    dNdX: np.ndarray
    wdetJ0: np.ndarray
    volume: np.ndarray

    @classmethod
    def of(cls, mesh: BlockMesh) -> ReferenceGeometry:
        X = mesh.nodes[mesh.elements]  # (ne, 8, 3)
        dNdxi = shape_gradients(GAUSS_POINTS)  # (g, 8, 3)
        J0 = np.einsum("eaI,gaj->egIj", X, dNdxi)  # dX_I / dxi_j
        det = np.linalg.det(J0)
        if np.any(det <= 0.0):
            bad = np.unique(np.nonzero(det <= 0.0)[0])[:5]
            raise ValueError(f"{mesh.source}: elements {bad.tolist()} have non-positive Jacobian")
        dNdX = np.einsum("gaj,egjI->egaI", dNdxi, np.linalg.inv(J0))
        wdetJ0 = det * GAUSS_WEIGHTS
        return cls(dNdX=dNdX, wdetJ0=wdetJ0, volume=wdetJ0.sum(axis=1))


@dataclass
class ElementState:
    """Element-level results at one displacement: energy, forces (ne, 24), stiffness (ne, 24, 24),
    forces per unit of each parameter (ne, 2, 24) when asked for, and which Gauss points' fibers
    are stretched (ne, 8; the compiled kernel's, None from :func:`element_state_numpy`)."""

    energy: float
    force: np.ndarray
    stiffness: np.ndarray | None
    dforce_dtheta: np.ndarray | None
    min_jacobian: float
    fiber_taut: np.ndarray | None = None


Modulus = float | np.ndarray


def per_element(value: Modulus, ne: int, name: str) -> np.ndarray:
    """A modulus as a contiguous float array of one value per element (a scalar is repeated);
    a wrong length or a NaN raises a ValueError naming it."""
    v = np.asarray(value, dtype=float)
    if v.ndim == 0:
        v = np.full(ne, float(v))
    if v.shape != (ne,):
        raise ValueError(f"{name}: expected a scalar or {ne} values (one per element), got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name}: holds NaN or infinite values")
    return np.ascontiguousarray(v)


def element_state(
    geometry: ReferenceGeometry,
    u_e: np.ndarray,
    c1: Modulus,
    c5: Modulus,
    kappa: Modulus,
    fiber: np.ndarray,
    tangent: bool = True,
    parameter_derivatives: bool = False,
    c2: Modulus = 0.0,
    *,
    fiber_mean: bool = False,
) -> ElementState:
    """Energy, internal forces and exact tangent of every element at element displacements
    ``u_e`` (ne, 8, 3), by the compiled kernel (:mod:`forward.hex8_kernel_numba`). The moduli
    are scalars or one value per element; ``dforce_dtheta`` is d(force)/d(c1, c5) of a change
    of c1 or c5 in every element alike. ``fiber_mean``: the fiber term at each element's mean
    I4~ (:func:`element_state_numpy`)."""
    ne = u_e.shape[0]
    force = np.empty((ne, 24))
    K = np.empty((ne, 24, 24)) if tangent else np.empty((1, 24, 24))
    dforce = np.empty((ne, 2, 24)) if parameter_derivatives else np.empty((1, 2, 24))
    energy = np.empty(ne)
    taut = np.empty((ne, 8), dtype=np.int8)
    min_j = hex8_three_field_kernel(
        geometry.dNdX,
        geometry.wdetJ0,
        geometry.volume,
        np.ascontiguousarray(u_e, dtype=float),
        per_element(c1, ne, "c1"),
        per_element(c2, ne, "c2"),
        per_element(c5, ne, "c5"),
        per_element(kappa, ne, "kappa"),
        np.asarray(fiber, dtype=float),
        tangent,
        parameter_derivatives,
        fiber_mean,
        force,
        K,
        energy,
        dforce,
        taut,
    )
    if not np.isfinite(min_j) or min_j <= 0.0:
        raise InvertedElementError()
    return ElementState(
        float(energy.sum()),
        force,
        K if tangent else None,
        dforce if parameter_derivatives else None,
        float(min_j),
        taut.view(bool),
    )


def element_state_numpy(
    geometry: ReferenceGeometry,
    u_e: np.ndarray,
    c1: Modulus,
    c5: Modulus,
    kappa: Modulus,
    fiber: np.ndarray,
    tangent: bool = True,
    parameter_derivatives: bool = False,
    c2: Modulus = 0.0,
    *,
    fiber_mean: bool = False,
) -> ElementState:
    """Reference numpy implementation of :func:`element_state` (same closed form).

    The tangent of eq. 3 is contracted in closed form. With m = J^(-2/3), H = F^-T,
    a1 = c1 m, a4 = c5 h'(I4~) m, S = 2 a1 F + 2 a4 (F a0) x a0, beta = a1 I1 + a4 I4,
    D = dI4~/dF, p = U'(J_bar) and the spatial gradients g_a = H dN_a/dX:

        P = S - 2/3 beta H + p J H,
        K_ai,bk = sum_g w [ 2 delta_ik dN_a.(a1 I + a4 a0 x a0) dN_b
                            - 2/3 (g_ai s_bk + s_ai g_bk) + (4/9 beta + p J) g_ai g_bk
                            + (2/3 beta - p J) g_ak g_bi + c5 h'' d_ai d_bk ]
                  + U''(J_bar) / V_e (dv/du_ai)(dv/du_bk),

    with s_a = S dN_a, d_a = D dN_a; h(I4~) is the fiber energy per unit c5 (forward.material).

    The Mooney-Rivlin term c2 (I2~ - 3), with n = J^(-4/3), a2 = c2 n, S2 = 2 a2 (I1 F - F C),
    beta2 = 2 a2 I2 and f_a = F dN_a, adds S2 - 2/3 beta2 H to P and

        sum_g w [ 8/9 beta2 g_ai g_bk - 4/3 (g_ai s2_bk + s2_ai g_bk) + 2/3 beta2 g_ak g_bi
                  + 2 a2 (2 f_ai f_bk - f_bi f_ak - B_ik dN_a.dN_b
                          + delta_ik (I1 dN_a.dN_b - dN_a.C dN_b)) ]

    to K.

    With ``fiber_mean`` the fiber energy is V_e c5 h(I4m), evaluated once per element at the mean
    I4m = (1 / V_e) sum_g w I4~_g, as the volumetric term is at J_bar: fibers much stiffer than the
    matrix (c5 / c1 of 100 and more) otherwise lock a hex8 as near incompressibility does. Then h'
    in a4 is the element's h'(I4m), the Gauss points' c5 h'' d d terms drop, and the element adds
    c5 h''(I4m) / V_e (sum_g w d_ai)(sum_g w d_bk).
    """
    dNdX, w = geometry.dNdX, geometry.wdetJ0
    ne_all = u_e.shape[0]
    c1 = per_element(c1, ne_all, "c1")[:, None]
    c2 = per_element(c2, ne_all, "c2")[:, None]
    c5 = per_element(c5, ne_all, "c5")[:, None]
    kappa = per_element(kappa, ne_all, "kappa")
    a0 = np.asarray(fiber, dtype=float)
    F = np.eye(3) + np.einsum("eai,egaJ->egiJ", u_e, dNdX)
    J = np.linalg.det(F)
    min_j = float(J.min())
    if not np.isfinite(min_j) or min_j <= 0.0:
        raise InvertedElementError()
    H = np.linalg.inv(F).swapaxes(-1, -2)
    m = J ** (-2.0 / 3.0)
    I1 = np.einsum("egiJ,egiJ->eg", F, F)
    Fa = F @ a0
    I4 = np.einsum("egi,egi->eg", Fa, Fa)
    lam = np.sqrt(m * I4)
    if fiber_mean:  # one stretch per element, the same at its Gauss points
        lam = np.repeat(
            np.sqrt(np.einsum("eg,eg->e", w, m * I4) / geometry.volume)[:, None], J.shape[1], axis=1
        )
    on = lam > 1.0
    lam_on = np.where(on, lam, 1.0)
    h = np.where(on, lam_on - 1.0 - np.log(lam_on), 0.0)
    dh = np.where(on, (lam_on - 1.0) / (2.0 * lam_on**2), 0.0)
    d2h = np.where(on, (2.0 - lam_on) / (4.0 * lam_on**4), 0.0)

    v = np.einsum("eg,eg->e", w, J)
    Jbar = v / geometry.volume
    U, p, dp = volumetric_energy(Jbar, kappa)
    pJ = p[:, None] * J

    a1 = c1 * m
    a4 = c5 * dh * m
    G4 = 2.0 * Fa[..., :, None] * a0  # dI4/dF
    S = 2.0 * a1[..., None, None] * F + a4[..., None, None] * G4
    beta = a1 * I1 + a4 * I4
    P = S + ((pJ - (2.0 / 3.0) * beta)[..., None, None]) * H
    force = np.einsum("eg,egiJ,egaJ->eai", w, P, dNdX).reshape(-1, 24)
    W_dev = c1 * (m * I1 - 3.0) + c5 * h  # h is the element's with fiber_mean: sum_g w h = V_e h
    energy = float(np.einsum("eg,eg->", w, W_dev) + np.dot(geometry.volume, U))
    d2h_point = np.zeros_like(d2h) if fiber_mean else d2h

    K = None
    if tangent:
        ne = J.shape[0]
        D = m[..., None, None] * (G4 - (2.0 / 3.0) * I4[..., None, None] * H)
        gx = np.einsum("egiJ,egaJ->egai", H, dNdX)  # (ne, g, 8, 3)
        sx = np.einsum("egiJ,egaJ->egai", S, dNdX)
        dx = np.einsum("egiJ,egaJ->egai", D, dNdX)
        wc3 = (w * ((4.0 / 9.0) * beta + pJ))[..., None, None]
        wg = w[..., None, None]
        left = np.concatenate(
            [
                wc3 * gx - (2.0 / 3.0) * wg * sx,
                -(2.0 / 3.0) * wg * gx,
                (w * c5 * d2h_point)[..., None, None] * dx,
            ],
            axis=1,
        ).reshape(ne, -1, 24)
        right = np.concatenate([gx, sx, dx], axis=1).reshape(ne, -1, 24)
        K = np.matmul(left.transpose(0, 2, 1), right)  # (ne, 24, 24): [a i, b k]
        wc4 = (w * ((2.0 / 3.0) * beta - pJ))[..., None, None] * gx
        swap = np.matmul(wc4.reshape(ne, -1, 24).transpose(0, 2, 1), gx.reshape(ne, -1, 24))
        K += swap.reshape(ne, 8, 3, 8, 3).transpose(0, 1, 4, 3, 2).reshape(ne, 24, 24)
        na = np.einsum("egaJ,J->ega", dNdX, a0)
        q = np.einsum("eg,egaJ,egbJ->eab", 2.0 * a1 * w, dNdX, dNdX) + np.einsum(
            "eg,ega,egb->eab", 2.0 * a4 * w, na, na
        )
        K4 = K.reshape(ne, 8, 3, 8, 3)
        for i in range(3):
            K4[:, :, i, :, i] += q
        g = np.einsum("eg,egai->eai", w * J, gx).reshape(-1, 24)  # dv_e / du
        K += (dp / geometry.volume)[:, None, None] * g[:, :, None] * g[:, None, :]
        if fiber_mean:
            gf = np.einsum("eg,egai->eai", w, dx).reshape(-1, 24)  # V_e dI4m / du
            cf = c5[:, 0] * d2h[:, 0] / geometry.volume
            K += cf[:, None, None] * gf[:, :, None] * gf[:, None, :]

    if np.any(c2 != 0.0):
        energy, force, K = _mooney_rivlin_numpy(
            geometry, F, J, I1=I1, H=H, c2=c2, energy=energy, force=force, K=K
        )

    dforce = None
    if parameter_derivatives:
        dI1t = m[..., None, None] * (2.0 * F - (2.0 / 3.0) * I1[..., None, None] * H)
        dI4t = m[..., None, None] * (G4 - (2.0 / 3.0) * I4[..., None, None] * H)
        dP = np.stack([dI1t, dh[..., None, None] * dI4t], axis=2)
        dforce = np.einsum("eg,egpiJ,egaJ->epai", w, dP, dNdX).reshape(-1, 2, 24)
    return ElementState(energy, force, K, dforce, min_j)


def _mooney_rivlin_numpy(
    geometry: ReferenceGeometry,
    F: np.ndarray,
    J: np.ndarray,
    I1: np.ndarray,
    H: np.ndarray,
    c2: np.ndarray,
    energy: float,
    force: np.ndarray,
    K: np.ndarray | None,
) -> tuple[float, np.ndarray, np.ndarray | None]:
    """Add the Mooney-Rivlin term c2 (I2~ - 3) to the energy, forces and tangent of
    :func:`element_state_numpy` (the closed form in its docstring)."""
    dNdX, w = geometry.dNdX, geometry.wdetJ0
    n = J ** (-4.0 / 3.0)
    a2 = c2 * n
    C = np.swapaxes(F, -1, -2) @ F
    B = F @ np.swapaxes(F, -1, -2)
    I2 = 0.5 * (I1**2 - np.einsum("egIJ,egIJ->eg", C, C))
    beta2 = 2.0 * a2 * I2
    S2 = 2.0 * a2[..., None, None] * (I1[..., None, None] * F - F @ C)
    P2 = S2 - (2.0 / 3.0) * beta2[..., None, None] * H
    force = force + np.einsum("eg,egiJ,egaJ->eai", w, P2, dNdX).reshape(-1, 24)
    energy = energy + float(np.einsum("eg,eg->", w, c2 * (n * I2 - 3.0)))
    if K is None:
        return energy, force, None
    ne = J.shape[0]
    gx = np.einsum("egiJ,egaJ->egai", H, dNdX)
    s2 = np.einsum("egiJ,egaJ->egai", S2, dNdX)
    fx = np.einsum("egiJ,egaJ->egai", F, dNdX)
    q = np.einsum("egaJ,egbJ->egab", dNdX, dNdX)
    cq = np.einsum("egaJ,egJL,egbL->egab", dNdX, C, dNdX)
    wb = w * beta2
    w2 = 2.0 * w * a2
    K2 = (
        np.einsum("eg,egai,egbk->eaibk", (8.0 / 9.0) * wb, gx, gx)
        - np.einsum("eg,egai,egbk->eaibk", (4.0 / 3.0) * w, gx, s2)
        - np.einsum("eg,egai,egbk->eaibk", (4.0 / 3.0) * w, s2, gx)
        + np.einsum("eg,egak,egbi->eaibk", (2.0 / 3.0) * wb, gx, gx)
        + np.einsum("eg,egai,egbk->eaibk", 2.0 * w2, fx, fx)
        - np.einsum("eg,egbi,egak->eaibk", w2, fx, fx)
        - np.einsum("eg,egik,egab->eaibk", w2, B, q)
    )
    diag = np.einsum("eg,egab->eab", w2, I1[..., None, None] * q - cq)
    K2 += np.einsum("eab,ik->eaibk", diag, np.eye(3))
    return energy, force, K + K2.reshape(ne, 24, 24)
