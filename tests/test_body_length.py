"""The body length, the field's unit of speed: one rule (tensim.structure.body_length) that the
roll experiment and the RL evaluation both use."""

from __future__ import annotations

import pytest

from tensim.structure import Cable, Node, Rod, Structure, StructureError, body_length


def _nodes() -> tuple[Node, ...]:  # fixed: a node touching no rod needs a mass or a fixing
    return (Node("a", (0.0, 0.0, 0.0), fixed=True), Node("b", (3.0, 4.0, 0.0), fixed=True),
            Node("c", (0.0, 0.0, 2.0), fixed=True), Node("d", (0.0, 0.0, 9.0), fixed=True))


def test_the_longest_rod_else_the_longest_cable():
    rods = (Rod("short", ("a", "c"), 0.01, linear_density=1.0),
            Rod("long", ("a", "b"), 0.01, linear_density=1.0))
    cable = Cable("longer_cable", ("c", "d"), 100.0, rest_length=6.0)  # 7 m: not a rod
    assert body_length(Structure("rods", _nodes(), rods, (cable,))) == pytest.approx(5.0)
    assert body_length(Structure("cables", _nodes(), (), (cable,))) == pytest.approx(7.0)
    with pytest.raises(StructureError, match="neither rods nor cables"):
        body_length(Structure("none", _nodes()))


def test_the_roll_experiment_and_the_rl_evaluation_use_the_one_rule():
    from tensim.experiments import roll
    from tensim.models import load_model
    from tensim.rl import evaluate

    assert roll.body_length is body_length
    assert evaluate.body_length("three_bar") == body_length(load_model("three_bar"))
