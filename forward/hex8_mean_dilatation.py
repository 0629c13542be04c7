"""Hex8 with 2x2x2 Gauss points and the mean-dilatation (three-field u-p-J) volumetric term.

This is FEBio's default element for uncoupled materials on hex8 (FE3FieldElasticSolidDomain):
the isochoric energy of eq. 3 is integrated at the Gauss points, the volumetric energy
U(J) = kappa/2 (ln J)^2 is evaluated once per element at the element's dilatation
J_bar = v_e / V_e (current over reference volume), and the pressure is p = U'(J_bar). In energy
form (Simo, Taylor & Pister 1985):

    Pi(u) = sum_e [ sum_g w_g detJ0_g W_dev(F_g) + V_e U(v_e / V_e) ].

Internal forces and the exact tangent are the first and second derivatives of Pi; the tangent
is symmetric. Plain hex8 (U at every Gauss point) locks for kappa / c1 = 100.

Everything is vectorised over elements and Gauss points; there is no loop over elements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .hex8_kernel_numba import hex8_three_field_kernel
from .material import InvertedElementError, volumetric_energy
from .mesh import BlockMesh

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
    forces per unit of each parameter (ne, 2, 24) when asked for."""

    energy: float
    force: np.ndarray
    stiffness: np.ndarray | None
    dforce_dtheta: np.ndarray | None
    min_jacobian: float


def element_state(
    geometry: ReferenceGeometry,
    u_e: np.ndarray,
    c1: float,
    c5: float,
    kappa: float,
    fiber: np.ndarray,
    tangent: bool = True,
    parameter_derivatives: bool = False,
) -> ElementState:
    """Energy, internal forces and exact tangent of every element at element displacements
    ``u_e`` (ne, 8, 3), by the compiled kernel (:mod:`forward.hex8_kernel_numba`)."""
    ne = u_e.shape[0]
    force = np.empty((ne, 24))
    K = np.empty((ne, 24, 24)) if tangent else np.empty((1, 24, 24))
    dforce = np.empty((ne, 2, 24)) if parameter_derivatives else np.empty((1, 2, 24))
    energy = np.empty(ne)
    min_j = hex8_three_field_kernel(
        geometry.dNdX,
        geometry.wdetJ0,
        geometry.volume,
        np.ascontiguousarray(u_e, dtype=float),
        float(c1),
        float(c5),
        float(kappa),
        np.asarray(fiber, dtype=float),
        tangent,
        parameter_derivatives,
        force,
        K,
        energy,
        dforce,
    )
    if not np.isfinite(min_j) or min_j <= 0.0:
        raise InvertedElementError()
    return ElementState(
        float(energy.sum()),
        force,
        K if tangent else None,
        dforce if parameter_derivatives else None,
        float(min_j),
    )


def element_state_numpy(
    geometry: ReferenceGeometry,
    u_e: np.ndarray,
    c1: float,
    c5: float,
    kappa: float,
    fiber: np.ndarray,
    tangent: bool = True,
    parameter_derivatives: bool = False,
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
    """
    dNdX, w = geometry.dNdX, geometry.wdetJ0
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
    W_dev = c1 * (m * I1 - 3.0) + c5 * h
    energy = float(np.einsum("eg,eg->", w, W_dev) + np.dot(geometry.volume, U))

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
                (w * c5 * d2h)[..., None, None] * dx,
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

    dforce = None
    if parameter_derivatives:
        dI1t = m[..., None, None] * (2.0 * F - (2.0 / 3.0) * I1[..., None, None] * H)
        dI4t = m[..., None, None] * (G4 - (2.0 / 3.0) * I4[..., None, None] * H)
        dP = np.stack([dI1t, dh[..., None, None] * dI4t], axis=2)
        dforce = np.einsum("eg,egpiJ,egaJ->epai", w, dP, dNdX).reshape(-1, 2, 24)
    return ElementState(energy, force, K, dforce, min_j)
