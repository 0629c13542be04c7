"""Threads that wait for work sleep instead of spinning (``OMP_WAIT_POLICY=PASSIVE``).

MKL's PARDISO (on GNU OpenMP with pip's wheels, ``libmkl_gnu_thread``; Intel OpenMP elsewhere),
numba's kernels and torch keep their idle threads spinning by default, which pays where every thread has a core of its own and costs dearly where
one does not: with another process on one of two cores, a contact-L1 run with sensitivities (the
fit's FE confirmation) took 51.4 s with PARDISO on two threads against 6.3 s on one; with the
waits passive, 6.7 s (docs/validation/solver-and-speed.md, "Threads that wait"). An OpenMP
runtime reads the policy when it starts, so it is set when the package is imported, before any
of them is loaded; a value the user set is kept.
"""

from __future__ import annotations

import os

__all__ = ["WAIT_POLICY", "sleeping_thread_waits"]

#: The OpenMP wait policy the package asks for unless the user set one.
WAIT_POLICY = "PASSIVE"


def sleeping_thread_waits() -> str:
    """Ask the OpenMP runtimes loaded from now on to let waiting threads sleep.

    Returns
    -------
    str
        The policy in force: ``OMP_WAIT_POLICY`` as the user set it, else ``WAIT_POLICY``.

    Examples
    --------
    >>> from indentation_studio.thread_waits import sleeping_thread_waits
    >>> sleeping_thread_waits() in ("PASSIVE", "ACTIVE", "passive", "active")
    True
    """
    return os.environ.setdefault("OMP_WAIT_POLICY", WAIT_POLICY)
