"""Writers own only what they create: every output option writes a new path or over a regular
file (a folder for a run), follows a symbolic link to its target, refuses devices, FIFOs,
sockets and folders naming the option, never replaces the command's own input, and names the
output and the cause in words when a write fails."""

from __future__ import annotations

import errno
import os
import socket
from pathlib import Path

import pytest

from tensim import InputError
from tensim._files import WriteError, check_writable, write_text
from tensim.cli import main


def _fifo(path: Path) -> Path:
    os.mkfifo(path)
    return path


def _socket(path: Path) -> Path:
    sock = socket.socket(socket.AF_UNIX)
    sock.bind(str(path))
    sock.close()
    return path


@pytest.mark.parametrize(("make", "what"), [(_fifo, "a FIFO"), (_socket, "a socket"),
                                            (Path.mkdir, "a folder")])
@pytest.mark.parametrize("command", [["info", "prism3", "--json"],
                                     ["controller", "init", "prism3", "--out"],
                                     ["export-mjcf", "prism3", "--out"]])
def test_a_file_option_refuses_what_is_not_a_regular_file(tmp_path, capsys, make, what,
                                                         command):
    path = tmp_path / "x"
    make(path)
    kind = os.stat(path).st_mode
    assert main([*command, str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{command[-1]} {path}: is {what}" in err
    assert os.stat(path).st_mode == kind  # still what it was


@pytest.mark.parametrize("make", [_fifo, _socket])
def test_a_run_folder_option_refuses_a_fifo_or_socket(tmp_path, capsys, make):
    path = make(tmp_path / "x")
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.01", "--out", str(path)]) == 2
    assert f"--out {path}: is a" in capsys.readouterr().err
    assert not path.is_dir()


def test_a_device_is_refused_without_writing_it():
    # only stats the device: the check runs before anything is opened
    with pytest.raises(InputError, match="is a character device"):
        check_writable(Path(os.devnull), "file", "--json")


def test_a_symbolic_link_is_followed_and_stays_a_link(tmp_path):
    target = tmp_path / "target.json"
    target.write_text("old")
    link = tmp_path / "link.json"
    link.symlink_to(target.name)
    assert main(["info", "prism3", "--json", str(link)]) == 0
    assert link.is_symlink() and '"nodes"' in target.read_text()
    dangling = tmp_path / "dangling.json"
    dangling.symlink_to("new.json")
    write_text(dangling, "x")
    assert dangling.is_symlink() and (tmp_path / "new.json").read_text() == "x"


def test_a_run_folder_behind_a_link_is_replaced_and_the_link_kept(tmp_path):
    real = tmp_path / "real"
    link = tmp_path / "run"
    link.symlink_to(real.name, target_is_directory=True)
    for _ in range(2):  # new, then over the earlier run
        assert main(["--quiet", "simulate", "prism3", "--duration", "0.01",
                     "--out", str(link)]) == 0
    assert link.is_symlink() and (real / "summary.json").is_file()


def test_a_command_never_replaces_its_own_input(tmp_path, capsys):
    robot = tmp_path / "robot.yaml"
    from tensim.models import PRESETS
    from tensim.structure import save_structure

    save_structure(PRESETS["prism3"].build(), robot)
    before = robot.read_bytes()
    assert main(["controller", "init", str(robot), "--out", str(robot)]) == 2
    assert f"--out {robot}: is the input" in capsys.readouterr().err
    assert robot.read_bytes() == before
    # nor a run folder that holds its input: replacing the folder would delete it
    run = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.01", "--out", str(run)]) == 0
    inside = run / "structure.yaml"
    assert main(["--quiet", "simulate", str(inside), "--duration", "0.01",
                 "--out", str(run)]) == 2
    assert f"--out {run}: holds the input" in capsys.readouterr().err


@pytest.mark.parametrize(("code", "words"), [(errno.ENOSPC, "no space left on the disk"),
                                             (errno.EROFS, "the file system is read-only")])
def test_a_failed_write_names_the_option_and_the_cause_in_words(tmp_path, capsys, monkeypatch,
                                                                code, words):
    def refuse(self, *args, **kwargs):
        raise OSError(code, os.strerror(code), str(self))

    monkeypatch.setattr(Path, "write_text", refuse)
    out = tmp_path / "c.yaml"
    assert main(["controller", "init", "prism3", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"--out {out}: cannot be written ({words})" in err
    assert "Errno" not in err and ".tmp" not in err and not list(tmp_path.iterdir())
    run = tmp_path / "run"
    assert main(["--quiet", "simulate", "prism3", "--duration", "0.01", "--out", str(run)]) == 2
    err = capsys.readouterr().err
    assert f"--out {run}: cannot be written while writing" in err and f"({words})" in err
    assert ".partial-" not in err and "Errno" not in err and not run.exists()


def test_a_write_error_is_an_os_error_naming_the_path(tmp_path, monkeypatch):
    monkeypatch.setattr(os, "replace", lambda *a: (_ for _ in ()).throw(
        OSError(errno.ENOSPC, "No space left on device", a[0])))
    with pytest.raises(WriteError) as info:
        write_text(tmp_path / "a.txt", "x")
    assert str(info.value) == f"{tmp_path / 'a.txt'}: cannot be written (no space left on the disk)"
