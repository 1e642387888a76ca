"""Hostile inputs, one surface at a time: each gets tensim's own error naming the file (or
option), the field and the expectation, never a silent wrong run, a hang or a traceback."""

from __future__ import annotations

import json
import os
import textwrap

import pytest
import yaml

from tensim import InputError
from tensim._input import load_yaml
from tensim.cli import main
from tensim.control import ControllerFileError, load_velocity_table
from tensim.control.files import check_table_columns
from tensim.hardware import read_log, read_pairs
from tensim.hardware.loadcell import load_calibration
from tensim.io import import_ntrt
from tensim.limits import check_run
from tensim.models import load_controller, preset
from tensim.structure import StructureError, load_structure, structure_from_dict
from tensim.terrain import TerrainError, parse_terrain

_PRISM = """\
name: p
nodes:
  - {name: a, position: [0, 0, 0.1]}
  - {name: b, position: [1, 0, 0.1]}
  - {name: c, position: [0, 1, 0.1]}
rods:
  - {name: r, nodes: [a, b], radius: 0.01, linear_density: 0.1}
  - {name: s, nodes: [a, c], radius: 0.01, linear_density: 0.1}
cables:
  - {name: k, nodes: [b, c], stiffness: 100, pretension: 5}
"""


def _file(tmp_path, text: str | bytes, name: str = "f.yaml"):
    path = tmp_path / name
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    return path


# -- YAML itself ----------------------------------------------------------------------------------


@pytest.mark.parametrize(("text", "value"), [
    ("v: 1e12", 1e12),  # YAML 1.1 reads a string here
    ("v: yes", "yes"), ("v: no", "no"), ("v: on", "on"),  # YAML 1.1 reads booleans
    ("v: 010", 10),  # YAML 1.1 reads octal 8
    ("v: 1:20", "1:20"),  # YAML 1.1 reads sexagesimal 80
    ("v: 2001-12-14", "2001-12-14"),  # YAML 1.1 reads a date
    ("v: true", True), ("v: 0x1f", 31), ("v: -2.5", -2.5), ("v: .inf", float("inf")),
])
def test_yaml_reads_the_1_2_core_schema(text, value):
    assert load_yaml(text, "f.yaml") == {"v": value}


@pytest.mark.parametrize(("text", "words"), [
    ("a: 1\nb: 2\na: 3\n", "line 3: duplicate key 'a' \\(first given on line 1\\)"),
    ("a: &x [*x]\n", "refers to a value that contains it"),
    ("a: " + "[" * 200 + "]" * 200 + "\n", "nested"),
    ("".join(f"l{i}: &l{i} [" + ",".join([f"*l{i - 1}" if i else "x"] * 9) + "]\n"
             for i in range(10)), "expands to more than"),
    ("a: [1, 2\n", "not valid YAML at line 2"),
])
def test_yaml_refusals_name_the_file_and_line(text, words):
    with pytest.raises(InputError, match=words) as info:
        load_yaml(text, "robot.yaml")
    assert str(info.value).startswith("robot.yaml: ")


# -- structure files -----------------------------------------------------------------------------


@pytest.mark.parametrize(("old", "new", "words"), [
    ("{name: a, position", "{name: a, fixed: 'false', position", "fixed must be true or false"),
    ("{name: a, position", "{name: a, fixed: yes, position", "fixed must be true or false"),
    ("stiffness: 100", "stiffness: true", "stiffness must be a finite number"),
    ("stiffness: 100", "stiffness: '100'", "stiffness must be a finite number"),
    ("stiffness: 100", "stiffness: .nan", "stiffness must be a finite number"),
    ("radius: 0.01, linear", "radius: [0.01], linear", "radius must be a finite number"),
    ("position: [0, 0, 0.1]", "position: [0, 0]", "three numbers"),
    ("position: [0, 0, 0.1]", "position: [0, 0, true]", "three finite numbers"),
    ("nodes: [a, b], radius", "nodes: ab, radius", "nodes must be a list of names"),
    ("nodes: [b, c]", "nodes: [b, 3]", "must be a non-empty string"),
    ("{name: k,", "{name: 7,", "name must be a non-empty string"),
    ("{name: k,", "{name: k, tags: [1],", "tags must be a non-empty string"),
    ("{name: k,", "{name: k, motor: 5,", "motor: expected a mapping"),
    ("{name: k,", "{name: k, via: a,", "via must be a list"),
    ("name: p", "name: [p]", "name must be a non-empty string"),
    ("name: p", "name: p\nname: q", "duplicate key 'name'"),
    ("name: p", "name: p\ndefaults: [1]", "defaults must map"),
    ("cables:\n  -", "cables: {}\nx:\n  -", "unknown top-level field 'x'"),
])
def test_structure_values_of_the_wrong_type_are_refused(tmp_path, old, new, words):
    assert old in _PRISM
    path = _file(tmp_path, _PRISM.replace(old, new, 1))
    with pytest.raises(StructureError, match=words) as info:
        load_structure(path)
    assert str(path) in str(info.value)


def test_a_structure_number_without_a_dot_is_a_number(tmp_path):
    s = load_structure(_file(tmp_path, _PRISM.replace("stiffness: 100", "stiffness: 1e3")))
    assert s.cables[0].stiffness == 1000.0


@pytest.mark.parametrize("content", [b"name: caf\xe9\n", b"\xff\xfe\x00n"])
def test_a_structure_file_that_is_not_utf8_names_the_file_and_line(tmp_path, content):
    path = _file(tmp_path, content)
    with pytest.raises(StructureError, match="line 1: not UTF-8") as info:
        load_structure(path)
    assert str(path) in str(info.value)


def test_a_folder_named_like_a_structure_file_is_refused(tmp_path):
    (tmp_path / "x.yaml").mkdir()
    with pytest.raises(StructureError, match="is a folder; expected a file"):
        load_structure(tmp_path / "x.yaml")


def test_a_structure_listing_too_many_items_is_refused_before_building():
    node = {"name": "n", "position": [0, 0, 0], "fixed": True}
    with pytest.raises(StructureError, match="10001 nodes is more than the limit of 10000"):
        structure_from_dict({"name": "big", "nodes": [node] * 10_001})


# -- controller files ----------------------------------------------------------------------------


def _controller(tmp_path, change=None, name: str = "c.yaml"):
    robot = preset("tetraspine3").build()
    data = yaml.safe_load(load_controller_text())
    if change is not None:
        change(data)
    return _file(tmp_path, yaml.safe_dump(data, sort_keys=False), name), robot


def load_controller_text() -> str:
    from tensim.control import controller_path

    return controller_path("tetraspine3_cpg").read_text()


@pytest.mark.parametrize(("change", "field", "words"), [
    (lambda d: d["impedance"]["cables"].pop("outer_top_2"), "impedance",
     "1 of the 12 cables .* get no impedance gains: \\['outer_top_2'\\]"),
    (lambda d: d["impedance"].update(passive=["nothing"]), "impedance.passive", "no cable"),
    (lambda d: d.update(version=True), "version", "reads version 1"),
    (lambda d: d.update(description=[1]), "description", "expected text"),
    (lambda d: d.update(model="tetraspine"), "model", "made for 'tetraspine'"),
    (lambda d: d["gait"].update(duration=float("inf")), "gait.duration", "finite number"),
    (lambda d: d["gait"].update(duration=True), "gait.duration", "finite number"),
    (lambda d: d["impedance"].update(groups=[{"tag": 5}]), "groups[0].tag", "tag name"),
])
def test_controller_file_mistakes_name_the_field(tmp_path, change, field, words):
    path, robot = _controller(tmp_path, change)
    with pytest.raises(ControllerFileError, match=words) as info:
        load_controller(path, robot)
    assert str(path) in str(info.value) and field in str(info.value)


def test_a_controller_file_cut_in_half_is_refused(tmp_path):
    text = load_controller_text()
    cut = text[:text.index("inner_left_2")]  # the rest of the cables and the gait are gone
    with pytest.raises(ControllerFileError, match="get no impedance gains"):
        load_controller(_file(tmp_path, cut), preset("tetraspine3").build())


def test_a_controller_file_with_a_duplicate_key_is_refused(tmp_path):
    text = load_controller_text().replace("impedance:", "description: a\ndescription: b\n"
                                          "impedance:", 1)
    with pytest.raises(ControllerFileError, match="duplicate key 'description'"):
        load_controller(_file(tmp_path, text), preset("tetraspine3").build())


@pytest.mark.parametrize("text", ['{"format": "tensim-controller", "format": "x"}', "[1, 2"])
def test_json_controller_files_are_read_strictly(tmp_path, text):
    with pytest.raises(ControllerFileError, match=r"c\.json: (duplicate key|line 1)"):
        load_controller(_file(tmp_path, text, "c.json"), preset("tetraspine3").build())


# -- V* tables -----------------------------------------------------------------------------------


def test_a_velocity_table_missing_a_driven_cable_is_refused(tmp_path):
    robot = preset("tetraspine3").build()
    config = load_controller("tetraspine3_impedance", robot)
    names = [c.name for c in robot.cables][:-1]
    path = _file(tmp_path, "time_s " + " ".join(names) + "\n0 " + " ".join(["0"] * 11) + "\n"
                 "0.01 " + " ".join(["0"] * 11) + "\n", "v.txt")
    with pytest.raises(ValueError, match="no column for \\['inner_top_2'\\]"):
        check_table_columns(load_velocity_table(path), config.impedance)
    assert main(["--quiet", "simulate", "tetraspine3", "--controller", "tetraspine3_impedance",
                 "--velocity-input", str(path), "--out", str(tmp_path / "run")]) == 2


@pytest.mark.parametrize(("body", "words"), [
    (b"time_s a\n0 1\n0.01 caf\xe9\n", "line 3: not UTF-8"),
    (b"time_s a a\n0 1 2\n0.01 1 2\n", "unique"),
    (b"time_s a\n0 nan\n0.01 1\n", "finite"),
])
def test_bad_velocity_tables_name_the_file(tmp_path, body, words):
    path = _file(tmp_path, body, "v.txt")
    with pytest.raises(InputError, match=words) as info:
        load_velocity_table(path)
    assert str(path) in str(info.value)


# -- hardware logs, load-cell pairs, calibrations ------------------------------------------------


@pytest.mark.parametrize(("body", "words"), [
    (b"time_s,tension_N/c\n0,1\n", "at least two data rows"),
    (b"time_s,tension_N/c\n0,1\n0.1,\xff\n", "line 3: not UTF-8"),
    (b"time_s,tension_N/c\n0,1\n0.1,1\x00\n", "not valid CSV|expected a finite number"),
    (b"time_s,tension_N/c\n0,1\n0.1,inf\n", "expected a finite number"),
])
def test_bad_hardware_logs_name_the_file(tmp_path, body, words):
    path = _file(tmp_path, body, "log.csv")
    with pytest.raises(InputError, match=words) as info:
        read_log(path)
    assert str(path) in str(info.value)


def test_a_log_stamped_far_in_the_future_is_refused_before_allocating(tmp_path):
    path = _file(tmp_path, "time_s,tension_N/c,vstar_mps/c\n0,1,0\n1e9,1,0\n", "log.csv")
    with pytest.raises(InputError, match="rows: 1e\\+11 is more than the limit"):
        read_log(path).velocity_table(0.01)


@pytest.mark.parametrize(("body", "words"), [
    ("adc\n1\n", "header 'adc,force_N'"), ("adc,force_N\n1,nan\n", "expected a number"),
    ("adc,force_N\n1,2,3\n", "expected 2 cells"),
])
def test_bad_load_cell_pairs_name_the_line(tmp_path, body, words):
    with pytest.raises(InputError, match=words):
        read_pairs(_file(tmp_path, body, "pairs.csv"))


@pytest.mark.parametrize(("data", "words"), [
    ({"gain_N_per_count": True, "offset_N": 0}, "gain must be > 0"),
    ({"gain_N_per_count": 0.1, "offset_N": "1"}, "offset must be a finite force"),
    ({"gain_N_per_count": 0.1, "offset_N": 0, "max_force_N": float("nan")}, "max_force"),
    ({"gain_N_per_count": 0.1}, "'offset_N' is missing"),
    ([1, 2], "expected a JSON object"),
])
def test_bad_calibration_files_name_the_file(tmp_path, data, words):
    path = _file(tmp_path, json.dumps(data), "cal.json")
    with pytest.raises(InputError, match=words) as info:
        load_calibration(path)
    assert str(path) in str(info.value)


# -- NTRT import ---------------------------------------------------------------------------------


_NTRT = """\
nodes: {a: [0, 0, 0], b: [0, 10, 0], c: [10, 0, 0]}
pair_groups: {rod: [[a, b]], string: [[b, c]]}
"""


@pytest.mark.parametrize(("text", "words"), [
    (_NTRT + "substructures: {s: {path: x.yaml, scale: true}}\n", "no such file|scale"),
    (_NTRT.replace("[0, 0, 0]", "[0, 0, '0']"), "expected three finite numbers"),
    (_NTRT.replace("{a:", "{a: [1, 1, 1], a:"), "duplicate key 'a'"),
    (_NTRT + "builders: {rod: {class: 5}}\n", "'class' must be a builder class name"),
])
def test_ntrt_files_are_read_strictly(tmp_path, text, words):
    with pytest.raises(StructureError, match=words):
        import_ntrt(_file(tmp_path, text), "cm")


def test_ntrt_import_refuses_a_negative_clearance(tmp_path):
    with pytest.raises(ValueError, match="clearance must be a finite distance >= 0"):
        import_ntrt(_file(tmp_path, _NTRT), "cm", clearance=-1.0)


# -- terrain strings -----------------------------------------------------------------------------


@pytest.mark.parametrize(("text", "words"), [
    ("", "unknown kind ''"), ("blocks:count=100000000", "at most 10000"),
    ("stairs:steps=10000000", "at most 10000"), ("blocks:count=1e8", "expects an integer"),
    ("hills:height=nan", "finite"), ("rough:resolution=0.0001", "coarse enough"),
])
def test_terrain_strings_past_their_bounds_are_refused(text, words):
    with pytest.raises(TerrainError, match=words):
        parse_terrain(text)


def test_a_damaged_height_field_image_is_a_terrain_error(tmp_path):
    _file(tmp_path, b"\x89PNG\r\n\x1a\nnot really", "h.png")
    with pytest.raises(TerrainError, match="cannot be read"):
        parse_terrain(f"heightfield:file={tmp_path / 'h.png'}").geometry()


# -- work bounds ---------------------------------------------------------------------------------


def test_work_past_the_limits_is_refused_with_the_figure_unless_forced():
    with pytest.raises(InputError, match="physics steps: 1e\\+10 is more than the limit of"):
        check_run(10.0, 1e-9)
    with pytest.raises(InputError, match="recorded samples: 1e\\+08"):
        check_run(1e6, 0.5, 0.01)
    check_run(10.0, 1e-9, force=True)  # asked for explicitly
    with pytest.raises(InputError, match="finite time > 0"):
        check_run(float("inf"), 1e-3, force=True)


# -- the command line: numbers, output paths, run folders ----------------------------------------


@pytest.mark.parametrize(("argv", "words"), [
    (["simulate", "prism3", "--duration", "0"], "--duration: expected a number > 0"),
    (["simulate", "prism3", "--duration", "inf"], "--duration: expected a finite number"),
    (["simulate", "prism3", "--dt", "nan"], "--dt: expected a finite number"),
    (["simulate", "prism3", "--record-dt", "-1"], "--record-dt: expected a number > 0"),
    (["learn", "--workers", "-1"], "--workers: expected a whole number >= 0"),
    (["learn", "--evaluations", "2.5"], "--evaluations: expected a whole number"),
    (["import-ntrt", "x.yaml", "--units", "cm", "--clearance", "-1", "--out", "y.yaml"],
     "--clearance: expected a number >= 0"),
    (["calibrate-loadcell", "p.csv", "--max-force", "nan"], "--max-force: expected a finite"),
])
def test_command_line_numbers_are_checked(argv, words, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    assert words in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "words"), [
    (["simulate", "prism3", "--dt", "1e-9"], "is more than the limit"),
    (["simulate", "prism3", "--duration", "1e9"], "is more than the limit"),
    (["simulate", "prism3", "--terrain", ""], "unknown kind ''"),
])
def test_work_that_would_hang_is_refused_up_front(argv, words, capsys, tmp_path):
    assert main([*argv, "--out", str(tmp_path / "run")]) == 2
    assert words in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_output_paths_that_cannot_be_written_get_one_line(tmp_path, capsys):
    _file(tmp_path, "mine", "notes.txt")
    for out, words in ((tmp_path / "notes.txt", "is a file; expected a folder"),
                       (tmp_path / "notes.txt" / "run", "is a file, so nothing can be written"),
                       (tmp_path, "holds no tensim run")):
        assert main(["--quiet", "simulate", "prism3", "--duration", "0.05", "--out",
                     str(out)]) == 2
        err = capsys.readouterr().err
        assert words in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "notes.txt").read_text() == "mine"
    assert main(["export-trajectory", "tetraspine3_cpg", "--out", str(tmp_path)]) == 2
    assert "is a folder; expected the path of a file" in capsys.readouterr().err


def test_an_earlier_run_folder_is_replaced_whole(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["--quiet", "simulate", "prism3", "--duration", "0.05", "--out", str(out)]
    assert main(argv) == 0
    (out / "stale_figure.png").write_bytes(b"from an earlier run")
    assert main(argv) == 0
    assert not (out / "stale_figure.png").exists()  # never a mix of two runs
    assert (out / "summary.json").is_file()
    assert [p.name for p in tmp_path.iterdir()] == ["run"]  # no staging folder left


def test_a_controller_file_naming_no_preset_says_so(tmp_path):
    path = _file(tmp_path, textwrap.dedent("""\
        format: tensim-controller
        model: yes
        impedance: {cables: {}}
        """))
    with pytest.raises(ControllerFileError, match="names no preset \\('yes'\\)"):
        load_controller(path)



def test_a_write_deletes_the_temporary_files_of_killed_writers_only(tmp_path):
    from tensim._files import write_text

    dead = _file(tmp_path, "half", ".out.txt.999999999.k2j4.tmp")  # no such pid
    live = _file(tmp_path, "busy", f".out.txt.{os.getpid()}.a1b2.tmp")  # a writer that runs
    write_text(tmp_path / "out.txt", "done")
    assert not dead.exists() and live.exists()
    assert (tmp_path / "out.txt").read_text() == "done"


@pytest.mark.parametrize(("argv", "words"), [
    (["export-trajectory", "tetraspine3_cpg", "--period", "1e-12"], "rows: 6e+13 is more than"),
    (["simulate", "prism3", "--duration", "1e-12"], "shorter than one physics step"),
    (["simulate", "no_such_robot"], "unknown model 'no_such_robot'"),
    (["bench", "--duration", "1e9"], "physics steps: 1e+12 is more than"),
])
def test_more_commands_refuse_in_one_line(argv, words, capsys, tmp_path):
    assert main(["--quiet", *argv, "--out" if argv[0] != "bench" else "--json",
                 str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="needs /dev/zero")
def test_a_device_named_as_an_input_file_is_refused_not_read_forever(tmp_path):
    robot = preset("tetraspine3").build()
    path = _file(tmp_path, yaml.safe_dump({
        "format": "tensim-controller", "impedance": {"groups": [
            {"tag": "joint_1", "offset_tension": 1, "stiffness_gain": 1, "damping_gain": 1,
             "target_length": 0.2},
            {"tag": "joint_2", "offset_tension": 1, "stiffness_gain": 1, "damping_gain": 1,
             "target_length": 0.2}]},
        "gait": {"type": "table", "file": "/dev/zero"}}))
    with pytest.raises(ControllerFileError, match="/dev/zero: not a regular file"):
        load_controller(path, robot)
