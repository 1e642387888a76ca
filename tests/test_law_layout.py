"""The cable law's one parameter layout: the C header is generated from it, the compiler writes
through it, and the views derived from a model follow that model's edits."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from tensim.io import mjcf_spec
from tensim.model import WorldOptions, compile_structure
from tensim.model import _law_layout as layout
from tensim.models import preset
from tensim.sim import Simulation, compiled_available
from tensim.structure import Cable, DCMotor, Motor, Node, Structure
from tensim.viz.cables import TensionColors

ROOT = Path(__file__).resolve().parents[1]


def _tool() -> object:
    spec = importlib.util.spec_from_file_location("law_header", ROOT / "tools" / "law_header.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_committed_header_is_the_one_the_layout_generates():
    committed = (ROOT / "src" / "tensim" / "sim" / "_cable_layout.h").read_text()
    assert committed == layout.c_header() == _tool().c_header()  # type: ignore[attr-defined]


def test_every_slot_has_its_own_index_and_a_define():
    header = layout.c_header()
    for prefix, table in (("P", layout.DYNPRM), ("G", layout.GAINPRM), ("B", layout.BIASPRM),
                          ("A", layout.ACT)):
        names = [n for n, _ in table]
        assert len(set(names)) == len(names)
        for k, name in enumerate(names):
            assert f"#define TENSIM_{prefix}_{name.upper()} {k} " in header
    assert len(layout.DYNPRM) == len(layout.BIASPRM) == 10  # MuJoCo's mjNDYN, mjNBIAS


@pytest.mark.skipif(not compiled_available(), reason="compiled cable law not built")
def test_compiled_law_was_built_from_this_layout():
    from tensim.sim import _law

    assert _law._LIB is not None and _law._LIB.tensim_layout_id() == layout.layout_id()


def test_compiler_writes_each_parameter_into_its_named_slot():
    motor = Motor(max_speed=0.3, max_tension=70.0, min_rest_length=0.02, min_length=0.05,
                  dc=DCMotor(spool_radius=0.01, stall_torque=0.5, no_load_speed=10.0,
                             rotor_inertia=5e-4, viscous_friction=1e-4, coulomb_friction=0.02,
                             back_drivable=False))
    s = Structure("held", (Node("a", (0.0, 0.0, 1.0), fixed=True),
                           Node("b", (0.5, 0.0, 1.0), fixed=True)),
                  cables=(Cable("c", ("a", "b"), 123.0, damping=4.5, pretension=2.0,
                                motor=motor),))
    compiled = compile_structure(s, WorldOptions(ground=False))
    p, b = compiled.model.actuator_dynprm[0], compiled.model.actuator_biasprm[0]
    line = motor.dc.line()  # type: ignore[union-attr]
    assert p[layout.P_MARKER] == layout.CABLE_MARKER and p[layout.P_MODE] == layout.MODE_REST
    assert (p[layout.P_MAX_SPEED], p[layout.P_MAX_TENSION]) == (0.3, 70.0)
    assert (p[layout.P_MIN_REST], p[layout.P_MIN_LENGTH]) == (0.02, 0.05)
    assert p[layout.P_TARGET_LENGTH] == compiled.rest_length[0]
    g = compiled.model.actuator_gainprm[0]
    assert (g[layout.G_STIFFNESS], g[layout.G_DAMPING]) == (123.0, 4.5)
    assert b[layout.B_STALL_FORCE] == line["stall_force"]
    assert b[layout.B_NO_LOAD_SPEED] == line["no_load_line_speed"]
    assert (b[layout.B_MASS], b[layout.B_VISCOUS]) == (line["mass"], line["viscous"])
    assert b[layout.B_COULOMB] == line["coulomb"]
    assert b[layout.B_POSITION_TIME] == motor.dc.position_time  # type: ignore[union-attr]
    assert b[layout.B_BACK_DRIVABLE] == 0.0 and b[2] == 0.0
    assert b[layout.B_LAG_TIME] == 0.0 and b[layout.B_SATURATE] == 0.0  # no lag, no cap
    assert compiled.model.actuator_actnum[0] == layout.DC_ACTDIM
    assert compiled.model.actuator_gainprm[0, 0] == layout.GAIN


def test_derived_views_follow_edits_of_the_model():
    compiled = compile_structure(preset("tetraspine3").build())
    law = compiled.law()
    compiled.model.actuator_gainprm[2, layout.G_STIFFNESS] = 777.0
    compiled.model.actuator_gainprm[3, layout.G_DAMPING] = 9.25
    compiled.model.actuator_dynprm[:, layout.P_MAX_TENSION] = 12.0
    assert law.stiffness[2] == compiled.law().stiffness[2] == 777.0
    assert law.damping[3] == 9.25 and np.all(law.max_tension == 12.0)
    # the readers derive from the model: the MJCF export and the colour scale follow
    spec = mjcf_spec(compiled)
    assert spec.tendon(compiled.index.cables[2]).stiffness[0] == 777.0
    assert spec.tendon(compiled.index.cables[3]).damping[0] == 9.25
    assert TensionColors.for_model(compiled).max_tension <= 12.0
    # a simulation's own model copy has its own views: editing it leaves the compiled one
    with Simulation(compiled) as sim:
        sim.drive.stiffness[0] = 55.0
        assert compiled.law(sim.model).stiffness[0] == 55.0
        assert sim.model.actuator_gainprm[0, layout.G_STIFFNESS] == 55.0
        assert compiled.law().stiffness[0] != 55.0


def test_drive_and_law_parameters_are_the_same_views():
    compiled = compile_structure(preset("tetraspine3").build())
    with Simulation(compiled) as sim:
        law = compiled.law(sim.model)
        for field in ("stiffness", "damping", "mode", "max_speed", "max_tension", "min_rest",
                      "min_length", "offset_tension", "gain_k", "gain_b", "target_length"):
            assert np.shares_memory(getattr(sim.drive, field), getattr(law, field)), field


def test_layout_rows_round_trip():
    row = layout.dynprm(layout.MODE_IMPEDANCE, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0)
    assert row == [layout.CABLE_MARKER, 1.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]
    bias = layout.biasprm({"coulomb": 0.25})
    assert bias[layout.B_COULOMB] == 0.25 and sum(bias) == 0.25
    gain = layout.gainprm(10.0, 0.5)
    assert (gain[layout.G_STIFFNESS], gain[layout.G_DAMPING]) == (10.0, 0.5) and sum(gain) == 10.5
