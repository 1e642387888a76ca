"""The single run's recorder (one gather of MjData per sample) against an obvious reference.

The reference steps the same simulation a record at a time with ``Simulation.step`` and reads
each field by name (``data.ten_length[index.tendon]``, ...) into :class:`SampleBuffers`
through its per-field ``put``, the batch engine's path; the channels must agree bit for bit,
for kinematic and DC motors, contact cables' beads and a second run continuing the first.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tensim.model import compile_structure
from tensim.models import preset
from tensim.sim import Simulation
from tensim.sim._samples import SampleBuffers, _flat_view, sample_channels
from tensim.structure import CableContact, DCMotor


def _reference(sim: Simulation, records: int):
    """The channels of ``records`` records read field by field, stepping one record at a time."""
    buffers = SampleBuffers.empty(sim.compiled, records + 1, (1,))
    d, one = sim.data, np.zeros(1, dtype=int)
    for k in range(records + 1):
        if k:
            sim.step(sim.record_steps)
        fields = {name: getattr(d, name)[None].copy() for name in
                  ("ten_length", "ten_velocity", "act", "ctrl", "xpos", "xquat", "subtree_com")}
        buffers.put(one, np.array([k]), np.array([sim.time]), fields, sim.index)
    n = sim.compiled.n_cables
    return sample_channels(buffers.trial(0), sim.index, sim.model.actuator_dynprm[:n],
                           sim.model.actuator_gainprm[:n])


def _robots():
    p = preset("tetraspine3")
    s = p.build()
    dc = dataclasses.replace(s, cables=tuple(
        dataclasses.replace(c, motor=dataclasses.replace(c.motor, dc=DCMotor(stall_torque=0.3)))
        if k % 2 else c for k, c in enumerate(s.cables)))
    beads = dataclasses.replace(s, cables=tuple(
        dataclasses.replace(c, contact=CableContact(spacing=0.03)) if k < 2 else c
        for k, c in enumerate(s.cables)))
    bare = dataclasses.replace(preset("six_bar").build(), cables=())  # empty cable fields
    return {"impedance": (s, p.controller()), "dc motors": (dc, p.controller()),
            "contact beads": (beads, None), "no cables": (bare, None)}


@pytest.mark.parametrize("robot", ["impedance", "dc motors", "contact beads", "no cables"])
def test_recorder_equals_field_by_field_reads_bit_for_bit(robot):
    structure, controller = _robots()[robot]
    compiled = compile_structure(structure)
    runs = []
    for _ in range(2):
        with Simulation(compiled, controller=controller, record_dt=0.01) as sim:
            runs.append(sim)
    fast, slow = runs
    for records in (40, 15):  # a second run continues the first
        got, want = fast.run(records * 0.01), _reference(slow, records)
        assert set(got.channels) == set(want.channels)
        np.testing.assert_array_equal(got.time, want.time)
        for name, values in want.channels.items():
            # NaN setpoints (cables not under impedance control) compare equal
            np.testing.assert_array_equal(got.channels[name], values, err_msg=name)
            assert got.channels[name].dtype == values.dtype


def test_sample_rows_refuse_fields_outside_one_float64_buffer():
    with pytest.raises(ValueError, match="float64"):
        _flat_view([np.zeros(3), np.zeros(3, dtype=np.float32)])
