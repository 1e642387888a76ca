"""The one error type for bad structure descriptions."""

from __future__ import annotations

from tensim._input import InputError


class StructureError(InputError):
    """A structure description is invalid.

    The message names the file (when read from one), the item and what was expected.
    """

    def __init__(self, message: str, *, item: str | None = None, source: str | None = None):
        self.detail = message
        self.item = item
        self.source = source
        super().__init__(self._format())

    def _format(self) -> str:
        where = ": ".join(p for p in (self.source, self.item) if p)
        return f"{where}: {self.detail}" if where else self.detail

    def with_source(self, source: str) -> StructureError:
        """Returns a copy that also names the file it came from."""
        return StructureError(self.detail, item=self.item, source=source)
