"""Exceptions that the command line turns into one clear message and a non-zero exit."""


class MmocapError(Exception):
    """Base class: an error the user can fix (bad input, bad config, missing data)."""


class ConfigError(MmocapError):
    """A configuration value is missing, unknown or out of range."""


class DataError(MmocapError):
    """A data file (calibration, image, sequence metadata) is missing or malformed."""


class MmocapWarning(UserWarning):
    """Input that is usable but questionable: the command line prints it as one line, and
    a tracking run records it in ``summary.json`` under ``warnings``."""
