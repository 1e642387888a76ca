"""The rolling presets' standing poses are stored data (tensim.models._standing): read bit for
bit, they must still be the static pose the design tools solve for the preset as written."""

from __future__ import annotations

import dataclasses
import importlib
import json

import numpy as np
import pytest

import tensim.models._standing as stored
from tensim.models import six_bar, superball, three_bar
from tensim.models._standing import pose_record, standing
from tensim.structure import StructureError

# 1e-9 m: a fresh solve differs from the stored one by round-off (below 1e-14 m on any LAPACK);
# a changed parameter moves the pose by far more (1 % more end-cap mass: 77 um, see below)
POSE_TOLERANCE = 1e-9
# the module (``tensim.models.six_bar`` is also the name of its preset function)
six_bar_module = importlib.import_module("tensim.models.six_bar")


def _largest_difference(a, b) -> float:
    """The largest difference of a node coordinate or a rest length [m]."""
    nodes = np.abs(np.array([n.position for n in a.nodes]) - [n.position for n in b.nodes])
    rest = [a.rest_length(c) - b.rest_length(d) for c, d in zip(a.cables, b.cables, strict=True)]
    return float(max(nodes.max(), np.abs(rest).max()))


def _unposed(structure):
    """``structure`` without its pose (node positions, rest lengths): what the file does not
    hold."""
    return dataclasses.replace(
        structure, nodes=tuple(dataclasses.replace(n, position=(float(i), 0.0, 0.0))
                               for i, n in enumerate(structure.nodes)),
        cables=tuple(dataclasses.replace(c, rest_length=1.0, pretension=None)
                     for c in structure.cables))


@pytest.mark.parametrize("build", [three_bar, six_bar, superball])
def test_a_stored_pose_is_the_static_pose_the_design_tools_solve(build):
    """Read from its file, the pose equals a fresh statics solve of the preset as written (a
    parameter changed without rerunning tools/standing_poses.py --write fails here), and
    everything but the pose comes from the preset's code."""
    built, fresh = build(), standing(build(standing=False))
    assert _largest_difference(built, fresh) < POSE_TOLERANCE
    assert _unposed(built) == _unposed(fresh)


def test_a_changed_parameter_is_caught(monkeypatch):
    """A change the file cannot see at load (the end caps' mass: the rest lengths stay) moves
    the solved pose far past the tolerance, so the test above fails; a change to the cables
    (stiffness) is refused at load, naming the file."""
    before = standing(six_bar(standing=False))
    monkeypatch.setattr(six_bar_module, "END_MASS", 1.01 * six_bar_module.END_MASS)
    assert _largest_difference(six_bar(), standing(six_bar(standing=False))) > 1e3 * POSE_TOLERANCE
    assert _largest_difference(six_bar(), before) < POSE_TOLERANCE  # still the stored pose
    monkeypatch.setattr(six_bar_module, "STIFFNESS", 1.01 * six_bar_module.STIFFNESS)
    with pytest.raises(StructureError, match=r"six_bar\.json: made for another six_bar: "
                       r"cable 'cable_\w+' has rest length .* regenerate"):
        six_bar()


def test_the_stored_floats_read_back_exactly():
    """JSON writes a float as its shortest repr, which reads back as the same float: the
    file keeps a pose bit for bit (checked on a fresh solve's record and on the shipped
    files, which hold exactly what the presets build)."""
    for build in (three_bar, six_bar, superball):
        record = pose_record(standing(build(standing=False)))
        assert json.loads(json.dumps(record)) == record
        shipped = json.loads((stored.STORED / f"{build.__name__}.json").read_text())
        assert shipped == pose_record(build())
    assert sorted(p.stem for p in stored.STORED.glob("*.json")) == \
        ["six_bar", "superball", "three_bar"]


def _write(folder, data) -> None:
    text = data if isinstance(data, str) else json.dumps(data)
    (folder / "six_bar.json").write_text(text)


def _edited(edit):
    record = pose_record(six_bar())
    edit(record)
    return record


@pytest.mark.parametrize("content, message", [
    (None, r"six_bar\.json: no such file; the preset 'six_bar' reads its standing pose"),
    ("{", r"six_bar\.json: line 1: not valid JSON"),
    ([1, 2], r"six_bar\.json: expected a mapping with the keys"),
    (_edited(lambda r: r["nodes"].pop("x00")), r"six_bar\.json: nodes: .*missing \['x00'\]"),
    (_edited(lambda r: r["nodes"].update(x00=[0.0, "a", 0.0])),
     r"six_bar\.json: nodes\.x00: expected three finite numbers \[m\]"),
    (_edited(lambda r: r["rest_lengths"].update(cable_x00_y00=-1.0)),
     r"six_bar\.json: rest_lengths\.cable_x00_y00: expected a positive number"),
    (_edited(lambda r: r.update(structure="superball")), r"structure: expected 'six_bar'"),
    (_edited(lambda r: r["rest_lengths"].update(
        cable_x00_y00=r["rest_lengths"]["cable_x00_y00"] + 1e-6)),
     r"made for another six_bar: cable 'cable_x00_y00'"),
])
def test_a_missing_or_malformed_file_is_refused_by_name(tmp_path, monkeypatch, content, message):
    """No silent fallback to solving: that would bring back the round-off the files remove."""
    monkeypatch.setattr(stored, "STORED", tmp_path)
    if content is not None:
        _write(tmp_path, content)
    with pytest.raises(StructureError, match=message):
        six_bar()
