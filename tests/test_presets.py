"""Every preset builds, compiles and runs stably, with its declared shape."""

from __future__ import annotations

import numpy as np
import pytest

from tensim.model import compile_structure
from tensim.models import PRESETS, preset
from tensim.sim import simulate

DECLARED_CABLES = {"tetraspine3": 12, "tetraspine": 66, "six_bar": 24, "prism3": 9,
                   "prism4": 12, "prism5": 15, "superball": 24, "tetrahedral_complex": 40,
                   "octahedral_complex": 40, "three_bar": 9}
# six_bar runs 20 s: a six-bar with bare thin rods was reported to blow up within 20 s
DURATION = {"six_bar": 20.0}


def test_every_preset_is_covered():
    assert set(PRESETS) == set(DECLARED_CABLES)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_preset_builds_compiles_and_runs(name):
    p = preset(name)
    structure = p.build()
    compiled = compile_structure(structure)
    assert compiled.n_cables == DECLARED_CABLES[name]
    assert compiled.model.ntendon == compiled.model.nu == DECLARED_CABLES[name]
    duration = DURATION.get(name, 2.0)
    result = simulate(compiled, duration, controller=p.controller(), record_dt=0.02)
    ts = result.trajectory
    assert ts.time[-1] == pytest.approx(duration, abs=1e-9)  # ran to the end; rounding of time
    for channel, values in ts.channels.items():
        if not channel.startswith("setpoint/"):  # NaN by definition for passive cables
            assert np.all(np.isfinite(values)), channel
    # cables only pull, and stay below the motor's force limit by a wide margin
    tension = ts.matrix("tension")
    assert np.all(tension >= 0.0)
    motorised = np.array([not c.motor.passive for c in structure.cables])  # a passive cable
    # has no motor whose limit it could reach
    assert np.all(result.peak_tension[motorised] < compiled.law().max_tension[motorised])
    # nothing flew away or sank through the ground: the COM stays within a robot's size
    com = np.stack([ts["pos_x/com"], ts["pos_y/com"], ts["pos_z/com"]], axis=1)
    assert np.all(com[:, 2] > 0.0)
    assert np.linalg.norm(com[-1] - com[0]) < 0.5


def test_unknown_preset_lists_known_ones():
    with pytest.raises(KeyError, match="tetraspine3"):
        preset("hexapod")


def test_tetraspine_preset_shapes():
    # 6 cables per joint, n_segments - 1 joints; 8 rods and 6 nodes per segment
    for name, segments in (("tetraspine3", 3), ("tetraspine", 12)):
        s = preset(name).build()
        assert len(s.cables) == 6 * (segments - 1)
        assert len(s.rods) == 8 * segments and len(s.nodes) == 6 * segments
        assert len(s.rigid_groups()) == segments
        controller = preset(name).controller()
        assert controller is not None and set(controller.gains) == {c.name for c in s.cables}
