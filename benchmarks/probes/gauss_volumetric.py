"""The composite phantom with its matrix's volumetric energy at every Gauss point: does the
R = 4.77 mm indentation then pass the depth where the three-field element stops? (issue 57).

The solver's element is the three-field hex8 (:mod:`forward.hex8_mean_dilatation`): the
volumetric energy U(J) = kappa / 2 (ln J)^2 is read once per element at its dilatation
J_bar = v_e / V_e, so the Gauss points' own J may spread about it. Here, in the chosen element
set, that term is replaced by the plain hex8's, sum_g w detJ0_g U(J_g) (as a coupled material on
a fully integrated element would have it; it locks where kappa >> the shear modulus):

    force_ai = sum_g w detJ0 kappa ln J_g g_ai,
    K_ai,bk  = sum_g w detJ0 kappa (g_ai g_bk - ln J_g g_ak g_bi),      g_a = F^-T dN_a/dX,

and the element's own term, p dv/du with p = U'(J_bar) and its tangent, is taken off. The
replacement is checked before the run: the three-field state minus its volumetric part equals the
reference implementation with kappa = 0, and the new term's tangent equals its forces' finite
differences.

    .venv/bin/python benchmarks/probes/gauss_volumetric.py --mesh composite-medium --steps 28 [--set matrix] [--blend B]

With ``--blend B`` the element keeps (1 - B) of its own term and takes B of the Gauss points'
(a stabilised mean dilatation: the Gauss points' J resisted with the bulk modulus B kappa, which
locks little where B kappa is of the order of the shear modulus).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from indentation_studio.forward.hex8_mean_dilatation import ElementState, element_state_numpy
from indentation_studio.forward.solver import EmbeddedSolver, SimulationError
from indentation_studio.forward.spec import Contact, Indenter, ModelSpec, Protocol


def _gradients(geometry, u_e):
    """J (ne, g) and the spatial gradients g (ne, g, 8, 3)."""
    F = np.eye(3) + np.einsum("eai,egaJ->egiJ", u_e, geometry.dNdX)
    J = np.linalg.det(F)
    g = np.einsum("egaJ,egJi->egai", geometry.dNdX, np.linalg.inv(F))  # dN_a/dX F^-1 = (F^-T dN_a/dX)^T
    return J, g


def _outer(c, g):
    """sum_g c g_ai g_bk as (ne, 24, 24), by batched products."""
    ne, ng = c.shape
    G = g.reshape(ne, ng, 24)
    return np.matmul(np.swapaxes(c[:, :, None] * G, 1, 2), G)


def _crossed(c, g):
    """sum_g c g_ak g_bi as (ne, 24, 24) (rows ai, columns bk)."""
    ne = c.shape[0]
    M = _outer(c, g).reshape(ne, 8, 3, 8, 3)  # [a, k, b, i]
    return np.transpose(M, (0, 1, 4, 3, 2)).reshape(ne, 24, 24)


def gauss_volumetric(geometry, u_e, kappa):
    """Forces (ne, 24) and tangent (ne, 24, 24) of sum_g w detJ0 U(J_g) (module docstring)."""
    J, g = _gradients(geometry, u_e)
    w = geometry.wdetJ0 * kappa[:, None]
    lnJ = np.log(J)
    ne = u_e.shape[0]
    force = np.einsum("eg,egai->eai", w * lnJ, g).reshape(ne, 24)
    return force, _outer(w, g) - _crossed(w * lnJ, g)


def mean_dilatation_volumetric(geometry, u_e, kappa):
    """Forces and tangent of V_e U(v_e / V_e), the three-field element's volumetric term."""
    J, g = _gradients(geometry, u_e)
    w = geometry.wdetJ0
    V = geometry.volume
    Jbar = (w * J).sum(axis=1) / V
    lnJ = np.log(Jbar)
    p = kappa * lnJ / Jbar  # U'(J_bar)
    dp = kappa * (1.0 - lnJ) / Jbar**2  # U''(J_bar)
    dv = np.einsum("eg,egai->eai", w * J, g)  # dv/du
    ne = u_e.shape[0]
    force = (p[:, None, None] * dv).reshape(ne, 24)
    d2v = _outer(w * J, g) - _crossed(w * J, g)
    dv = dv.reshape(ne, 24)
    K = (dp / V)[:, None, None] * dv[:, :, None] * dv[:, None, :] + p[:, None, None] * d2v
    return force, K


class GaussVolumetric:
    """The solver's moduli with the volumetric term of ``elements`` at every Gauss point."""

    def __init__(self, moduli, elements: np.ndarray, blend: float = 1.0):
        self.moduli, self.elements, self.blend = moduli, elements, blend
        kappa = np.asarray(moduli.kappa, float)
        self.kappa = kappa[elements] if kappa.ndim else np.full(elements.size, float(kappa))

    def __getattr__(self, name):
        return getattr(self.moduli, name)

    def element_state(self, geometry, u_e, *, tangent=True, parameter_derivatives=False, fiber_mean=False):
        st = self.moduli.element_state(
            geometry, u_e, tangent=tangent, parameter_derivatives=parameter_derivatives, fiber_mean=fiber_mean
        )
        sub = _Sub(geometry, self.elements)
        ue = u_e[self.elements]
        f_old, K_old = mean_dilatation_volumetric(sub, ue, self.kappa)
        f_new, K_new = gauss_volumetric(sub, ue, self.kappa)
        force = st.force.copy()
        force[self.elements] += self.blend * (f_new - f_old)
        K = None
        if st.stiffness is not None:
            K = st.stiffness.copy()
            K[self.elements] += self.blend * (K_new - K_old)
        return ElementState(st.energy, force, K, st.dforce_dtheta, st.min_jacobian, st.fiber_taut)


class _Sub:
    def __init__(self, geometry, elements):
        self.dNdX = geometry.dNdX[elements]
        self.wdetJ0 = geometry.wdetJ0[elements]
        self.volume = geometry.volume[elements]


def check(solver: EmbeddedSolver, elements: np.ndarray) -> None:
    """The replacement's two checks on a random state of a few elements (module docstring)."""
    rng = np.random.default_rng(0)
    pick = elements[:: max(1, elements.size // 5)][:5]
    sub = _Sub(solver.geometry, pick)
    u_e = 0.05 * rng.standard_normal((pick.size, 8, 3))
    m = solver._mat
    kap = np.asarray(m.kappa, float)[pick] if np.ndim(m.kappa) else np.full(pick.size, float(m.kappa))
    at = (lambda v: np.asarray(v)[pick]) if np.ndim(m.c1) else (lambda v: v)
    full = element_state_numpy(sub, u_e, at(m.c1), at(m.c5), kap, m.fiber, c2=at(m.c2))
    dev = element_state_numpy(sub, u_e, at(m.c1), at(m.c5), 0.0 * kap, m.fiber, c2=at(m.c2))
    f_vol, K_vol = mean_dilatation_volumetric(sub, u_e, kap)
    print(
        "three-field minus its volumetric term against kappa = 0: forces "
        f"{np.abs(full.force - f_vol - dev.force).max() / np.abs(full.force).max():.1e}, tangent "
        f"{np.abs(full.stiffness - K_vol - dev.stiffness).max() / np.abs(full.stiffness).max():.1e}"
    )
    _, K = gauss_volumetric(sub, u_e, kap)
    h, fd = 1e-6, np.zeros_like(K)
    for j in range(24):
        du = np.zeros(24)
        du[j] = h
        fp, _ = gauss_volumetric(sub, u_e + du.reshape(8, 3), kap)
        fm, _ = gauss_volumetric(sub, u_e - du.reshape(8, 3), kap)
        fd[:, :, j] = (fp - fm) / (2 * h)
    print(
        f"Gauss-point term: tangent against its forces' differences {np.abs(K - fd).max() / np.abs(K).max():.1e}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--mesh", default="composite-medium")
    parser.add_argument("--radius", type=float, default=4.77)
    parser.add_argument("--steps", type=int, default=28)
    parser.add_argument("--set", default="matrix", choices=("matrix", "all"))
    parser.add_argument(
        "--blend",
        type=float,
        default=1.0,
        help="the share beta of the Gauss points' term: (1 - beta) U(J_bar) V_e + beta sum_g w U(J_g)",
    )
    args = parser.parse_args()
    spec = ModelSpec.composite_phantom(
        args.mesh,
        indenter=Indenter(args.radius),
        protocol=Protocol(step_size=0.5, steps=args.steps),
        contact=Contact(integration="surface", order=1),
    )
    solver = EmbeddedSolver(spec)
    mesh = solver.mesh
    elements = (
        np.flatnonzero(mesh.element_material == 0) if args.set == "matrix" else np.arange(mesh.n_elements)
    )
    check(solver, elements)
    solver._mat = GaussVolumetric(solver._mat, elements, blend=args.blend)
    print(
        f"{mesh.n_nodes} nodes; a share {args.blend:g} of the volumetric term at every Gauss point"
        f" in {elements.size} elements",
        flush=True,
    )
    t = time.process_time()
    try:
        result = solver.run(progress=lambda k, n, f: print(f"step {k}/{n}: {f:.1f} mN", flush=True))
        print(f"reached {result.depth[-1]:g} mm, {result.force[-1]:.1f} mN")
    except SimulationError as exc:
        print(f"stopped: {exc}")
    print(f"CPU {time.process_time() - t:.0f} s")


if __name__ == "__main__":
    main()
