"""Reading input files strictly: text that decodes, YAML without surprises, values of one type.

Every file tensim reads goes through :func:`read_text` (a clear error for a missing file, a
folder, a file too large or bytes that are not UTF-8) and YAML through :func:`load_yaml`, which
reads the YAML 1.2 core schema rather than PyYAML's 1.1 one: only ``true``/``false`` are
booleans (``yes``, ``no``, ``on``, ``off`` stay strings), ``1e12`` is a number, ``010`` is ten
and dates stay strings. It refuses duplicate keys, nesting deeper than :data:`MAX_DEPTH` and
documents whose aliases would expand past :data:`MAX_NODES` values (an "alias bomb"), naming
the file and line. Every error of a bad input is an :class:`InputError`.
"""

from __future__ import annotations

import hashlib
import math
import numbers
import os
import pickle
import re
from collections import OrderedDict
from pathlib import Path
from typing import Any, ClassVar

import yaml

MAX_FILE_BYTES = 64 * 2**20  # largest text input read [bytes]
MAX_DEPTH = 64  # deepest nesting of a YAML document
MAX_NODES = 1_000_000  # most values a YAML document may expand to, aliases counted each time


class InputError(ValueError):
    """A file, option or value given to tensim is invalid.

    The message names the file (or option), the field and what was expected. Every error type
    of a bad input (structure, controller, hardware log, terrain, run folder) derives from it.
    """


def is_real(value: object) -> bool:
    """Whether ``value`` is a finite real number (a boolean is not a number)."""
    return (isinstance(value, numbers.Real) and not isinstance(value, bool)
            and type(value).__name__ != "bool_" and math.isfinite(float(value)))


def describe(value: object) -> str:
    """A short description of a wrong value for a message: its repr and, if odd, its type."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    if isinstance(value, bool | str | type(None)) or is_real(value):
        return text
    return f"{text} (a {type(value).__name__})"


def read_text(path: str | os.PathLike[str], limit: int = MAX_FILE_BYTES) -> str:
    """The text of a UTF-8 file.

    Raises:
        FileNotFoundError: no such file.
        InputError: a folder, a device or pipe, a file larger than ``limit`` bytes, or bytes
            that are not UTF-8; naming the file.
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{path}: is a folder; expected a file")
    try:
        size = path.stat().st_size
    except FileNotFoundError:
        raise FileNotFoundError(f"{path}: no such file") from None
    if not path.is_file():  # a device or a pipe could be read forever
        raise InputError(f"{path}: not a regular file; expected a file")
    if size > limit:
        raise InputError(f"{path}: {size} bytes is larger than the limit of {limit} bytes")
    data = path.read_bytes()
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[:err.start].count(b"\n") + 1
        raise InputError(f"{path}: line {line}: not UTF-8 text (byte 0x{data[err.start]:02x} "
                         f"at offset {err.start}); save the file as UTF-8") from None


# libyaml's parser where PyYAML was built with it: a structure of hundreds of cables (an
# imported NTRT robot) parses in a tenth of the pure-Python parser's time
_SafeLoader: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class _Loader(_SafeLoader):
    """PyYAML's safe loader with YAML 1.2 core scalars, refusing duplicate keys."""

    yaml_implicit_resolvers: ClassVar[dict[str, list[tuple[str, re.Pattern[str]]]]] = {}

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, yaml.Node] = {}
        for key_node, _ in node.value:
            if key_node.tag == "tag:yaml.org,2002:merge":
                continue
            key = self.construct_object(key_node, deep=True)
            try:
                first = seen.setdefault(key, key_node)
            except TypeError:
                raise yaml.constructor.ConstructorError(
                    None, None, f"a mapping key must be a plain value, got {key!r}",
                    key_node.start_mark) from None
            if first is not key_node:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r} (first given on line "
                    f"{first.start_mark.line + 1})", key_node.start_mark)
        return super().construct_mapping(node, deep=deep)

    def construct_yaml_int(self, node: yaml.ScalarNode) -> int:
        text = str(self.construct_scalar(node))
        sign, digits = (-1, text[1:]) if text.startswith("-") else (1, text.lstrip("+"))
        if digits[:2] in ("0o", "0x"):
            return sign * int(digits[2:], 8 if digits[1] == "o" else 16)
        return sign * int(digits, 10)


_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_yaml_int)
for _tag, _pattern, _first in (
        ("bool", r"^(?:true|True|TRUE|false|False|FALSE)$", "tTfF"),
        ("int", r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$", "-+0123456789"),
        ("float", r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
                  r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$", "-+.0123456789"),
        ("null", r"^(?:~|null|Null|NULL|)$", ["~", "n", "N", ""]),
        ("merge", r"^(?:<<)$", "<")):
    _Loader.add_implicit_resolver(f"tag:yaml.org,2002:{_tag}", re.compile(_pattern),
                                  list(_first))


def _expanded_size(node: yaml.Node) -> int:
    """Values ``node`` expands to (an alias counts its target each time); refuses cycles,
    nesting deeper than MAX_DEPTH and sizes over MAX_NODES.

    A document without aliases (no node reached twice) is a tree: its size is its count of
    nodes, taken in one pass without the memory of each node's size. Anything else (an
    alias, a refusal) is left to the full walk, which names the line as before.
    """
    seen: set[int] = set()
    stack = [(node, 0)]
    while stack:
        n, depth = stack.pop()
        if depth > MAX_DEPTH or id(n) in seen or len(seen) >= MAX_NODES:
            return _aliased_size(node)
        seen.add(id(n))
        if isinstance(n, yaml.SequenceNode):
            stack.extend((c, depth + 1) for c in n.value)
        elif isinstance(n, yaml.MappingNode):
            stack.extend((c, depth + 1) for pair in n.value for c in pair)
    return len(seen)


def _aliased_size(node: yaml.Node) -> int:
    """:func:`_expanded_size` of any document: each node's size kept, so that an alias counts
    its target's once known."""
    sizes: dict[int, int] = {}

    def size(n: yaml.Node, depth: int, path: frozenset[int]) -> int:
        if id(n) in sizes:
            return sizes[id(n)]
        if depth > MAX_DEPTH:
            raise _Refused(n, f"nested deeper than {MAX_DEPTH} levels")
        if id(n) in path:
            raise _Refused(n, "an alias refers to a value that contains it")
        children: list[yaml.Node] = []
        if isinstance(n, yaml.SequenceNode):
            children = n.value
        elif isinstance(n, yaml.MappingNode):
            children = [c for pair in n.value for c in pair]
        inner = path | {id(n)}
        total = 1 + sum(size(c, depth + 1, inner) for c in children)
        if total > MAX_NODES:
            raise _Refused(n, f"expands to more than {MAX_NODES} values (through aliases)")
        sizes[id(n)] = total
        return total

    return size(node, 0, frozenset())


class _Refused(Exception):
    def __init__(self, node: yaml.Node, message: str):
        super().__init__(message)
        self.line = node.start_mark.line + 1


# documents read, by their text's digest, as pickles (each reader gets a fresh copy): a run
# reads its structure file more than once (the structure, the check's passive cables), and
# unpickling an imported robot's 460 kB file costs a tenth of parsing it
_PARSED: OrderedDict[bytes, bytes] = OrderedDict()
PARSED_KEPT = 8  # documents kept


def load_yaml(text: str, source: str) -> Any:
    """The data of a YAML (or JSON) document, read strictly (see the module's docstring).

    A document read before (the same text) is not parsed again: the reader gets a fresh copy
    of its data.

    Args:
        text: the document.
        source: the file it came from, for messages.

    Raises:
        InputError: not valid YAML, a duplicate key, too deep or too large; naming ``source``
            and the line.
    """
    key = hashlib.blake2b(text.encode("utf-8", "surrogatepass"), digest_size=20).digest()
    if key in _PARSED:
        _PARSED.move_to_end(key)
        return pickle.loads(_PARSED[key])
    data = _parse_yaml(text, source)
    _PARSED[key] = pickle.dumps(data, protocol=pickle.HIGHEST_PROTOCOL)
    if len(_PARSED) > PARSED_KEPT:
        _PARSED.popitem(last=False)
    return data


def _parse_yaml(text: str, source: str) -> Any:
    """:func:`load_yaml` without the memory of documents read."""
    try:
        loader = _Loader(text)
    except yaml.YAMLError as err:  # a character YAML does not allow
        raise InputError(f"{source}: not valid YAML: {err}") from None
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _expanded_size(node)
        return loader.construct_document(node)
    except _Refused as err:
        raise InputError(f"{source}: line {err.line}: {err}") from None
    except yaml.MarkedYAMLError as err:
        line = f" at line {err.problem_mark.line + 1}" if err.problem_mark else ""
        raise InputError(f"{source}: not valid YAML{line}: {err.problem or err}") from None
    except yaml.YAMLError as err:
        raise InputError(f"{source}: not valid YAML: {err}") from None
    except RecursionError:
        raise InputError(f"{source}: nested too deeply (more than {MAX_DEPTH} levels)") from None
    finally:
        loader.dispose()


def load_yaml_file(path: str | os.PathLike[str]) -> Any:
    """:func:`read_text` then :func:`load_yaml`."""
    return load_yaml(read_text(path), str(path))


def _unique_pairs(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise InputError(f"duplicate key {key!r}")
        out[key] = value
    return out


def load_json(text: str, source: str) -> Any:
    """The data of a JSON document, refusing duplicate keys.

    Raises:
        InputError: not valid JSON, a duplicate key or nested too deeply; naming ``source``.
    """
    import json

    try:
        return json.loads(text, object_pairs_hook=_unique_pairs)
    except json.JSONDecodeError as err:
        raise InputError(f"{source}: line {err.lineno}: not valid JSON: {err.msg}") from None
    except InputError as err:
        raise InputError(f"{source}: {err}") from None
    except RecursionError:
        raise InputError(f"{source}: nested too deeply") from None
