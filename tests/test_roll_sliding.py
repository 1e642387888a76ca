"""Tip plans on sliding feet: the statics of a robot whose feet stand on frictionless ground
(:class:`tensim.control.rolling.RollSettings` ``sliding``), on the 3-bar written in
tests/test_roll_prism.py."""

from __future__ import annotations

import numpy as np
import pytest

from tensim.control.rolling import (
    _com,
    _com_jacobian,
    _sensitivity,
    support_face,
)
from tensim.design.inverse import PIN_STIFFNESS, settle, with_rest_lengths
from tensim.model import WorldOptions, compile_structure
from test_roll_prism import _prism


@pytest.fixture(scope="module")
def prism():
    compiled = compile_structure(_prism(), WorldOptions())
    return compiled.structure, compiled.rest_length.copy()


@pytest.mark.parametrize("sliding", [False, True])
def test_the_centre_of_mass_sensitivity_matches_finite_differences(prism, sliding):
    # the linearised dc/dl0 (J_c K^-1 A diag(k)) against static poses re-solved with each
    # motorised cable's rest length moved by +-1 mm
    structure, built = prism
    feet = support_face({n.name: np.asarray(n.position) for n in structure.nodes})
    explicit = with_rest_lengths(structure, built)
    lin = settle(explicit, feet, sliding=sliding)
    linear = _com_jacobian(lin) @ _sensitivity(lin, structure, sliding)
    h = 1e-3
    # within a few per cent of the largest entry: the held linearisation holds the feet
    # exactly where the re-solved poses hold them by springs of PIN_STIFFNESS (which give
    # way by about cable stiffness / PIN_STIFFNESS, 1 %), and the tangent stiffness is a
    # linearisation (1.4 % off on sliding feet, measured)
    stiffest = max(c.stiffness for c in structure.cables)
    rel = 3 * stiffest / PIN_STIFFNESS
    motorised = [i for i, c in enumerate(structure.cables) if not c.motor.passive]
    numeric = np.zeros((3, len(motorised)))
    for j, i in enumerate(motorised):
        moved = [_com(settle(with_rest_lengths(explicit, built + s * h * np.eye(len(built))[i]),
                             feet, sliding=sliding)) for s in (1, -1)]
        numeric[:, j] = (moved[0] - moved[1]) / (2 * h)
    assert np.abs(numeric).max() > 0.05  # the centre of mass moves with the cables
    assert linear[:, motorised] == pytest.approx(numeric, abs=rel * np.abs(numeric).max())
