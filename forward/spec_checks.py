"""The model spec's error and its checks of a field's value (:mod:`.spec`)."""

from __future__ import annotations

import math

__all__ = ["SpecError", "finite", "finite_positive"]


class SpecError(ValueError):
    """A model spec field holds a value the model cannot take; the message names the field.

    Parameters
    ----------
    field_name : str
        The field, dotted (``"material.c1"``); kept as :attr:`field`.
    message : str
        What is wrong with it.
    """

    def __init__(self, field_name: str, message: str) -> None:
        self.field = field_name
        super().__init__(f"{field_name}: {message}")


def finite(name: str, value: float) -> float:
    """``value`` as a finite float, else a :class:`SpecError` naming the field ``name``."""
    try:
        v = float(value)
    except (TypeError, ValueError) as exc:
        raise SpecError(name, f"must be a number, got {value!r}") from exc
    if not math.isfinite(v):
        raise SpecError(name, f"must be finite, got {value!r}")
    return v


def finite_positive(name: str, value: float) -> float:
    """``value`` as a finite positive float, else a :class:`SpecError` naming the field ``name``."""
    v = finite(name, value)
    if v <= 0.0:
        raise SpecError(name, f"must be positive, got {value!r}")
    return v
