"""Writing stream files: whole lines, appended, visible at once."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from prezence.samples import Sample
from prezence.streams.tail import read_stream
from prezence.streams.writer import StreamWriter, append_sample


def test_with_creates_parent_folders_and_writes_one_line_per_sample(tmp_path: Path) -> None:
    path = tmp_path / "session" / "streams" / "speech_speed.txt"
    with StreamWriter(path) as w:
        w.write(0.5, 150.0)
        w.write(1.25, 162.5)
    assert path.read_bytes() == b"0.5 150.0\n1.25 162.5\n"
    samples, stats = read_stream(path, "speech_speed")
    assert samples == [Sample("speech_speed", 0.5, 150.0), Sample("speech_speed", 1.25, 162.5)]
    assert stats.malformed == 0


def test_constructor_creates_nothing(tmp_path: Path) -> None:
    StreamWriter(tmp_path / "later" / "x.txt")
    assert not (tmp_path / "later").exists()


def test_each_write_is_visible_to_a_reader_before_close(tmp_path: Path) -> None:
    path = tmp_path / "v.txt"
    w = StreamWriter(path).open()
    try:
        w.write(2.0, 61.5)
        assert path.read_bytes() == b"2.0 61.5\n"
    finally:
        w.close()


def test_opening_appends_to_an_existing_file(tmp_path: Path) -> None:
    path = tmp_path / "v.txt"
    path.write_bytes(b"1.0 2.0\n")
    with StreamWriter(path) as w:
        w.write(3.0, 4.0)
    assert path.read_bytes() == b"1.0 2.0\n3.0 4.0\n"


@pytest.mark.parametrize(
    ("t", "value"),
    [(1.0, math.nan), (1.0, math.inf), (math.nan, 1.0), (-1.0, 1.0)],
    ids=["nan-value", "inf-value", "nan-t", "negative-t"],
)
def test_write_rejects_unreadable_samples_and_writes_nothing(
    tmp_path: Path, t: float, value: float
) -> None:
    path = tmp_path / "v.txt"
    with StreamWriter(path) as w, pytest.raises(ValueError):
        w.write(t, value)
    assert path.read_bytes() == b""


def test_write_before_open_raises(tmp_path: Path) -> None:
    w = StreamWriter(tmp_path / "v.txt")
    with pytest.raises(ValueError, match="not open"):
        w.write(1.0, 2.0)


def test_write_after_close_raises(tmp_path: Path) -> None:
    w = StreamWriter(tmp_path / "v.txt").open()
    w.close()
    with pytest.raises(ValueError, match="not open"):
        w.write(1.0, 2.0)


def test_close_twice_is_harmless_and_open_state_is_reported(tmp_path: Path) -> None:
    w = StreamWriter(tmp_path / "v.txt")
    assert w.closed
    w.open()
    assert not w.closed
    w.close()
    w.close()
    assert w.closed


def test_append_sample_creates_folders_and_appends(tmp_path: Path) -> None:
    path = tmp_path / "a" / "b" / "gaze.txt"
    append_sample(path, 1.0, -12.5)
    append_sample(path, 2.0, -3.0)
    assert path.read_text() == "1.0 -12.5\n2.0 -3.0\n"


def test_append_sample_rejects_nan_before_creating_anything(tmp_path: Path) -> None:
    path = tmp_path / "new" / "x.txt"
    with pytest.raises(ValueError):
        append_sample(path, 1.0, math.nan)
    assert not path.parent.exists()
