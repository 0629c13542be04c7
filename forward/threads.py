"""How many threads a solve uses: as many as the machine has idle cores.

A lone run (a CLI call, a fit's FE stage) takes the cores nobody else is using; a campaign worker,
one of as many workers as cores, asks for one thread (``EmbeddedSolver.run(threads=1)``). Busy
cores are read from the kernel's count of runnable tasks (``/proc/loadavg``, sampled a few times
over a few milliseconds, the smallest count kept so that a passing task is not counted), not from
the load average, which lags a minute behind. ``INDENTATION_STUDIO_THREADS`` overrides the policy.

The numbers do not depend on the thread count beyond round-off: numba's element kernel writes each
element's share to its own slot and PARDISO's factorisation is deterministic per thread count
(tests/test_solver.py compares 1 and 2 threads to 1e-8 relative).

Threads that wait spin by default, and a spinning thread on a core another process needs costs
more than the thread gains: the package asks OpenMP runtimes to spin briefly, then sleep
(:mod:`indentation_studio.thread_waits`), and the experiment workflows (``fit_experiment``,
``sample_posterior_for``) keep numpy's BLAS (OpenBLAS, whose threads spin whatever the policy) on
one thread (measured in docs/validation/solver-and-speed.md, "Threads that wait").
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Iterator

import numba
from threadpoolctl import threadpool_limits

__all__ = ["busy_cores", "solver_threads", "thread_limits"]

#: Environment variable that fixes the thread count of every solve (a whole number >= 1).
THREADS_ENV = "INDENTATION_STUDIO_THREADS"


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def busy_cores(samples: int = 5, interval_s: float = 0.002) -> int:
    """Cores busy with other processes now, from the runnable tasks the kernel counts.

    Parameters
    ----------
    samples : int, default 5
        Readings of ``/proc/loadavg``.
    interval_s : float, default 0.002
        Time between readings, s.

    Returns
    -------
    int
        The smallest reading less this process; 0 where it cannot be read.
    """
    counts = []
    for k in range(samples):
        try:
            with open("/proc/loadavg") as fh:
                running = int(fh.read().split()[3].split("/")[0])
        except (OSError, ValueError, IndexError):
            return 0
        counts.append(running - 1)  # the reader itself is running
        if k + 1 < samples:
            time.sleep(interval_s)
    return max(0, min(counts))


def solver_threads() -> int:
    """The thread count of a lone solve.

    Returns
    -------
    int
        ``INDENTATION_STUDIO_THREADS`` if set, else the idle cores (at least 1).

    Raises
    ------
    ValueError
        If ``INDENTATION_STUDIO_THREADS`` is not a whole number >= 1.
    """
    fixed = os.environ.get(THREADS_ENV)
    if fixed:
        try:
            value = int(fixed)
        except ValueError:
            value = 0
        if value < 1:
            raise ValueError(f"{THREADS_ENV}={fixed!r}: use a whole number >= 1")
        return value
    return max(1, available_cores() - busy_cores())


@contextlib.contextmanager
def thread_limits(threads: int | None) -> Iterator[None]:
    """A context that limits numba's and the BLAS/OpenMP libraries' (MKL's PARDISO) threads.

    numba's count is restored on exit.

    Parameters
    ----------
    threads : int or None
        The thread limit; None leaves them as they are.

    Yields
    ------
    None
        Inside the block the limits hold.

    Examples
    --------
    >>> from indentation_studio.forward import thread_limits
    >>> with thread_limits(1):
    ...     pass
    """
    if threads is None:
        yield
        return
    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    try:
        with threadpool_limits(threads):
            yield
    finally:
        numba.set_num_threads(before)
