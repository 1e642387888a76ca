"""The named model parameters that system identification fits, and what each one changes.

Physical parameters change the structure description (then it is recompiled and simulated
again): robot-ground friction, cable stiffness and damping, motor speed limit, the DC motors'
stall torque, no-load speed, rotor inertia and friction, point masses, and the scale of the V*
input; world parameters (torsional and rolling friction) change the ``WorldOptions`` instead.
Measurement parameters (sensor offset, gain, delay) act on the simulated signals only, as in
MuJoCo's ``mujoco.sysid`` toolbox. Cable-wide parameters take the mean over the cables as their
value and scale every cable by the same factor, so cables that differ keep their ratios.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Literal

import numpy as np

from tensim.control import Bounds, Parameter, ParameterVector
from tensim.hardware.sensor import SensorModel
from tensim.model import WorldOptions
from tensim.structure import Cable, DCMotor, Structure

PHYSICAL, MEASUREMENT = "physical", "measurement"


@dataclasses.dataclass(frozen=True)
class Definition:
    """What one named parameter means.

    Attributes:
        name: its name on the command line.
        kind: ``physical`` (re-simulate) or ``measurement`` (signals only).
        unit: its unit.
        description: one line.
        nominal: its value in a structure (or the default for signals).
        span: default (low, high) bounds around a nominal value.
        apply: the structure with this value (physical parameters that change the structure).
        world_field: the ``WorldOptions`` field this parameter sets (world parameters: their
            nominal value is the world's, not the structure's).
    """

    name: str
    kind: str
    unit: str
    description: str
    nominal: Callable[[Structure], float]
    span: Callable[[float], tuple[float, float]]
    apply: Callable[[Structure, float], Structure] | None = None
    world_field: Literal["torsional_friction", "rolling_friction"] | None = None

    def nominal_in(self, structure: Structure, world: WorldOptions | None) -> float:
        """The nominal value: the world's for world parameters, else the structure's."""
        if self.world_field is not None:
            return float(getattr(world or WorldOptions(), self.world_field))
        return self.nominal(structure)


def _mean(values: Sequence[float]) -> float:
    if not values:
        raise ValueError("the structure has none of the items this parameter changes")
    return float(np.mean(values))


# how each scaled cable or DC motor field is set: by keyword, so that each one is type-checked
_CABLE_FIELDS: dict[str, Callable[[Cable, float], Cable]] = {
    "stiffness": lambda c, v: dataclasses.replace(c, stiffness=v),
    "damping": lambda c, v: dataclasses.replace(c, damping=v),
}
_DC_FIELDS: dict[str, Callable[[DCMotor, float], DCMotor]] = {
    "stall_torque": lambda d, v: dataclasses.replace(d, stall_torque=v),
    "no_load_speed": lambda d, v: dataclasses.replace(d, no_load_speed=v),
    "rotor_inertia": lambda d, v: dataclasses.replace(d, rotor_inertia=v),
    "coulomb_friction": lambda d, v: dataclasses.replace(d, coulomb_friction=v),
    "viscous_friction": lambda d, v: dataclasses.replace(d, viscous_friction=v),
}


def _cable_scale(field: str) -> Callable[[Structure, float], Structure]:
    def apply(structure: Structure, value: float) -> Structure:
        factor = value / _mean([getattr(c, field) for c in structure.cables])
        return dataclasses.replace(structure, cables=tuple(
            _CABLE_FIELDS[field](c, float(getattr(c, field) * factor))
            for c in structure.cables))
    return apply


def _friction(structure: Structure, value: float) -> Structure:
    return dataclasses.replace(structure, rods=tuple(
        dataclasses.replace(r, friction=float(value)) for r in structure.rods))


def _max_speed(structure: Structure, value: float) -> Structure:
    factor = value / _mean([c.motor.max_speed for c in structure.cables])
    return dataclasses.replace(structure, cables=tuple(
        dataclasses.replace(c, motor=dataclasses.replace(
            c.motor, max_speed=float(c.motor.max_speed * factor))) for c in structure.cables))


def _dc_motors(structure: Structure, field: str) -> list[float]:
    values = [getattr(c.motor.dc, field) for c in structure.cables if c.motor.dc is not None]
    if not values:
        raise ValueError(f"{field} is a DC motor's parameter, and no cable of "
                         f"{structure.name!r} has a DC motor (motor: dc: ...)")
    return values


def _dc_scale(field: str) -> Callable[[Structure, float], Structure]:
    """Sets the DC motors' mean ``field`` to the value, scaling every DC motor alike."""
    def apply(structure: Structure, value: float) -> Structure:
        mean = _mean(_dc_motors(structure, field))
        factor = value / mean if mean > 0 else 1.0

        def motor(c: Cable) -> Cable:
            dc = c.motor.dc
            if dc is None:
                return c
            new = float(getattr(dc, field) * factor) if mean > 0 else float(value)
            return dataclasses.replace(c, motor=dataclasses.replace(
                c.motor, dc=_DC_FIELDS[field](dc, new)))
        return dataclasses.replace(structure, cables=tuple(motor(c) for c in structure.cables))
    return apply


def _dc_definition(field: str, unit: str, description: str,
                   zero_span: tuple[float, float]) -> Definition:
    return Definition(field, PHYSICAL, unit, description,
                      lambda s: _mean(_dc_motors(s, field)),
                      lambda n: (0.2 * n, 5.0 * n) if n > 0 else zero_span, _dc_scale(field))


def _mass_scale(structure: Structure, value: float) -> Structure:
    return dataclasses.replace(structure, point_masses=tuple(
        dataclasses.replace(p, mass=float(p.mass * value)) for p in structure.point_masses))


DEFINITIONS: dict[str, Definition] = {d.name: d for d in (
    Definition("friction", PHYSICAL, "-", "robot-ground Coulomb friction of every rod",
               lambda s: _mean([r.friction for r in s.rods]),
               lambda n: (0.25 * n, 4.0 * n) if n > 0 else (0.0, 1.0), _friction),
    Definition("stiffness", PHYSICAL, "N/m", "effective cable stiffness (mean; all scaled)",
               lambda s: _mean([c.stiffness for c in s.cables]),
               lambda n: (0.5 * n, 2.0 * n), _cable_scale("stiffness")),
    Definition("damping", PHYSICAL, "N s/m", "cable damping (mean; all scaled)",
               lambda s: _mean([c.damping for c in s.cables]),
               lambda n: (0.2 * n, 5.0 * n) if n > 0 else (0.0, 50.0), _cable_scale("damping")),
    Definition("max_speed", PHYSICAL, "m/s", "motor speed limit (mean; all scaled)",
               lambda s: _mean([c.motor.max_speed for c in s.cables]),
               lambda n: (0.3 * n, 3.0 * n), _max_speed),
    _dc_definition("stall_torque", "N m", "DC motors' stall torque at the spool (mean; all "
                   "scaled)", (0.0, 1.0)),
    _dc_definition("no_load_speed", "rad/s", "DC motors' no-load speed at the spool (mean; all "
                   "scaled)", (0.0, 1.0)),
    _dc_definition("rotor_inertia", "kg m^2", "DC motors' inertia at the spool (mean; all "
                   "scaled)", (0.0, 1e-3)),
    _dc_definition("coulomb_friction", "N m", "DC motors' Coulomb friction at the spool (mean; "
                   "all scaled)", (0.0, 0.05)),
    _dc_definition("viscous_friction", "N m s/rad", "DC motors' viscous friction at the spool "
                   "(mean; all scaled)", (0.0, 0.01)),
    Definition("torsional_friction", PHYSICAL, "m", "robot-ground torsional friction "
               "(WorldOptions; acts with condim 4 or 6)", lambda s: math.nan,
               lambda n: (0.0, 4.0 * n) if n > 0 else (0.0, 0.05),
               world_field="torsional_friction"),
    Definition("rolling_friction", PHYSICAL, "m", "robot-ground rolling friction "
               "(WorldOptions; acts with condim 6)", lambda s: math.nan,
               lambda n: (0.0, 4.0 * n) if n > 0 else (0.0, 0.01),
               world_field="rolling_friction"),
    Definition("mass_scale", PHYSICAL, "-", "factor on every point mass",
               lambda s: 1.0, lambda n: (0.5, 1.5), _mass_scale),
    Definition("vstar_scale", PHYSICAL, "-", "factor on the logged V* input (sim = scale x log)",
               lambda s: 1.0, lambda n: (0.05, 20.0)),
    Definition("offset", MEASUREMENT, "N", "load-cell zero offset added to every reading",
               lambda s: 0.0, lambda n: (-5.0, 5.0)),
    Definition("gain", MEASUREMENT, "-", "load-cell gain on the true tension",
               lambda s: 1.0, lambda n: (0.8, 1.25)),
    Definition("delay", MEASUREMENT, "s", "readings lag the commands by this much",
               lambda s: 0.0, lambda n: (-0.1, 0.3)),
)}


def definition(name: str) -> Definition:
    """The definition of ``name``.

    Raises:
        KeyError: naming the known parameters.
    """
    try:
        return DEFINITIONS[name]
    except KeyError:
        raise KeyError(f"unknown parameter {name!r}; expected one of "
                       f"{', '.join(DEFINITIONS)}") from None


def apply_physical(structure: Structure, values: Mapping[str, float]) -> Structure:
    """``structure`` with the named physical parameters set (others are ignored)."""
    for name, value in values.items():
        d = definition(name)
        if d.apply is not None:
            structure = d.apply(structure, float(value))
    return structure


def apply_world(world: WorldOptions | None, values: Mapping[str, float]) -> WorldOptions:
    """``world`` (default: WorldOptions()) with the named world parameters set (others are
    ignored)."""
    fields = {d.world_field: float(v) for d, v in
              ((definition(n), v) for n, v in values.items()) if d.world_field is not None}
    world = world or WorldOptions()
    return dataclasses.replace(
        world, torsional_friction=fields.get("torsional_friction", world.torsional_friction),
        rolling_friction=fields.get("rolling_friction", world.rolling_friction))


def check_world(names: Sequence[str], world: WorldOptions | None) -> None:
    """Refuses world friction parameters that the world's contact model ignores.

    Raises:
        ValueError: torsional friction with condim 3, rolling friction with condim < 6.
    """
    condim = (world or WorldOptions()).condim
    needs = {"torsional_friction": 4, "rolling_friction": 6}
    for name in names:
        if name in needs and condim < needs[name]:
            raise ValueError(f"{name} acts only on contacts with condim >= {needs[name]}, and "
                             f"the world has condim {condim} (WorldOptions.condim); fitting it "
                             "would be ill-posed")


def apply_measurement(sensor: SensorModel, values: Mapping[str, float]) -> SensorModel:
    """``sensor`` with the named measurement parameters set (others are ignored)."""
    fields = {n: float(v) for n, v in values.items() if definition(n).kind == MEASUREMENT}
    return dataclasses.replace(sensor, offset=fields.get("offset", sensor.offset),
                               gain=fields.get("gain", sensor.gain),
                               delay=fields.get("delay", sensor.delay))


@dataclasses.dataclass(frozen=True)
class SysidSpace(ParameterVector):
    """The fitted parameters: names, bounds and starting values (each entry's ``nominal``),
    and the unit-cube map.

    Attributes:
        structure: the nominal structure (the structure's own values come from it).
        entries: the parameters, in vector order (see :meth:`build`).
    """

    structure: Structure
    entries: tuple[Parameter, ...]
    world: WorldOptions | None = None

    @classmethod
    def build(cls, structure: Structure, names: Sequence[str], *,
              bounds: Mapping[str, tuple[float, float]] | None = None,
              start: Mapping[str, float] | None = None,
              world: WorldOptions | None = None) -> SysidSpace:
        """The space of ``names`` with default or given bounds and starting values.

        Raises:
            KeyError: an unknown name.
            ValueError: duplicate names, or a start outside its bounds.
        """
        bounds, start = dict(bounds or {}), dict(start or {})
        if len(set(names)) != len(names) or not names:
            raise ValueError(f"expected one or more distinct parameter names, got {list(names)}")
        for extra in sorted((set(bounds) | set(start)) - set(names)):
            raise ValueError(f"bounds or start given for {extra!r}, which is not fitted "
                             f"(fitted: {list(names)})")
        entries = []
        for name in names:
            d = definition(name)
            nominal = d.nominal_in(structure, world)
            value = start.get(name, nominal)
            low, high = bounds.get(name, d.span(nominal))
            try:
                entries.append(Parameter(name, Bounds(float(low), float(high), float(value))))
            except ValueError as err:
                raise ValueError(f"parameter {name!r}: {err}") from None
        return cls(structure, tuple(entries), world)

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """The entries, in vector order."""
        return self.entries

    @property
    def start(self) -> np.ndarray:
        """(n,) starting values."""
        return self.nominal

    def structure_values(self) -> np.ndarray:
        """(n,) the values in the nominal structure (measurement defaults: no offset etc.)."""
        return np.array([definition(n).nominal_in(self.structure, self.world)
                         for n in self.names])

    @property
    def physical(self) -> np.ndarray:
        """(n,) True for the entries that need a new simulation."""
        return np.array([definition(n).kind == PHYSICAL for n in self.names])

    def from_unit(self, unit: Sequence[float] | np.ndarray) -> np.ndarray:
        """[0, 1] -> values in the bounds; a point a rounding error outside is clipped."""
        return super().from_unit(np.clip(self.vector(unit, "unit"), 0.0, 1.0))

    def snap(self, values: np.ndarray, resolution: float = 1e-4) -> np.ndarray:
        """``values`` with the physical entries rounded to ``resolution`` of their range.

        Contacts make a simulation's tensions change irregularly under tiny parameter changes;
        on this grid an optimizer's sub-resolution steps reuse one simulation.
        """
        unit = self.to_unit(values)
        snapped = np.where(self.physical, np.round(unit / resolution) * resolution, unit)
        return self.low + snapped * (self.high - self.low)

    def physical_key(self, values: np.ndarray) -> tuple[float, ...]:
        """The physical entries, rounded: equal keys give the same simulation."""
        return tuple(round(float(v), 12) for v in np.asarray(values)[self.physical])


def parse_assignments(text: str | None, what: str) -> dict[str, float]:
    """``"friction=0.1,stiffness=250"`` -> {"friction": 0.1, "stiffness": 250.0}.

    Raises:
        KeyError: an unknown parameter name.
        ValueError: naming the bad entry of ``what`` (e.g. ``--set``).
    """
    out: dict[str, float] = {}
    for entry in _entries(text):
        name, _, value = (part.strip() for part in entry.partition("="))
        definition(name)
        out[name] = _float(value, f"{what}: expected NAME=NUMBER, got {entry!r}")
    return out


def parse_bounds(text: str | None) -> dict[str, tuple[float, float]]:
    """``"friction=0.01:0.5"`` -> {"friction": (0.01, 0.5)}.

    Raises:
        KeyError: an unknown parameter name.
        ValueError: naming the bad entry of ``--bounds``.
    """
    out: dict[str, tuple[float, float]] = {}
    for entry in _entries(text):
        name, _, span = (part.strip() for part in entry.partition("="))
        definition(name)
        low, _, high = span.partition(":")
        message = f"--bounds: expected NAME=LOW:HIGH, got {entry!r}"
        out[name] = (_float(low, message), _float(high, message))
    return out


def _entries(text: str | None) -> list[str]:
    return [e.strip() for e in (text or "").split(",") if e.strip()]


def _float(text: str, message: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ValueError(message) from None
    if not math.isfinite(value):
        raise ValueError(f"{message} (a finite number)")
    return value
