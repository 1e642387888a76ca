"""structure.yaml written directly (tensim.structure._emit): PyYAML's text, byte for byte."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import yaml

from tensim.models import PRESETS
from tensim.structure import DCMotor, load_structure, save_structure, structure_to_dict
from tensim.structure import _yaml as structure_yaml
from tensim.structure._emit import block_yaml

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted([*ROOT.glob("examples/*.yaml"), *ROOT.glob("examples/design/*.yaml"),
                   *ROOT.glob("examples/ntrt/*.yaml")])


def _pyyaml(data: object) -> str:
    return yaml.dump(data, Dumper=structure_yaml._SafeDumper, sort_keys=False)


def _structures() -> dict[str, object]:
    robots = {name: preset.build() for name, preset in PRESETS.items()}
    for path in EXAMPLES:
        try:
            robots[path.name] = load_structure(path)
        except Exception:  # not a structure file (a motor table, a sketch)
            continue
    spine = robots["tetraspine3"]
    dc = dataclasses.replace(spine.cables[0].motor, dc=DCMotor(back_drivable=False))
    robots["dc motor"] = dataclasses.replace(
        spine, cables=(dataclasses.replace(spine.cables[0], motor=dc), *spine.cables[1:]))
    return robots


STRUCTURES = _structures()


@pytest.mark.parametrize("name", sorted(STRUCTURES))
def test_structure_file_is_pyyamls_text(name: str, tmp_path: Path) -> None:
    structure = STRUCTURES[name]
    data = structure_to_dict(structure)
    # the records' conversion is dataclasses.asdict's, less its copy
    reference = structure_yaml._as_dict
    try:
        structure_yaml._as_dict = dataclasses.asdict
        assert structure_to_dict(structure) == data
    finally:
        structure_yaml._as_dict = reference
    text = block_yaml(data)
    assert text is not None  # every shipped robot takes the direct path
    assert text == _pyyaml(data)
    save_structure(structure, tmp_path / "s.yaml", header=["from a test"])
    assert (tmp_path / "s.yaml").read_text() == "# from a test\n" + text
    assert load_structure(tmp_path / "s.yaml") == structure


SCALARS = [0.0, -0.0, 1.5, -2.25e-16, 1e17, 1e-5, 12345678901234.5, float("inf"),
           float("-inf"), float("nan"), 0, 7, -3, 10**20, True, False, None, "a", "p1/spine",
           "string_0", "x.y-z", "_u", [], {}]
NEEDS_PYYAML = ["", "yes", "No", "on", "OFF", "null", "true", "Null", "1.0", "0x1f",
                "a b", "-a", "a:b", "é", ".5", "#c", "'q'", "a" * 100 + " " + "b" * 100,
                (1, 2), np.float64(1.0), np.int64(2), 1 + 2j, b"x"]


def _random_data(rng: np.random.Generator, depth: int, pool: list[object]) -> object:
    pick = rng.random()
    if depth > 0 and pick < 0.3:
        return {f"k{j}": _random_data(rng, depth - 1, pool)
                for j in range(int(rng.integers(0, 4)))}
    if depth > 0 and pick < 0.55:
        return [_random_data(rng, depth - 1, pool) for _ in range(int(rng.integers(0, 4)))]
    value = pool[int(rng.integers(len(pool)))]
    return type(value)() if type(value) in (list, dict) else value  # a fresh [] or {}


def test_block_yaml_is_pyyamls_text_or_leaves_it_to_pyyaml() -> None:
    rng = np.random.default_rng(35)
    written = 0
    for trial in range(400):
        pool = SCALARS + (NEEDS_PYYAML if trial % 2 else [])
        data = {f"top{j}": _random_data(rng, 4, pool) for j in range(1, 4)}
        text = block_yaml(data)
        if trial % 2 == 0:  # only values it writes: it writes them all, as PyYAML does
            assert text == _pyyaml(data)
            written += 1
        elif text is not None:
            assert text == _pyyaml(data)
    assert written == 200
    for value in NEEDS_PYYAML:  # each alone is left to PyYAML (which quotes or refuses it)
        assert block_yaml({"v": value}) is None
        assert block_yaml({"v": [{"w": value}]}) is None
    assert block_yaml({"a b": 1}) is None  # a key that PyYAML would quote
    shared = [1.0]  # a list written twice: PyYAML's anchor and alias
    assert block_yaml({"a": shared, "b": [shared]}) is None
    assert "&id001" in _pyyaml({"a": shared, "b": [shared]})
