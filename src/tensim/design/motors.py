"""Motor sizing from recorded runs: what each cable's motor must deliver, and which motor does.

From a run's trajectory (``tension/``, ``rest_length/`` per cable; any sample rate) each
cable's motor winds the rest length l0 at the line speed u = dl0/dt [m/s] (central
differences, one-sided at the ends) against the tension T [N]. It delivers the mechanical power
P = -T u [W] (positive while it reels in against the tension) and the work
W = integral of max(P, 0) dt [J] (trapezoidal rule; per cycle: W x period / duration). The
power through the spool, either way, is T |u|.

The simulation also tracks, at every physics step, each cable's peak tension T*, peak line
speed u* and peak power P* = max T |u| (:class:`TrackedPeaks`, in the run's summary). Where a
run has them, the peaks come from them, not from the samples, which miss what happens between
them (recorded at 100 Hz, the line speed peaks read 5.9 % low).

Behind a spool of radius R [m] and a gear ratio N [-] the motor shaft must give the torque
tau = S T R / N [N m] at the speed omega = S |u| N / R [rad/s], S the safety factor (the
paper's 1.15). A DC motor of stall torque tau_s and no-load speed omega_0 (its shaft) gives
that where tau / tau_s + omega / omega_0 <= 1 (the linear torque-speed line); the margin is
1 - max over the samples of that sum, negative for a motor too weak. With tracked peaks every
step's operating point lies in the box T <= T*, |u| <= u* cut by T |u| <= P*, so the margin
is taken at that region's worst corner: a bound the motor meets at every step, not only at
the samples (it may judge a motor short whose peaks of torque and speed never coincide).
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tensim._input import describe, is_real, load_yaml_file
from tensim.design._errors import DesignError
from tensim.sim import SimulationResult, TimeSeries

SAFETY_FACTOR = 1.15  # the paper's, from its simulated-versus-measured tensions
SPEED_FLOOR = 1e-9  # m/s: slower line speeds are the round-off of a rest length that holds


@dataclasses.dataclass(frozen=True)
class CableDuty:
    """What one cable's motor did in the recorded runs (largest over runs, per cable).

    Attributes:
        cable: cable name.
        peak_tension: largest tension [N].
        rms_tension: root mean square tension [N].
        peak_speed: largest |dl0/dt| [m/s].
        peak_power: largest power through the spool T |dl0/dt| [W].
        mean_power: mean of the mechanical power [W].
        work: positive work over the run [J].
        duration: recorded time [s].
        at_speed_limit: fraction of the time within 1 % of the motor's max_speed [-].
        at_force_limit: fraction of the time within 1 % of the motor's max_tension [-].
        tension: (T,) the tension samples [N], for the operating-point check.
        speed: (T,) the line speed samples [m/s].
        tracked: the peaks are the simulation's over every physics step (else the samples').
    """

    cable: str
    peak_tension: float
    rms_tension: float
    peak_speed: float
    peak_power: float
    mean_power: float
    work: float
    duration: float
    at_speed_limit: float
    at_force_limit: float
    tension: np.ndarray = dataclasses.field(repr=False)
    speed: np.ndarray = dataclasses.field(repr=False)
    tracked: bool = False

    def work_per_cycle(self, period: float) -> float:
        """Positive work per gait cycle of ``period`` seconds [J]."""
        return self.work * period / self.duration


@dataclasses.dataclass(frozen=True)
class TrackedPeaks:
    """A cable's maxima over every physics step of a run, as the cable law tracks them.

    Attributes:
        tension: peak load-cell tension T* [N].
        speed: peak line speed u* = max |dl0/dt| [m/s].
        power: peak power through the spool P* = max T |dl0/dt| [W].
    """

    tension: float
    speed: float
    power: float


def tracked_peaks(result: SimulationResult) -> dict[str, TrackedPeaks]:
    """Cable -> its peaks over every physics step of ``result`` (empty if not tracked)."""
    if result.peak_speed is None or result.peak_power is None:
        return {}
    return {c: TrackedPeaks(float(t), float(u), float(p)) for c, t, u, p in
            zip(result.cables, result.peak_tension, result.peak_speed, result.peak_power,
                strict=True)}


PEAK_SHORTFALL = 0.01  # recorded peak tension this far below the tracked one: too coarse


def check_sampling(series: TimeSeries, tracked: dict[str, float], source: str) -> None:
    """Refuses a run recorded too coarsely for its gait: the simulation tracks each cable's
    peak tension at every physics step (``max_tension_N`` in its summary); where the largest
    recorded sample is more than :data:`PEAK_SHORTFALL` below it, the samples miss the peaks
    of the tension and of the line speed, and a motor sized from them could fail on the same
    gait (recorded every 0.25 s, a motor passed with +3.1 % margin that fails by 12 %).

    Args:
        series: the run's trajectory.
        tracked: cable -> peak tension over every physics step [N].
        source: the run, for the message.

    Raises:
        DesignError: naming the run, the cable and the figures, and what to do.
    """
    shortfall = _shortfall(series, tracked, source)
    if shortfall:
        raise DesignError(f"{shortfall}, and its line speed peaks are missed too; rerun the "
                          "simulation with a smaller --record-dt")


def sampling_note(series: TimeSeries, tracked: dict[str, TrackedPeaks], source: str
                  ) -> str | None:
    """A note where a run with tracked peaks was recorded too coarsely for its gait (as
    :func:`check_sampling` judges it): its peaks stand, but the figures taken from its samples
    (RMS tension, mean power, work, time at the limits) are rough; None where it is fine."""
    shortfall = _shortfall(series, {c: p.tension for c, p in tracked.items()}, source)
    return None if shortfall is None else (
        f"{shortfall}: the peaks are the ones tracked at every step, but its RMS tension, "
        "mean power, work and time at the limits come from those samples")


def _shortfall(series: TimeSeries, tracked: dict[str, float], source: str) -> str | None:
    """Where the recorded tension peaks fall over :data:`PEAK_SHORTFALL` below the tracked
    ones: the run, its sample period and the worst cable's figures; else None."""
    worst, cable, recorded = 0.0, "", 0.0
    for name, peak in tracked.items():
        if f"tension/{name}" not in series.channels or not peak > 0:
            continue
        sampled = float(np.max(series[f"tension/{name}"]))
        if 1 - sampled / peak > worst:
            worst, cable, recorded = 1 - sampled / peak, name, sampled
    if worst <= PEAK_SHORTFALL:
        return None
    period = float(np.median(np.diff(series.time)))
    return (f"{source}: recorded every {period:g} s, too coarse for its gait: cable {cable!r} "
            f"peaked at {tracked[cable]:.4g} N between samples, its largest sample reads "
            f"{recorded:.4g} N ({100 * worst:.2g} % low; limit {100 * PEAK_SHORTFALL:g} %)")


def cable_duty(series: TimeSeries, limits: dict[str, tuple[float, float]] | None = None,
               tracked: dict[str, TrackedPeaks] | None = None) -> list[CableDuty]:
    """Each cable's duty in one recorded run.

    Args:
        series: a run's trajectory with ``tension/`` and ``rest_length/`` channels.
        limits: cable -> (max_speed [m/s], max_tension [N]) of its motor, for the time at limit.
        tracked: cable -> its peaks over every physics step; where given, the peaks are these
            (or a sample's, where one reads higher by round-off).

    Raises:
        DesignError: no cable channels, or fewer than two samples.
    """
    cables = [c for c in series.items("tension") if f"rest_length/{c}" in series.channels]
    if not cables or len(series.time) < 2:
        raise DesignError("the trajectory has no tension/ and rest_length/ channels over two "
                          "samples or more; expected a simulation's trajectory.parquet")
    time = series.time
    out = []
    for cable in cables:
        tension = series[f"tension/{cable}"]
        speed = np.gradient(series[f"rest_length/{cable}"], time)
        speed[np.abs(speed) < SPEED_FLOOR] = 0.0  # round-off of a rest length that holds
        power = -tension * speed
        max_speed, max_tension = (limits or {}).get(cable, (np.inf, np.inf))
        peaks = (tracked or {}).get(cable)
        sampled = (float(tension.max()), float(np.abs(speed).max()),
                   float(np.abs(power).max()))
        if peaks is not None:
            sampled = (max(sampled[0], peaks.tension), max(sampled[1], peaks.speed),
                       max(sampled[2], peaks.power))
        out.append(CableDuty(
            cable, sampled[0], float(np.sqrt(np.mean(tension**2))), sampled[1], sampled[2],
            float(power.mean()), float(np.trapezoid(np.maximum(power, 0.0), time)),
            float(time[-1] - time[0]), float(np.mean(np.abs(speed) >= 0.99 * max_speed)),
            float(np.mean(tension >= 0.99 * max_tension)), tension, speed, peaks is not None))
    return out


def merge(duties: Sequence[list[CableDuty]]) -> list[CableDuty]:
    """Per cable, the run with the largest peak tension's duty and the samples of every run."""
    by_cable: dict[str, list[CableDuty]] = {}
    for run in duties:
        for duty in run:
            by_cable.setdefault(duty.cable, []).append(duty)
    out = []
    for runs in by_cable.values():
        worst = max(runs, key=lambda d: d.peak_tension)
        out.append(dataclasses.replace(
            worst, peak_speed=max(d.peak_speed for d in runs),
            peak_power=max(d.peak_power for d in runs),
            tension=np.concatenate([d.tension for d in runs]),
            speed=np.concatenate([d.speed for d in runs]),
            tracked=all(d.tracked for d in runs)))
    return out


@dataclasses.dataclass(frozen=True)
class DriveMotor:
    """A DC motor as its datasheet gives it, at its own shaft (before the gearbox).

    Attributes:
        name: catalogue name.
        stall_torque: torque at zero speed and full voltage [N m].
        no_load_speed: speed at no load and full voltage [rad/s].
    """

    name: str
    stall_torque: float
    no_load_speed: float

    def __post_init__(self) -> None:
        for field in ("stall_torque", "no_load_speed"):
            value = getattr(self, field)
            if not is_real(value) or value <= 0:
                raise DesignError(f"motor {self.name!r}: {field} must be a number > 0, got "
                                  f"{describe(value)}")


def load_catalogue(path: str | os.PathLike[str]) -> list[DriveMotor]:
    """Motors from a YAML file: ``motors: [{name, stall_torque [N m], no_load_speed [rad/s]}]``.

    Raises:
        DesignError: naming the file and the entry that is wrong.
    """
    data = load_yaml_file(Path(path))
    entries = data.get("motors") if isinstance(data, dict) else None
    if not isinstance(entries, list) or not entries:
        raise DesignError(f"{path}: expected a 'motors' list of {{name, stall_torque [N m], "
                          "no_load_speed [rad/s]}")
    motors = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, dict) or set(entry) != {"name", "stall_torque",
                                                         "no_load_speed"}:
            raise DesignError(f"{path}: motors[{i}]: expected exactly name, stall_torque "
                              f"[N m] and no_load_speed [rad/s], got {describe(entry)}")
        try:
            motors.append(DriveMotor(str(entry["name"]), entry["stall_torque"],
                                     entry["no_load_speed"]))
        except DesignError as err:
            raise DesignError(f"{path}: motors[{i}]: {err}") from None
    return motors


@dataclasses.dataclass(frozen=True)
class Requirement:
    """What a cable's motor shaft must deliver, safety factor included.

    Attributes:
        cable: cable name.
        torque: peak shaft torque S T_peak R / N [N m].
        speed: peak shaft speed S u_peak N / R [rad/s].
        power: peak mechanical power S^2 P_peak [W].
    """

    cable: str
    torque: float
    speed: float
    power: float


def requirements(duties: Sequence[CableDuty], spool_radius: float, gear_ratio: float,
                 safety: float = SAFETY_FACTOR) -> list[Requirement]:
    """Each cable's shaft torque, speed and power with the safety factor."""
    _check_drive(spool_radius, gear_ratio, safety)
    return [Requirement(d.cable, safety * d.peak_tension * spool_radius / gear_ratio,
                        safety * d.peak_speed * gear_ratio / spool_radius,
                        safety**2 * d.peak_power) for d in duties]


def margin(duty: CableDuty, motor: DriveMotor, spool_radius: float, gear_ratio: float,
           safety: float = SAFETY_FACTOR) -> float:
    """1 - max_t (tau(t) / tau_s + omega(t) / omega_0): >= 0 where the motor suffices; over
    the samples and, with tracked peaks, over every step (:func:`peak_use`)."""
    _check_drive(spool_radius, gear_ratio, safety)
    per_newton = safety * spool_radius / gear_ratio / motor.stall_torque  # [1/N]
    per_speed = safety * gear_ratio / spool_radius / motor.no_load_speed  # [s/m]
    use = float(np.max(per_newton * np.maximum(duty.tension, 0.0)
                       + per_speed * np.abs(duty.speed)))
    if duty.tracked:
        use = max(use, peak_use(duty.peak_tension, duty.peak_speed, duty.peak_power,
                                per_newton, per_speed))
    return 1.0 - use


def peak_use(tension: float, speed: float, power: float, per_newton: float,
             per_speed: float) -> float:
    """The largest a T + b u over 0 <= T <= ``tension``, 0 <= u <= ``speed``, T u <= ``power``
    (a linear function's maximum over that region lies at one of its two upper corners)."""
    at_peak_tension = min(speed, power / tension) if tension > 0 else speed
    at_peak_speed = min(tension, power / speed) if speed > 0 else tension
    return max(per_newton * tension + per_speed * at_peak_tension,
               per_newton * at_peak_speed + per_speed * speed)


def _check_drive(spool_radius: float, gear_ratio: float, safety: float) -> None:
    for name, value in (("spool radius", spool_radius), ("gear ratio", gear_ratio),
                        ("safety factor", safety)):
        if not is_real(value) or value <= 0:
            raise DesignError(f"{name} must be a number > 0, got {describe(value)}")
