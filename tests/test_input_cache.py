"""A YAML document read twice is parsed once: each reader gets a fresh copy equal to a parse."""

from __future__ import annotations

import pytest

from tensim import InputError
from tensim._input import _parse_yaml, load_yaml

_DOC = """\
name: robot
shared: &pose [0.5, -1.0e-3, .inf]
nodes:
  - {name: a, position: *pose, fixed: true}
  - {name: b, position: [1, 2, 3], tag: yes, when: 2001-12-14, octal: 0o17}
empty: ~
"""


def test_a_document_read_again_equals_a_fresh_parse_and_is_its_own_copy() -> None:
    fresh = _parse_yaml(_DOC, "f.yaml")
    first = load_yaml(_DOC, "f.yaml")
    second = load_yaml(_DOC, "g.yaml")  # read again (another name: the same text)
    assert first == fresh and second == fresh
    assert second is not first and second["nodes"] is not first["nodes"]
    # an alias is one value in both, as the parser makes it
    assert second["shared"] is second["nodes"][0]["position"]
    assert fresh["shared"] is fresh["nodes"][0]["position"]
    first["nodes"].append("edited")  # a reader's edits never reach the next reader
    second["shared"][0] = 9.0
    assert load_yaml(_DOC, "f.yaml") == fresh


def test_an_edited_document_is_parsed_again_and_a_refused_one_refused_every_time() -> None:
    assert load_yaml("v: 1\n", "f.yaml") == {"v": 1}
    assert load_yaml("v: 2\n", "f.yaml") == {"v": 2}
    for _ in range(2):
        with pytest.raises(InputError, match="duplicate key"):
            load_yaml("v: 1\nv: 2\n", "f.yaml")
