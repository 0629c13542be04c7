"""The registry of surrogate kinds: the name a surrogate file records (``gp``, ``mlp``, ``mf``)
and the class that rebuilds it. Classes are named as ``module:Class`` and imported only when a
file of that kind is read, so that reading a GP never imports torch; the persistence layer and the
multi-fidelity surrogate (which rebuilds its low level) both look kinds up here, not in each other.
"""

from __future__ import annotations

import importlib

__all__ = ["SAVED_KINDS", "surrogate_class"]

#: kind -> "module (under indentation_studio.surrogate):Class"
SAVED_KINDS: dict[str, str] = {
    "gp": "gaussian_process:GaussianProcessSurrogate",
    "mlp": "mlp:MLPSurrogate",
    "mf": "multi_fidelity:MultiFidelitySurrogate",
    "slip": "slip_surrogate:SlipSurrogate",
}


def surrogate_class(kind: str) -> type:
    """The class that rebuilds a saved surrogate of ``kind`` (its module imported now).

    Parameters
    ----------
    kind : {"gp", "mlp", "mf", "slip"}
        The kind a surrogate file records.

    Returns
    -------
    type
        The surrogate class.

    Raises
    ------
    ValueError
        If ``kind`` is unknown.

    Examples
    --------
    >>> from indentation_studio.surrogate import surrogate_class
    >>> surrogate_class("gp").__name__
    'GaussianProcessSurrogate'
    """
    if kind not in SAVED_KINDS:
        raise ValueError(f"unknown surrogate kind {kind!r}; known: {', '.join(sorted(SAVED_KINDS))}")
    module, name = SAVED_KINDS[kind].split(":")
    return getattr(importlib.import_module(f"{__package__}.{module}"), name)
