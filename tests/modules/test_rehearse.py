"""Real rehearsals end to end: a recording through the real modules and the coach, and
``prezence up`` fed by files as if live (no microphone or camera needed)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("av", reason='the speech module needs PyAV: pip install "prezence[speech]"')
pytest.importorskip(
    "pocketsphinx", reason='the speech module needs pocketsphinx: pip install "prezence[speech]"'
)
pytest.importorskip("cv2", reason='the vision module needs OpenCV: pip install "prezence[vision]"')

from prezence.cli import main  # noqa: E402
from prezence.errors import ConfigError  # noqa: E402
from prezence.rehearse import rehearse  # noqa: E402
from prezence.session import read_jsonl  # noqa: E402

HERE = Path(__file__).parent
FAST = HERE / "material" / "rate_225.flac"  # 225 wpm, festival voice, 17.6 s
GESTURES = HERE / "material_video" / "gestures.mp4"


def test_rehearse_a_recording_gives_a_session_and_a_report(tmp_path: Path) -> None:
    result = rehearse(FAST, out=tmp_path / "s")
    m = result.summary["metrics"]["speech_speed"]
    assert m["samples"] >= 5
    assert 200.0 < m["p50"] < 250.0  # the recording's own pace, measured by the module
    assert len(read_jsonl(tmp_path / "s" / "decisions.jsonl")) == int(
        round(result.summary["talk_s"] / 0.5)
    )
    assert main(["report", str(tmp_path / "s")]) == 0
    assert (tmp_path / "s" / "report" / "report.html").exists()


def test_rehearse_refuses_what_is_not_a_recording(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("hello")
    with pytest.raises(ConfigError, match="notes.txt"):
        rehearse(notes, out=tmp_path / "s")


def test_rehearse_of_a_missing_file_names_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="nope.mp4: no such recording"):
        rehearse(tmp_path / "nope.mp4", out=tmp_path / "s")


@pytest.mark.slow
def test_up_with_file_inputs_runs_a_short_live_talk(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "live"
    argv = ["-q", "up", "--audio", str(FAST), "--video", str(GESTURES), "--backend", "fake"]
    assert main([*argv, "--duration", "19", "--out", str(out)]) == 0
    streams = out / "streams"
    assert (streams / "speech_speed.txt").read_text().strip()  # the speech module ran live
    assert (streams / "cv_gestures.txt").read_text().strip()  # and the vision module
    decisions = read_jsonl(out / "decisions.jsonl")
    assert decisions and decisions[-1]["t"] >= 18.0
    assert "session folder" in capsys.readouterr().out
