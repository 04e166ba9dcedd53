"""Session 22, a researcher's walkthrough: ``prezence replay`` of the peers' workload folder
(mkload.py: ``rules.conf``, ``room.toml`` and streams named ``volume.txt``, ``gesture_rate.txt``)
judged it under Prezence's default rules without a word: two of its five streams and its rules
were left aside, and pz16 gave 1067 cues where the peers give 1614."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest

from prezence.cli import main
from prezence.synthetic.runner import run_talk

RULES = """\
speech_speed inRange 140 180 below=speedUp above=slowDown
volume min 60 below=louder
cv_headGaze min ANGLE below=lookUp
gesture_rate inRange 2 12 below=gestureMore above=gestureLess
"""


def _peers_folder(root: Path) -> Path:
    src = root / "load"
    (src / "streams").mkdir(parents=True)
    streams = {
        "speech_speed": lambda t: 220.0 if t % 60 < 20 else 160.0,
        "volume": lambda t: 50.0 if t % 90 < 30 else 64.0,
        "cv_headGaze": lambda t: -5.0,
        "gesture_rate": lambda t: 6.0,
    }
    for name, f in streams.items():
        text = "".join(f"{t:.1f} {f(t):.3f}\n" for t in range(0, 300))
        (src / "streams" / f"{name}.txt").write_text(text)
        (src / f"{name}.txt").write_text(text)
    (src / "rules.conf").write_text(RULES)
    (src / "room.toml").write_text("format = 1\n[room.values]\nANGLE = -15.0\n")
    (src / "notes.txt").write_text("how this folder was made\n")  # not a stream: not named
    return src


def _replay_warnings(caplog: pytest.LogCaptureFixture, *argv: str) -> list[str]:
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="prezence.replay"):
        assert main(["replay", *argv, "--no-report"]) == 0
    return [r.getMessage() for r in caplog.records if r.name == "prezence.replay"]


def test_a_foreign_folders_unread_streams_and_unused_rules_are_said(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    src = _peers_folder(tmp_path)
    said = _replay_warnings(caplog, str(src), "--policy", "pz16", "--out", str(tmp_path / "a"))
    assert len(said) == 2, said
    assert said[0].startswith(f"{src}: gesture_rate.txt, volume.txt: stream file(s) no rule reads")
    assert f"{src / 'rules.conf'}: not used (the rules are Prezence's default rules)" in said[1]
    assert f"pass --config {src / 'rules.conf'} --room {src / 'room.toml'}" in said[1]
    # given as said: no warning, every stream judged
    said = _replay_warnings(
        caplog, str(src), "--policy", "pz16", "--out", str(tmp_path / "b"),
        "--config", str(src / "rules.conf"), "--room", str(src / "room.toml"),
    )  # fmt: skip
    assert said == []
    assert (tmp_path / "b" / "streams" / "volume.txt").exists()


def test_a_prezence_session_folders_replay_warns_of_nothing(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    rec = tmp_path / "demo"
    run_talk("demo", out=rec, seed=3, backend="fake")
    # every stream a Prezence module writes, judged or not (the camera's gesture source too)
    for name in ("cv_headYaw", "cv_gestures_source", "speech_snr", "speech_activity"):
        (rec / "streams" / f"{name}.txt").write_text("1.0 0.5\n2.0 0.5\n")
    assert _replay_warnings(caplog, str(rec), "--out", str(tmp_path / "r")) == []
