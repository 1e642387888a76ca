# mypy: disable-error-code="valid-type, misc"
# (Warp kernel signatures annotate arguments with calls such as wp.array(dtype=float), and
# wp.tid() returns a tuple inside a kernel: mypy reads both as plain Python and cannot follow.)
"""The cable law as a Warp kernel for MuJoCo Warp (the optional ``tensim[gpu]`` extra).

MuJoCo Warp calls a model's ``act_dyn`` callback once per step for all worlds, after its own
actuator stage; :func:`install_warp_law` sets it to launch :func:`cable_law` over worlds x
actuators. The kernel is the law of ``_cable.c`` and :mod:`tensim.sim._laws`, operation for
operation, on the same layout (rest length and the peak tension, line speed and power in ``act``,
then a DC motor's line speed and the implicit law's pull; the command in ``ctrl``, the parameters
in ``actuator_dynprm``/``actuator_gainprm``/``actuator_biasprm``, per world where MuJoCo Warp holds
them per world), so a batch moves between the CPU engine and the GPU unchanged. It writes the motor
rates into ``act_dot`` and the cable force into ``actuator_force`` (this callback runs after MuJoCo
Warp's actuator stage and replaces its force: under the implicit law the force is the law's own,
while MuJoCo Warp's implicit integrator takes the derivatives of the affine gain times the pull, as
MuJoCo does). MuJoCo Warp computes in float32.
"""

from __future__ import annotations

import copy
from typing import Any

import mujoco
import warp as wp
from mujoco_warp._src.types import vec10  # the type of MuJoCo Warp's actuator parameters

from tensim.model import _law_layout as layout

# the layout's slots as Warp constants (the one specification: tensim.model._law_layout)
_MARKER = wp.constant(float(layout.CABLE_MARKER))
_IMPEDANCE = wp.constant(float(layout.MODE_IMPEDANCE))
_PD = wp.constant(float(layout.MODE_PD))
_ACTDIM, _DC_ACTDIM = wp.constant(layout.ACTDIM), wp.constant(layout.DC_ACTDIM)
_EXTRA = wp.constant(layout.IMPLICIT_EXTRA)
_AFFINE = wp.constant(int(mujoco.mjtGain.mjGAIN_AFFINE))
_P_MARKER, _P_MODE = wp.constant(layout.P_MARKER), wp.constant(layout.P_MODE)
_P_MAX_SPEED, _P_MAX_TENSION = wp.constant(layout.P_MAX_SPEED), wp.constant(layout.P_MAX_TENSION)
_P_MIN_REST, _P_MIN_LENGTH = wp.constant(layout.P_MIN_REST), wp.constant(layout.P_MIN_LENGTH)
_P_OFFSET, _P_GAIN_K = wp.constant(layout.P_OFFSET), wp.constant(layout.P_GAIN_K)
_P_GAIN_B, _P_TARGET = wp.constant(layout.P_GAIN_B), wp.constant(layout.P_TARGET_LENGTH)
_G_K, _G_DAMPING = wp.constant(layout.G_STIFFNESS), wp.constant(layout.G_DAMPING)
_THETA_DISCRETE = wp.constant(layout.THETA_DISCRETE)
_THETA_FAST = wp.constant(layout.THETA_IMPLICITFAST)
_IMPLICITFAST = wp.constant(int(mujoco.mjtIntegrator.mjINT_IMPLICITFAST))
_G_PD_K, _G_PD_B = wp.constant(layout.G_PD_STIFFNESS), wp.constant(layout.G_PD_DAMPING)
_B_STALL, _B_V0 = wp.constant(layout.B_STALL_FORCE), wp.constant(layout.B_NO_LOAD_SPEED)
_B_MASS, _B_VISCOUS = wp.constant(layout.B_MASS), wp.constant(layout.B_VISCOUS)
_B_COULOMB, _B_TP = wp.constant(layout.B_COULOMB), wp.constant(layout.B_POSITION_TIME)
_B_BACK_DRIVABLE = wp.constant(layout.B_BACK_DRIVABLE)
_B_LAG = wp.constant(layout.B_LAG_TIME)
_B_SATURATE = wp.constant(layout.B_SATURATE)
_A_REST, _A_PEAK = wp.constant(layout.A_REST), wp.constant(layout.A_PEAK)
_A_SPEED = wp.constant(layout.A_SPEED)
_A_PEAK_SPEED = wp.constant(layout.A_PEAK_SPEED)
_A_PEAK_POWER = wp.constant(layout.A_PEAK_POWER)


@wp.func
def _dc_step(p: vec10, g: vec10, b: vec10, speed: float, rest: float, target: float, x: float,
             v: float, dt: float) -> wp.vec2:
    """DC motor: (new rest length, new line speed), as ``_cable.c``'s dc_step."""
    stretch = x - rest
    measured = 0.0
    applied = 0.0
    if stretch > 0.0:
        measured = g[_G_K] * stretch
        applied = wp.max(measured + g[_G_DAMPING] * v, 0.0)
    # position loop: full voltage at an error of v0 t_p; no reeling in past the limits
    drive = wp.min(wp.max((target - rest) / (b[_B_V0] * b[_B_TP]), -1.0), 1.0)
    if drive < 0.0 and (measured >= p[_P_MAX_TENSION] or x <= p[_P_MIN_LENGTH]):
        drive = 0.0
    # backward Euler in the speed, Coulomb friction set-valued (the spool may stick)
    inertia = b[_B_MASS] + dt * (b[_B_STALL] / b[_B_V0] + b[_B_VISCOUS])
    free = (b[_B_MASS] * speed + dt * (applied + b[_B_STALL] * drive)) / inertia
    slip = dt * b[_B_COULOMB] / inertia
    new_speed = 0.0
    if free > slip:
        new_speed = free - slip
    elif free < -slip:
        new_speed = free + slip
    if b[_B_BACK_DRIVABLE] == 0.0:  # a worm gear: the spool turns only where the motor drives it
        if drive > 0.0:
            new_speed = wp.max(new_speed, 0.0)
        elif drive < 0.0:
            new_speed = wp.min(new_speed, 0.0)
        else:
            new_speed = 0.0
    new = rest + new_speed * dt
    if new < p[_P_MIN_REST]:  # the floor on the rest length stops the spool
        new = p[_P_MIN_REST]
        new_speed = 0.0
    return wp.vec2(new, new_speed)


@wp.kernel(module="unique", enable_backward=False)
def cable_law(
    opt_timestep: wp.array(dtype=float),
    opt_integrator: int,
    actuator_dynprm: wp.array2d(dtype=vec10),
    actuator_gainprm: wp.array2d(dtype=vec10),
    actuator_biasprm: wp.array2d(dtype=vec10),
    actuator_gaintype: wp.array(dtype=int),
    actuator_actadr: wp.array(dtype=int),
    actuator_actnum: wp.array(dtype=int),
    actuator_ctrladr: wp.array(dtype=int),
    actuator_trnid: wp.array(dtype=wp.vec2i),
    ten_length: wp.array2d(dtype=float),
    ten_velocity: wp.array2d(dtype=float),
    act: wp.array2d(dtype=float),
    ctrl: wp.array2d(dtype=float),
    act_dot: wp.array2d(dtype=float),
    actuator_force: wp.array2d(dtype=float),
):
    """One cable of one world: motor step, peaks, and the tension-only force (eq. 1-3)."""
    world, i = wp.tid()
    p = actuator_dynprm[world % actuator_dynprm.shape[0], i]
    implicit = actuator_gaintype[i] == _AFFINE
    actnum = actuator_actnum[i]
    if implicit:
        actnum = actnum - _EXTRA
    if p[_P_MARKER] != _MARKER or (actnum != _ACTDIM and actnum != _DC_ACTDIM):
        return
    g = actuator_gainprm[world % actuator_gainprm.shape[0], i]
    b = actuator_biasprm[world % actuator_biasprm.shape[0], i]
    dt = opt_timestep[world % opt_timestep.shape[0]]
    tendon = actuator_trnid[i][0]
    adr = actuator_actadr[i]
    x = ten_length[world, tendon]
    v = ten_velocity[world, tendon]
    k = g[_G_K]
    rest = act[world, adr + _A_REST]
    command = ctrl[world, actuator_ctrladr[i]]
    target = command
    if p[_P_MODE] == _IMPEDANCE:
        # impedance law (eq. 3): the rest length that turns the measured tension into T_set
        stretch = x - rest
        measured = 0.0
        if stretch > 0.0:
            measured = k * stretch
        setpoint = wp.max(0.0, p[_P_OFFSET] + p[_P_GAIN_K] * (x - p[_P_TARGET])
                          + p[_P_GAIN_B] * (v - command))
        target = rest - (setpoint - measured) / k
    pd = p[_P_MODE] == _PD
    if pd:  # a PD motor's command is its target length: the rest length stays
        target = rest
    new = rest
    if actnum == _DC_ACTDIM:
        speed = act[world, adr + _A_SPEED]
        dc = _dc_step(p, g, b, speed, rest, target, x, v, dt)
        act_dot[world, adr + _A_SPEED] = (dc[1] - speed) / dt
        new = dc[0]
    else:
        # motor: at most max_speed, never reeling in past max_tension or below the floors
        share = 1.0
        if b[_B_LAG] > 0.0:  # lag: a share 1 - exp(-dt / lag_time) of the way to the target
            share = 1.0 - wp.exp(-dt / b[_B_LAG])
        reach = p[_P_MAX_SPEED] * dt
        step = wp.min(wp.max((target - rest) * share, -reach), reach)
        new = rest + step
        if step < 0.0:
            new = wp.max(new, wp.min(rest, x - p[_P_MAX_TENSION] / k))
            if x <= p[_P_MIN_LENGTH]:
                new = rest
        if b[_B_SATURATE] != 0.0:  # a saturating force cap: pay out to the static max_tension
            new = wp.max(new, x - p[_P_MAX_TENSION] / k)
        new = wp.max(new, p[_P_MIN_REST])
    rate = (new - rest) / dt
    act_dot[world, adr + _A_REST] = rate
    # cable (eq. 1-2) from the rest length after this step, as Euler integration stores it
    stretch = x - (rest + rate * dt)
    spring = 0.0
    applied = 0.0
    if stretch > 0.0:
        spring = k * stretch
        applied = wp.max(spring + g[_G_DAMPING] * v, 0.0)
    if pd:  # a PD motor pulls beside the spring, in [0, max_tension]; the load cell reads both
        pull_pd = g[_G_PD_K] * (x - command)
        spring += wp.min(wp.max(pull_pd, 0.0), p[_P_MAX_TENSION])
        applied += wp.min(wp.max(pull_pd + g[_G_PD_B] * v, 0.0), p[_P_MAX_TENSION])
    peak = act[world, adr + _A_PEAK]
    act_dot[world, adr + _A_PEAK] = (wp.max(peak, spring) - peak) / dt
    # the running maxima of the line speed |dl/dt| and of the power it takes, tension x speed
    speed_now = wp.abs(rate)
    power = spring * speed_now
    peak_speed = act[world, adr + _A_PEAK_SPEED]
    act_dot[world, adr + _A_PEAK_SPEED] = (wp.max(peak_speed, speed_now) - peak_speed) / dt
    peak_power = act[world, adr + _A_PEAK_POWER]
    act_dot[world, adr + _A_PEAK_POWER] = (wp.max(peak_power, power) - peak_power) / dt
    if implicit:  # the pull, the last activation: -theta while taut (the gain term's input)
        last = adr + actnum + _EXTRA - 1
        pull = 0.0
        if stretch > 0.0:
            pull = -_THETA_DISCRETE
            if opt_integrator == _IMPLICITFAST:
                pull = -_THETA_FAST
        act_dot[world, last] = (pull - act[world, last]) / dt
    actuator_force[world, i] = -applied


def _launch(m: Any, d: Any) -> None:
    wp.launch(cable_law, dim=(d.nworld, m.nactuator),
              inputs=[m.opt.timestep, int(m.opt.integrator), m.actuator_dynprm,
                      m.actuator_gainprm, m.actuator_biasprm, m.actuator_gaintype,
                      m.actuator_actadr, m.actuator_actnum, m.actuator_ctrladr, m.actuator_trnid,
                      d.ten_length, d.ten_velocity, d.act, d.ctrl],
              outputs=[d.act_dot, d.actuator_force])


def warp_host_model(model: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of a tensim model for ``mujoco_warp.put_model``.

    MuJoCo Warp leaves the activations of user-dynamics actuators to the user, where MuJoCo
    integrates them (act += act_dot dt); declaring the cable actuators integrators makes MuJoCo
    Warp integrate them the same way, from the rates :func:`cable_law` writes over the
    integrator's own. MuJoCo Warp needs the midphase, which MuJoCo may skip bit-identically.
    """
    host = copy.copy(model)
    cables = _law_actuators(host)
    host.actuator_dyntype[cables] = mujoco.mjtDyn.mjDYN_INTEGRATOR
    host.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_MIDPHASE)
    return host


def _law_actuators(model: mujoco.MjModel) -> Any:
    return layout.is_cable(model).nonzero()[0]


def install_warp_law(m: Any) -> None:
    """Makes the MuJoCo Warp model ``m`` run the cable law in every step.

    Raises:
        ValueError: ``m`` already runs another actuator-dynamics callback.
    """
    if m.callback.act_dyn not in (None, _launch):
        raise ValueError("this MuJoCo Warp model already has an act_dyn callback; tensim's "
                         "cable law would replace it")
    m.callback.act_dyn = _launch
