"""The `simulate` command with the linear solver's correction columns (``max_extra``) set, and
optionally the fibers' kink rule off: how the cap on the contact's low-rank correction and the kink
rule change a run's factorisations and Krylov work (docs/validation/solver-and-speed.md, "The
correction's columns on the finest level").

    .venv/bin/python benchmarks/probes/correction_columns.py 90 simulate --mesh contact-L4 --radius 4.77 \\
        --c1 11 --c5 330 --contact surface --contact-order 1 --steps 4 --out RUN.npz
    .venv/bin/python benchmarks/probes/correction_columns.py 0 --no-kink-rule simulate ... --restart --out RUN.npz

The first argument is the column count (0 leaves the solver's own); ``--no-kink-rule`` puts
``linear_steps.KINK_DOFS`` out of reach; ``--per-cell-cap`` puts back the rule before
2026-11-30's session 30 for how many changed cells the correction holds (``max_extra`` over 3 dofs
for each node of each cell, shared nodes counted again), in place of
``contact_quadrature.cells_within``'s distinct dofs; the rest is the command line of ``indent-studio``. Run it
on a copy of a checkpoint (``--restart``) to measure one step of a long run. The counts are in the
result's ``solver["stats"]`` and convergence record.
"""

import sys

from indentation_studio.forward import linear_solver, linear_steps, penalty_contact
from indentation_studio.studio.cli import app

columns = int(sys.argv[1])
rest = sys.argv[2:]
if rest and rest[0] == "--no-kink-rule":
    linear_steps.KINK_DOFS = 10**12
    rest = rest[1:]
if rest and rest[0] == "--per-cell-cap":
    penalty_contact.cells_within = lambda cell_dofs, columns: max(1, columns // (3 * cell_dofs.shape[1]))
    rest = rest[1:]
made = linear_solver.ConstrainedSymmetricSolver.__init__


def with_columns(self, *args, **kwargs):
    made(self, *args, **kwargs)
    if columns:
        self.max_extra = columns


linear_solver.ConstrainedSymmetricSolver.__init__ = with_columns
app(rest)
