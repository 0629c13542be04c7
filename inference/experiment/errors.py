"""The error of malformed experiment data, below every module that reads or checks it (so that
the readers, the hold checks and the relaxation fit import it without importing each other)."""

__all__ = ["ExperimentDataError"]


class ExperimentDataError(ValueError):
    """Malformed experiment data; the message names the file, row and column."""
