"""Benchmark (by hand): with friction, skip the Krylov try on a factorisation across which more than T
Gauss points crossed the fibers' kink (stretch 1) and factorise at once (docs/validation/
solver-and-speed.md, "Skipping the Krylov try across the fibers' kink"; issue 58). A probe: the rule
is put in by replacing ``LinearSteps.newton_step`` here, not in the library.

    .venv/bin/python benchmarks/probes/kink_skip.py MESH R C1 C5 MU STEPS T

Run it with T = inf first (today's rule, its forces saved under /tmp), then with T.
"""

import sys
import time

import numpy as np

from indentation_studio.forward import linear_steps
from indentation_studio.forward.solver import EmbeddedSolver
from indentation_studio.forward.spec import Indenter, MeshChoice, ModelSpec, Protocol

mesh, radius, c1, c5, mu, steps, T = (
    sys.argv[1],
    float(sys.argv[2]),
    float(sys.argv[3]),
    float(sys.argv[4]),
    float(sys.argv[5]),
    int(sys.argv[6]),
    float(sys.argv[7]),
)
spec = (
    ModelSpec(
        mesh=MeshChoice(mesh), indenter=Indenter(radius=radius), protocol=Protocol(step_size=0.5, steps=steps)
    )
    .with_material(c1=c1, c5=c5)
    .with_friction(None if mu == 0 else mu)
)
solver = EmbeddedSolver(spec)
a0 = np.array([0.0, 1.0, 0.0])


def taut(u):
    ue = u[solver.mesh.elements]
    F = np.eye(3) + np.einsum("eai,egaJ->egiJ", ue, solver.geometry.dNdX)
    J = np.linalg.det(F)
    Fa = F @ a0
    return J ** (-2.0 / 3.0) * np.einsum("egi,egi->eg", Fa, Fa) > 1.0


state = {"u": None, "fact": None, "skips": 0}
oasm = type(solver).assemble


def assemble(self, u, tangent=True, parameter_derivatives=False):
    if tangent:
        state["u"] = u.copy()
    return oasm(self, u, tangent, parameter_derivatives)


type(solver).assemble = assemble
ofact = linear_steps.LinearSteps.factorize


def factorize(self, K, c):
    state["fact"] = taut(state["u"])
    return ofact(self, K, c)


linear_steps.LinearSteps.factorize = factorize
ostep = linear_steps.LinearSteps.newton_step


def newton_step(self, K, cmask, rhs, rtol=linear_steps.KRYLOV_RTOL):
    if state["fact"] is not None and np.count_nonzero(taut(state["u"]) != state["fact"]) > T:
        state["skips"] += 1
        return self.fresh_step(K, cmask, rhs)
    return ostep(self, K, cmask, rhs, rtol)


linear_steps.LinearSteps.newton_step = newton_step
t = time.process_time()
r = solver.run(threads=1)
st = r.solver["stats"]
tag = f"{mesh}-{radius}-{c1}-{c5}-{mu}-{steps}"
np.save(f"/tmp/kskip-{sys.argv[7]}-{tag}.npy", r.force)
try:
    f0 = np.load(f"/tmp/kskip-inf-{tag}.npy")
    d = np.max(np.abs(r.force[1:] - f0[1:]) / np.abs(f0[1:]))
except FileNotFoundError:
    d = float("nan")
print(
    f"T {T} {tag} CPU {time.process_time() - t:.1f} s newton {int(np.sum(r.convergence['newton_iterations']))} fact {st['factorizations']} kcalls {st['krylov_calls']} kfail {st['krylov_failures']} kits {st['krylov_iterations']} skips {state['skips']} dF {d:.1e}"
)
