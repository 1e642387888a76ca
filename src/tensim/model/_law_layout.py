"""The cable law's parameter layout: the one specification every body of the law reads.

A tensim cable is one MuJoCo actuator whose law parameters live in the ``MjModel``
(``actuator_dynprm``, ``actuator_gainprm``, ``actuator_biasprm``) and whose state lives in
``act``. Under the explicit law (``LAW_EXPLICIT``) the gain is fixed at zero and the law writes
the whole force as bias; under the implicit laws (``LAW_IMPLICIT``, ``LAW_IMPLICITFAST``) the
gain is MuJoCo's affine one, ``k x + b xdot`` from ``gainprm``'s stiffness and damping, times
the last activation (``pull``: -theta while the cable is taut, else 0), so MuJoCo's implicit
integrators see the cable's stiffness and damping (``discrete``) or damping (``implicitfast``);
the bias then makes the force exactly the law's (docs/architecture.md). This module names each
slot once. The compiler writes the parameters through these names, the Python reference law and
the MuJoCo Warp kernel read them through these names, and the compiled law reads them from
``_cable_layout.h``, which :func:`c_header` generates from this module (``python
tools/law_header.py`` rewrites it; a test checks the committed header equals its output).

:class:`LawParameters` gives every per-cable parameter as a live view of a model's arrays, so
readers derive the values from the model the physics steps (nothing goes stale when a
controller or a physics scale edits that model).
"""

from __future__ import annotations

import zlib

import mujoco
import numpy as np

# actuator_dynprm[0] of a tensim cable: it also selects the law's body, per model
CABLE_MARKER = 7317.0  # the compiled law (the default)
REFERENCE_MARKER = 7318.0  # the Python reference law (a Simulation with backend="python")

# -- the slots, in order: (name, meaning [unit]) ---------------------------------------------
DYNPRM = (
    ("marker", "CABLE_MARKER or REFERENCE_MARKER: a tensim cable, and its law's body"),
    ("mode", "MODE_REST, MODE_IMPEDANCE or MODE_PD"),
    ("max_speed", "motor speed limit [m/s]"),
    ("max_tension", "the motor reels in no further at this static tension [N]"),
    ("min_rest", "floor on the rest length [m]"),
    ("min_length", "no reeling in while the cable is this short [m]"),
    ("offset_tension", "impedance law T0 [N]"),
    ("gain_k", "impedance law K [N/m]"),
    ("gain_b", "impedance law B [N s/m]"),
    ("target_length", "impedance law L* [m]"),
)
GAINPRM = (
    ("gain", "stays 0: the constant of the gain (the explicit law's whole gain)"),
    ("stiffness", "cable k [N/m]: the implicit law's gain per metre of length"),
    ("damping", "cable b [N s/m]: the implicit law's gain per m/s of lengthening"),
    ("pd_stiffness", "PD motor kp [N/m]: its tension per metre of length past the target"),
    ("pd_damping", "PD motor kd [N s/m]: its tension per m/s of lengthening"),
)
BIASPRM = (
    ("lag_time", "kinematic motor's first-order lag [s] (0: none)"),
    ("saturate", "1.0: max_tension back-drives the kinematic motor (a force cap), 0.0: stops it"),
    ("reserved", "stays 0: MuJoCo's compiler reads a positive one as a damping ratio"),
    # DC motors only (DC_ACTDIM), in cable coordinates (tensim.structure.DCMotor.line)
    ("stall_force", "DC motor stall force F_s [N]"),
    ("no_load_speed", "DC motor no-load line speed v0 [m/s]"),
    ("mass", "DC motor reflected mass M [kg]"),
    ("viscous", "DC motor viscous friction c [N s/m]"),
    ("coulomb", "DC motor Coulomb friction F_c [N]"),
    ("position_time", "DC motor position loop time constant t_p [s]"),
    ("back_drivable", "1.0 where the cable may drive the spool, 0.0 for a worm gear"),
)
ACT = (
    ("rest", "the motor's rest length l [m]"),
    ("peak", "running maximum of the load-cell tension [N]"),
    ("peak_speed", "running maximum of the motor's line speed |dl/dt| [m/s]"),
    ("peak_power", "running maximum of the load-cell tension times the line speed [W]"),
    ("speed", "DC motors only: the spool's line speed dl/dt [m/s]"),
    ("pull", "implicit law only, always the last: -theta while the cable is taut after this "
             "step's motor update, else 0.0 (the gain's input)"),
)
GAIN = 0.0  # actuator_gainprm[0]

# the cable laws, each with its MuJoCo integrator (tensim.model.INTEGRATORS)
LAW_EXPLICIT = "explicit"  # the law writes the whole force (Euler)
LAW_IMPLICIT = "implicit"  # MuJoCo's affine gain carries the law's stiffness and damping (discrete)
LAW_IMPLICITFAST = "implicitfast"  # the same law; implicitfast takes the damping, per body
CABLE_LAWS = (LAW_EXPLICIT, LAW_IMPLICIT, LAW_IMPLICITFAST)

MODE_REST = 0  # the motor follows a commanded rest length (ctrl: the rest length [m])
MODE_IMPEDANCE = 1  # the motor realises the impedance law's setpoint (ctrl: V* [m/s])
MODE_PD = 2  # a tension-only PD on length beside the cable's spring (ctrl: its target [m])
ACTDIM = 4  # a kinematic motor's activations: rest length, peak tension, speed and power
DC_ACTDIM = 5  # a DC motor's: those and its line speed
IMPLICIT_EXTRA = 1  # the implicit law adds the pull after them
# the pull of a taut cable is -THETA: the share of the gain term's derivatives that MuJoCo's
# implicit integrator takes (the rest of the force stays explicit, in the bias); 1/2 makes the
# discrete step trapezoidal in the cable's stiffness and damping (second order), implicitfast,
# which loses the cross-body terms, needs all of it (docs/architecture.md)
THETA_DISCRETE = 0.5
THETA_IMPLICITFAST = 1.0


def _slot(table: tuple[tuple[str, str], ...], name: str) -> int:
    return [n for n, _ in table].index(name)


P_MARKER, P_MODE = _slot(DYNPRM, "marker"), _slot(DYNPRM, "mode")
P_MAX_SPEED, P_MAX_TENSION = _slot(DYNPRM, "max_speed"), _slot(DYNPRM, "max_tension")
P_MIN_REST, P_MIN_LENGTH = _slot(DYNPRM, "min_rest"), _slot(DYNPRM, "min_length")
P_OFFSET, P_GAIN_K = _slot(DYNPRM, "offset_tension"), _slot(DYNPRM, "gain_k")
P_GAIN_B, P_TARGET_LENGTH = _slot(DYNPRM, "gain_b"), _slot(DYNPRM, "target_length")
G_STIFFNESS, G_DAMPING = _slot(GAINPRM, "stiffness"), _slot(GAINPRM, "damping")
G_PD_STIFFNESS, G_PD_DAMPING = _slot(GAINPRM, "pd_stiffness"), _slot(GAINPRM, "pd_damping")
B_STALL_FORCE, B_NO_LOAD_SPEED = _slot(BIASPRM, "stall_force"), _slot(BIASPRM, "no_load_speed")
B_MASS, B_VISCOUS, B_COULOMB = (_slot(BIASPRM, n) for n in ("mass", "viscous", "coulomb"))
B_POSITION_TIME = _slot(BIASPRM, "position_time")
B_BACK_DRIVABLE = _slot(BIASPRM, "back_drivable")
B_LAG_TIME, B_SATURATE = _slot(BIASPRM, "lag_time"), _slot(BIASPRM, "saturate")
A_REST, A_PEAK, A_SPEED = (_slot(ACT, n) for n in ("rest", "peak", "speed"))
A_PEAK_SPEED, A_PEAK_POWER = _slot(ACT, "peak_speed"), _slot(ACT, "peak_power")
# the pull is the last activation (MuJoCo's gain reads the last): slot actdim - 1, not A_PULL
A_PULL = _slot(ACT, "pull")


def dynprm(mode: int, max_speed: float, max_tension: float, min_rest: float, min_length: float,
           offset_tension: float, gain_k: float, gain_b: float, target_length: float
           ) -> list[float]:
    """A cable actuator's ``dynprm`` row, the marker first."""
    row = [0.0] * len(DYNPRM)
    for slot, value in ((P_MARKER, CABLE_MARKER), (P_MODE, mode), (P_MAX_SPEED, max_speed),
                        (P_MAX_TENSION, max_tension), (P_MIN_REST, min_rest),
                        (P_MIN_LENGTH, min_length), (P_OFFSET, offset_tension),
                        (P_GAIN_K, gain_k), (P_GAIN_B, gain_b),
                        (P_TARGET_LENGTH, target_length)):
        row[slot] = float(value)
    return row


def gainprm(stiffness: float, damping: float, pd_stiffness: float = 0.0,
            pd_damping: float = 0.0) -> list[float]:
    """A cable actuator's ``gainprm`` row (MuJoCo's mjNGAIN = 10 values)."""
    row = [0.0] * 10
    row[G_STIFFNESS], row[G_DAMPING] = float(stiffness), float(damping)
    row[G_PD_STIFFNESS], row[G_PD_DAMPING] = float(pd_stiffness), float(pd_damping)
    return row


def biasprm(dc: dict[str, float] | None = None) -> list[float]:
    """A cable actuator's ``biasprm`` row; ``dc`` holds a DC motor's slots by name."""
    row = [0.0] * len(BIASPRM)
    for name, value in (dc or {}).items():
        row[_slot(BIASPRM, name)] = float(value)
    return row


def theta(model: mujoco.MjModel) -> float:
    """The share of the gain term's derivatives that the model's integrator takes: the pull of
    a taut cable is -theta (THETA_IMPLICITFAST under ``implicitfast``, else THETA_DISCRETE)."""
    fast = model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    return THETA_IMPLICITFAST if fast else THETA_DISCRETE


def implicit(model: mujoco.MjModel) -> np.ndarray:
    """(nu,) whether each actuator runs the implicit law (MuJoCo's affine gain)."""
    return model.actuator_gaintype == mujoco.mjtGain.mjGAIN_AFFINE


def motor_actdim(model: mujoco.MjModel) -> np.ndarray:
    """(nu,) each actuator's activations without the implicit law's pull: ACTDIM for a
    kinematic motor, DC_ACTDIM for a DC motor."""
    return model.actuator_actnum - IMPLICIT_EXTRA * implicit(model)


def is_cable(model: mujoco.MjModel) -> np.ndarray:
    """(nu,) whether each actuator of ``model`` is a tensim cable."""
    return np.isin(model.actuator_dynprm[:, P_MARKER], (CABLE_MARKER, REFERENCE_MARKER)) \
        & np.isin(motor_actdim(model), (ACTDIM, DC_ACTDIM))


def law_of(model: mujoco.MjModel, n: int) -> str:
    """The cable law of a model's first ``n`` actuators (its cables), one of CABLE_LAWS (a
    model without cables counts as explicit)."""
    if not (n and bool(implicit(model)[:n].all())):
        return LAW_EXPLICIT
    fast = model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    return LAW_IMPLICITFAST if fast else LAW_IMPLICIT


class LawParameters:
    """The law parameters of a model's first ``n`` actuators (its cables), as live views.

    Each attribute is a (n,) view of ``actuator_dynprm``/``actuator_gainprm``: reading it
    gives what the physics uses now, writing it edits the model.

    Attributes:
        stiffness, damping: cable k [N/m] and b [N s/m].
        mode: MODE_REST, MODE_IMPEDANCE or MODE_PD per cable.
        max_speed, max_tension, min_rest, min_length: motor limits [m/s], [N], [m], [m].
        offset_tension, gain_k, gain_b, target_length: impedance T0 [N], K [N/m], B [N s/m],
            L* [m].
        pd_stiffness, pd_damping: a PD motor's kp [N/m] and kd [N s/m] (MODE_PD).
    """

    def __init__(self, model: mujoco.MjModel, n: int):
        p, g = model.actuator_dynprm[:n], model.actuator_gainprm[:n]
        self.stiffness, self.damping = g[:, G_STIFFNESS], g[:, G_DAMPING]
        self.pd_stiffness, self.pd_damping = g[:, G_PD_STIFFNESS], g[:, G_PD_DAMPING]
        self.mode = p[:, P_MODE]
        self.max_speed, self.max_tension = p[:, P_MAX_SPEED], p[:, P_MAX_TENSION]
        self.min_rest, self.min_length = p[:, P_MIN_REST], p[:, P_MIN_LENGTH]
        self.offset_tension, self.gain_k = p[:, P_OFFSET], p[:, P_GAIN_K]
        self.gain_b, self.target_length = p[:, P_GAIN_B], p[:, P_TARGET_LENGTH]


def _definitions() -> list[str]:
    lines = [f"#define TENSIM_CABLE_MARKER {CABLE_MARKER!r}",
             f"#define TENSIM_REFERENCE_MARKER {REFERENCE_MARKER!r}",
             f"#define TENSIM_MODE_REST {float(MODE_REST)!r}",
             f"#define TENSIM_MODE_IMPEDANCE {float(MODE_IMPEDANCE)!r}",
             f"#define TENSIM_MODE_PD {float(MODE_PD)!r}",
             f"#define TENSIM_ACTDIM {ACTDIM}", f"#define TENSIM_DC_ACTDIM {DC_ACTDIM}",
             f"#define TENSIM_IMPLICIT_EXTRA {IMPLICIT_EXTRA}",
             f"#define TENSIM_THETA_DISCRETE {THETA_DISCRETE!r}",
             f"#define TENSIM_THETA_IMPLICITFAST {THETA_IMPLICITFAST!r}"]
    for prefix, table in (("P", DYNPRM), ("G", GAINPRM), ("B", BIASPRM), ("A", ACT)):
        lines.append("")
        lines += [f"#define TENSIM_{prefix}_{name.upper()} {k} /* {doc} */"
                  for k, (name, doc) in enumerate(table)]
    return lines


def layout_id() -> int:
    """A checksum of the layout: the compiled law reports the one it was built with, and the
    loader refuses a library built from another layout."""
    return zlib.crc32("\n".join(_definitions()).encode())


def c_header() -> str:
    """The text of ``_cable_layout.h``: this layout as C constants for ``_cable.c``."""
    return "\n".join([
        "/* Generated from tensim/model/_law_layout.py by tools/law_header.py: do not edit. */",
        "#ifndef TENSIM_CABLE_LAYOUT_H", "#define TENSIM_CABLE_LAYOUT_H", "",
        *_definitions(), "", f"#define TENSIM_LAYOUT_ID {layout_id()}u", "", "#endif", ""])
