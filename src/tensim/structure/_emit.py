"""Block YAML text of plain data, written directly: the text PyYAML's safe dumper writes.

A structure file of hundreds of cables is some 36,000 values. PyYAML's dumper turns each into
a node in Python (its representer) and asks its resolver, in Python, how each scalar would
read back, before libyaml's emitter writes them: a third of a second for the centipede's 796
cables, several times the cost of the text itself. :func:`block_yaml` writes the same text
for the data a structure holds (mappings with plain names as keys, lists, numbers, booleans
and names) and returns None for anything else (a string that would need quotes, another
type), where the caller lets PyYAML write it. A test checks the text against PyYAML's.
"""

from __future__ import annotations

import functools
import math
import re
from typing import Any

import yaml

# strings written unquoted here: a letter or underscore, then letters, digits and _ . / -
# (no space, so never folded at the line width; ASCII, so never escaped)
_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_./-]*\Z")
_STR_TAG = "tag:yaml.org,2002:str"


class _Unsupported(Exception):
    """A value this writer leaves to PyYAML."""


def block_yaml(data: dict[str, Any]) -> str | None:
    """``yaml.safe_dump(data, sort_keys=False)``'s text (block style), or None where ``data``
    holds something this writer leaves to PyYAML (then call it).

    Args:
        data: a mapping of plain names to values: mappings, lists, None, booleans, ints,
            floats and strings of letters, digits and ``_ . / -`` (exact types: a subclass,
            e.g. a NumPy float, is left to PyYAML, which refuses it).
    """
    if type(data) is not dict or not data:
        return None
    lines: list[str] = []
    try:
        _Writer(lines).mapping(data, 0)
    except _Unsupported:
        return None
    lines.append("")
    return "\n".join(lines)


class _Writer:
    """Appends the lines of a mapping or sequence at an indent to ``lines``."""

    def __init__(self, lines: list[str]):
        self.lines = lines
        self.seen: set[int] = set()  # the lists and mappings written (PyYAML: one used twice
        # becomes an anchor and an alias)

    def mapping(self, data: dict[Any, Any], indent: int) -> None:
        self._once(data)
        pad, lines = " " * indent, self.lines
        for key, value in data.items():
            head = f"{pad}{_name(key)}:"
            kind = type(value)
            if kind is list and value:  # a sequence under a key is not indented (PyYAML's way)
                lines.append(head)
                self.sequence(value, indent)
            elif kind is dict and value:
                lines.append(head)
                self.mapping(value, indent + 2)
            else:
                lines.append(f"{head} {self.scalar(value)}")

    def sequence(self, data: list[Any], indent: int) -> None:
        self._once(data)
        pad, lines = " " * indent, self.lines
        for item in data:
            kind = type(item)
            if (kind is dict or kind is list) and item:  # its first line joins the dash
                start = len(lines)
                if kind is dict:
                    self.mapping(item, indent + 2)
                else:
                    self.sequence(item, indent + 2)
                lines[start] = f"{pad}- {lines[start][indent + 2:]}"
            else:
                lines.append(f"{pad}- {self.scalar(item)}")

    def scalar(self, value: Any) -> str:
        """A leaf value's text (empty lists and mappings included), as PyYAML writes it."""
        kind = type(value)
        if kind is float:
            return _float(value)
        if kind is str:
            return _name(value)
        if kind is bool:
            return "true" if value else "false"
        if kind is int:
            return str(value)
        if value is None:
            return "null"
        if (kind is list or kind is dict) and not value:
            self._once(value)
            return "[]" if kind is list else "{}"
        raise _Unsupported

    def _once(self, container: object) -> None:
        if id(container) in self.seen:
            raise _Unsupported
        self.seen.add(id(container))


def _float(value: float) -> str:
    """PyYAML's ``SafeRepresenter.represent_float``."""
    if math.isnan(value):
        return ".nan"
    if math.isinf(value):
        return ".inf" if value > 0 else "-.inf"
    text = repr(value).lower()
    if "." not in text and "e" in text:  # 1e17: YAML's float needs the point
        text = text.replace("e", ".0e", 1)
    return text


def _name(value: Any) -> str:
    if type(value) is not str or not _reads_as_string(value):
        raise _Unsupported
    return value


@functools.lru_cache(maxsize=4096)
def _reads_as_string(text: str) -> bool:
    """Whether ``text`` written plain reads back as that string (not ``true``, ``null``, a
    number: PyYAML's resolver decides, as when it writes)."""
    return _PLAIN.match(text) is not None and yaml.resolver.Resolver().resolve(
        yaml.ScalarNode, text, (True, False)) == _STR_TAG
