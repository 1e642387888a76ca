"""Runs the command transcripts in README.md and docs/*.md and checks their printed figures.

A transcript is a fenced code block whose first line starts with ``$ ``: each ``$ `` line
(continued by a trailing backslash) is a command, the lines after it are what it prints on
standard output. A line ``...`` stands for any number of lines (wall times and other figures
that vary between machines). Every figure a page quotes comes from one of these transcripts,
so running this script (CI does) shows any figure that has drifted.

Figures are compared exactly unless the line above the block states a tolerance for its
numbers, as an HTML comment the rendered page hides::

    <!-- check_docs: rel=0.02 abs=0.005 -->

Then a printed number matches the quoted one when they differ by at most ``abs`` or ``rel``
times the quoted number (for long contact-rich runs whose last digits differ between CPUs);
the text around the numbers must still match exactly.

Each transcript runs in a fresh temporary folder that sees the repository's ``examples/``, so
``--out runs/...`` never touches the working tree. It runs under ``bash -o pipefail``, so a
command that fails is seen even when it is piped into ``head`` or ``tail``.

Usage: python tools/check_docs.py [--only TEXT] [--page PATH ...] [--list]
"""

from __future__ import annotations

import argparse
import dataclasses
import difflib
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PAGES = ("README.md", "docs/*.md")
_FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", re.M | re.S)
_TOLERANCE = re.compile(r"<!--\s*check_docs:\s*(?P<spec>[^>]*?)\s*-->\s*$")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


@dataclasses.dataclass(frozen=True)
class Tolerance:
    """How far a printed number may be from the quoted one: ``abs`` or ``rel`` times it."""

    rel: float = 0.0
    abs: float = 0.0

    @classmethod
    def parse(cls, spec: str, where: str) -> Tolerance:
        """``rel=0.02 abs=0.005`` (either may be left out)."""
        values = {}
        for item in spec.split():
            key, _, value = item.partition("=")
            if key not in ("rel", "abs"):
                raise ValueError(f"{where}: check_docs tolerance {item!r}: expected rel=X or "
                                 "abs=Y")
            values[key] = float(value)
        return cls(**values)

    def same(self, expected: str, actual: str) -> bool:
        """Whether ``actual`` is ``expected`` with its numbers within the tolerance."""
        if expected == actual:
            return True
        if not (self.rel or self.abs):
            return False
        quoted, printed = _NUMBER.split(expected), _NUMBER.split(actual)
        if quoted != printed:  # the text between the numbers differs
            return False
        return all(abs(float(a) - float(e)) <= max(self.abs, self.rel * abs(float(e)))
                   for e, a in zip(_NUMBER.findall(expected), _NUMBER.findall(actual),
                                   strict=True))


@dataclasses.dataclass(frozen=True)
class Transcript:
    """A documented command and the output the page shows for it."""

    page: str
    line: int
    command: str
    expected: tuple[str, ...]
    tolerance: Tolerance = Tolerance()


def transcripts(root: Path = ROOT) -> list[Transcript]:
    """Every transcript of the pages, in page order."""
    found = []
    for pattern in PAGES:
        for path in sorted(root.glob(pattern)):
            text = path.read_text()
            for block in _FENCE.finditer(text):
                if block.group(1).startswith("$ "):
                    line = text.count("\n", 0, block.start(1)) + 1
                    page = path.relative_to(root).as_posix()
                    above = text[:block.start()].rstrip("\n").rpartition("\n")[2]
                    stated = _TOLERANCE.search(above)
                    tolerance = Tolerance.parse(stated["spec"], f"{page}:{line - 1}") \
                        if stated else Tolerance()
                    found += [dataclasses.replace(t, tolerance=tolerance)
                              for t in _split(page, line, block.group(1))]
    return found


def _split(page: str, first: int, body: str) -> list[Transcript]:
    """The commands of one block, each with the output lines that follow it."""
    result: list[Transcript] = []
    lines = body.rstrip("\n").split("\n")
    k = 0
    while k < len(lines):
        start, command = k, lines[k][2:]
        while command.endswith("\\"):
            k += 1
            command = command[:-1].rstrip() + " " + lines[k].strip()
        k += 1
        output = []
        while k < len(lines) and not lines[k].startswith("$ "):
            output.append(lines[k].rstrip())
            k += 1
        result.append(Transcript(page, first + start, command, tuple(output)))
    return result


def matches(expected: tuple[str, ...], actual: list[str],
            tolerance: Tolerance = Tolerance()) -> bool:
    """Whether ``actual`` lines match ``expected`` (``...`` matches any run of lines; numbers
    within ``tolerance``)."""
    if not expected:
        return not actual
    if expected[0] == "...":
        return any(matches(expected[1:], actual[i:], tolerance)
                   for i in range(len(actual) + 1))
    return bool(actual) and tolerance.same(expected[0], actual[0].rstrip()) and \
        matches(expected[1:], actual[1:], tolerance)


def run(transcript: Transcript, folder: Path) -> list[str]:
    """The command's standard output lines, run in ``folder`` with this Python's ``tensim``."""
    bin_dir = str(Path(sys.executable).parent)
    env = {**os.environ, "PATH": bin_dir + os.pathsep + os.environ.get("PATH", "")}
    if env.get("PYTHONPATH"):  # the commands run elsewhere: a relative entry would not resolve
        env["PYTHONPATH"] = os.pathsep.join(str(Path(entry).resolve()) if entry else entry
                                            for entry in env["PYTHONPATH"].split(os.pathsep))
    done = subprocess.run(["bash", "-o", "pipefail", "-c", transcript.command], cwd=folder,
                          env=env, text=True, capture_output=True, check=False)
    if done.returncode != 0:
        return [f"(exit status {done.returncode}) {done.stderr.strip()}"]
    return done.stdout.rstrip("\n").split("\n") if done.stdout.strip() else []


def check(transcript: Transcript) -> list[str]:
    """Runs one transcript; the differences as unified-diff lines (empty: it matches)."""
    with tempfile.TemporaryDirectory(prefix="tensim-docs-") as tmp:
        folder = Path(tmp)
        (folder / "examples").symlink_to(ROOT / "examples")
        actual = run(transcript, folder)
    if matches(transcript.expected, actual, transcript.tolerance):
        return []
    return list(difflib.unified_diff(list(transcript.expected), actual, "documented",
                                     "printed", lineterm=""))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", default=None, help="only commands containing this text")
    parser.add_argument("--page", nargs="+", default=None, metavar="PATH",
                        help="only the transcripts of these pages (e.g. docs/rl.md README.md)")
    parser.add_argument("--list", action="store_true", help="list the transcripts and stop")
    args = parser.parse_args()
    found = transcripts()
    unknown = sorted(set(args.page or ()) - {str(t.page) for t in found})
    if unknown:
        parser.error(f"--page: no transcripts on {', '.join(unknown)}; expected pages such as "
                     "docs/rl.md or README.md (see --list)")
    chosen = [t for t in found if (args.only is None or args.only in t.command)
              and (args.page is None or str(t.page) in args.page)]
    failed = 0
    for t in chosen:
        where = f"{t.page}:{t.line}: {t.command}"
        if args.list:
            print(where)
            continue
        diff = check(t)
        print(("ok    " if not diff else "DRIFT ") + where, flush=True)
        if diff:
            failed += 1
            print("\n".join("      " + d for d in diff))
    if not args.list:
        print(f"{len(chosen) - failed} of {len(chosen)} transcripts match")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
