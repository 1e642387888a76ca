"""Maps a tendon's spring and its actuator onto a tensim cable and motor.

tensim's cable pulls k (x - l) + b dx/dt while taut and its motor moves the rest length l
toward a command at up to ``max_speed`` (a floor ``min_rest_length``, a stop at
``max_tension``). The actuators labs put on tendons map onto that as follows:

- a force actuator (``motor``, or ``general`` with a fixed gain and no bias) in parallel with
  the tendon spring adds a tension T = -gear x gain x u: while taut that is the spring with the
  rest length l0 - T/k, so the command becomes a rest length; the pull limit on top of the
  build tension becomes the motor's stop (``max_tension``), the tendon's lower limit its floor
  (the file's actuator shortens the cable as far as its pull folds the robot), and a
  ``filter`` time constant tau the motor's lag (``Motor.lag_time``: the rest length is linear
  in the filtered input), its speed the range in one step (the file's actuator does not limit
  how fast its cable shortens);
- a position actuator (``position``, or ``general`` with a fixed gain g and bias
  [b0, -kp, -kv]) is a PD on tendon length, tension gear^2 kp (x - L) + gear^2 kv dx/dt with
  the target L = (g u + b0) / (kp gear) (g = kp for ``position``): beside a tendon spring it
  becomes tensim's PD motor (``Motor.pd_stiffness``) on the spring's cable, the command a
  target length, exact where the file's force range lets it only pull; without a spring (or
  with integrator dynamics, where the control is the target's rate) it is one cable of
  stiffness k + gear^2 kp and damping b + gear^2 kv whose rest length is the
  stiffness-weighted mean of the two targets (alone on its tendon, its force limit a
  saturating cap, ``Motor.saturate``);
- tensim's own export carries its motors in each actuator's ``user`` numbers (read back
  exactly);
- anything else (velocity servos, muscles, user dynamics) leaves the cable passive.

Every difference from the file's semantics is stated in :attr:`ActuatorMapping.differences`.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from tensim.io._mjcf_read import Loaded, kind_name
from tensim.structure import PASSIVE, DCMotor, Motor

# tensim's export: names of the numbers in each cable actuator's ``user`` data (see io.mjcf)
USER_TEXT = "tensim_cable_user"
NODE_SITE = "node_"  # tensim's export marks each node with a site named node_<name>
USER_FIELDS = ("motor", "stiffness", "damping", "rest_length", "max_speed", "max_tension",
               "min_rest_length", "min_length", "spool_radius", "stall_torque", "no_load_speed",
               "rotor_inertia", "viscous_friction", "coulomb_friction", "back_drivable",
               "position_time", "lag_time", "saturate", "pd_stiffness", "pd_damping",
               "pd_target")
MOTOR_KIND = {"passive": 0.0, "kinematic": 1.0, "dc": 2.0}
_DYN = mujoco.mjtDyn
_FILTERS = (_DYN.mjDYN_FILTER, _DYN.mjDYN_FILTEREXACT)


@dataclasses.dataclass(frozen=True)
class Spring:
    """A tendon's own spring and pose, as MuJoCo compiled them.

    Attributes:
        stiffness: k [N/m].
        damping: b [N s/m].
        dead_band: (2,) spring lengths [low, high]: no force between them [m].
        length: the tendon's length in the file's pose [m].
        tendon: the tendon's id.
    """

    stiffness: float
    damping: float
    dead_band: tuple[float, float]
    length: float
    tendon: int


@dataclasses.dataclass(frozen=True)
class CommandMap:
    """How the file's control input becomes a tensim rest-length command:
    rest length = offset + scale x u [m], u the actuator's ``ctrl`` (its ``act`` after the
    filter, or a rate where ``rate`` is true)."""

    offset: float
    scale: float
    rate: bool = False


@dataclasses.dataclass(frozen=True)
class ActuatorMapping:
    """One tendon actuator as a tensim cable and motor.

    Attributes:
        actuator: the actuator's name.
        cable: the cable (tendon) it drives.
        kind: ``"force"``, ``"position"``, ``"tensim"`` (tensim's own export) or
            ``"unsupported"``.
        motor: the motor chosen.
        stiffness: the cable's stiffness, spring and actuator together [N/m].
        damping: the cable's damping [N s/m].
        rest_length: the rest length at the file's initial control [m].
        command: how its control input maps to a rest length (None: it does not).
        differences: what tensim does differently from the file, one line each.
    """

    actuator: str
    cable: str
    kind: str
    motor: Motor
    stiffness: float
    damping: float
    rest_length: float
    command: CommandMap | None
    differences: tuple[str, ...]


def map_actuator(f: Loaded, a: int, cable: str, spring: Spring) -> ActuatorMapping:
    """The cable and motor for actuator ``a`` on tendon ``cable`` (see the module docstring).

    Raises:
        StructureError: a cable that would have no stiffness.
    """
    m = f.model
    name = f.name(mujoco.mjtObj.mjOBJ_ACTUATOR, a, f"actuator{a}")
    text = f.spec.text(USER_TEXT)
    fields = text.data.split() if text is not None else []
    if fields and m.nuser_actuator >= len(fields):  # an older export may name fewer
        return _tensim(name, cable, dict(zip(fields, m.actuator_user[a], strict=False)))
    bias = m.actuator_biasprm[a]
    fixed = m.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED and \
        not np.any(m.actuator_gainprm[a][1:])
    no_bias = m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_NONE or not np.any(bias)
    affine = m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE
    dyn = _DYN(m.actuator_dyntype[a])
    if fixed and no_bias and dyn in (_DYN.mjDYN_NONE, *_FILTERS, _DYN.mjDYN_INTEGRATOR):
        return _force(f, a, name, cable, spring)
    if fixed and affine and m.actuator_gainprm[a][0] > 0 and bias[1] < 0 and bias[2] <= 0 \
            and dyn in (_DYN.mjDYN_NONE, *_FILTERS, _DYN.mjDYN_INTEGRATOR):
        return _position(f, a, name, cable, spring)
    what = _describe(f, a)
    if spring.stiffness <= 0:
        raise f.refuse(f"actuator {name!r}", f"is {what}, which tensim's motor cannot express, "
                       f"and its tendon {cable!r} has no spring to keep as a passive cable")
    return ActuatorMapping(name, cable, "unsupported", PASSIVE, spring.stiffness, spring.damping,
                           spring.dead_band[1], None,
                           (f"{what}: tensim's motor (a rest length moved toward a command) "
                            "cannot express it; chosen: a passive cable (the tendon's spring "
                            "only)",))


def _describe(f: Loaded, a: int) -> str:
    m = f.model
    return (f"a {kind_name(mujoco.mjtGain(m.actuator_gaintype[a]))}-gain, "
            f"{kind_name(mujoco.mjtBias(m.actuator_biastype[a]))}-bias actuator with "
            f"{kind_name(mujoco.mjtDyn(m.actuator_dyntype[a]))} dynamics (gain "
            f"{m.actuator_gainprm[a][:3].tolist()}, bias {m.actuator_biasprm[a][:3].tolist()})")


def _range(f: Loaded, a: int) -> tuple[float, float]:
    """The span of the actuator's input u (its act for filters and integrators)."""
    m = f.model
    lo, hi = -math.inf, math.inf
    if m.actuator_ctrllimited[a]:
        lo, hi = m.actuator_ctrlrange[a]
    if m.actuator_dyntype[a] == _DYN.mjDYN_INTEGRATOR:
        lo, hi = m.actuator_actrange[a] if m.actuator_actlimited[a] else (-math.inf, math.inf)
    elif m.actuator_actlimited[a] and m.actuator_dyntype[a] in _FILTERS:
        lo, hi = max(lo, m.actuator_actrange[a][0]), min(hi, m.actuator_actrange[a][1])
    return float(lo), float(hi)


def _start(f: Loaded, a: int, lo: float, hi: float) -> float:
    """The input at the start: the first keyframe's (its act after a filter, else its ctrl),
    else MuJoCo's reset value 0; clamped into the input's range as MuJoCo clamps it."""
    m, u = f.model, 0.0
    if m.nkey:
        filtered = m.actuator_dyntype[a] in (*_FILTERS, _DYN.mjDYN_INTEGRATOR) and \
            m.actuator_actadr[a] >= 0
        u = float(m.key_act[0][m.actuator_actadr[a]] if filtered else m.key_ctrl[0][a])
    return float(np.clip(u, lo, hi))


def _lag(f: Loaded, a: int, span: float) -> tuple[float, float, list[str]]:
    """The motor's speed [m/s] and lag time [s] for a command span [m], and what they leave
    out. The rest length is linear in the actuator's input, so a filter on the input (time
    constant tau) is the motor's first-order lag of tau; the speed is the span in one step:
    a force or a target does not limit how fast the cable itself moves."""
    m = f.model
    step = float(m.opt.timestep)
    speed = span / step
    if _DYN(m.actuator_dyntype[a]) in _FILTERS:
        tau = float(m.actuator_dynprm[a][0])
        return speed, tau, [f"a filter lags the input with time constant {tau:g} s: tensim's "
                            f"motor moves the rest length 1 - exp(-dt / {tau:g} s) of the way "
                            "to its command each step (lag_time), the filter itself within "
                            f"the command map's range; at up to {speed:.4g} m/s (the range "
                            "in one step), so a command beyond that range is approached "
                            "faster than the file's input can move"]
    return speed, 0.0, [f"the force acts at once; tensim's motor crosses its range in one step "
                        f"({step:g} s) at up to {speed:.4g} m/s"]


def _force(f: Loaded, a: int, name: str, cable: str, spring: Spring) -> ActuatorMapping:
    m = f.model
    k = spring.stiffness
    if k <= 0:
        raise f.refuse(f"actuator {name!r}", f"is a force actuator on tendon {cable!r}, which "
                       "has no spring (stiffness 0): tensim's cables are springs whose rest "
                       "length a motor moves; give the tendon a stiffness")
    per_u = float(m.actuator_gear[a][0] * m.actuator_gainprm[a][0])  # d(-tension)/du [N]
    lo, hi = _range(f, a)
    tensions = sorted(-per_u * u for u in (lo, hi))  # pull positive
    if m.actuator_forcelimited[a]:
        flo, fhi = sorted(-m.actuator_gear[a][0] * v for v in m.actuator_forcerange[a])
        tensions = [max(tensions[0], flo), min(tensions[1], fhi)]
    push, pull = -tensions[0], tensions[1]
    rest0 = spring.dead_band[1]
    command = CommandMap(rest0, per_u / k, rate=m.actuator_dyntype[a] == _DYN.mjDYN_INTEGRATOR)
    notes = []
    # the file's actuator shortens the cable as far as its pull folds the robot: the motor may
    # reel in down to the tendon's lower limit, its force bounded by the stop at max_tension
    floor = _min_length(f, spring.tendon)
    span = (pull + push) / k if math.isfinite(pull + push) else rest0
    if command.rate:
        speed = abs(command.scale) * max(abs(v) for v in m.actuator_ctrlrange[a]) \
            if m.actuator_ctrllimited[a] else span / float(m.opt.timestep)
        notes.append("the control is a force rate (integrator dynamics): the rest length "
                     f"moves at scale x ctrl, up to {speed:.4g} m/s; tensim's motor takes a "
                     "rest-length target")
        lag_time = 0.0
    else:
        speed, lag_time, lag = _lag(f, a, span)
        notes += lag
    cap = pull + k * max(spring.length - rest0, 0.0) if math.isfinite(pull) else 0.0
    if cap <= 0:
        cap = k * spring.length
    if math.isfinite(pull):
        notes.append(f"the file adds up to {pull:.4g} N of pull to the spring whatever the "
                     f"stretch; tensim's motor reels in (down to the tendon's lower limit, "
                     f"{floor:g} m) while the static tension stays below {cap:.4g} N (the pull "
                     "on top of the build tension): the command map matches the file's force "
                     "while taut; beyond the map's range the stop holds more than the file "
                     f"where the cable is shorter than its spring's rest length ({pull:.4g} N "
                     "there) and less where it is stretched past its build length")
    else:
        notes.append("the file's pull is unlimited (no ctrlrange or forcerange); chosen: a "
                     f"rest-length floor of {floor:g} m and a stop above {cap:.4g} N of static "
                     "tension (k x the tendon's length)")
    notes.append("while the cable is slacker than its rest length the file's actuator still "
                 "pulls; tensim's cable pulls nothing")
    if push <= 0 and not command.rate:
        notes.append(f"the file's actuator only pulls, so its cable's rest length is never "
                     f"above the spring's {rest0:g} m; tensim's motor pays out above it where a "
                     "controller commands that (beyond the command map's range)")
    motor = Motor(max_speed=speed, max_tension=cap, min_rest_length=floor,
                  min_length=_min_length(f, spring.tendon), lag_time=lag_time)
    rest = rest0 + command.scale * _start(f, a, lo, hi)
    return ActuatorMapping(name, cable, "force", motor, k, spring.damping, rest, command,
                           tuple(notes))


def _position(f: Loaded, a: int, name: str, cable: str, spring: Spring) -> ActuatorMapping:
    if spring.stiffness > 0 and f.model.actuator_dyntype[a] != _DYN.mjDYN_INTEGRATOR:
        return _servo(f, a, name, cable, spring)
    return _stiffer_cable(f, a, name, cable, spring)


def _servo_gains(f: Loaded, a: int) -> tuple[float, float, float]:
    """A position actuator's gear, stiffness kp (-bias[1]) and the ratio of its control gain
    to kp (1 for MuJoCo's ``position``; a ``general`` may scale its control)."""
    m = f.model
    kp = -float(m.actuator_biasprm[a][1])
    return float(m.actuator_gear[a][0]), kp, float(m.actuator_gainprm[a][0]) / kp


def _servo(f: Loaded, a: int, name: str, cable: str, spring: Spring) -> ActuatorMapping:
    """A position actuator beside a tendon spring: the spring's cable with a PD motor."""
    m = f.model
    gear, kp, ratio = _servo_gains(f, a)
    b0, kv = float(m.actuator_biasprm[a][0]), -float(m.actuator_biasprm[a][2])
    command = CommandMap(b0 / (kp * gear), ratio / gear)  # the target length L [m]
    lo, hi = _range(f, a)
    target = command.offset + command.scale * _start(f, a, lo, hi)
    if target <= 0:
        raise f.refuse(f"actuator {name!r}", f"its initial target length for tendon {cable!r} "
                       f"is {target:.4g} m; give a keyframe whose ctrl sets the targets, or a "
                       "ctrlrange above 0")
    notes = []
    if m.actuator_dyntype[a] in _FILTERS:
        notes.append(f"a filter lags the target with time constant "
                     f"{float(m.actuator_dynprm[a][0]):g} s; tensim's PD motor takes its target "
                     "at once")
    cap, push = gear**2 * kp * spring.length, True  # no force limit: never binds before L = 0
    if m.actuator_forcelimited[a]:
        tensions = sorted(-gear * v for v in m.actuator_forcerange[a])
        push = tensions[0] < 0
        if tensions[1] > 0:
            cap = tensions[1]
        if tensions[0] > 0:
            notes.append(f"the file's force range makes the servo pull at least "
                         f"{tensions[0]:.4g} N; tensim's servo lets go at its target")
    if push:
        notes.append("the file's servo also pushes when the tendon is shorter than its target "
                     "(its force range allows lengthening force); tensim's PD motor never pushes")
    if not m.actuator_forcelimited[a]:
        notes.append(f"no force limit in the file; chosen max_tension {cap:.4g} N (kp x the "
                     "tendon's length: it never binds before the target reaches 0)")
    motor = Motor(max_tension=cap, pd_stiffness=gear**2 * kp, pd_damping=gear**2 * kv,
                  pd_target=target)
    return ActuatorMapping(name, cable, "position", motor, spring.stiffness, spring.damping,
                           spring.dead_band[1], command, tuple(notes))


def _stiffer_cable(f: Loaded, a: int, name: str, cable: str,
                   spring: Spring) -> ActuatorMapping:
    """A position actuator without a spring, or driven through its target's rate: one cable."""
    m = f.model
    gear, kp, ratio = _servo_gains(f, a)
    b0, kv = float(m.actuator_biasprm[a][0]), -float(m.actuator_biasprm[a][2])
    k_act, b_act = gear**2 * kp, gear**2 * kv
    k = spring.stiffness + k_act
    # rest length = (k_s l_s + k_act (u + b0 / kp) / gear) / k
    rate = m.actuator_dyntype[a] == _DYN.mjDYN_INTEGRATOR  # intvelocity: ctrl moves the target
    command = CommandMap((spring.stiffness * spring.dead_band[1] + k_act * b0 / (kp * gear)) / k,
                         ratio * (k_act / (gear * k)), rate=rate)
    lo, hi = _range(f, a)
    rests = sorted(command.offset + command.scale * u for u in (lo, hi))
    floor = max(rests[0], 0.0) if math.isfinite(rests[0]) else 0.0
    span = rests[1] - rests[0] if math.isfinite(rests[1] - rests[0]) else spring.length
    if rate:
        speed = abs(command.scale) * max(abs(v) for v in m.actuator_ctrlrange[a]) \
            if m.actuator_ctrllimited[a] else span / float(m.opt.timestep)
        notes = [f"the control is the target's rate (integrator dynamics): tensim's motor takes "
                 f"a rest-length target and moves toward it at up to {speed:.4g} m/s"]
        lag_time = 0.0
    else:
        speed, lag_time, notes = _lag(f, a, span)
    pull = math.inf
    if m.actuator_forcelimited[a]:
        forces = sorted(-gear * v for v in m.actuator_forcerange[a])
        pull = forces[1]
        if forces[0] < 0:
            notes.append("the actuator also pushes (its force range allows lengthening "
                         "force) when the tendon is shorter than its target; tensim's cable "
                         "goes slack")
    else:
        notes.append("the actuator also pushes when the tendon is shorter than its target; "
                     "tensim's cable goes slack")
    cap = pull if math.isfinite(pull) and pull > 0 else k * spring.length
    # alone on its tendon, the servo's clamped pull is the cable's: a saturating force cap
    saturate = math.isfinite(pull) and pull > 0 and spring.stiffness <= 0
    notes.append(f"the force limit: the pull saturates at {cap:.4g} N (tensim's motor pays out "
                 "above it, Motor.saturate; the cable's damping acts on top of the cap, where "
                 "the file clamps the servo's damping with its pull)" if saturate else
                 f"the force limit: tensim stops reeling in above {cap:.4g} N of static tension "
                 "rather than saturating the force" if math.isfinite(pull) else
                 f"no force limit in the file; chosen max_tension {cap:.4g} N (k x the "
                 "tendon's length: it never binds before the rest length reaches 0)")
    if spring.stiffness > 0:
        notes.append(f"the tendon's spring ({spring.stiffness:g} N/m) and the actuator's "
                     f"kp ({k_act:g} N/m) make one cable of {k:g} N/m, exact while both pull")
    motor = Motor(max_speed=speed, max_tension=cap, min_rest_length=floor,
                  min_length=_min_length(f, spring.tendon), lag_time=lag_time, saturate=saturate)
    rest = command.offset + command.scale * _start(f, a, lo, hi)
    if rest <= 0:
        raise f.refuse(f"actuator {name!r}", f"its initial target gives tendon {cable!r} a rest "
                       f"length of {rest:.4g} m; give a keyframe whose ctrl sets the targets, or a "
                       "ctrlrange above 0")
    return ActuatorMapping(name, cable, "position", motor, k, spring.damping + b_act, rest,
                           command, tuple(notes))


def _min_length(f: Loaded, t: int) -> float:
    """The tendon's lower length limit, where tensim's motor stops reeling in (0: none)."""
    return float(f.model.tendon_range[t][0]) if f.model.tendon_limited[t] else 0.0


def _tensim(name: str, cable: str, user: dict[str, float]) -> ActuatorMapping:
    """A cable of tensim's own export, exactly as it was."""
    kind = int(user["motor"])
    if kind == MOTOR_KIND["passive"]:
        motor = PASSIVE
    else:
        dc = None if kind != MOTOR_KIND["dc"] else DCMotor(
            spool_radius=user["spool_radius"], stall_torque=user["stall_torque"],
            no_load_speed=user["no_load_speed"], rotor_inertia=user["rotor_inertia"],
            viscous_friction=user["viscous_friction"],
            coulomb_friction=user["coulomb_friction"],
            back_drivable=bool(user["back_drivable"]), position_time=user["position_time"])
        target = user.get("pd_target", 0.0)
        motor = Motor(max_speed=user["max_speed"], max_tension=user["max_tension"],
                      min_rest_length=user["min_rest_length"], min_length=user["min_length"],
                      dc=dc, lag_time=user.get("lag_time", 0.0),
                      saturate=bool(user.get("saturate", 0.0)),
                      pd_stiffness=user.get("pd_stiffness", 0.0),
                      pd_damping=user.get("pd_damping", 0.0),
                      pd_target=target if target > 0 else None)
    return ActuatorMapping(name, cable, "tensim", motor, user["stiffness"], user["damping"],
                           user["rest_length"], None, ())
