"""A clarity cue in a noisy room names the noise (session 21): the robot's phrase, the cue's
record, the decision log and the report's advice, from the speech module's ``speech_snr``.

The recordings here are stream files written by hand (what the speech module writes: a
clarity and an SNR per word window); tests/modules/test_rehearse.py runs the real module.
"""

from __future__ import annotations

import json
from pathlib import Path

from prezence.cli import main
from prezence.feedback.commands import get_command
from prezence.session import read_jsonl

PLAIN = get_command("articulate").phrase
NOISY = get_command("articulate").phrase_noisy


def _recording(
    tmp_path: Path, snr: list[tuple[float, float]] | None, metric: str = "speech_accuracy"
) -> Path:
    """90 s of clarity at 0.2 (a cue's worth after about 20 s), and the SNR per ``(until_t,
    dB)`` stretch (None: no speech_snr stream, a recording made before session 21)."""
    src = tmp_path / "rec"
    (src / "streams").mkdir(parents=True)
    ts = range(10, 91)
    (src / "streams" / f"{metric}.txt").write_text("".join(f"{t} 0.2\n" for t in ts))
    if snr is not None:
        rows = [f"{t} {next(db for until, db in snr if t <= until)}\n" for t in ts]
        (src / "streams" / "speech_snr.txt").write_text("".join(rows))
    return src


def _replay(src: Path, out: Path, *extra: str) -> list[dict[str, object]]:
    assert main(["-q", "replay", str(src), "--out", str(out), "--allocated", "90", *extra]) == 0
    return read_jsonl(out / "cues.jsonl")


def test_a_clarity_cue_in_a_noisy_room_names_the_noise(tmp_path: Path) -> None:
    cues = _replay(_recording(tmp_path, [(90, 9.0)]), tmp_path / "out")
    said = [c for c in cues if c["command"] == "articulate"]
    assert NOISY is not None and "noisy" in NOISY.lower()
    assert said and all(c["phrase"] == NOISY for c in said)
    assert all(c["params"] == {"noisy": True, "snr_db": 9.0} for c in said)
    logged = [
        d for d in read_jsonl(tmp_path / "out" / "decisions.jsonl") if d["winner"] == "articulate"
    ]
    assert len(logged) == len(said)
    assert all(
        "the room is noisy or echoing (estimated SNR 9 dB" in str(d["reason"]) for d in logged
    )
    assert all(d["cue"]["params"]["snr_db"] == 9.0 for d in logged)
    report = json.loads((tmp_path / "out" / "report" / "report.json").read_text())
    (row,) = [p for p in report["priorities"] if p["metric"] == "speech_accuracy"]
    # all of the low clarity came in noise: the advice is the room's, not the articulation's
    assert "quieter" in row["advice"] and "articulate" not in row["advice"]
    assert "for all of it the room was noisy or echoing" in row["noise"]
    assert "not your articulation" in row["noise"]
    text = (tmp_path / "out" / "report" / "summary.txt").read_text()
    assert "the room was noisy or echoing (estimated SNR under 15 dB)" in text
    assert "quieter" in (tmp_path / "out" / "report" / "spoken.txt").read_text()


def test_a_clarity_cue_in_a_quiet_room_asks_for_clearer_speech(tmp_path: Path) -> None:
    cues = _replay(_recording(tmp_path, [(90, 30.0)]), tmp_path / "out")
    said = [c for c in cues if c["command"] == "articulate"]
    assert said and all(c["phrase"] == PLAIN and "noisy" not in c["params"] for c in said)
    report = json.loads((tmp_path / "out" / "report" / "report.json").read_text())
    (row,) = [p for p in report["priorities"] if p["metric"] == "speech_accuracy"]
    assert row["advice"] == "articulate more clearly" and "noise" not in row


def test_the_report_says_how_much_of_a_low_clarity_came_in_noise(tmp_path: Path) -> None:
    # noisy for the first 30 s of the 80 s clarity read low: said, but the advice stays
    _replay(_recording(tmp_path, [(39, 9.0), (90, 30.0)]), tmp_path / "out", "--no-report")
    assert main(["-q", "report", str(tmp_path / "out")]) == 0
    report = json.loads((tmp_path / "out" / "report" / "report.json").read_text())
    (row,) = [p for p in report["priorities"] if p["metric"] == "speech_accuracy"]
    assert row["advice"] == "articulate more clearly"
    assert row["noisy_s"] == 30.0
    assert row["noise"].startswith(
        "clarity read low for 1:20; for 0:30 of it the room was noisy or echoing"
    )
    assert row["noise"].endswith("rehearse somewhere quieter or nearer the microphone")


def test_a_recording_without_the_snr_stream_is_coached_as_before(tmp_path: Path) -> None:
    cues = _replay(_recording(tmp_path, None), tmp_path / "out")
    said = [c for c in cues if c["command"] == "articulate"]
    assert said and all(c["phrase"] == PLAIN and c["params"] == {} for c in said)
    report = json.loads((tmp_path / "out" / "report" / "report.json").read_text())
    (row,) = [p for p in report["priorities"] if p["metric"] == "speech_accuracy"]
    assert row["advice"] == "articulate more clearly" and "noise" not in row


def test_articulate_on_a_metric_of_your_own_is_not_about_the_noise(tmp_path: Path) -> None:
    # only the speech module's clarity falls with the room's noise: a rule of one's own that
    # cues `articulate` on another metric says the plain phrase in a noisy room too
    src = _recording(tmp_path, [(90, 9.0)], metric="my_clarity")
    rules = tmp_path / "rules.txt"
    rules.write_text("my_clarity min 0.5 articulate\n")
    cues = _replay(src, tmp_path / "out", "--config", str(rules))
    said = [c for c in cues if c["command"] == "articulate"]
    assert said and all(c["metric"] == "my_clarity" for c in said)
    assert all(c["phrase"] == PLAIN and "noisy" not in c["params"] for c in said)
