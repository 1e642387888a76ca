"""Atomic file writing: results are either complete or absent, never half-written.

A file is written to a temporary file beside it, named ``.<name>.<pid>.<random>.tmp``, then
renamed over it. A process killed mid-write leaves that temporary file; the next write of the
same file deletes it (its pid no longer runs).
"""

from __future__ import annotations

import contextlib
import glob
import json
import os
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


def check_writable(path: Path, kind: str) -> None:
    """Refuses an output path that cannot become a ``kind`` ("file" or "folder").

    Raises:
        InputError: a folder where a file is expected (or a file where a folder is), or a path
            under a file.
    """
    if kind == "file" and path.is_dir():
        raise InputError(f"{path}: is a folder; expected the path of a file to write")
    if kind == "folder" and path.exists() and not path.is_dir():
        raise InputError(f"{path}: is a file; expected a folder to write into")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{path}: {parent} is a file, so nothing can be written "
                                 "under it")
            break


@contextlib.contextmanager
def atomic_path(path: Path) -> Iterator[Path]:
    """Yields a temporary path beside ``path``; on success it replaces ``path`` in one step.

    Raises:
        InputError: ``path`` is a folder, or lies under a file.
    """
    check_writable(path, "file")
    path.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.",
                               suffix=".tmp")
    os.close(fd)
    os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; results get the usual permissions
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
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


def write_text(path: Path, text: str) -> None:
    """Writes ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_json(path: Path, data: Any) -> None:
    """Writes ``data`` as indented JSON, atomically."""
    write_text(path, json.dumps(data, indent=2, sort_keys=False) + "\n")
