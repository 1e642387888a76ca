"""Controller families a gait is learned for, and the base controllers they start from.

A family names a :class:`~tensim.control.parameters.ParameterLayout`: ``cpg`` the CPG of
:mod:`tensim.control.spine` on any structure (116 parameters for Tetraspine3), ``sine``
per-cable sine waves with a shared frequency, ``sine-pattern`` the paper's four-number
Tetraspine sine pattern, ``wave`` a travelling wave (:mod:`tensim.control.wave`): of joint
bending along a Tetraspine (eight parameters whatever the spine's length), on any other robot one
sine wave passed along its driven cables in ``wave_<k>`` tag order or an order derived from the
build pose (three parameters), ``roll`` a wave of contraction around a rolling robot's axis
(five parameters whatever the robot, :mod:`tensim.control.roll_parameters`). Every family
drives the cables the base controller gives impedance laws. The base controller file gives
the impedance laws, the command period and, where its gait is of the family, the layout's
bounds and the starting point; a structure
without a controller of its own starts from :func:`tensim.control.default_impedance`.
"""

from __future__ import annotations

import numpy as np

from tensim.control import (
    ControllerConfig,
    ParameterLayout,
    SineGait,
    SpineCPG,
    default_impedance,
    load_controller,
    spine_parameters,
    spine_wave_parameters,
)
from tensim.control._common import as_tuple
from tensim.control.roll_parameters import roll_parameters
from tensim.control.sine_parameters import sine_parameters, tetraspine_sine_parameters
from tensim.control.wave import spine_tagged, travelling_wave_parameters
from tensim.models import resolve_controller
from tensim.structure import Structure

FAMILIES = ("cpg", "sine", "sine-pattern", "wave", "roll")
# shipped controller files used as the base for the Tetraspine3 preset
SHIPPED_BASE = {"cpg": "tetraspine3_cpg", "sine": "tetraspine3_sine",
                "sine-pattern": "tetraspine3_sine", "wave": "tetraspine3_sine",
                "roll": "tetraspine3_sine"}


def check_family(family: str) -> str:
    """``family`` if known.

    Raises:
        ValueError: naming the known families.
    """
    if family not in FAMILIES:
        raise ValueError(f"unknown controller family {family!r}; expected one of "
                         f"{list(FAMILIES)}")
    return family


def gait_layout(family: str, structure: Structure, base: ControllerConfig
                ) -> tuple[ParameterLayout, np.ndarray]:
    """The family's parameter layout for ``structure`` and the starting values.

    A base gait of the same family supplies the layout (its bounds and cables) and the
    starting values; otherwise the family's defaults over the cables under impedance control.

    Raises:
        ValueError: an unknown family, or a structure the family does not fit.
    """
    cables = [c.name for c in structure.cables if c.name in base.impedance.gains]
    gait = base.gait
    if check_family(family) == "cpg":
        if isinstance(gait, SpineCPG):
            return gait.layout, np.asarray(gait.values)
        layout = spine_parameters(structure, cables)
        return layout, layout.nominal
    if family == "sine":
        start = gait if isinstance(gait, SineGait) \
            and len(set(as_tuple(gait.frequency))) == 1 else None
        sine_layout = sine_parameters(structure, None if start else cables, start=start)
        return sine_layout, sine_layout.nominal
    if family == "roll":
        rolling = roll_parameters(structure, cables)
        return rolling, rolling.nominal
    if family == "wave":
        if spine_tagged(structure):
            waves = spine_wave_parameters(structure)
            return waves, waves.nominal
        travel = travelling_wave_parameters(structure, cables)
        return travel, travel.nominal
    if not spine_tagged(structure):
        raise ValueError(f"sine-pattern is the paper's Tetraspine pattern: every cable needs "
                         f"'joint_<j>', 'inner'/'outer' and a side tag, which {structure.name!r} "
                         "lacks; use --controller sine, wave or cpg")
    pattern = tetraspine_sine_parameters(structure)
    return pattern, pattern.nominal


def default_base(model: str, family: str, structure: Structure) -> ControllerConfig:
    """The base controller when none is given: a shipped file for Tetraspine3, else the
    preset's own impedance laws, else laws that hold the build pose
    (:func:`~tensim.control.default_impedance`).

    Raises:
        ValueError: the model has no motorised cable to drive.
    """
    if model == "tetraspine3":
        return load_controller(SHIPPED_BASE[check_family(family)], structure)
    config = resolve_controller(model, structure, None)
    if config is None:
        try:
            impedance = default_impedance(structure)
        except ValueError as err:
            raise ValueError(f"cannot learn a gait for {model!r}: {err}; a gait drives "
                             "motorised cables through their impedance laws") from None
        config = ControllerConfig(impedance, description="default_impedance: holds the "
                                  "build pose")
    return config
