"""``rehearse`` with a module of one's own that writes values without their time.

Session 22's walkthrough: the 52 bare ``<value>`` lines of a filler counter (51 s of talk at
6-8.5 per minute) were all read at one instant: "measured for only 6 s", no advice,
``malformed samples 0``. Read after the fact, a bare value cannot be placed in time.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

pytest.importorskip("av", reason='the speech module needs PyAV: pip install "prezence[speech]"')
pytest.importorskip(
    "pocketsphinx", reason='the speech module needs pocketsphinx: pip install "prezence[speech]"'
)

from prezence.cli import main  # noqa: E402

FAST = Path(__file__).parent / "material" / "rate_225.flac"  # 17.6 s

#: a filler counter that forgets the time: one bare value a second
_BARE_MODULE = """
import argparse
from pathlib import Path

from prezence.modules.audio_io import read_file
from prezence.modules.common import add_common_arguments

ap = argparse.ArgumentParser()
ap.add_argument("--audio", required=True)
add_common_arguments(ap)
args = ap.parse_args()
seconds = len(read_file(args.audio)) // 16000
streams = Path(args.out) / "streams"
streams.mkdir(parents=True, exist_ok=True)
(streams / "speech_fillers.txt").write_text("".join("9.0\\n" for _ in range(seconds)))
"""


def test_rehearse_names_bare_values_as_unreadable_lines(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from prezence import metrics

    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "bare_fillers.py").write_text(_BARE_MODULE)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(pkg), *sys.path]))
    monkeypatch.setitem(
        metrics.INPUT_MODULES,
        "fillers",
        metrics.InputModule("fillers", "bare_fillers", "--audio", (), metrics.DEFAULT_HANG_S),
    )
    monkeypatch.setitem(
        metrics.METRICS,
        "speech_fillers",
        metrics.Metric("speech_fillers", "fillers/min", "filler words", "fillers", 1.0),
    )
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_fillers max 6 above=slowDown range=0..60\n")
    out = tmp_path / "s"
    argv = ["-q", "rehearse", str(FAST), "--out", str(out), "--config", str(rules)]
    assert main([*argv, "--allocated", "20", "--speech-args", "--hop 2"]) == 0
    printed = capsys.readouterr().out
    assert "malformed samples 17" in printed, printed
    assert "streams/speech_fillers.txt:1: no time stamp: '9.0'" in printed
    summary = json.loads((out / "summary.json").read_text())
    assert summary["metrics"]["speech_fillers"]["samples"] == 0  # not 17 at one instant
    assert len(summary["stream_problems"]) == 17
    report = (out / "report" / "summary.txt").read_text()
    assert "17 unreadable lines in streams/speech_fillers.txt were skipped" in report
