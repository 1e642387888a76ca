"""The documented command transcripts: found, parsed, matched; a cheap one run for real.

``python tools/check_docs.py`` runs them all (minutes); this keeps its machinery honest.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("check_docs", ROOT / "tools" / "check_docs.py")
check_docs = importlib.util.module_from_spec(_spec)
sys.modules["check_docs"] = check_docs
_spec.loader.exec_module(check_docs)


def test_the_pages_transcripts_are_found_with_their_commands():
    found = {t.command.split(" --out")[0]: t for t in check_docs.transcripts()}
    assert "tensim --quiet experiment timestep" in found  # docs/speed.md
    assert "tensim --quiet experiment drag" in found  # README.md
    timestep = found["tensim --quiet experiment timestep"]
    assert timestep.page == "docs/speed.md"
    assert any("4000 Hz" in line for line in timestep.expected)
    # a command continued with a backslash is one command
    assert any(t.command.startswith("tensim compare examples/hardware/sine_log.csv --model")
               for t in found.values())


def test_an_ellipsis_matches_any_lines_and_nothing_else_does():
    assert check_docs.matches(("a", "...", "z"), ["a", "b", "c", "z"])
    assert check_docs.matches(("a", "...", "z"), ["a", "z"])
    assert check_docs.matches(("a", "..."), ["a"])
    assert not check_docs.matches(("a", "z"), ["a", "b", "z"])
    assert not check_docs.matches(("0.82 %",), ["0.76 %"])  # a drifted figure


def test_the_load_cell_transcript_matches_what_the_command_prints():
    (calibration,) = [t for t in check_docs.transcripts() if "calibrate-loadcell" in t.command]
    assert check_docs.check(calibration) == []


def test_a_failing_command_piped_into_head_or_tail_is_seen():
    for command in ("python -c 'import sys; print(1); sys.exit(3)' | tail -1",
                    "python -c 'raise SystemExit(4)' 2>&1 | head -1"):
        transcript = check_docs.Transcript("page.md", 1, command, ("1",))
        (line,) = [d for d in check_docs.check(transcript) if d.startswith("+(exit status")]
        assert "exit status" in line


def test_a_stated_tolerance_covers_the_numbers_and_nothing_else(tmp_path):
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "page.md").write_text(
        "text\n\n<!-- check_docs: rel=0.02 abs=0.001 -->\n```\n$ echo 1\nmoved 1.000 m in 3 s\n"
        "```\n\n```\n$ echo 2\nmoved 1.000 m\n```\n")
    tolerant, exact = check_docs.transcripts(tmp_path)
    assert tolerant.tolerance == check_docs.Tolerance(0.02, 0.001)
    assert exact.tolerance == check_docs.Tolerance()
    same = check_docs.matches
    assert same(tolerant.expected, ["moved 1.019 m in 3 s"], tolerant.tolerance)
    assert not same(tolerant.expected, ["moved 1.021 m in 3 s"], tolerant.tolerance)
    assert not same(tolerant.expected, ["moved 1.000 m in 3 s!"], tolerant.tolerance)
    assert not same(tolerant.expected, ["moved 1.000 km in 3 s"], tolerant.tolerance)
    assert same(("0.000 N",), ["0.001 N"], tolerant.tolerance)  # the absolute part
    assert not same(exact.expected, ["moved 1.001 m"], exact.tolerance)


def _untranscribed_figures(page: str) -> list[str]:
    """Lines of a page's fenced output blocks that quote a figure with a unit but are no
    transcript (no ``$`` command that check_docs runs)."""
    import re

    figure = re.compile(r"\d+\.\d+ ?(m|s|N|%|kg|ms|mm|m/s|Hz|J|W)\b")
    text = (ROOT / page).read_text()
    lines = []
    for block in re.finditer(r"^```([^\n]*)\n(.*?)^```", text, re.M | re.S):
        language, body = block.group(1).strip(), block.group(2)
        if language in ("", "text", "console") and not body.lstrip().startswith("$ "):
            lines += [line for line in body.splitlines() if figure.search(line)]
    return lines


def test_pages_quote_no_figures_from_blocks_that_are_not_run():
    """docs/cables.md's wall climb and docs/learning.md's robust gaits quoted figures from
    output blocks check_docs never ran (and that had drifted); what is left outside a
    transcript are timings, which vary between machines and say so."""
    assert _untranscribed_figures("docs/cables.md") == []
    timings = _untranscribed_figures("docs/learning.md")
    assert timings and all("evaluations/s" in line or "CPU" in line for line in timings), \
        timings


def test_a_relative_pythonpath_reaches_the_commands_as_the_caller_meant(monkeypatch, tmp_path):
    """Transcripts run in a scratch folder: ``PYTHONPATH=src`` must still name this tree's
    sources there, not fall through to an installed copy."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "src").mkdir()
    monkeypatch.setenv("PYTHONPATH", "src")
    transcript = check_docs.Transcript(
        "page.md", 1, "python -c 'import os; print(os.environ[\"PYTHONPATH\"])'", ("",))
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    assert check_docs.run(transcript, folder) == [str((tmp_path / "src").resolve())]


def test_page_lists_the_named_pages_transcripts_only(monkeypatch, capsys):
    """``--page`` keeps exactly the transcripts whose page is named, in page order."""
    everything = check_docs.transcripts()
    named = ("docs/speed.md", "README.md")
    monkeypatch.setattr(sys, "argv", ["check_docs", "--list", "--page", *named])
    assert check_docs.main() == 0
    listed = capsys.readouterr().out.splitlines()
    expected = [f"{t.page}:{t.line}: {t.command}" for t in everything if t.page in named]
    assert listed == expected and {t.page for t in everything if t.page in named} == set(named)
    assert {t.page for t in everything} - set(named)  # other pages were left out


def test_a_page_without_transcripts_is_refused(monkeypatch, capsys):
    monkeypatch.setattr(sys, "argv", ["check_docs", "--list", "--page", "docs/nowhere.md"])
    try:
        check_docs.main()
    except SystemExit as stop:
        assert stop.code == 2
    else:
        raise AssertionError("an unknown page was accepted")
    assert "--page: no transcripts on docs/nowhere.md" in capsys.readouterr().err
