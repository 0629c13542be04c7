"""The solver's speed by commit, as an airspeed velocity (asv) suite (``benchmarks/asv.conf.json``).

Each ``time_*`` wraps a timing case of ``benchmarks/`` so that asv keeps its history commit by
commit: the paper protocol on ``default``, warm (``forward_speed.py``, ``speed_history.py``); one
contact-L1 run with Coulomb friction and sensitivities (``thread_waits.py``, ``contact_cost.py``);
the posterior of the shipped example on the shipped surrogate (``posterior_speed.py``). The
numba kernels are compiled in ``setup`` (one run), so a sample is a warm run.
"""
