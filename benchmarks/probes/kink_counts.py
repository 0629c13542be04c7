"""How many fibers crossed stretch 1 since the factorisation in hand at each Krylov try of a run with
friction, and whether the try converged: the data behind the fibers' kink rule's threshold
(``forward.linear_steps.KINK_CROSSINGS``; docs/validation/solver-and-speed.md, "The kink rule's
threshold"; issue 58). The rule is put out of reach so that every try is made and recorded.

    .venv/bin/python benchmarks/probes/kink_counts.py OUT.json simulate --mesh contact-L4 --radius 8 \\
        --c1 7 --c5 520 --friction 0.3 --restart --out RUN.npz

The rest is the command line of ``indent-studio``; run it on a copy of a checkpoint (``--restart``)
to record some steps of a long run. OUT.json holds one record per try: the crossings, the Gauss
points with fibers, the dofs, the Krylov iterations and whether the try converged.
"""

import json
import sys

import numpy as np

from indentation_studio.forward import linear_steps
from indentation_studio.studio.cli import app

out, rest = sys.argv[1], sys.argv[2:]
linear_steps.KINK_DOFS = 10**12  # every try made
records: list[dict] = []
krylov = linear_steps.LinearSteps.krylov


def recorded(self, K, cmask, rhs, rtol, maxiter, **kwargs):
    now, then = self.fiber_taut, self._taut_factorised
    crossed = (
        None if now is None or then is None or now.shape != then.shape else int(np.count_nonzero(now != then))
    )
    before = self.stats["krylov_iterations"]
    x = krylov(self, K, cmask, rhs, rtol, maxiter, **kwargs)
    records.append(
        {
            "crossed": crossed,
            "points": None if now is None else int(now.size),
            "dofs": int(self.n_dofs),
            "iterations": int(self.stats["krylov_iterations"] - before),
            "maxiter": int(maxiter),
            "converged": x is not None,
            "fresh": bool(kwargs.get("unfinished", False)),
        }
    )
    with open(out, "w") as f:
        json.dump(records, f)
    return x


linear_steps.LinearSteps.krylov = recorded
app(rest)
