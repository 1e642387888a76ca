"""The error raised for an invalid terrain description."""


class TerrainError(ValueError):
    """A terrain description or file is invalid; the message names the field and the fix."""
