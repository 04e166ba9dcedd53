"""``prezence progress``: one speaker's rehearsals side by side, from their summary.json files."""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Any

import pytest

from prezence.cli import main


def _session(root: Path, name: str, t0: float, metrics: dict[str, Any]) -> Path:
    s = root / name
    (s / "streams").mkdir(parents=True)
    (s / "session.json").write_text(json.dumps({"format": 1, "kind": "live", "t0_epoch": t0}))
    (s / "summary.json").write_text(json.dumps({"metrics": metrics}))
    return s


def test_a_time_in_range_that_is_not_a_fraction_is_refused_naming_file_and_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    good = {"time_in_range": 0.9}
    _session(tmp_path, "a", 1e9, {"speech_volume": {"time_in_range": 0.98}, "cv_gestures": good})
    b = _session(tmp_path, "b", 1e9 + 60, {})
    # NaN and a string, as a hand-edited or damaged file may hold them (json writes NaN)
    bad = {"time_in_range": float("nan")}
    metrics = {"speech_volume": {"time_in_range": 7.5}, "cv_gestures": bad}
    metrics["speech_speed"] = {"time_in_range": "abc"}
    (b / "summary.json").write_text(json.dumps({"metrics": metrics}))
    with caplog.at_level(logging.WARNING, logger="prezence.progress"):
        assert main(["progress", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "750%" not in out and "nan%" not in out
    volume = next(ln for ln in out.splitlines() if ln.startswith("volume"))
    assert volume.split()[1:] == ["98%", "-", "–"]  # left out for b only, no trend from it
    warned = [r.getMessage() for r in caplog.records]
    for key, value in [("speech_volume", "7.5"), ("cv_gestures", "nan"), ("speech_speed", "'abc'")]:
        assert any(
            f"{b / 'summary.json'}: metrics.{key}.time_in_range: {value} is not a number in [0, 1]"
            in m
            for m in warned
        ), warned


def test_folders_left_out_are_named_with_the_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _session(tmp_path, "a", 1e9, {"speech_volume": {"time_in_range": 0.5}})
    unfinished = tmp_path / "unfinished"  # its talk never wrote summary.json
    (unfinished / "streams").mkdir(parents=True)
    (unfinished / "streams" / "speech_volume.txt").write_text("0.0 60\n")
    (tmp_path / "empty").mkdir()
    r = _session(tmp_path, "r", 1e9 + 5, {"speech_volume": {"time_in_range": 0.5}})
    (r / "session.json").write_text(json.dumps({"format": 1, "kind": "replay"}))
    assert main(["progress", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("1 rehearsals of")
    assert (
        f"left out: unfinished: no summary.json (its talk did not finish?); "
        f"`prezence report {unfinished}` still reports on its streams"
    ) in out
    assert "left out: empty: not a session folder (no summary.json, no streams)" in out
    assert "left out: r: a replay, the same talk coached again" in out
