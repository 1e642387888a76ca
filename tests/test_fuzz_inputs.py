"""Property-based fuzzing of every input surface (hypothesis).

Random and mutated versions of valid inputs must either load or raise tensim's own error type
(:class:`tensim.InputError` and its subclasses), never another exception, and never hang:
each example runs under a CPU-time alarm (and a generous wall-clock one for a blocked hang).
Mutations are of two kinds: on the text (cut, insert YAML/CSV punctuation or stray bytes,
delete, duplicate a line) and on the parsed data (replace, delete or add a value anywhere in
the tree with a hostile one). The runs are derandomized, so CI sees the same examples every
time; ``TENSIM_FUZZ_SCALE=20 pytest tests/test_fuzz_inputs.py`` hunts longer with fresh
random examples.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import json
import math
import os
import signal
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tensim import InputError
from tensim._input import load_yaml
from tensim.cli import _common
from tensim.control import controller_path, load_controller, load_velocity_table
from tensim.hardware import read_log, read_pairs
from tensim.hardware.loadcell import load_calibration
from tensim.io import import_ntrt
from tensim.models import preset
from tensim.runs import check_run_folder
from tensim.structure import load_structure
from tensim.terrain import KINDS, parse_terrain

EXAMPLES = Path(__file__).parents[1] / "examples"
LIMIT_S = 10.0  # CPU seconds per example: far above the milliseconds a load takes, far below a
# hang; CPU time, so a loaded machine cannot make an example fail
HANG_S = 600.0  # wall seconds per example: a hang guard only (a load blocked without using CPU)


SCALE = int(os.environ.get("TENSIM_FUZZ_SCALE", "1"))  # > 1: that many times the examples, new
# random ones each run (a longer hunt than CI's fixed set)


def fuzz(examples: int) -> Any:
    return settings(max_examples=examples * SCALE, derandomize=SCALE == 1, database=None,
                    deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@contextlib.contextmanager
def bounded(seconds: float = LIMIT_S) -> Iterator[None]:
    """Fails the example (rather than hanging the suite) if it takes more than ``seconds`` of
    this process's CPU time (not wall time: other load on the machine does not count), or
    ``HANG_S`` wall seconds."""
    def expire(signum: int, _: object) -> None:
        raise TimeoutError(f"an example ran longer than {seconds} s of CPU time"
                           if signum == signal.SIGPROF else f"an example hung for {HANG_S} s")

    previous = signal.signal(signal.SIGPROF, expire), signal.signal(signal.SIGALRM, expire)
    signal.setitimer(signal.ITIMER_PROF, seconds)
    signal.setitimer(signal.ITIMER_REAL, HANG_S)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0)
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGPROF, previous[0])
        signal.signal(signal.SIGALRM, previous[1])


def loads_or_refuses(load: Any, *args: Any) -> Any:
    """Runs ``load``; tensim's own error is an accepted outcome, anything else fails."""
    with bounded():
        try:
            return load(*args)
        except InputError:
            return None


# -- mutations ------------------------------------------------------------------------------------

_PUNCTUATION = ":-[]{},&*!|>'\"#%@`?\n\t 0123456789.eE+-xyz_/\\\x00é"
HOSTILE = st.one_of(
    st.none(), st.booleans(), st.integers(-10**15, 10**15),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["", "yes", "no", "on", "1e3", "nan", ".inf", "0x1f", "010", "1:20",
                     "2001-12-14", "a/b", "ünï", "x" * 200, "outer_top_1", "inner", "cpg"]),
    st.lists(st.one_of(st.integers(-5, 5), st.text(max_size=3)), max_size=4),
    st.dictionaries(st.text(max_size=4), st.integers(-5, 5), max_size=3),
)


def _paths(data: Any, prefix: tuple = ()) -> Iterator[tuple]:
    yield prefix
    if isinstance(data, dict):
        for key, value in data.items():
            yield from _paths(value, (*prefix, key))
    elif isinstance(data, list):
        for k, value in enumerate(data):
            yield from _paths(value, (*prefix, k))


@st.composite
def mutated_data(draw: st.DrawFn, base: Any) -> Any:
    """``base`` with one to three values replaced, deleted or added anywhere in its tree."""
    data = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(sorted(_paths(data), key=repr)))
        if not path:
            continue
        *head, last = path
        parent = data
        for key in head:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "replace", "delete", "add"]))
        if action == "replace":
            parent[last] = draw(HOSTILE)
        elif action == "delete":
            del parent[last]
        elif isinstance(parent, dict):
            parent[draw(st.sampled_from(["name", "extra", "tags", "gait", "via", "nodes"]))] = \
                draw(HOSTILE)
        else:
            parent.append(draw(HOSTILE))
    return data


@st.composite
def mutated_text(draw: st.DrawFn, text: str) -> bytes:
    """``text`` with one to four cuts, insertions, deletions or duplicated lines (bytes, so
    stray non-UTF-8 bytes can be inserted too)."""
    out = text.encode()
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(out)))
        action = draw(st.sampled_from(["cut", "insert", "delete", "line", "byte"]))
        if action == "cut":
            out = out[:i]
        elif action == "insert":
            out = out[:i] + draw(st.text(_PUNCTUATION, max_size=8)).encode() + out[i:]
        elif action == "delete":
            out = out[:i] + out[i + draw(st.integers(1, 20)):]
        elif action == "line":
            lines = out.split(b"\n")
            k = draw(st.integers(0, len(lines) - 1))
            out = b"\n".join([*lines[:k + 1], lines[k], *lines[k + 1:]])
        else:
            out = out[:i] + bytes([draw(st.integers(0x80, 0xff))]) + out[i:]
    return out


@pytest.fixture(scope="module")
def folder() -> Iterator[Path]:
    with tempfile.TemporaryDirectory() as name:
        yield Path(name)


def _write(folder: Path, name: str, content: bytes | str) -> Path:
    path = folder / name
    path.write_bytes(content.encode() if isinstance(content, str) else content)
    return path


# -- YAML -----------------------------------------------------------------------------------------


@fuzz(300)
@given(st.text(_PUNCTUATION + "abc&*<", max_size=80))
def test_yaml_text_loads_or_raises_input_error(text):
    loads_or_refuses(load_yaml, text, "f.yaml")


# -- structure files ------------------------------------------------------------------------------

PRISM = (EXAMPLES / "tensegrity_prism.yaml").read_text()
PRISM_DATA = yaml.safe_load(PRISM)


@fuzz(150)
@given(mutated_text(PRISM))
def test_mutated_structure_text(folder, content):
    loads_or_refuses(load_structure, _write(folder, "s.yaml", content))


@fuzz(100)
@given(mutated_data(PRISM_DATA))
def test_mutated_structure_data(folder, data):
    structure = loads_or_refuses(load_structure, _write(folder, "s.yaml", yaml.safe_dump(data)))
    if structure is not None:  # what loads is typed and finite
        for node in structure.nodes:
            assert isinstance(node.fixed, bool) and all(map(math.isfinite, node.position))
        for cable in structure.cables:
            assert type(cable.stiffness) is float and math.isfinite(cable.stiffness)


# -- controller files -----------------------------------------------------------------------------

ROBOT = preset("tetraspine3").build()
CONTROLLER = controller_path("tetraspine3_cpg").read_text()
CONTROLLER_DATA = yaml.safe_load(CONTROLLER)


@fuzz(80)
@given(mutated_text(CONTROLLER))
def test_mutated_controller_text(folder, content):
    loads_or_refuses(load_controller, _write(folder, "c.yaml", content), ROBOT)


@fuzz(60)
@given(mutated_data(CONTROLLER_DATA))
def test_mutated_controller_data(folder, data):
    config = loads_or_refuses(load_controller, _write(folder, "c.yaml", yaml.safe_dump(data)),
                              ROBOT)
    if config is not None:  # every cable is driven or listed passive
        passive = {c.name for c in ROBOT.cables
                   if any(p == c.name or p in c.tags for p in config.passive)}
        assert set(config.impedance.gains) | passive == {c.name for c in ROBOT.cables}


@fuzz(40)
@given(mutated_data(CONTROLLER_DATA))
def test_mutated_json_controller(folder, data):
    text = json.dumps(data)  # NaN and Infinity included, as Python writes them
    loads_or_refuses(load_controller, _write(folder, "c.json", text), ROBOT)


# -- V* tables, hardware logs, load-cell pairs, calibrations ------------------------------------

TABLE = ("# period_s: 0.01\n# hardware_scale: 2\ntime_s outer_top_1 inner_top_1\n"
         + "".join(f"{k / 100!r} {0.01 * k} {-0.02 * k}\n" for k in range(6)))
LOG = "\n".join((EXAMPLES / "hardware" / "sine_log.csv").read_text().splitlines()[:14]) + "\n"
PAIRS = (EXAMPLES / "hardware" / "loadcell_pairs.csv").read_text()
CALIBRATION = {"gain_N_per_count": 0.1567, "offset_N": -4.9363, "max_force_N": 111.21,
               "adc_max": 1023}


@fuzz(150)
@given(mutated_text(TABLE))
def test_mutated_velocity_tables(folder, content):
    loads_or_refuses(load_velocity_table, _write(folder, "v.txt", content))


@fuzz(150)
@given(mutated_text(LOG))
def test_mutated_hardware_logs(folder, content):
    log = loads_or_refuses(read_log, _write(folder, "log.csv", content))
    if log is not None:
        assert log.series.time.size >= 2
        loads_or_refuses(log.velocity_table)  # within the sample bound, or refused


@fuzz(150)
@given(mutated_text(PAIRS))
def test_mutated_load_cell_pairs(folder, content):
    loads_or_refuses(read_pairs, _write(folder, "pairs.csv", content))


@fuzz(150)
@given(mutated_data(CALIBRATION))
def test_mutated_calibrations(folder, data):
    cell = loads_or_refuses(load_calibration, _write(folder, "cal.json", json.dumps(data)))
    if cell is not None:
        assert math.isfinite(cell.gain) and cell.gain > 0 and math.isfinite(cell.offset)


# -- NTRT import ----------------------------------------------------------------------------------

NTRT = """\
nodes:
  bottom: [0, 0, 0]
  top: [0, 30, 0]
  side: [15, 15, 0]
  back: [0, 15, 15]
pair_groups:
  rod: [[bottom, top]]
  string: [[top, side], [side, bottom], [back, top]]
builders:
  rod: {class: tgRodInfo, parameters: {density: 0.688, radius: 0.31}}
  string: {class: tgBasicActuatorInfo, parameters: {stiffness: 1000, damping: 10,
           pretension: 200}}
"""


@fuzz(120)
@given(mutated_text(NTRT))
def test_mutated_ntrt_text(folder, content):
    loads_or_refuses(import_ntrt, _write(folder, "n.yaml", content), "cm")


@fuzz(120)
@given(mutated_data(yaml.safe_load(NTRT)))
def test_mutated_ntrt_data(folder, data):
    loads_or_refuses(import_ntrt, _write(folder, "n.yaml", yaml.safe_dump(data)), "cm")


# -- terrain strings ------------------------------------------------------------------------------

_VALUES = st.one_of(st.sampled_from(["", "nan", "inf", "-1", "0", "1e8", "1e300", "true",
                                     "3", "0.5", "x", "1,2"]),
                    st.floats(allow_nan=False).map(repr), st.integers(-10**9, 10**9).map(str))


@st.composite
def terrain_strings(draw: st.DrawFn) -> str:
    kind = draw(st.one_of(st.sampled_from(sorted(KINDS)), st.text(_PUNCTUATION, max_size=6)))
    keys = ["friction", "restitution", "height", "count", "steps", "seed", "size", "resolution",
            "angle", "length", "width", "rise", "run", "file", "roughness", "bogus"]
    items = draw(st.lists(st.tuples(st.sampled_from(keys), _VALUES), max_size=4))
    text = kind + (":" + ",".join(f"{k}={v}" for k, v in items) if items else "")
    return draw(st.sampled_from([text, text.upper(), f" {text} ", text + ","]))


@fuzz(400)
@given(st.one_of(terrain_strings(), st.text(_PUNCTUATION + "flatslope:=", max_size=30)))
def test_terrain_strings_parse_or_raise_terrain_error(text):
    loads_or_refuses(parse_terrain, text)


# -- command-line numbers and output folders ------------------------------------------------------

_NUMBERS = st.one_of(st.text(_PUNCTUATION, max_size=12), st.floats().map(repr),
                     st.integers(-10**30, 10**30).map(str),
                     st.sampled_from(["nan", "inf", "-inf", "1e-9", "1e400", "0", "-0", "1_0"]))


@fuzz(300)
@given(_NUMBERS)
def test_command_line_numbers_parse_to_what_they_promise(text):
    checks = {_common.finite: lambda v: math.isfinite(v),
              _common.positive: lambda v: math.isfinite(v) and v > 0,
              _common.nonnegative: lambda v: math.isfinite(v) and v >= 0,
              _common.count: lambda v: isinstance(v, int) and v >= 1,
              _common.natural: lambda v: isinstance(v, int) and v >= 0}
    for parse, holds in checks.items():
        try:
            value = parse(text)
        except argparse.ArgumentTypeError:
            continue
        assert holds(value), (parse.__name__, text, value)


@st.composite
def output_trees(draw: st.DrawFn) -> list[tuple[str, str]]:
    """Up to four entries (path, kind) under a folder: files, folders, run folders."""
    names = st.sampled_from(["out", "out/a", "out/a/b", "x", "out/summary.json"])
    kinds = st.sampled_from(["file", "folder", "run"])
    return draw(st.lists(st.tuples(names, kinds), max_size=4))


@fuzz(150)
@given(output_trees(), st.sampled_from(["out", "out/a", "out/a/b", "x/y", "new"]))
def test_output_folders_are_accepted_only_when_they_can_be_replaced(tree, target):
    with tempfile.TemporaryDirectory() as name:
        root = Path(name)
        for path, kind in tree:
            where = root / path
            with contextlib.suppress(OSError):  # a later entry may clash with an earlier one
                if kind == "file":
                    where.parent.mkdir(parents=True, exist_ok=True)
                    where.write_text("x")
                else:
                    where.mkdir(parents=True, exist_ok=True)
                    if kind == "run":
                        (where / "summary.json").write_text("{}")
        out = root / target
        try:
            with bounded():
                check_run_folder(out)
        except InputError:
            return
        # accepted: a missing path whose nearest existing parent is a folder, an empty folder,
        # or an earlier run
        existing = next(p for p in (out, *out.parents) if p.exists())
        assert existing.is_dir()
        if out.exists():
            assert not any(out.iterdir()) or (out / "summary.json").is_file()


# -- learning run folders -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def run_folder() -> Iterator[Path]:
    from tensim.learn import (
        InlineExecutor,
        LearningSettings,
        OptimizerSettings,
        SphereProblem,
        learn,
    )

    with tempfile.TemporaryDirectory() as name:
        settings = LearningSettings(OptimizerSettings("cma", batch=4), 12, seed=1)
        learn(SphereProblem(3), settings, Path(name) / "run", executor=InlineExecutor)
        yield Path(name) / "run"


@fuzz(100)
@given(st.data())
def test_mutated_run_folders_reopen_or_raise_run_folder_errors(run_folder, data):
    from tensim.learn import RunStore
    from tensim.learn.run import _Session

    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for path in run_folder.iterdir():
            (folder / path.name).write_bytes(path.read_bytes())
        target = data.draw(st.sampled_from(["config.json", "checkpoint.json",
                                            "evaluations.jsonl"]))
        text = (folder / target).read_text()
        if target == "evaluations.jsonl":
            content = data.draw(mutated_text(text))
        else:
            content = json.dumps(data.draw(mutated_data(json.loads(text)))).encode()
        (folder / target).write_bytes(content)
        store = RunStore(folder)

        def reopen() -> None:  # what a resume reads before its first trial
            _Session(store, store.load_problem(), store.read_config(), store.load_checkpoint(),
                     None)

        loads_or_refuses(reopen)
