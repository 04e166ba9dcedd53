"""A stream line of only ``<value>`` (no time stamp), read after the talk.

Session 22's walkthrough: a module that wrote bare values was rehearsed; the 52 values of 51 s of
talk were all read at one instant ("measured for only 6 s", no advice, ``malformed samples 0``,
no ``.stamps``). Read afterwards (``rehearse``, ``replay``, ``report``) such a line cannot be
placed in time: it is an unreadable line, named with its file and line, as a garbled one is.
A live coach still stamps it as it reads it, and notes the stamp in ``.stamps``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from prezence.cli import main
from prezence.streams.tail import StreamTailer, read_stream, stamps_path


def _folder(root: Path) -> Path:
    """Stream files of a 30 s talk: a timed pace, and a volume written as bare values."""
    folder = root / "streams_only"
    folder.mkdir()
    (folder / "speech_speed.txt").write_text("".join(f"{t}.0 150\n" for t in range(1, 31)))
    (folder / "speech_volume.txt").write_text("".join(f"{50 + t % 3}\n" for t in range(1, 31)))
    return folder


def test_a_replay_counts_bare_values_as_unreadable_lines_with_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _folder(tmp_path)
    out = tmp_path / "again"
    assert main(["-q", "replay", str(folder), "--allocated", "30", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "malformed samples 30" in printed, printed
    assert (
        "note: 30 unreadable lines of speech_volume skipped (e.g. streams/speech_volume.txt:1: "
        "no time stamp: '51' (write '<t> <value>': only a live coach can time a bare value))"
    ) in printed, printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["metrics"]["speech_volume"]["samples"] == 0  # not 30 samples at one instant
    assert summary["stream_problems"][0].startswith(
        "streams/speech_volume.txt:1: no time stamp: '51'"
    )
    report = (out / "report" / "summary.txt").read_text()
    assert "30 unreadable lines in streams/speech_volume.txt were skipped" in report, report


def test_the_report_of_such_a_folder_says_so_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    folder = _folder(tmp_path)
    assert main(["-q", "report", str(folder)]) == 0
    capsys.readouterr()
    report = (folder / "report" / "summary.txt").read_text()
    assert "30 unreadable lines in speech_volume.txt were skipped" in report, report
    assert "no time stamp: '51'" in report


def test_a_live_coach_stamps_bare_values_and_notes_them_for_the_readings_after(
    tmp_path: Path,
) -> None:
    stream = tmp_path / "speech_volume.txt"
    live = StreamTailer(stream, "speech_volume", record_stamps=True)
    stream.write_text("61\n")
    assert [s.t for s in live.poll(4.5)] == [4.5]
    with stream.open("a") as f:
        f.write("62\n")
    assert [s.t for s in live.poll(5.0)] == [5.0]
    assert stamps_path(stream).read_text() == "1 4.5\n2 5.0\n"
    samples, stats = read_stream(stream, "speech_volume")
    assert [(s.t, s.value) for s in samples] == [(4.5, 61.0), (5.0, 62.0)]
    assert stats.malformed == 0
