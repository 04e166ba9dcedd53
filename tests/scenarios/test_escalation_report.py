"""What the coach stopped repeating reaches the summary, the report and the robot's last words.

The fast talker ignores "slow down": the default policy gives up after two unheeded cues
(escalation) and must then say so once at the end, not silently drop the subject.
"""

from __future__ import annotations

import json
from pathlib import Path

from prezence.synthetic.runner import run_talk


def test_an_unheeded_cue_is_said_once_at_the_end_and_reported(tmp_path: Path) -> None:
    out = tmp_path / "s"
    result = run_talk("fast_talker", out=out, report=True)
    notes = result.summary["stopped_repeating"]
    assert [n["metric"] for n in notes] == ["speech_speed"]
    stopped_at = notes[0]["t"]
    # no slowDown cue after the coach stopped repeating it
    assert not [c for c in result.cues if c["command"] == "slowDown" and c["t"] > stopped_at]
    spoken = (out / "report" / "spoken.txt").read_text()
    assert "stopped reminding you about your pace" in spoken
    report = json.loads((out / "report" / "report.json").read_text())
    assert [n["metric"] for n in report["stopped_repeating"]] == ["speech_speed"]
    assert (
        "stopped reminding you about your <b>pace</b>"
        in (out / "report" / "report.html").read_text()
    )


def test_a_talk_where_every_cue_worked_stops_repeating_nothing(tmp_path: Path) -> None:
    result = run_talk("quiet_speaker", out=tmp_path / "s", report=True)
    assert "stopped_repeating" not in result.summary
    assert "stopped reminding" not in (tmp_path / "s" / "report" / "spoken.txt").read_text()
