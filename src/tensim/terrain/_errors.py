"""The error raised for an invalid terrain description."""

from tensim._input import InputError


class TerrainError(InputError):
    """A terrain description or file is invalid; the message names the field and the fix."""
