"""Threads that wait for work spin briefly, then sleep (``GOMP_SPINCOUNT=3000``).

MKL's PARDISO (on GNU OpenMP with pip's wheels, ``libmkl_gnu_thread``; Intel OpenMP elsewhere),
numba's ``omp`` layer and torch keep their idle threads spinning by default (GNU OpenMP about
300,000 spins after each parallel region, Intel OpenMP 200 ms), which pays where every thread has
a core of its own and costs dearly where one does not. Sleeping at once (``OMP_WAIT_POLICY=
PASSIVE``, the package's choice until issue 58) pays the wake-ups instead: 20 to 30 % of a small
run on an idle machine. A short spin keeps both: two threads, measured by
``benchmarks/thread_waits.py --waits`` (docs/validation/solver-and-speed.md, "Threads that wait"),
the paper protocol warm 0.98 s idle and 1.88 s beside a busy core with 3,000 spins, against 1.21
and 1.65 s passive and 0.90 and 10 s with the runtime's default. Intel OpenMP, which ignores
GNU's spin count, keeps the passive wait (``KMP_BLOCKTIME=0``).

A runtime reads these when it starts, so they are set when the package is imported, before any
of them is loaded. A wait policy or spin count the user set is kept, and then nothing is added.
"""

from __future__ import annotations

import os

__all__ = ["USER_CHOICES", "WAIT_SETTINGS", "brief_thread_waits"]

#: What the package asks of OpenMP runtimes unless the user chose: GNU's waiting threads spin
#: 3,000 times (a few microseconds) before they sleep; Intel's sleep at once.
WAIT_SETTINGS = {"GOMP_SPINCOUNT": "3000", "KMP_BLOCKTIME": "0"}

#: The variables by which a user chooses the waits; if any is set, the package adds nothing.
USER_CHOICES = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "KMP_BLOCKTIME")


def brief_thread_waits() -> dict[str, str]:
    """Ask the OpenMP runtimes loaded from now on to spin briefly, then sleep, when they wait.

    Returns
    -------
    dict of str to str
        The wait settings in force: the user's where any of ``USER_CHOICES`` is set (the
        package then sets nothing), else ``WAIT_SETTINGS``.

    Examples
    --------
    >>> from indentation_studio.thread_waits import brief_thread_waits
    >>> isinstance(brief_thread_waits(), dict)
    True
    """
    chosen = {k: os.environ[k] for k in USER_CHOICES if k in os.environ}
    if chosen:
        return chosen
    os.environ.update(WAIT_SETTINGS)
    return dict(WAIT_SETTINGS)
