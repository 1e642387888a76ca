"""The cable, motor and impedance laws: each one pure, vectorised function.

These are the reference definitions. The compiled callback (``_cable.c``) mirrors them
operation for operation, and the tests check the two against each other.
"""

from __future__ import annotations

import numpy as np


def load_cell_tension(length: np.ndarray | float, rest_length: np.ndarray | float,
                      stiffness: np.ndarray | float) -> np.ndarray:
    """The load cell's reading k max(0, x - l) [N] (the spring part of :func:`cable_tension`).

    Args:
        length: (n,) anchor-to-anchor length x [m].
        rest_length: (n,) rest length l [m].
        stiffness: (n,) k [N/m].
    """
    stretch = length - rest_length
    return np.where(stretch > 0.0, stiffness * stretch, 0.0)


def cable_tension(length: np.ndarray | float, velocity: np.ndarray | float,
                  rest_length: np.ndarray | float, stiffness: np.ndarray | float,
                  damping: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    """Paper eq. (1)-(2): a tension-only Hooke spring with linear damping.

    f = k (x - l) + b xdot while x > l, else 0, and never negative.

    Args:
        length: (n,) anchor-to-anchor length x [m].
        velocity: (n,) its rate xdot [m/s].
        rest_length: (n,) rest length l [m].
        stiffness: (n,) k [N/m].
        damping: (n,) b [N s/m].

    Returns:
        (spring, applied): the load-cell reading k max(0, x - l) and the applied force f [N].
    """
    spring = load_cell_tension(length, rest_length, stiffness)
    taut = length - rest_length > 0.0
    applied = np.where(taut, np.maximum(spring + damping * velocity, 0.0), 0.0)
    return spring, applied


def pd_tension(length: np.ndarray | float, velocity: np.ndarray | float,
               target: np.ndarray | float, pd_stiffness: np.ndarray | float,
               pd_damping: np.ndarray | float, max_tension: np.ndarray | float
               ) -> tuple[np.ndarray, np.ndarray]:
    """A PD motor's tension-only pull on the cable's length (a lab's position servo on a
    tendon whose force range lets it pull only): T = kp (x - L) + kd xdot, clamped to
    [0, max_tension] (MuJoCo's force range): it never pushes, and where its target is above
    the length it pulls only while the cable lengthens fast enough.

    Args:
        length: (n,) anchor-to-anchor length x [m].
        velocity: (n,) its rate xdot [m/s].
        target: (n,) the servo's target length L [m] (its command).
        pd_stiffness: (n,) kp [N/m] (0 where the motor is no PD).
        pd_damping: (n,) kd [N s/m].
        max_tension: (n,) the force cap [N].

    Returns:
        (static, applied): the static pull min(max(0, kp (x - L)), max_tension), which the
        load cell reads beside the spring, and the applied tension T [N].
    """
    stretch = pd_stiffness * (length - target)
    static = np.minimum(np.maximum(stretch, 0.0), max_tension)
    applied = np.minimum(np.maximum(stretch + pd_damping * velocity, 0.0), max_tension)
    return static, applied


def load_cell_reading(length: np.ndarray, rest_length: np.ndarray, stiffness: np.ndarray,
                      pd: np.ndarray, command: np.ndarray, pd_stiffness: np.ndarray,
                      max_tension: np.ndarray) -> np.ndarray:
    """The load cell's reading [N]: k max(0, x - l) (:func:`load_cell_tension`), plus a PD
    motor's static pull (:func:`pd_tension`) where ``pd``, its target the command ``command``.
    The first of :func:`motor_cable_tension`'s results, without the rates."""
    static = pd_tension(length, 0.0, command, pd_stiffness, 0.0, max_tension)[0]
    return load_cell_tension(length, rest_length, stiffness) + np.where(pd, static, 0.0)


def motor_cable_tension(length: np.ndarray, velocity: np.ndarray, rest_length: np.ndarray,
                        stiffness: np.ndarray, damping: np.ndarray, pd: np.ndarray,
                        command: np.ndarray, pd_stiffness: np.ndarray, pd_damping: np.ndarray,
                        max_tension: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cable_tension`, plus a PD motor's pull (:func:`pd_tension`) where ``pd``: its
    target is the cable's command. The load cell reads both.

    Returns:
        (reading, applied) [N].
    """
    spring, applied = cable_tension(length, velocity, rest_length, stiffness, damping)
    static, pulled = pd_tension(length, velocity, command, pd_stiffness, pd_damping,
                                max_tension)
    return spring + np.where(pd, static, 0.0), applied + np.where(pd, pulled, 0.0)


def impedance_setpoint(length: np.ndarray, velocity: np.ndarray, offset_tension: np.ndarray,
                       stiffness_gain: np.ndarray, damping_gain: np.ndarray,
                       target_length: np.ndarray, target_velocity: np.ndarray) -> np.ndarray:
    """Paper eq. (3), clamped: T_set = max(0, T0 + K (L - L*) + B (V - V*)) [N]."""
    return np.maximum(
        0.0,
        offset_tension + stiffness_gain * (length - target_length)
        + damping_gain * (velocity - target_velocity),
    )


def impedance_rest_target(rest_length: np.ndarray, setpoint: np.ndarray, measured: np.ndarray,
                          stiffness: np.ndarray) -> np.ndarray:
    """Rest length that would turn the measured tension into the setpoint: l - (T_set - T)/k."""
    return rest_length - (setpoint - measured) / stiffness


def lag_share(lag_time: np.ndarray, dt: float) -> np.ndarray:
    """The share of the way to its target that a motor's rest length moves in one step:
    1 - exp(-dt / lag_time) under a first-order lag, 1.0 without one (lag_time 0)."""
    lagged = lag_time > 0.0
    return np.where(lagged, 1.0 - np.exp(-dt / np.where(lagged, lag_time, 1.0)), 1.0)


def motor_step(rest_length: np.ndarray, target: np.ndarray, length: np.ndarray,
               stiffness: np.ndarray, max_speed: np.ndarray, max_tension: np.ndarray,
               min_rest_length: np.ndarray, min_length: np.ndarray, dt: float,
               share: np.ndarray | float = 1.0,
               saturate: np.ndarray | float = 0.0) -> np.ndarray:
    """One motor update: the rest length moves toward ``target`` under the motor's limits.

    - lag: it moves ``share`` of the way (:func:`lag_share`; 1: all of it);
    - speed: it changes by at most max_speed * dt;
    - force: it does not reel in past the rest length x - max_tension/k at which the static
      tension k (x - l) reaches max_tension (and never lets out because of this rule);
    - floors: it does not reel in while x <= min_length, and stays >= min_rest_length;
    - a saturating force cap (``saturate`` 1.0): it pays out, at any speed, to no shorter than
      x - max_tension/k, where the static tension is max_tension.

    Returns:
        (n,) the new rest lengths [m].
    """
    reach = max_speed * dt
    step = np.minimum(np.maximum((target - rest_length) * share, -reach), reach)
    new = rest_length + step
    reel = step < 0.0
    force_floor = np.minimum(rest_length, length - max_tension / stiffness)
    new = np.where(reel, np.maximum(new, force_floor), new)
    new = np.where(reel & (length <= min_length), rest_length, new)
    new = np.where(saturate != 0.0, np.maximum(new, length - max_tension / stiffness), new)
    return np.maximum(new, min_rest_length)


def dc_drive(rest_length: np.ndarray, target: np.ndarray, no_load_line_speed: np.ndarray,
             position_time: np.ndarray) -> np.ndarray:
    """The DC motor's drive u in [-1, 1] (fraction of full voltage; > 0 pays cable out): a
    proportional position loop, u = (target - l) / (v0 t_p), saturated.

    Args:
        rest_length, target: (n,) rest length l and its target [m].
        no_load_line_speed: (n,) v0, the spool's surface speed at no load [m/s].
        position_time: (n,) t_p, the position loop's time constant [s].
    """
    error = (target - rest_length) / (no_load_line_speed * position_time)
    return np.minimum(np.maximum(error, -1.0), 1.0)


def dc_motor_speed(speed: np.ndarray, drive: np.ndarray, tension: np.ndarray,
                   stall_force: np.ndarray, no_load_line_speed: np.ndarray, mass: np.ndarray,
                   viscous: np.ndarray, coulomb: np.ndarray, back_drivable: np.ndarray,
                   dt: float) -> np.ndarray:
    """One step of the DC motor's line speed s = dl/dt [m/s] (> 0: paying cable out).

    In cable coordinates (torques / spool radius, inertia / radius^2) the spool obeys
    M ds/dt = T + F_s (u - s / v0) - c s - F_c sgn(s): the cable's tension T pulls cable out,
    the motor's linear torque-speed curve drives it, viscous and Coulomb friction resist. The
    step is backward Euler, M (s' - s) / dt = T + F_s u - (F_s / v0 + c) s' - F_c sgn(s'),
    with sgn(0) anywhere in [-1, 1] (the spool sticks while the other forces are within F_c):
    stable for any M >= 0, and exact for a static spool. A spool that is not back-drivable
    (a worm gear) turns only where the motor drives it (sgn(s') = sgn(u), or not at all).

    Args:
        speed: (n,) s [m/s]. drive: (n,) u [-]. tension: (n,) T [N].
        stall_force: (n,) F_s [N]. no_load_line_speed: (n,) v0 [m/s]. mass: (n,) M [kg].
        viscous: (n,) c [N s/m]. coulomb: (n,) F_c [N].
        back_drivable: (n,) 1.0 where the cable may drive the spool, else 0.0.
        dt: time step [s].

    Returns:
        (n,) the new speed s' [m/s].
    """
    inertia = mass + dt * (stall_force / no_load_line_speed + viscous)
    free = (mass * speed + dt * (tension + stall_force * drive)) / inertia
    slip = dt * coulomb / inertia
    new = np.where(np.abs(free) > slip, free - np.copysign(slip, free), 0.0)
    # a worm gear: the spool turns only where the motor drives it
    held = np.where(drive > 0.0, np.maximum(new, 0.0),
                    np.where(drive < 0.0, np.minimum(new, 0.0), 0.0))
    return np.where(back_drivable != 0.0, new, held)


def pull(length: np.ndarray, rest_length: np.ndarray, theta: float = 1.0) -> np.ndarray:
    """The implicit law's pull: -theta where the cable is taut (x > l), else 0.0.

    Args:
        length: (n,) anchor-to-anchor length x [m].
        rest_length: (n,) rest length l after this step's motor update [m].
        theta: the share of the gain term's derivatives the integrator takes
            (``_law_layout.theta``).
    """
    return np.where(length - rest_length > 0.0, -theta, 0.0)


def gain_term(length: np.ndarray, velocity: np.ndarray, stiffness: np.ndarray,
              damping: np.ndarray, pull_: np.ndarray) -> np.ndarray:
    """The implicit law's native term, MuJoCo's affine gain times the pull:
    (0 + k x + b xdot) * pull [N], in MuJoCo's order of operations.

    Its derivatives, k pull and b pull, are what MuJoCo's implicit integrator sees; the bias
    that the law returns beside it (the force less this term) makes the total exactly the law's.
    """
    return (0.0 + stiffness * length + damping * velocity) * pull_
