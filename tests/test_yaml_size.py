"""The YAML reader's size check: one pass over a tree, the full walk where aliases are."""

from __future__ import annotations

import numpy as np
import pytest
import yaml

from tensim._input import MAX_DEPTH, InputError, _aliased_size, _expanded_size, load_yaml


def _document(rng: np.random.Generator, depth: int) -> str:
    """A random block of nested mappings and lists (flow style)."""
    if depth == 0 or rng.random() < 0.3:
        return str(rng.integers(100))
    if rng.random() < 0.5:
        return "[" + ", ".join(_document(rng, depth - 1) for _ in range(rng.integers(4))) + "]"
    return "{" + ", ".join(f"k{j}: {_document(rng, depth - 1)}"
                           for j in range(rng.integers(4))) + "}"


def test_one_pass_counts_what_the_full_walk_counts() -> None:
    rng = np.random.default_rng(35)
    for _ in range(200):
        node = yaml.compose(_document(rng, 6))
        assert _expanded_size(node) == _aliased_size(node)
    aliased = yaml.compose("a: &x [1, 2, [3, 4]]\nb: *x\nc: [*x, *x]\n")
    # the mapping, its keys, a, b and c (a list of two more)
    assert _expanded_size(aliased) == _aliased_size(aliased) == 1 + 3 + 6 + 6 + (1 + 6 + 6)


def test_refusals_name_the_line_as_before() -> None:
    deep = "a:\n" + "".join(" " * (2 * k + 2) + f"k{k}:\n" for k in range(MAX_DEPTH + 1)) \
        + " " * (2 * MAX_DEPTH + 4) + "1\n"
    with pytest.raises(InputError, match=r"f.yaml: line \d+: nested deeper than 64 levels"):
        load_yaml(deep, "f.yaml")
    bomb = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join(['*' + chr(97 + k)] * 10)}]\n"
        for k in range(6))
    with pytest.raises(InputError, match=r"line \d+: expands to more than 1000000 values"):
        load_yaml(bomb, "f.yaml")
