"""A rule with ``at=listener`` or ``offset=`` shows its values as judged (session 21, a tester's
walkthrough): the cue's reason, the decision log, the terminal table, ``summary.json`` and the
report said "73.2 is 204% below 60 dB SPL" while the rule judged 73.2 − 25.5 = 47.7 dB at the
back row. The recordings are stream files written by hand: 80 s at 73.2 dB at the microphone.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from prezence.cli import main
from prezence.session import read_jsonl

ROOM = Path(__file__).parents[2] / "examples" / "rooms" / "lecture_hall.toml"
AT_LISTENER = "at the farthest listener (25.5 dB less than at your microphone)"


def _replay(tmp_path: Path, rule: str, *room: str) -> Path:
    src = tmp_path / "rec"
    (src / "streams").mkdir(parents=True)
    (src / "streams" / "speech_volume.txt").write_text(
        "".join(f"{t} 73.2\n" for t in range(10, 91))
    )
    rules = tmp_path / "rules.txt"
    rules.write_text(f"speech_volume min 60 scale=6 louder {rule}\n")
    out = tmp_path / "out"
    args = ["replay", str(src), "--out", str(out), "--allocated", "90", "--config", str(rules)]
    assert main([*args, *room]) == 0
    return out


@pytest.fixture
def listener(tmp_path: Path) -> Path:
    return _replay(tmp_path, "at=listener", "--room", str(ROOM))


def test_a_listener_rules_cue_gives_the_value_at_the_listener_and_the_shift(
    listener: Path,
) -> None:
    cues = [c for c in read_jsonl(listener / "cues.jsonl") if c["command"] == "louder"]
    assert cues
    for c in cues:
        assert str(c["reason"]).startswith(
            "speech_volume 47.74 at the farthest listener (73.2 at the microphone − 25.5 dB) "
            "is 12.3 dB SPL below 60 dB SPL (204% of its 6 dB SPL scale) since 10.0 s"
        )  # the distance in the unit, then in scales: (60 − 47.74) / 6


def test_the_decision_log_holds_the_judged_value_and_the_offset(listener: Path) -> None:
    views = [
        m
        for d in read_jsonl(listener / "decisions.jsonl")
        for m in d["metrics"]
        if m["value"] is not None
    ]
    assert views
    assert all(m["value"] == pytest.approx(47.74, abs=0.01) for m in views)
    assert all(m["offset"] == pytest.approx(-25.46, abs=0.01) for m in views)


def test_the_table_and_summary_show_the_figures_at_the_listener(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    listener = _replay(tmp_path, "at=listener", "--room", str(ROOM))
    shown = capsys.readouterr().out
    assert "speech_volume             0%       -     47.74" in shown
    assert f"speech_volume: judged {AT_LISTENER}: its figures are there" in shown
    assert "(mean 73.2 dB SPL at your microphone)" in shown
    m = json.loads((listener / "summary.json").read_text())["metrics"]["speech_volume"]
    assert m["mean"] == pytest.approx(47.74, abs=0.01) and m["p90"] < 60.0
    assert m["measured_mean"] == pytest.approx(73.2)
    assert (m["at"], round(m["offset"], 2)) == ("listener", -25.46)


def test_the_report_names_the_band_at_the_listener(listener: Path) -> None:
    text = (listener / "report" / "summary.txt").read_text()
    assert (
        f"speak louder (your volume was below the lowest good value, 60 dB SPL {AT_LISTENER}, "
        "for 80 s in all)"
    ) in text
    assert "      48      48      48" in text  # mean, p10, p90 at the listener, not 73
    html = (listener / "report" / "report.html").read_text()
    assert f"≥ 60 dB SPL {AT_LISTENER}" in html
    assert (
        f"volume was below the lowest good value, 60 dB SPL {AT_LISTENER}; 47.7 dB SPL there, "
        "73.2 at your microphone"
    ) in html


def test_a_replay_of_the_replay_still_judges_and_says_it_at_the_listener(
    listener: Path, tmp_path: Path
) -> None:
    # config.toml keeps at = "listener" with its room: the offset, and the words, come back
    assert 'at = "listener"' in (listener / "config.toml").read_text()
    again = tmp_path / "again"
    assert main(["-q", "replay", str(listener), "--out", str(again), "--no-report"]) == 0
    reasons = [c["reason"] for c in read_jsonl(again / "cues.jsonl") if c["command"] == "louder"]
    assert reasons == [c["reason"] for c in read_jsonl(listener / "cues.jsonl") if c["metric"]]


def test_a_plain_offset_is_named_in_neutral_words(tmp_path: Path) -> None:
    out = _replay(tmp_path, "offset=-25.5")
    reason = next(c["reason"] for c in read_jsonl(out / "cues.jsonl") if c["command"] == "louder")
    assert reason.startswith(
        "speech_volume 47.7 after the rule's offset of −25.5 (73.2 measured) is 12.3 dB SPL "
        "below 60 dB SPL (205% of its 6 dB SPL scale)"
    )
    text = (out / "report" / "summary.txt").read_text()
    assert "below the lowest good value, 60 dB SPL after the rule's offset of −25.5, for" in text
    assert "judged after the rule's offset of −25.5: its figures are after it" in text


def test_what_the_coach_stopped_repeating_is_recorded_as_judged(tmp_path: Path) -> None:
    # session 21's review: summary.json's stopped_repeating gave the microphone's 73.2 against
    # a band at the listener, the one value of such a rule still shown as measured
    src = tmp_path / "rec"
    (src / "streams").mkdir(parents=True)
    (src / "streams" / "speech_volume.txt").write_text(
        "".join(f"{t} 73.2\n" for t in range(10, 301))
    )
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_volume min 60 scale=6 louder at=listener\n")
    out = tmp_path / "out"
    args = ["-q", "replay", str(src), "--out", str(out), "--allocated", "300"]
    assert main([*args, "--config", str(rules), "--room", str(ROOM), "--no-report"]) == 0
    stopped = json.loads((out / "summary.json").read_text())["stopped_repeating"]
    assert stopped and all(s["metric"] == "speech_volume" for s in stopped)
    assert all(s["value"] == pytest.approx(73.2 - 25.46, abs=0.01) for s in stopped)
    assert all(s["offset"] == pytest.approx(-25.46, abs=0.01) for s in stopped)
