"""The error of a design request that cannot be met."""

from __future__ import annotations

from tensim._input import InputError


class DesignError(InputError):
    """A design request has no answer: no all-tension self-stress, an unreachable target, a
    motor too weak. The message says what was asked, what stands in the way and what to change.
    """
