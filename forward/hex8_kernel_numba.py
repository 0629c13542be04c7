"""Compiled (numba) kernel of the three-field hex8 element: the same closed form as
:func:`forward.hex8_mean_dilatation.element_state_numpy`, fused into one pass per element.

It is the default, about ten times faster than the numpy version (README, "Solver choices"); the
numpy version stays as the readable reference and is tested equal to it.

The moduli c1, c2, c5, kappa are arrays with one value per element (a composite's element sets,
paper 2.4.2). The Mooney-Rivlin term c2 (I2~ - 3) is evaluated only in elements where c2 is not
0, in a block of its own, so that the homogeneous model (c2 = 0) does exactly the arithmetic it
did before.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

_TWO_THIRDS = 2.0 / 3.0
_FOUR_NINTHS = 4.0 / 9.0


@njit(cache=True, nogil=True, parallel=True)
def hex8_three_field_kernel(
    dNdX, w, vol, ue, c1, c2, c5, kappa, a0, want_K, want_dtheta, fiber_mean, force, K, energy, dforce, taut
):  # pragma: no cover - compiled
    """Fill ``force`` (ne, 24), ``K`` (ne, 24, 24), ``energy`` (ne,), ``dforce`` (ne, 2, 24) and
    ``taut`` (ne, 8): 1 where the Gauss point's fiber is stretched (isochoric stretch >= 1, the
    fibers' kink of eq. 3; with ``fiber_mean`` the element's), else 0.

    ``fiber_mean``: the fiber energy of eq. 3 is evaluated once per element at the element's mean
    isochoric I4~ (volume average of the Gauss points' values) instead of at every Gauss point
    (:func:`forward.hex8_mean_dilatation.element_state_numpy` has the closed form).

    Elements are split into chunks processed in parallel (numba threads; a campaign pins them
    to one per process). Returns the smallest Gauss-point det F (<= 0 signals an inverted
    element; outputs are then incomplete)."""
    ne = dNdX.shape[0]
    n_chunks = min(ne, 64)
    chunk_min = np.full(n_chunks, np.inf)
    for ch in prange(n_chunks):
        lo = ch * ne // n_chunks
        hi = (ch + 1) * ne // n_chunks
        # fmt: off
        chunk_min[ch] = _elements(
            lo, hi, dNdX, w, vol, ue, c1, c2, c5, kappa, a0,
            want_K, want_dtheta, fiber_mean, force, K, energy, dforce, taut,
        )
        # fmt: on
    return chunk_min.min()


# fmt: off
@njit(cache=True, nogil=True)
def _elements(
    lo, hi, dNdX, w, vol, ue, c1_e, c2_e, c5_e, kappa_e, a0,
    want_K, want_dtheta, fiber_mean, force, K, energy, dforce, taut,
):  # pragma: no cover - compiled
    # fmt: on
    """Elements lo..hi-1 of :func:`hex8_three_field_kernel`; returns their smallest det F."""
    minJ = np.inf
    F = np.empty((8, 3, 3))
    Jg = np.empty(8)
    H = np.empty((3, 3))
    S = np.empty((3, 3))
    D = np.empty((3, 3))
    gx = np.empty((8, 3))
    sx = np.empty((8, 3))
    dx = np.empty((8, 3))
    na = np.empty(8)
    gv = np.empty(24)
    gf = np.empty(24)
    Fa = np.empty(3)
    C = np.empty((3, 3))
    B = np.empty((3, 3))
    S2 = np.empty((3, 3))
    fx = np.empty((8, 3))
    s2x = np.empty((8, 3))
    cdn = np.empty((8, 3))
    gv24 = np.empty(24)
    sv24 = np.empty(24)
    dv24 = np.empty(24)
    for e in range(lo, hi):
        c1 = c1_e[e]
        c2 = c2_e[e]
        c5 = c5_e[e]
        kappa = kappa_e[e]
        v = 0.0
        i4sum = 0.0
        for g in range(8):
            for i in range(3):
                for j in range(3):
                    s = 1.0 if i == j else 0.0
                    for a in range(8):
                        s += ue[e, a, i] * dNdX[e, g, a, j]
                    F[g, i, j] = s
            det = (
                F[g, 0, 0] * (F[g, 1, 1] * F[g, 2, 2] - F[g, 1, 2] * F[g, 2, 1])
                - F[g, 0, 1] * (F[g, 1, 0] * F[g, 2, 2] - F[g, 1, 2] * F[g, 2, 0])
                + F[g, 0, 2] * (F[g, 1, 0] * F[g, 2, 1] - F[g, 1, 1] * F[g, 2, 0])
            )
            Jg[g] = det
            if det < minJ:
                minJ = det
            v += w[e, g] * det
            if fiber_mean and det > 0.0:
                fa2 = 0.0
                for i in range(3):
                    t = F[g, i, 0] * a0[0] + F[g, i, 1] * a0[1] + F[g, i, 2] * a0[2]
                    fa2 += t * t
                i4sum += w[e, g] * det ** (-_TWO_THIRDS) * fa2
        if minJ <= 0.0:
            return minJ
        # the element's fiber term (fiber_mean): h, h', h'' at the mean I4~
        hm = 0.0
        dhm = 0.0
        d2hm = 0.0
        lam_m = 0.0
        if fiber_mean:
            lam_m = math.sqrt(i4sum / vol[e])
            if lam_m >= 1.0:
                hm = lam_m - 1.0 - math.log(lam_m)
                dhm = (lam_m - 1.0) / (2.0 * lam_m * lam_m)
                d2hm = (2.0 - lam_m) / (4.0 * lam_m**4)
        Jbar = v / vol[e]
        lnJ = math.log(Jbar)
        p = kappa * lnJ / Jbar
        dp = kappa * (1.0 - lnJ) / (Jbar * Jbar)
        en = 0.5 * kappa * lnJ * lnJ * vol[e]
        for r in range(24):
            force[e, r] = 0.0
            gv[r] = 0.0
            gf[r] = 0.0
        if want_K:
            for r in range(24):
                for c in range(24):
                    K[e, r, c] = 0.0
        if want_dtheta:
            for q in range(2):
                for r in range(24):
                    dforce[e, q, r] = 0.0
        for g in range(8):
            J = Jg[g]
            wg = w[e, g]
            Fg = F[g]
            inv = 1.0 / J
            # H = F^-T = cofactor(F) / J
            H[0, 0] = (Fg[1, 1] * Fg[2, 2] - Fg[1, 2] * Fg[2, 1]) * inv
            H[0, 1] = (Fg[1, 2] * Fg[2, 0] - Fg[1, 0] * Fg[2, 2]) * inv
            H[0, 2] = (Fg[1, 0] * Fg[2, 1] - Fg[1, 1] * Fg[2, 0]) * inv
            H[1, 0] = (Fg[0, 2] * Fg[2, 1] - Fg[0, 1] * Fg[2, 2]) * inv
            H[1, 1] = (Fg[0, 0] * Fg[2, 2] - Fg[0, 2] * Fg[2, 0]) * inv
            H[1, 2] = (Fg[0, 1] * Fg[2, 0] - Fg[0, 0] * Fg[2, 1]) * inv
            H[2, 0] = (Fg[0, 1] * Fg[1, 2] - Fg[0, 2] * Fg[1, 1]) * inv
            H[2, 1] = (Fg[0, 2] * Fg[1, 0] - Fg[0, 0] * Fg[1, 2]) * inv
            H[2, 2] = (Fg[0, 0] * Fg[1, 1] - Fg[0, 1] * Fg[1, 0]) * inv
            m = J ** (-_TWO_THIRDS)
            I1 = 0.0
            for i in range(3):
                Fa[i] = Fg[i, 0] * a0[0] + Fg[i, 1] * a0[1] + Fg[i, 2] * a0[2]
                for j in range(3):
                    I1 += Fg[i, j] * Fg[i, j]
            I4 = Fa[0] * Fa[0] + Fa[1] * Fa[1] + Fa[2] * Fa[2]
            lam = math.sqrt(m * I4)
            taut[e, g] = 1 if (lam_m if fiber_mean else lam) >= 1.0 else 0
            hf = 0.0
            dh = 0.0
            d2h = 0.0
            if fiber_mean:
                dh = dhm  # the element's: hf and h'' enter once per element below
            elif lam >= 1.0:
                hf = lam - 1.0 - math.log(lam)
                dh = (lam - 1.0) / (2.0 * lam * lam)
                d2h = (2.0 - lam) / (4.0 * lam**4)
            a1 = c1 * m
            a4 = c5 * dh * m
            beta = a1 * I1 + a4 * I4
            pJ = p * J
            en += wg * (c1 * (m * I1 - 3.0) + c5 * hf)
            for i in range(3):
                for j in range(3):
                    G4 = 2.0 * Fa[i] * a0[j]
                    S[i, j] = 2.0 * a1 * Fg[i, j] + a4 * G4
                    D[i, j] = m * (G4 - _TWO_THIRDS * I4 * H[i, j])
            cP = pJ - _TWO_THIRDS * beta
            for a in range(8):
                na[a] = dNdX[e, g, a, 0] * a0[0] + dNdX[e, g, a, 1] * a0[1] + dNdX[e, g, a, 2] * a0[2]
                for i in range(3):
                    sg = 0.0
                    ss = 0.0
                    sd = 0.0
                    for j in range(3):
                        dn = dNdX[e, g, a, j]
                        sg += H[i, j] * dn
                        ss += S[i, j] * dn
                        sd += D[i, j] * dn
                    gx[a, i] = sg
                    sx[a, i] = ss
                    dx[a, i] = sd
                    force[e, 3 * a + i] += wg * (ss + cP * sg)
                    gv[3 * a + i] += wg * J * sg
                    if fiber_mean:
                        gf[3 * a + i] += wg * sd
            if c2 != 0.0:
                en += _mooney_rivlin_term(
                    e, g, wg, Fg, J, I1, c2, dNdX, gx, want_K, C, B, S2, fx, s2x, cdn, force, K
                )
            if want_dtheta:
                for a in range(8):
                    for i in range(3):
                        d1 = 0.0
                        d4 = 0.0
                        for j in range(3):
                            dn = dNdX[e, g, a, j]
                            d1 += m * (2.0 * Fg[i, j] - _TWO_THIRDS * I1 * H[i, j]) * dn
                            d4 += D[i, j] * dn
                        dforce[e, 0, 3 * a + i] += wg * d1
                        dforce[e, 1, 3 * a + i] += wg * dh * d4
            if want_K:
                c3 = wg * (_FOUR_NINTHS * beta + pJ)
                c4 = wg * (_TWO_THIRDS * beta - pJ)
                cg = wg * c5 * d2h
                cs = wg * _TWO_THIRDS
                for a in range(8):
                    for i in range(3):
                        gv24[3 * a + i] = gx[a, i]
                        sv24[3 * a + i] = sx[a, i]
                        dv24[3 * a + i] = dx[a, i]
                # the rank updates c3 g g^T - cs (g s^T + s g^T) + cg d d^T, row by row over
                # contiguous columns of the upper block triangle (27 % faster than by 3 x 3 blocks)
                for r in range(24):
                    gr = c3 * gv24[r] - cs * sv24[r]
                    sr = cs * gv24[r]
                    dr = cg * dv24[r]
                    for c in range(r // 3 * 3, 24):
                        K[e, r, c] += gr * gv24[c] - sr * sv24[c] + dr * dv24[c]
                # the swapped term c4 g_a,k g_b,i and the matrix and fiber parts on the blocks' diagonals
                for a in range(8):
                    for b in range(a, 8):
                        qab = 0.0
                        for j in range(3):
                            qab += dNdX[e, g, a, j] * dNdX[e, g, b, j]
                        qab = 2.0 * wg * (a1 * qab + a4 * na[a] * na[b])
                        for i in range(3):
                            r = 3 * a + i
                            K[e, r, 3 * b + i] += qab
                            gbi = c4 * gx[b, i]
                            for k in range(3):
                                K[e, r, 3 * b + k] += gx[a, k] * gbi
        en += vol[e] * c5 * hm
        energy[e] = en
        if want_K:
            cv = dp / vol[e]
            for r in range(24):
                for c in range(r // 3 * 3, 24):
                    K[e, r, c] += cv * gv[r] * gv[c]
            if fiber_mean:
                cf = c5 * d2hm / vol[e]
                for r in range(24):
                    for c in range(r // 3 * 3, 24):
                        K[e, r, c] += cf * gf[r] * gf[c]
            for r in range(24):  # mirror the upper block triangle
                for c in range(r // 3 * 3):
                    K[e, r, c] = K[e, c, r]
    return minJ


@njit(cache=True, nogil=True)
def _mooney_rivlin_term(
    e, g, wg, Fg, J, I1, c2, dNdX, gx, want_K, C, B, S2, fx, s2x, cdn, force, K
):  # pragma: no cover - compiled
    """Add the Mooney-Rivlin term c2 (I2~ - 3), I2~ = J^(-4/3) I2, of Gauss point ``g`` of
    element ``e`` to its forces and tangent and return its energy (the closed form of
    :func:`forward.hex8_mean_dilatation.element_state_numpy`)."""
    n = J ** (-2.0 * _TWO_THIRDS)
    a2 = c2 * n
    for i in range(3):
        for j in range(3):
            sc = 0.0
            sb = 0.0
            for k in range(3):
                sc += Fg[k, i] * Fg[k, j]
                sb += Fg[i, k] * Fg[j, k]
            C[i, j] = sc
            B[i, j] = sb
    cc = 0.0
    for i in range(3):
        for j in range(3):
            cc += C[i, j] * C[i, j]
    I2 = 0.5 * (I1 * I1 - cc)
    en = wg * c2 * (n * I2 - 3.0)
    beta2 = 2.0 * a2 * I2
    for i in range(3):
        for j in range(3):
            fc = 0.0
            for k in range(3):
                fc += Fg[i, k] * C[k, j]
            S2[i, j] = 2.0 * a2 * (I1 * Fg[i, j] - fc)
    for a in range(8):
        for i in range(3):
            sf = 0.0
            ss = 0.0
            sc = 0.0
            for j in range(3):
                dn = dNdX[e, g, a, j]
                sf += Fg[i, j] * dn
                ss += S2[i, j] * dn
                sc += C[i, j] * dn
            fx[a, i] = sf
            s2x[a, i] = ss
            cdn[a, i] = sc
            force[e, 3 * a + i] += wg * (ss - _TWO_THIRDS * beta2 * gx[a, i])
    if not want_K:
        return en
    c3 = wg * 2.0 * _FOUR_NINTHS * beta2
    c4 = wg * _TWO_THIRDS * beta2
    cs = wg * 2.0 * _TWO_THIRDS
    c8 = 2.0 * wg * a2
    for a in range(8):
        for b in range(a, 8):
            qab = 0.0
            cab = 0.0
            for j in range(3):
                qab += dNdX[e, g, a, j] * dNdX[e, g, b, j]
                cab += dNdX[e, g, a, j] * cdn[b, j]
            for i in range(3):
                r = 3 * a + i
                for k in range(3):
                    val = (
                        c3 * gx[a, i] * gx[b, k]
                        - cs * (gx[a, i] * s2x[b, k] + s2x[a, i] * gx[b, k])
                        + c4 * gx[a, k] * gx[b, i]
                        + c8 * (2.0 * fx[a, i] * fx[b, k] - fx[b, i] * fx[a, k] - B[i, k] * qab)
                    )
                    if i == k:
                        val += c8 * (I1 * qab - cab)
                    K[e, r, 3 * b + k] += val
    return en
