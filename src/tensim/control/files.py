"""Controller files: impedance laws and a gait as a documented YAML (or JSON) file.

A controller file holds everything needed to drive a robot's cables: the impedance law of
each cable (paper eq. 3: T0, K, B, L*) and optionally a gait on the laws' target velocity V*
(a spine CPG, sine waves, or a sampled V* table); and/or commanded rest lengths, toward which
the motors wind their cables at max_speed (:class:`~tensim.control.rest.RestCommand`; what
``tensim design pull`` writes). SI units throughout: tensions N, lengths m,
K N/m, B N·s/m, V* m/s, frequencies Hz, phases rad, times s. The layout::

    format: tensim-controller
    version: 1
    model: tetraspine3            # the preset it was made for (used when no robot is given)
    description: free text
    impedance:
      groups:                     # optional: fields shared by every motorised cable with a tag
        - {tag: top, stiffness_gain: 500, damping_gain: 150}
      cables:                     # per cable; overrides its groups; all four fields in the end
        inner_top_1: {offset_tension: 28, target_length: 0.19}
      passive: [outer]            # optional: cables (names or tags) left without gains on
                                  # purpose; any other motorised cable without gains is an
                                  # error (cables without a motor never get gains)
    rest_lengths:                 # optional: commanded rest lengths [m] of motorised cables
      vertical_0: 0.3808          # without impedance gains; with it 'impedance' is optional,
                                  # and every motorised cable needs gains, a rest length or
                                  # 'impedance.passive'
    rest_speed: 0.01              # optional, with rest_lengths: the motors wind at this line
                                  # speed [m/s] (at most their max_speed; omit: max_speed)
    gait:                         # optional
      type: cpg                   # cpg | sine | table
      duration: 60                # s of gait
      command_period: 0.01        # s between V* commands (omit: every physics step)
      # cpg: the spine layout of tensim.control.spine and one value per parameter
      convergence: 20
      bounds: {weight: [0, 100, 20], phase: [-3.14159, 3.14159, 0], amplitude: [...], ...}
      initial_phase: null         # rad per oscillator, or null for all 0
      initial_amplitude: 0        # m/s
      parameters: {amplitude: 0.02, frequency: 0.5, weight/0/outer_top|outer_left: 20, ...}
      # sine: per cable, or a pattern
      cables: {outer_top_1: {amplitude: 0.005, frequency: 0.5, phase: 0, offset: 0}, ...}
      pattern: {name: tetraspine, amplitude: 0.005, frequency: 0.5, phase: 0, offset: 0,
                joint_lag: 3.14159}
      # table: a velocity-input text file (see tensim.control.velocity_table), relative paths
      # are relative to the controller file
      file: trajectory.txt

Errors name the file, the field (e.g. ``impedance.cables.inner_top_1.stiffness_gain``) and what
was expected. :func:`save_controller` writes the fully expanded form (per-cable gains), so
``load_controller(save_controller(c))`` gives back ``c``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from tensim._files import write_text
from tensim._input import InputError, describe, load_json, load_yaml, read_text
from tensim.control.impedance import ImpedanceController, ImpedanceGains
from tensim.control.parameters import Bounds
from tensim.control.rest import RestCommand
from tensim.control.sine import SineGait, tetraspine_sine
from tensim.control.spine import (
    DEFAULT_AMPLITUDE,
    DEFAULT_FREQUENCY,
    DEFAULT_PHASE,
    DEFAULT_WEIGHT,
    CPGParameters,
    SpineCPG,
    spine_parameters,
)
from tensim.control.velocity_table import (
    TableController,
    VelocityFileError,
    VelocityTable,
    load_velocity_table,
    save_velocity_table,
)
from tensim.limits import MAX_SAMPLES, check_count
from tensim.sim import CableSetup, Controller
from tensim.structure import Structure

FORMAT = "tensim-controller"
VERSION = 1
Gait = SineGait | SpineCPG | VelocityTable
_GAIN_FIELDS = tuple(f.name for f in dataclasses.fields(ImpedanceGains))
_SINE_FIELDS = ("amplitude", "frequency", "phase", "offset")
_BOUND_NAMES = ("weight", "phase", "amplitude", "frequency")


class ControllerFileError(InputError):
    """A controller file is invalid; the message names the file, the field and the fix."""

    def __init__(self, message: str, *, field: str | None = None, source: str | None = None):
        self.detail, self.field, self.source = message, field, source
        where = ": ".join(p for p in (source, field) if p)
        super().__init__(f"{where}: {message}" if where else message)

    def with_source(self, source: str) -> ControllerFileError:
        """A copy that also names the file."""
        return ControllerFileError(self.detail, field=self.field, source=source)


@dataclasses.dataclass(frozen=True)
class ControllerConfig:
    """Impedance laws plus an optional gait and rest-length commands: a controller file.

    Attributes:
        impedance: the per-cable impedance laws.
        gait: the V* generator (None: V* = the impedance controller's constant, 0).
        duration: time the gait covers [s]; simulate at most this long.
        command_period: time between V* commands [s] (the robot's packets come every
            0.01 s); None samples V* at every physics step.
        model: the preset the file was made for, if any.
        description: free text.
        passive: cable names or tags the file leaves without impedance gains on purpose
            (``impedance.passive``); every other cable must have gains or a rest command.
        rest: commanded rest lengths of cables without impedance gains (``rest_lengths``).
    """

    impedance: ImpedanceController
    gait: Gait | None = None
    duration: float = 60.0
    command_period: float | None = None
    model: str | None = None
    description: str = ""
    passive: tuple[str, ...] = ()
    rest: RestCommand | None = None

    def __post_init__(self) -> None:
        if self.rest is not None:
            both = [c for c in self.rest.cables if c in self.impedance.gains]
            if both:
                raise ValueError(f"cables {both} have both impedance gains and a commanded "
                                 "rest length; give each one or the other")
        if not (math.isfinite(self.duration) and self.duration > 0):
            raise ValueError(f"duration must be a finite time > 0 s, got {self.duration}")
        if self.command_period is not None and not (
                math.isfinite(self.command_period) and self.command_period > 0):
            raise ValueError(f"command_period must be > 0 s or None, got {self.command_period}")
        if self.gait is not None:
            missing = [c for c in self.gait.cables if c not in self.impedance.gains]
            if missing:
                raise ValueError(f"gait cables {missing} have no impedance gains, so their V* "
                                 "would have no effect")


    def velocity_table(self, dt: float) -> VelocityTable | None:
        """The gait's V* commands for a physics step ``dt`` [s] (None without a gait).

        Raises:
            GaitError: a CPG integration failed or ran away.
        """
        if self.gait is None:
            return None
        return sampled_table(self.gait, self.duration, self.command_period or dt)

    def build(self, dt: float) -> Controller:
        """The controller to pass to :class:`~tensim.sim.Simulation` at physics step ``dt``."""
        table = self.velocity_table(dt)
        laws = self.impedance if table is None else TableController(table, self.impedance)
        return laws if self.rest is None else _Both(self.rest, laws)

    def with_gait(self, gait: Gait | None) -> ControllerConfig:
        """A copy with another gait (a table also sets the duration to its length)."""
        duration = gait.duration if isinstance(gait, VelocityTable) and gait.duration > 0 \
            else self.duration
        return dataclasses.replace(self, gait=gait, duration=duration)

    def with_duration(self, duration: float) -> ControllerConfig:
        """A copy whose gait covers ``duration`` seconds."""
        return dataclasses.replace(self, duration=duration)


@dataclasses.dataclass(frozen=True)
class _Both:
    """Rest-length commands for some cables and the impedance laws of the others."""

    rest: RestCommand
    laws: Controller

    def configure(self, sim: CableSetup) -> None:
        """Sets both up (they drive disjoint cables)."""
        self.rest.configure(sim)
        self.laws.configure(sim)


def check_table_columns(table: VelocityTable, impedance: ImpedanceController) -> None:
    """Refuses a V* table file that leaves out a cable the impedance laws drive (its V* would
    silently be 0).

    Raises:
        ValueError: naming the cables without a column.
    """
    absent = [c for c in impedance.gains if c not in table.cables]
    if absent:
        raise ValueError(f"the V* table has no column for {absent}, which have impedance "
                         "gains; give every driven cable a column (0 for a constant target "
                         "length)")


def sampled_table(gait: Gait, duration: float, period: float) -> VelocityTable:
    """``gait``'s V* table over ``duration`` [s] every ``period`` [s].

    Raises:
        InputError: more than :data:`tensim.limits.MAX_SAMPLES` rows.
        GaitError: a CPG integration failed or ran away.
    """
    check_count(f"a V* table of {duration:g} s every {period:g} s: rows",
                duration / period + 1, MAX_SAMPLES, forceable=False)
    return gait.velocity_table(duration, period)


# -- reading ------------------------------------------------------------------------------------


def _mapping(raw: Any, field: str, expected: str) -> dict[str, Any]:
    if not isinstance(raw, dict):
        raise ControllerFileError(f"expected a mapping of {expected}, got {describe(raw)}",
                                  field=field)
    return raw


def _number(raw: Any, field: str, *, positive: bool = False) -> float:
    if isinstance(raw, bool) or not isinstance(raw, int | float) or not math.isfinite(raw):
        raise ControllerFileError(f"expected a finite number, got {describe(raw)}", field=field)
    if positive and raw <= 0:
        raise ControllerFileError(f"expected a number > 0, got {describe(raw)}", field=field)
    return float(raw)


def _only(raw: dict[str, Any], allowed: tuple[str, ...], field: str) -> None:
    unknown = sorted(set(raw) - set(allowed))
    if unknown:
        raise ControllerFileError(f"unknown field {unknown[0]!r}; expected one of "
                                  f"{list(allowed)}", field=field)


def _passive(raw: dict[str, Any], structure: Structure, field: str) -> tuple[str, ...]:
    """The names and tags of ``impedance.passive``, each matching some cable."""
    passive = raw.get("passive") or []
    if not (isinstance(passive, list) and all(isinstance(p, str) for p in passive)):
        raise ControllerFileError(f"expected a list of cable names or tags, got "
                                  f"{describe(passive)}", field=f"{field}.passive")
    for entry in passive:
        if not any(entry == c.name or entry in c.tags for c in structure.cables):
            raise ControllerFileError(f"no cable of {structure.name!r} has the name or tag "
                                      f"{entry!r}", field=f"{field}.passive")
    return tuple(passive)


def _gains(raw: dict[str, Any], structure: Structure, field: str,
           commanded: frozenset[str] = frozenset()
           ) -> tuple[ImpedanceController, tuple[str, ...]]:
    _only(raw, ("groups", "cables", "target_velocity", "passive"), field)
    passive = _passive(raw, structure, field)
    partial: dict[str, dict[str, float]] = {}
    groups = raw.get("groups") or []
    if not isinstance(groups, list):
        raise ControllerFileError("expected a list of {tag: ..., <gain fields>}",
                                  field=f"{field}.groups")
    for k, group in enumerate(groups):
        where = f"{field}.groups[{k}]"
        group = _mapping(group, where, f"'tag' and gain fields {list(_GAIN_FIELDS)}")
        _only(group, ("tag", *_GAIN_FIELDS), where)
        tag = group.get("tag")
        if not isinstance(tag, str):
            raise ControllerFileError(f"expected a tag name, got {describe(tag)}",
                                      field=f"{where}.tag")
        members = [c.name for c in structure.cables if tag in c.tags and not c.motor.passive]
        if not members:
            raise ControllerFileError(f"no cable of {structure.name!r} has the tag {tag!r}",
                                      field=f"{where}.tag")
        for name in members:
            partial.setdefault(name, {}).update(
                {k2: _number(v, f"{where}.{k2}") for k2, v in group.items() if k2 != "tag"})
    cables = _mapping(raw.get("cables") or {}, f"{field}.cables", "cable name -> gains")
    known = {c.name for c in structure.cables}
    for name, fields in cables.items():
        where = f"{field}.cables.{name}"
        _check_motorised(structure, known, name, where, "no controller can drive it",
                         "drop its gains")
        fields = _mapping(fields, where, f"gain fields {list(_GAIN_FIELDS)}")
        _only(fields, _GAIN_FIELDS, where)
        partial.setdefault(name, {}).update(
            {k2: _number(v, f"{where}.{k2}") for k2, v in fields.items()})
    gains = {}
    for cable in structure.cables:  # structure order
        if cable.name not in partial:
            continue
        fields = partial[cable.name]
        missing = [f for f in _GAIN_FIELDS if f not in fields]
        if missing:
            raise ControllerFileError(f"cable {cable.name!r} lacks {missing} after its groups "
                                      "are applied", field=f"{field}.cables.{cable.name}")
        try:
            gains[cable.name] = ImpedanceGains(**fields)
        except ValueError as err:
            raise ControllerFileError(str(err), field=f"{field}.cables.{cable.name}") from None
    both = [name for name in gains if name in commanded]
    if both:
        raise ControllerFileError(f"cable {both[0]!r} also has impedance gains (in "
                                  f"'{field}'); give each cable gains or a rest length, not both",
                                  field=f"rest_lengths.{both[0]}")
    missing = [c.name for c in structure.cables if c.name not in gains and not c.motor.passive
               and c.name not in commanded
               and not any(p == c.name or p in c.tags for p in passive)]
    if missing:
        raise ControllerFileError(
            f"{len(missing)} of the {len(structure.cables)} cables of {structure.name!r} get "
            f"no impedance gains: {missing}; give every cable its four gains {list(_GAIN_FIELDS)} "
            "(through 'groups' or 'cables') or a commanded rest length ('rest_lengths'), or list "
            f"the cables left passive on purpose in '{field}.passive'", field=field)
    if not gains and not commanded:
        raise ControllerFileError("no cable gets impedance gains", field=field)
    velocity = _number(raw.get("target_velocity", 0.0), f"{field}.target_velocity")
    return ImpedanceController(gains, velocity), passive


def _check_motorised(structure: Structure, known: set[str], name: str, where: str,
                     why: str, instead: str) -> None:
    """Refuses a cable the structure lacks, or one without a motor (``why``, ``instead``)."""
    if name not in known:
        raise ControllerFileError(f"{structure.name!r} has no cable {name!r}", field=where)
    if structure.cable(name).motor.passive:
        raise ControllerFileError(f"cable {name!r} has no motor in {structure.name!r}, so "
                                  f"{why}; give it a 'motor' in the structure file (or its "
                                  f"'defaults'), or {instead}", field=where)


def _rest(raw: Any, structure: Structure, field: str) -> RestCommand:
    """The ``rest_lengths`` section: motorised cable -> commanded rest length [m]."""
    raw = _mapping(raw, field, "cable name -> commanded rest length [m]")
    if not raw:
        raise ControllerFileError("expected at least one cable name -> rest length [m] (or "
                                  "leave the section out)", field=field)
    known = {c.name for c in structure.cables}
    for name in raw:
        where = f"{field}.{name}"
        _check_motorised(structure, known, name, where,
                         "no motor can wind it to a rest length", "drop it here")
    lengths = {name: _number(value, f"{field}.{name}", positive=True)
               for name, value in raw.items()}
    order = [c.name for c in structure.cables if c.name in lengths]  # structure order
    return RestCommand(tuple(order), tuple(lengths[n] for n in order))


def _bounds(raw: Any, field: str) -> dict[str, Bounds]:
    raw = _mapping(raw or {}, field, f"{list(_BOUND_NAMES)} -> [low, high, nominal]")
    _only(raw, _BOUND_NAMES, field)
    out = {}
    for name, value in raw.items():
        if not (isinstance(value, list) and len(value) == 3):
            raise ControllerFileError("expected [low, high, nominal]", field=f"{field}.{name}")
        try:
            out[name] = Bounds(*(_number(v, f"{field}.{name}") for v in value))
        except ValueError as err:
            raise ControllerFileError(str(err), field=f"{field}.{name}") from None
    return out


def _cpg(raw: dict[str, Any], structure: Structure, field: str) -> SpineCPG:
    _only(raw, ("type", "duration", "command_period", "layout", "cables", "convergence",
                "bounds", "initial_phase", "initial_amplitude", "parameters"), field)
    if raw.get("layout", "spine") != "spine":
        raise ControllerFileError(f"unknown layout {raw['layout']!r}; expected 'spine'",
                                  field=f"{field}.layout")
    cables = raw.get("cables")
    if cables is not None and not (isinstance(cables, list) and cables
                                   and all(isinstance(c, str) for c in cables)):
        raise ControllerFileError("expected a list of cable names", field=f"{field}.cables")
    bounds = _bounds(raw.get("bounds"), f"{field}.bounds")
    convergence = _number(raw.get("convergence", 20.0), f"{field}.convergence", positive=True)
    try:
        layout = spine_parameters(structure, cables,
                                  weight=bounds.get("weight", DEFAULT_WEIGHT),
                                  phase=bounds.get("phase", DEFAULT_PHASE),
                                  amplitude=bounds.get("amplitude", DEFAULT_AMPLITUDE),
                                  frequency=bounds.get("frequency", DEFAULT_FREQUENCY),
                                  convergence=convergence)
    except KeyError as err:
        raise ControllerFileError(str(err.args[0]), field=f"{field}.cables") from None
    except ValueError as err:  # a cable listed twice, or the bounds
        raise ControllerFileError(str(err), field=field) from None
    named = _mapping(raw.get("parameters"), f"{field}.parameters",
                     f"the {layout.size} parameter names -> values")
    named = {k: _number(v, f"{field}.parameters.{k}") for k, v in named.items()}
    try:
        values = layout.from_dict(named)
    except ValueError as err:
        raise ControllerFileError(str(err), field=f"{field}.parameters") from None
    phase = raw.get("initial_phase")
    if phase is not None:
        if not isinstance(phase, list):
            raise ControllerFileError("expected a list of phases [rad] or null",
                                      field=f"{field}.initial_phase")
        phase = tuple(_number(p, f"{field}.initial_phase") for p in phase)
    try:
        return layout.gait(values, initial_phase=phase, initial_amplitude=_number(
            raw.get("initial_amplitude", 0.0), f"{field}.initial_amplitude"))
    except ValueError as err:
        raise ControllerFileError(str(err), field=field) from None


def _sine(raw: dict[str, Any], structure: Structure, field: str) -> SineGait:
    _only(raw, ("type", "duration", "command_period", "cables", "pattern"), field)
    if ("cables" in raw) == ("pattern" in raw):
        raise ControllerFileError("give exactly one of 'cables' (per-cable waves) or "
                                  "'pattern'", field=field)
    if "pattern" in raw:
        where = f"{field}.pattern"
        pattern = _mapping(raw["pattern"], where, "name, amplitude, frequency, ...")
        _only(pattern, ("name", "amplitude", "frequency", "phase", "offset", "joint_lag"), where)
        if pattern.get("name") != "tetraspine":
            raise ControllerFileError(f"unknown pattern {pattern.get('name')!r}; expected "
                                      "'tetraspine'", field=f"{where}.name")
        values = {k: _number(v, f"{where}.{k}") for k, v in pattern.items() if k != "name"}
        try:
            return tetraspine_sine(structure, **values)
        except (TypeError, ValueError) as err:
            raise ControllerFileError(str(err), field=where) from None
    cables = _mapping(raw["cables"], f"{field}.cables", "cable name -> wave")
    known = {c.name for c in structure.cables}
    columns: dict[str, list[float]] = {k: [] for k in _SINE_FIELDS}
    for name, wave in cables.items():
        where = f"{field}.cables.{name}"
        _check_motorised(structure, known, name, where, "no controller can drive it",
                         "drop its gains")
        wave = _mapping(wave, where, f"{list(_SINE_FIELDS)}")
        _only(wave, _SINE_FIELDS, where)
        for key in _SINE_FIELDS:
            if key in ("amplitude", "frequency") and key not in wave:
                raise ControllerFileError(f"missing {key!r}", field=where)
            columns[key].append(_number(wave.get(key, 0.0), f"{where}.{key}"))
    try:
        return SineGait(tuple(cables), *(tuple(columns[k]) for k in _SINE_FIELDS))
    except ValueError as err:
        raise ControllerFileError(str(err), field=f"{field}.cables") from None


def _table(raw: dict[str, Any], base: Path | None, field: str) -> VelocityTable:
    _only(raw, ("type", "duration", "command_period", "file"), field)
    name = raw.get("file")
    if not isinstance(name, str) or not name:
        raise ControllerFileError("expected the path of a velocity-input file",
                                  field=f"{field}.file")
    path = Path(name) if base is None or Path(name).is_absolute() else base / name
    try:
        return load_velocity_table(path)
    except (OSError, VelocityFileError) as err:
        raise ControllerFileError(str(err), field=f"{field}.file") from None


def controller_from_dict(data: Any, structure: Structure, base: Path | None = None
                         ) -> ControllerConfig:
    """Builds a controller from the plain mapping a controller file holds.

    Args:
        data: the parsed file.
        structure: the robot the controller drives (cables, tags, rigid bodies).
        base: folder that relative file names in the gait are taken from.

    Raises:
        ControllerFileError: naming the field and what was expected.
    """
    data = _mapping(data, "", "'format', 'impedance' and/or 'rest_lengths', optionally 'gait'")
    _only(data, ("format", "version", "model", "description", "impedance", "rest_lengths",
                 "rest_speed", "gait"), "")
    if data.get("format") != FORMAT:
        raise ControllerFileError(f"expected 'format: {FORMAT}', got {data.get('format')!r}",
                                  field="format")
    version = data.get("version", VERSION)
    if isinstance(version, bool) or version != VERSION:
        raise ControllerFileError(f"this tensim reads version {VERSION}, got "
                                  f"{data.get('version')!r}", field="version")
    rest = None if data.get("rest_lengths") is None else _rest(data["rest_lengths"], structure,
                                                                 "rest_lengths")
    if data.get("rest_speed") is not None:
        if rest is None:
            raise ControllerFileError("a wind speed needs 'rest_lengths' to wind to",
                                      field="rest_speed")
        rest = dataclasses.replace(rest, speed=_number(data["rest_speed"], "rest_speed",
                                                       positive=True))
    commanded = frozenset(rest.cables if rest else ())
    passive: tuple[str, ...]
    if rest is not None and data.get("impedance") is None:
        impedance, passive = ImpedanceController({}), ()
        missing = [c.name for c in structure.cables
                   if not c.motor.passive and c.name not in commanded]
        if missing:
            raise ControllerFileError(
                f"{len(missing)} motorised cables of {structure.name!r} get no rest length: "
                f"{missing}; give each one, or impedance gains (or 'impedance.passive') in "
                "'impedance'", field="rest_lengths")
    else:
        raw_impedance = _mapping(data.get("impedance"), "impedance", "'groups' and 'cables'")
        impedance, passive = _gains(raw_impedance, structure, "impedance", commanded)
    gait: Gait | None = None
    duration, period = 60.0, None
    if data.get("gait") is not None:
        raw = _mapping(data["gait"], "gait", "'type', 'duration' and the gait's fields")
        kind = raw.get("type")
        readers: dict[str, Callable[[], Gait]] = {
            "cpg": lambda: _cpg(raw, structure, "gait"),
            "sine": lambda: _sine(raw, structure, "gait"),
            "table": lambda: _table(raw, base, "gait")}
        if not isinstance(kind, str) or kind not in readers:
            raise ControllerFileError(f"unknown gait type {kind!r}; expected one of "
                                      f"{list(readers)}", field="gait.type")
        gait = readers[kind]()
        if isinstance(gait, VelocityTable):
            try:
                check_table_columns(gait, impedance)
            except ValueError as err:
                raise ControllerFileError(str(err), field="gait.file") from None
        default = gait.duration if isinstance(gait, VelocityTable) else 60.0
        duration = _number(raw.get("duration", default), "gait.duration", positive=True)
        if "command_period" in raw and raw["command_period"] is not None:
            period = _number(raw["command_period"], "gait.command_period", positive=True)
    for key in ("model", "description"):
        if data.get(key) is not None and not isinstance(data[key], str):
            raise ControllerFileError(f"expected text, got {describe(data[key])}", field=key)
    try:
        return ControllerConfig(impedance, gait, duration, period, data.get("model"),
                                data.get("description") or "", passive, rest)
    except ValueError as err:
        raise ControllerFileError(str(err), field="gait") from None


def _parse(path: Path) -> Any:
    try:
        text = read_text(path)
        return load_json(text, str(path)) if path.suffix == ".json" else load_yaml(text,
                                                                                   str(path))
    except InputError as err:  # the message names the file already
        raise ControllerFileError(str(err)) from None


def load_controller(source: str | os.PathLike[str], structure: Structure | None = None
                    ) -> ControllerConfig:
    """Reads a controller file, or a shipped controller by name (see :func:`shipped_controllers`).

    This layer knows no presets: :func:`tensim.models.load_controller` also builds the preset
    a file names when no robot is given, and refuses a file made for another preset.

    Args:
        source: a .yaml/.yml/.json path, or the name of a shipped controller.
        structure: the robot the file drives.

    Raises:
        FileNotFoundError: neither a file nor a shipped controller.
        ControllerFileError: naming the file, the field and what was expected (also a file
            that is not UTF-8 YAML/JSON or has duplicate keys), or no ``structure``.
    """
    path = controller_path(source)
    if structure is None:
        raise ControllerFileError("pass the structure it drives (tensim.models.load_controller "
                                  "builds the preset a file names)", source=str(path))
    return controller_from_file(path, read_controller_data(path), structure)


def read_controller_data(path: Path) -> Any:
    """The plain mapping a controller file holds (before it is checked against a robot).

    Raises:
        ControllerFileError: not UTF-8 YAML/JSON, or duplicate keys.
    """
    return _parse(path)


def controller_from_file(path: Path, data: Any, structure: Structure) -> ControllerConfig:
    """:func:`controller_from_dict` on a file's mapping; errors name the file."""
    try:
        return controller_from_dict(data, structure, path.parent)
    except ControllerFileError as err:
        raise err.with_source(str(path)) from None


# -- writing ------------------------------------------------------------------------------------


def _bounds_list(b: Bounds) -> list[float]:
    return [float(b.low), float(b.high), float(b.nominal)]


def _gait_dict(gait: Gait, path: Path) -> dict[str, Any]:
    if isinstance(gait, SpineCPG):
        layout: CPGParameters = gait.layout
        out: dict[str, Any] = {"type": "cpg", "layout": "spine",
                               "cables": list(layout.oscillators),
                               "convergence": float(layout.convergence),
                               "bounds": {n: _bounds_list(getattr(layout, n))
                                          for n in _BOUND_NAMES}}
        out["initial_phase"] = None if gait.initial_phase is None else list(gait.initial_phase)
        out["initial_amplitude"] = float(gait.initial_amplitude)
        out["parameters"] = layout.as_dict(gait.values)
        return out
    if isinstance(gait, SineGait):
        return {"type": "sine", "cables": {
            c: {k: float(getattr(gait, k)[i]) for k in _SINE_FIELDS}
            for i, c in enumerate(gait.cables)}}
    table = path.with_name(f"{path.stem}_velocity.txt")
    save_velocity_table(gait, table, comments=(f"played by {path.name}",))
    return {"type": "table", "file": table.name}


def controller_to_dict(config: ControllerConfig, path: Path) -> dict[str, Any]:
    """The plain mapping :func:`save_controller` writes (a table gait is written beside)."""
    out: dict[str, Any] = {"format": FORMAT, "version": VERSION}
    if config.model:
        out["model"] = config.model
    if config.description:
        out["description"] = config.description
    impedance: dict[str, Any] = {}
    if config.impedance.gains or config.rest is None:
        impedance["cables"] = {name: {f: float(getattr(g, f)) for f in _GAIN_FIELDS}
                               for name, g in config.impedance.gains.items()}
    if config.passive:
        impedance["passive"] = list(config.passive)
    if config.impedance.target_velocity:
        impedance["target_velocity"] = float(config.impedance.target_velocity)
    if impedance:
        out["impedance"] = impedance
    if config.rest is not None:
        out["rest_lengths"] = {n: float(r) for n, r in config.rest.as_dict().items()}
        if config.rest.speed is not None:
            out["rest_speed"] = float(config.rest.speed)
    if config.gait is not None:
        head: dict[str, Any] = {"duration": float(config.duration)}
        if config.command_period is not None:
            head["command_period"] = float(config.command_period)
        gait = _gait_dict(config.gait, path)
        out["gait"] = {"type": gait.pop("type"), **head, **gait}
    return out


_COMMENT = """\
# tensim controller file (format tensim-controller, version 1).
# Impedance law per cable (paper eq. 3): T_set = max(0, T0 + K (L - L*) + B (V - V*)) with
# offset_tension T0 [N], stiffness_gain K [N/m], damping_gain B [N s/m], target_length L* [m].
# The gait sets V* [m/s]; durations and periods in s, frequencies in Hz, phases in rad.
# rest_lengths: commanded rest lengths [m]; the motors wind there at their max_speed, or at
# rest_speed [m/s] where that is slower.
"""


def save_controller(config: ControllerConfig, path: str | os.PathLike[str]) -> Path:
    """Writes ``config`` as YAML (or JSON for a .json path), atomically.

    Returns:
        The path written.
    """
    path = Path(path)
    data = controller_to_dict(config, path)
    if path.suffix == ".json":
        write_text(path, json.dumps(data, indent=2) + "\n")
    else:
        write_text(path, _COMMENT + yaml.dump(data, Dumper=_SafeDumper, sort_keys=False,
                                              width=100))
    return path


# libyaml's emitter where PyYAML has it: the same text as yaml.safe_dump, 5x faster (a learning
# run writes its best controller each time the best improves)
_SafeDumper: type[yaml.SafeDumper] = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


# -- shipped controller files -------------------------------------------------------------------


def shipped_controllers() -> dict[str, Path]:
    """Name -> path of the controller files that ship with tensim."""
    folder = resources.files("tensim.control") / "shipped"
    return {Path(str(p)).stem: Path(str(p)) for p in sorted(folder.iterdir(), key=str)
            if str(p).endswith(".yaml")}


def controller_path(source: str | os.PathLike[str]) -> Path:
    """The file behind ``source``: an existing path, or a shipped controller's name.

    Raises:
        FileNotFoundError: naming the shipped controllers.
    """
    path = Path(source)
    if path.is_file():
        return path
    shipped = shipped_controllers()
    if str(source) in shipped:
        return shipped[str(source)]
    raise FileNotFoundError(f"no controller file {str(source)!r}; shipped controllers: "
                            f"{', '.join(shipped)}")
