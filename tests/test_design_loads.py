"""Static response to loads (tensim.design.loading) against simulation: displacements under a
held load and the load factor at which the first cable slackens under a ramped one."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import tensim
from tensim.cli import main
from tensim.design import DesignError
from tensim.design.loading import load_response
from tensim.hardware import node_positions
from tensim.model import WorldOptions
from tensim.sim import NodeLoad
from tensim.structure import Cable, Node

HOPPER = Path(__file__).parent.parent / "examples/design/hopper.yaml"
ZERO_G = WorldOptions(gravity=(0.0, 0.0, 0.0), ground=False)


def _anchored() -> tensim.Structure:
    """The hopper with each foot held by six stiff cables (+-x, +-y, +-z, 0.1 m, 500 N each,
    balanced) to fixed nodes: a support that the statics and the simulation model alike."""
    structure = tensim.load_structure(HOPPER)
    nodes, cables = list(structure.nodes), list(structure.cables)
    for foot in ("b0", "b1", "b2"):
        p = structure.position(foot)
        for k, d in enumerate(np.vstack([np.eye(3), -np.eye(3)])):
            nodes.append(Node(f"{foot}_anchor{k}", tuple(p + 0.1 * d), fixed=True))
            cables.append(Cable(f"{foot}_pin{k}", (foot, f"{foot}_anchor{k}"), 5e4,
                                damping=20.0, pretension=500.0))
    return dataclasses.replace(structure, nodes=tuple(nodes), cables=tuple(cables))


def test_first_slack_cable_matches_a_ramped_load_in_simulation() -> None:
    structure = _anchored()
    force = np.array([0.0, 5.0, 0.0])
    result = load_response(structure, {"t0": tuple(force)}, supports=False)
    assert result.slack_cable.startswith("top_")
    # ramp to 1.25 x the predicted factor over 4 s (the softest mode, ~10 Hz, follows it
    # quasi-statically) and find the first sample at which a cable goes slack
    duration, top = 4.0, 1.25 * result.slack_factor
    compiled = tensim.compile_structure(structure, ZERO_G, load_nodes=("t0",))
    run = tensim.simulate(compiled, duration, record_dt=0.001,
                          loads=[NodeLoad("t0", [0.0, duration], [np.zeros(3), top * force])])
    tensions = np.stack([run.trajectory[f"tension/{c.name}"] for c in structure.cables], 1)
    first = int(np.argmax(tensions.min(axis=1) <= 0.0))
    assert first > 0
    factor = run.trajectory.time[first] / duration * top
    assert factor == pytest.approx(result.slack_factor, rel=0.02)  # the bound
    assert structure.cables[int(np.argmin(tensions[first]))].name == result.slack_cable


def test_held_load_displacements_match_simulation() -> None:
    structure = _anchored()
    force = np.array([0.0, 5.0, 0.0])
    result = load_response(structure, {"t0": tuple(force)}, supports=False)
    compiled = tensim.compile_structure(structure, ZERO_G, load_nodes=("t0",))
    run = tensim.simulate(compiled, 3.0, record_dt=0.01,
                          loads=[NodeLoad("t0", [0.0, 0.5], [np.zeros(3), force])])
    nodes = ("t0", "t1", "t2")
    settled = node_positions(run.trajectory, compiled, nodes)
    for node in nodes:
        # the mean over the last second: the softest mode (~10 Hz) still rings lightly
        moved = settled[node][-100:].mean(axis=0) - structure.position(node)
        scale = np.linalg.norm(result.exact["t0"])
        # the exact static pose within 0.5 % of t0's motion (measured 0.05 %: what is left
        # of the ringing); the tangent stiffness's linear answer within 5 % (measured 2 %:
        # the response is not linear at millimetres)
        assert np.linalg.norm(moved - result.exact[node]) < 0.005 * scale, node
        assert np.linalg.norm(moved - result.linear[node]) < 0.05 * scale, node
    assert np.linalg.norm(result.exact["t0"]) > 1e-3  # a real motion, of millimetres


def test_bad_loads_are_refused() -> None:
    structure = tensim.load_structure(HOPPER)
    with pytest.raises(DesignError, match=r"a free structure .* needs a load that balances"):
        load_response(structure, {"t0": (1.0, 0.0, 0.0)}, supports=False)
    with pytest.raises(DesignError, match="node 'b0' is a foot"):
        load_response(structure, {"b0": (1.0, 0.0, 0.0)})
    with pytest.raises(DesignError, match="unknown node 'x9'"):
        load_response(structure, {"x9": (1.0, 0.0, 0.0)})


def test_loads_command_prints_the_factors(tmp_path: Path, capsys) -> None:
    path = tmp_path / "anchored.yaml"
    tensim.save_structure(_anchored(), path)
    assert main(["design", "loads", str(path), "--free", "--load", "t0:0,5,0"]) == 0
    out = capsys.readouterr().out
    assert "hopper free, at zero gravity; load t0 (0, 5, 0) N" in out
    assert "first cable to slacken: top_" in out
    assert "rods without a section: no buckling check" in out
    with pytest.raises(SystemExit):
        main(["design", "loads", str(path), "--load", "t0:0,x,0"])


def test_ground_forces_carry_the_weight_and_the_load() -> None:
    # the formed hopper (0.876 kg) standing on three feet: by symmetry each carries a third of
    # its weight at rest; under 20 N down at t0 the normals carry weight + 20 N, and the foot
    # that lifts first has zero normal force at the lift factor
    from tensim.design.form_finding import form
    from tensim.design.topology import load_topology

    structure = form(load_topology(HOPPER.with_name("hopper_topology.yaml"))).structure
    structure = dataclasses.replace(structure, rods=tuple(  # no sections: no buckling search
        dataclasses.replace(r, section=None) for r in structure.rods))
    result = load_response(structure, {"t0": (0.0, 0.0, -20.0)})
    weight = structure.total_mass() * 9.81
    normals = np.array([f[:, 2] for f in result.ground.values()])
    np.testing.assert_allclose(normals[:, 0], weight / 3, rtol=1e-6)  # the pins' compliance
    assert normals[:, 1].sum() == pytest.approx(weight + 20.0, rel=1e-6)
    tangential = np.array([f[:, :2].sum(axis=0) for f in result.ground.values()]).sum(axis=0)
    np.testing.assert_allclose(tangential, 0.0, atol=1e-6)  # no net sideways force
    assert result.lift_factor is not None and 0 < result.lift_factor < result.slack_factor
    assert result.slip_factor is not None and 0 < result.slip_factor < result.lift_factor
