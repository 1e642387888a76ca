"""What a trial is scored on: distance travelled in the ground plane, minus motor work.

The score of a recorded trial is the displacement of a chosen segment's centre of mass (or the
whole robot's, ``"com"``) in the ground plane from ``settle_s`` to the end: its length, or its
component along a direction, or the size of that component either way (sideways to the left
or right), or, with a target point, how much closer to it the segment got (goal-directed
locomotion); optionally minus ``energy_weight`` times the motor work. A trial in which any rigid
body's up axis tilts past ``max_tilt_deg`` has flipped over: it gets the problem's penalty.

With ``rolling`` the distance along the direction counts only as far as the robot rolled it
(:func:`~tensim.sim.motion.rolled_distance`: its net turn about the rolling axis z x
direction, times its centre of mass's mean height above the ground while turning): a robot
that crawls, slides on one face or rocks scores about 0 however far it goes.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tensim.sim import COM, TimeSeries
from tensim.sim.motion import rolled_distance

# named directions in the ground plane: (angle from +x toward +y [deg], either way)
DIRECTIONS: dict[str, tuple[float | None, bool]] = {
    "any": (None, False),
    "forward": (0.0, False),
    "left": (90.0, False),
    "backward": (180.0, False),
    "right": (270.0, False),
    "sideways": (90.0, True),
}


def parse_direction(text: str) -> tuple[float | None, bool]:
    """``(direction_deg, either_way)`` for a name of :data:`DIRECTIONS` or an angle in degrees.

    Raises:
        ValueError: neither a known name nor a number.
    """
    if text in DIRECTIONS:
        return DIRECTIONS[text]
    try:
        angle = float(text)
    except ValueError:
        raise ValueError(f"direction {text!r}: expected one of {list(DIRECTIONS)} or an angle "
                         "in degrees from +x toward +y") from None
    if not math.isfinite(angle):
        raise ValueError(f"direction must be a finite angle in degrees, got {text!r}")
    return angle, False


@dataclasses.dataclass(frozen=True)
class Objective:
    """How a trial is scored (higher is better).

    Attributes:
        segment: rigid body whose centre of mass is tracked, or ``"com"`` for the whole robot.
        direction_deg: direction in the ground plane [deg from +x toward +y]; None scores the
            planar distance whatever its direction.
        either_way: score the size of the component along ``direction_deg`` (e.g. sideways,
            to the left or to the right).
        energy_weight: score penalty per joule of motor work [m/J].
        settle_s: time left for the robot to settle before the displacement counts [s].
        max_tilt_deg: a body whose up axis tilts further than this from vertical has flipped
            [deg]; 180 turns the check off (rolling robots).
        target_xy: a target point (x, y) in the world frame [m]; the score is then the
            progress toward it (:func:`target_progress`) instead of a displacement.
        rolling: score the displacement along ``direction_deg`` only as far as the robot
            rolled it: the smaller of that displacement and the distance rolled toward
            ``direction_deg`` (:func:`~tensim.sim.motion.rolled_distance`), so that a crawl,
            a slide or a rock back and forth scores about 0 (needs a direction, one way).
    """

    segment: str = COM
    direction_deg: float | None = None
    either_way: bool = False
    energy_weight: float = 0.0
    settle_s: float = 0.0
    max_tilt_deg: float = 90.0
    target_xy: tuple[float, float] | None = None
    rolling: bool = False

    def __post_init__(self) -> None:
        if self.target_xy is not None:
            if len(self.target_xy) != 2 or not all(math.isfinite(v) for v in self.target_xy):
                raise ValueError(f"target_xy must be two finite coordinates [m], got "
                                 f"{self.target_xy!r}")
            if self.direction_deg is not None:
                raise ValueError("give a direction or a target point, not both")
        if self.direction_deg is not None and not math.isfinite(self.direction_deg):
            raise ValueError(f"direction_deg must be finite, got {self.direction_deg}")
        if self.either_way and self.direction_deg is None:
            raise ValueError("either_way needs a direction_deg")
        if not (math.isfinite(self.energy_weight) and self.energy_weight >= 0):
            raise ValueError(f"energy_weight must be >= 0 m/J, got {self.energy_weight}")
        if not (math.isfinite(self.settle_s) and self.settle_s >= 0):
            raise ValueError(f"settle_s must be >= 0 s, got {self.settle_s}")
        if not 0 < self.max_tilt_deg <= 180:
            raise ValueError(f"max_tilt_deg must be in (0, 180], got {self.max_tilt_deg}")
        if self.rolling and (self.direction_deg is None or self.either_way):
            raise ValueError("rolling scores the distance rolled toward a direction: give "
                             "one direction (an angle, or forward/left/backward/right)")

    def describe(self) -> str:
        """One line, e.g. ``displacement of com along 90 deg, either way``."""
        what = f"displacement of {self.segment}"
        if self.target_xy is not None:
            text = (f"progress of {self.segment} toward ({self.target_xy[0]:g}, "
                    f"{self.target_xy[1]:g}) m")
        elif self.direction_deg is None:
            text = f"planar {what}"
        else:
            text = f"{what} along {self.direction_deg:g} deg" + (
                ", either way" if self.either_way else "")
        if self.rolling:
            text += ", counted as far as rolled"
        if self.energy_weight:
            text += f" minus {self.energy_weight:g} m/J x motor work"
        return text

    def score(self, trajectory: TimeSeries, bodies: tuple[str, ...],
              points: np.ndarray | None = None, radii: np.ndarray | float = 0.0
              ) -> tuple[float, dict[str, float], str | None]:
        """The trial's score, its parts, and why it is void (flipped over) or None.

        Args:
            trajectory: the recorded trial (pose and cable channels).
            bodies: the rigid bodies checked for flipping over.
            points: (T, p, 3) the recorded paths of the robot's rod ends [m] (needed with
                ``rolling``).
            radii: () or (p,) each point's contact radius [m] (a rod's radius at its end).

        Returns:
            (score, metrics, reason): metrics ``dx_m``, ``dy_m`` (displacement [m]),
            ``distance_m`` (the scored distance [m]), ``work_J`` (motor work [J]),
            ``max_tilt_deg``, with a target ``target_distance_m`` (at the end [m]), with
            ``rolling`` ``along_m`` (the displacement along the direction [m]),
            ``rolled_m`` and ``roll_rad`` (:func:`~tensim.sim.motion.rolled_distance`).

        Raises:
            ValueError: ``rolling`` without ``points``.
        """
        start = int(np.searchsorted(trajectory.time, self.settle_s - 1e-9))
        if start >= trajectory.time.size - 1:
            raise ValueError(f"settle_s = {self.settle_s} s leaves no time to score in a "
                             f"{trajectory.time[-1]:g} s trial")
        dx, dy = planar_displacement(trajectory, self.segment, start)
        work = motor_work(trajectory, start)
        tilt, body, when = max_tilt(trajectory, bodies)
        metrics = {"dx_m": dx, "dy_m": dy}
        if self.rolling:
            if points is None:
                raise ValueError("a rolling score needs the rod ends' recorded paths")
            along = self.distance(dx, dy)
            rolled, turn = rolled_distance(points[start:], trajectory[f"pos_z/{COM}"][start:],
                                           self._unit(), radii)
            metrics.update(along_m=along, rolled_m=rolled, roll_rad=turn)
            distance = min(along, rolled)
        elif self.target_xy is None:
            distance = self.distance(dx, dy)
        else:
            distance = target_progress(trajectory, self.target_xy, self.segment, start)
            metrics["target_distance_m"] = float(
                target_distance(trajectory, self.target_xy, self.segment)[-1])
        metrics.update({"distance_m": distance, "work_J": work, "max_tilt_deg": tilt})
        reason = None
        if tilt > self.max_tilt_deg:
            reason = (f"flipped over: {body!r} tilted {tilt:.0f} deg from upright at "
                      f"t = {when:.2f} s (limit {self.max_tilt_deg:g} deg)")
        return distance - self.energy_weight * work, metrics, reason

    def distance(self, dx: float, dy: float) -> float:
        """The scored distance for a planar displacement (dx, dy) [m]."""
        if self.direction_deg is None:
            return math.hypot(dx, dy)
        unit = self._unit()
        along = float(dx * unit[0] + dy * unit[1])
        return abs(along) if self.either_way else along

    def _unit(self) -> np.ndarray:
        """(2,) the direction's unit vector."""
        assert self.direction_deg is not None
        angle = math.radians(self.direction_deg)
        # rounded so that the axes are exact (cos 90 deg = 0, not 6e-17)
        return np.array([round(math.cos(angle), 15), round(math.sin(angle), 15)])


def planar_displacement(trajectory: TimeSeries, item: str, start: int = 0
                        ) -> tuple[float, float]:
    """(dx, dy) of ``item``'s centre of mass from sample ``start`` to the last one [m]."""
    x, y = trajectory[f"pos_x/{item}"], trajectory[f"pos_y/{item}"]
    return float(x[-1] - x[start]), float(y[-1] - y[start])


def target_distance(trajectory: TimeSeries, target_xy: tuple[float, float], item: str = COM
                    ) -> np.ndarray:
    """(T,) horizontal distance from ``item``'s centre of mass to a target point [m]."""
    x, y = trajectory[f"pos_x/{item}"], trajectory[f"pos_y/{item}"]
    return np.hypot(x - target_xy[0], y - target_xy[1])


def target_progress(trajectory: TimeSeries, target_xy: tuple[float, float], item: str = COM,
                    start: int = 0) -> float:
    """How much closer ``item``'s centre of mass got to a target point [m].

    The reduction of the horizontal (x-y) distance to ``target_xy`` from sample ``start`` to
    the last one: positive when it approached, negative when it moved away, 0 for a robot that
    stayed put or circled at a constant distance.
    """
    distance = target_distance(trajectory, target_xy, item)
    return float(distance[start] - distance[-1])


def motor_work(trajectory: TimeSeries, start: int = 0) -> float:
    """Work the motors do on the cables from sample ``start`` on [J].

    Sum over cables and samples of tension × |change of rest length| (trapezoidal tension): a
    motor spends energy both reeling in against the tension and paying out under it.
    """
    tension = trajectory.matrix("tension")[start:]
    rest = trajectory.matrix("rest_length")[start:]
    if tension.shape[0] < 2 or tension.shape[1] == 0:
        return 0.0
    mean_tension = 0.5 * (tension[1:] + tension[:-1])
    return float(np.sum(mean_tension * np.abs(np.diff(rest, axis=0))))


def max_tilt(trajectory: TimeSeries, bodies: tuple[str, ...]) -> tuple[float, str, float]:
    """The largest tilt of any body's up axis from vertical: (angle [deg], body, time [s]).

    Body frames start aligned with the world, so a body's up axis is its frame's z axis; its
    world z component is 1 − 2(q_x² + q_y²) for the unit quaternion (w, x, y, z).
    """
    if not bodies:
        return 0.0, "-", 0.0
    qx, qy = trajectory.matrix("quat_x", bodies), trajectory.matrix("quat_y", bodies)
    up_z = np.clip(1.0 - 2.0 * (qx**2 + qy**2), -1.0, 1.0)
    k, b = np.unravel_index(int(np.argmin(up_z)), up_z.shape)
    return math.degrees(math.acos(up_z[k, b])), bodies[b], float(trajectory.time[k])
