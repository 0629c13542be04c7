"""The campaign package's errors, in a module of their own so that the command line can name
them without importing pandas and scipy."""

__all__ = ["CampaignError", "DesignError", "DiskFullError"]


class CampaignError(ValueError):
    """A campaign that cannot be created, resumed or read; the message says why."""


class DesignError(ValueError):
    """A design that cannot be built; the message names the offending part."""


class DiskFullError(CampaignError, OSError):
    """The disk filled while writing into the store; the message names the file.

    Nothing was written half: every write is a temporary file renamed only when complete.
    """
