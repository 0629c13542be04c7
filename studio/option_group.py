"""A frozen dataclass of options given to a command as its flags (:func:`option_group`): typer sees
one flag a field, the command gets one instance (``studio.options.ModelOptions``,
``studio.lab_options.LabOptions``)."""

from __future__ import annotations

import dataclasses
import functools
import inspect
from collections.abc import Callable
from typing import Any

__all__ = ["REQUIRED", "option_group"]


#: The default of a flag a command requires (:func:`option_group`'s ``values``).
REQUIRED = inspect.Parameter.empty


def option_group(
    options: type,
    flags: dict[str, Any],
    parameter: str,
    names: tuple[str, ...] = (),
    values: dict | None = None,
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """Give a command the flags of a frozen dataclass of options in place of its parameter
    ``parameter`` (annotated with that dataclass).

    Typer sees the flags where ``parameter`` stands in the command's signature (keyword-only, so
    that a flag without a default may follow one with it); the command gets one ``options``
    instance built from them.

    Parameters
    ----------
    options : type
        The dataclass (e.g. :class:`ModelOptions`).
    flags : dict
        Field name -> its flag's ``Annotated`` type, for every field that can be a flag.
    parameter : str
        The command's parameter the options replace.
    names : tuple of str
        The fields the command has flags for; empty: every field of ``flags``.
    values : dict, optional
        A flag's default (a field in ``names``; :data:`REQUIRED`: the flag is required), or the
        value of a field without a flag; other fields keep the dataclass's defaults (a field
        without one: a required flag).

    Returns
    -------
    Callable
        The decorator.
    """
    names = names or tuple(flags)
    values = values or {}
    unknown = sorted(set(names) - set(flags))
    if unknown:
        raise TypeError(f"{options.__name__}: no flag for {', '.join(unknown)}")
    fixed = {k: v for k, v in values.items() if k not in names}
    defaults = {
        f.name: REQUIRED if f.default is dataclasses.MISSING else f.default
        for f in dataclasses.fields(options)
    }

    def decorate(command: Callable[..., Any]) -> Callable[..., Any]:
        signature = inspect.signature(command, eval_str=True)
        params = list(signature.parameters.values())
        at = [p.name for p in params].index(parameter)
        taken = sorted({p.name for p in params} & set(names))
        if taken:
            raise TypeError(
                f"{command.__name__}: parameter(s) {', '.join(taken)} are {options.__name__} flags"
            )
        added = [
            inspect.Parameter(
                n, inspect.Parameter.KEYWORD_ONLY, default=values.get(n, defaults[n]), annotation=flags[n]
            )
            for n in names
        ]

        @functools.wraps(command)
        def run(*args: Any, **kwargs: Any) -> Any:
            group = options(**fixed, **{n: kwargs.pop(n) for n in names})
            return command(*args, **{parameter: group}, **kwargs)

        new = params[:at] + added + params[at + 1 :]
        run.__signature__ = signature.replace(
            parameters=[p.replace(kind=inspect.Parameter.KEYWORD_ONLY) for p in new]
        )
        run.__annotations__ = {p.name: p.annotation for p in new}
        del run.__wrapped__  # typer reads the signature above, not the command's
        return run

    return decorate
