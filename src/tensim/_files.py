"""Atomic file writing: results are either complete or absent, never half-written.

A file is written to a temporary file beside it, named ``.<name>.<pid>.<random>.tmp``, then
renamed over it. A process killed mid-write leaves that temporary file; the next write of the
same file deletes it (its pid no longer runs).

Writers own only what they create. An output path must be new or a regular file (a folder for
run folders): a device, FIFO, socket or folder is refused, never replaced. **A symbolic link is
followed**: tensim writes its final target (beside which the temporary file goes), and the link
stays a link to the new file. A write that fails (a full disk, a read-only folder) raises an
:class:`OSError` that names the output path, never the temporary file.
"""

from __future__ import annotations

import contextlib
import errno
import glob
import json
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from tensim._input import InputError

# a run folder's files that readers below the run writer look for (the replay)
STRUCTURE_FILE = "structure.yaml"  # the robot as it ran, in every simulation's folder
CONTROLLER_FILE = "controller.yaml"  # its controller, where it had one


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


_KINDS = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"))

# causes of a failed write, in words (the rest use the system's own text)
_CAUSES = {errno.ENOSPC: "no space left on the disk", errno.EROFS: "the file system is read-only",
           errno.EACCES: "permission denied", errno.EPERM: "permission denied",
           errno.EDQUOT: "the disk quota is used up", errno.EFBIG: "the file is too large",
           errno.ENAMETOOLONG: "the name is too long"}


class WriteError(OSError):
    """Writing an output failed; ``filename`` is the output's path and ``strerror`` the cause
    in words."""

    def __str__(self) -> str:
        return f"{self.filename}: cannot be written ({self.strerror})"


def cause(err: OSError) -> str:
    """Why a write failed, in words: ``"no space left on the disk"``, not ``[Errno 28]``."""
    return _CAUSES.get(err.errno or 0) or (err.strerror or str(err)).lower()


def output_target(path: Path) -> Path:
    """The path a write to ``path`` replaces: ``path``, or the final target of a symbolic link
    (the module's rule: links are followed, so the link keeps pointing at the new file)."""
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def check_writable(path: Path, kind: str, option: str | None = None) -> None:
    """Refuses an output path that cannot become a ``kind`` ("file" or "folder").

    Args:
        path: the output path (a symbolic link is judged by its target).
        kind: "file" or "folder".
        option: the command-line option that named ``path`` (``"--out"``), for the message.

    Raises:
        InputError: a device, FIFO or socket; a folder where a file is expected (or a file
            where a folder is); or a path under a file.
    """
    label = f"{option} {path}" if option else f"{path}"
    try:
        mode = os.stat(path).st_mode
    except OSError:
        mode = None  # new (or a dangling link, whose target will be created)
    if mode is not None:
        for test, what in _KINDS:
            if test(mode):
                where = "a folder for a run" if kind == "folder" else "a regular file"
                raise InputError(f"{label}: is {what}; tensim writes only a new path or over "
                                 f"{where}; choose another {option or 'path'}")
        if kind == "file" and stat.S_ISDIR(mode):
            raise InputError(f"{label}: is a folder; expected the path of a file to write")
        if kind == "folder" and not stat.S_ISDIR(mode):
            raise InputError(f"{label}: is a file; expected a folder to write into")
    for parent in output_target(path).parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{label}: {parent} is a file, so nothing can be written "
                                 "under it")
            break


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yields a temporary path beside ``path``; on success it replaces ``path`` in one step.

    A symbolic link is followed: its final target is replaced and the link left as it is.

    Raises:
        InputError: ``path`` is not a regular file or a new path (see :func:`check_writable`).
        WriteError: the write failed (a full disk, a read-only folder); it names ``path`` (the
            link, if ``path`` is one) and not the temporary file.
    """
    check_writable(path, "file")
    target = output_target(path)
    tmp = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        _remove_stale(target)
        fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.{os.getpid()}.",
                                   suffix=".tmp")
        os.close(fd)
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; results get the usual permissions
        yield Path(tmp)
        check_writable(path, "file")  # it may have become something else meanwhile
        os.replace(tmp, target)
    except WriteError:
        raise
    except OSError as err:  # name the output, not the temporary file
        raise WriteError(err.errno, cause(err), str(path)) from None
    finally:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)


def _remove_stale(path: Path) -> None:
    """Deletes temporary files of ``path`` left by processes that were killed mid-write."""
    for stale in path.parent.glob(f".{glob.escape(path.name)}.*.tmp"):
        pid = stale.name[len(path.name) + 2:].partition(".")[0]
        if pid.isdigit() and not pid_alive(int(pid)):
            stale.unlink(missing_ok=True)


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` runs (on this machine)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # it runs, as another user
        return True
    return True


RUN_MARKER = ".tensim-run"  # every run folder written through tensim.runs.replace_folder holds it


def run_folder_name(folder: Path) -> str:
    """The name a run folder will have: ``folder``'s own, or for a staging folder the name of
    the ``--out`` it becomes (its marker file's ``folder:`` line)."""
    marker = folder / RUN_MARKER
    if marker.is_file():
        for line in marker.read_text(errors="replace").splitlines():
            if line.startswith("folder: "):
                return line[len("folder: "):]
    return folder.name


def write_text(path: Path, text: str) -> None:
    """Writes ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_json(path: Path, data: Any) -> None:
    """Writes ``data`` as indented JSON, atomically."""
    write_text(path, json.dumps(data, indent=2, sort_keys=False) + "\n")
