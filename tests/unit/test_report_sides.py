"""What the report says of a metric out on both sides of its band, of how much of the talk each
metric covered, and which list a metric goes in (session 20's report faults), read as the
speaker reads them: summary.txt, report.html, the spoken summary, the timeline plot."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable
from itertools import pairwise
from pathlib import Path
from typing import Any

import pytest

from prezence.config.model import Check, Config, Rule, TimeSettings
from prezence.config.tomlconf import dumps_config
from prezence.report import build_report, summary_phrase, write_report
from prezence.report.speech import format_text
from prezence.session import SessionDir

SPEED = Rule(
    "speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp", above="slowDown", unit="wpm"
)
VOLUME = Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder", unit="dB")
#: head pitch goes stale 2 s after its last sample: a camera that stops is no data after that
GAZE = Rule(
    "cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp", unit="deg", stale_after_s=2.0
)
CONFIG = Config(rules=(SPEED, VOLUME, GAZE), time=TimeSettings(allocated_s=None))


def talk(
    root: Path,
    talk_s: int,
    values: dict[str, tuple[Iterable[int], Callable[[int], float]]],
    cues: Iterable[dict[str, Any]] = (),
) -> SessionDir:
    """A finished talk of ``talk_s`` seconds: per metric, one sample a second at the times
    given (each holds 1 s), and the cues given."""
    session = SessionDir(root).create()
    session.config.write_text(dumps_config(CONFIG))
    session.write_meta({"talk_s": float(talk_s), "kind": "live"})
    for metric, (times, value) in values.items():
        session.stream(f"{metric}.txt").write_text("".join(f"{t} {value(t)}\n" for t in times))
    session.cues.write_text("".join(json.dumps(c) + "\n" for c in cues))
    session.summary.write_text(json.dumps({"ended_at_s": float(talk_s)}))
    return session


def cue(t: float, command: str, metric: str, deviation: float) -> dict[str, Any]:
    return {
        "t": t,
        "command": command,
        "metric": metric,
        "kind": "weighted",
        "reason": "...",
        "params": {},
        "onset": t - 10.0,
        "deviation": deviation,
        "phrase": "...",
        "dropped": False,
    }


def pace_both_ways(t: int) -> float:
    """Too slow for 60 s (120 wpm), too fast for 30 s (210 wpm), then in range for 30 s."""
    return 120.0 if t < 60 else 210.0 if t < 90 else 160.0


def test_time_above_the_band_is_said_as_above_with_its_own_seconds(tmp_path: Path) -> None:
    # A 592 s rehearsal said "your pace was below 140 wpm for 257 s in all": 257 s was all the
    # time out of range, 71 of it above 180 wpm, and nothing told the speaker they were ever
    # too fast.
    steady = (range(120), lambda t: 66.0)
    session = talk(
        tmp_path / "t",
        120,
        {"speech_speed": (range(120), pace_both_ways), "speech_volume": steady},
        [cue(30.0, "speedUp", "speech_speed", 14.0)],
    )
    report = build_report(session.root)
    said = (
        "your pace was below the lowest good value, 140 wpm, for 60 s and above the highest "
        "good value, 180 wpm, for 30 s"
    )
    text = format_text(report)
    assert said in text and "for 90 s" not in text
    [pri] = report["priorities"]
    m = report["metrics"]["speech_speed"]
    assert (m["below_s"], m["above_s"]) == (pytest.approx(60.0), pytest.approx(30.0))
    assert "pick up the pace" in pri["advice"] and "slow down" in pri["advice"]
    page = write_report(session.root).read_text()
    assert said[1:] in page and "slow down" in page
    assert "slow down" in summary_phrase(report)


def test_a_little_off_on_both_sides_names_both_with_their_own_shares(tmp_path: Path) -> None:
    # a little slow for 15 s, a little fast for 10 s of 100 s: too little to work on, but
    # the "a little off" line said "below 140 wpm 25%" for both
    def pace(t: int) -> float:
        return 125.0 if t < 15 else 200.0 if 50 <= t < 60 else 150.0  # beyond the 8 % error

    session = talk(tmp_path / "t", 100, {"speech_speed": (range(100), pace)})
    report = build_report(session.root)
    assert report["priorities"] == []
    [off] = report["slightly_off"]
    assert off["share_out"] == pytest.approx(0.25)
    text = format_text(report)
    assert "your pace was below 140 wpm 15% and above 180 wpm 10% of the time" in text
    assert "slow down" in text and "pick up the pace" in text


def test_readings_out_by_less_than_the_measuring_error_are_not_advised_on(tmp_path: Path) -> None:
    # Session 23's verification: a LibriVox reader at a true 158 wpm, with one pause, read
    # 135-137 for 49 s of 120 around it (41 %) and was told "a little under the ideal range
    # 41% of the time: pick up the pace"; the pace is measured to 8 %, 140 - 8 % = 128.8
    def pace(t: int) -> float:
        return 136.0 if 20 <= t < 61 else 150.0

    def gaze(t: int) -> float:
        # 1.5 degrees under -15 (15 % of its 10 degree scale: 450 %.s, under a cue's worth)
        return -16.5 if 60 <= t < 90 else 0.0

    session = talk(
        tmp_path / "t", 100, {"speech_speed": (range(100), pace), "cv_headGaze": (range(100), gaze)}
    )
    report = build_report(session.root)
    assert report["priorities"] == [] and report["slightly_off"] == []
    m = report["metrics"]["speech_speed"]
    assert m["out_of_range_s"] == pytest.approx(41.0)
    assert m["within_error_s"] == pytest.approx(41.0)
    assert report["metrics"]["cv_headGaze"]["within_error_s"] == pytest.approx(30.0)
    near = {r["metric"]: r for r in report["near_range"]}
    assert near["speech_speed"]["within_error_s"] == pytest.approx(41.0)
    text = format_text(report)
    assert "pick up the pace" not in text and "look up" not in text
    assert (
        "pace was under 140 wpm for 41 s (41% of the time it was measured), all of it by less "
        "than the measurement's error (8%)"
    ) in text
    assert "all of it by less than the measurement's error (5 degrees)" in text
    said = summary_phrase(report)
    assert "pick up the pace" not in said and "Well done!" in said
    assert (
        "Your pace was under its ideal range for 41 seconds, by less than my measuring error."
        in said
    )

    # the same share out by more than the error is still "a little off", and the time within
    # the error does not count toward it: 25 s beyond of 41 s out is still 25 %
    def beyond(t: int) -> float:
        return 125.0 if 20 <= t < 45 else 136.0 if 45 <= t < 61 else 150.0

    session = talk(tmp_path / "u", 100, {"speech_speed": (range(100), beyond)})
    report = build_report(session.root)
    [off] = report["slightly_off"]
    assert off["metric"] == "speech_speed" and "pick up the pace" in off["advice"]
    assert report["metrics"]["speech_speed"]["within_error_s"] == pytest.approx(16.0)


def test_a_reading_under_the_band_most_of_the_talk_is_advised_on_beyond_the_error(
    tmp_path: Path,
) -> None:
    # out of its band for over half its measured time, the median reading is out: advised on
    # when it is out by more than the measurement's error (136 all talk, within it, is said
    # as what the module cannot tell since session 25: test_report_edge.py)
    session = talk(tmp_path / "t", 100, {"speech_speed": (range(100), lambda t: 125.0)})
    report = build_report(session.root)
    assert report["metrics"]["speech_speed"]["within_error_s"] == pytest.approx(0.0)
    [pri] = report["priorities"]
    assert pri["metric"] == "speech_speed" and "pick up the pace" in pri["advice"]
    session = talk(tmp_path / "u", 100, {"speech_speed": (range(100), lambda t: 136.0)})
    report = build_report(session.root)
    assert report["metrics"]["speech_speed"]["within_error_s"] == pytest.approx(100.0)
    assert report["priorities"] == [] and report["at_edge"][0]["metric"] == "speech_speed"


def test_a_metric_out_half_the_talk_and_cued_is_not_a_little_off(tmp_path: Path) -> None:
    # The video run: pace out of range 54 % of the time and cued by the robot was listed
    # under "A little off, not enough to work on first", below two metrics with larger
    # scores, as only two were kept to work on.
    session = talk(
        tmp_path / "t",
        100,
        {
            "speech_speed": (range(100), lambda t: 130.0 if t < 60 else 160.0),  # 7 % under
            "speech_volume": (range(100), lambda t: 50.0 if t < 30 else 66.0),  # far under
            "cv_headGaze": (range(100), lambda t: -25.0 if t < 20 else 0.0),  # far down
        },
        [cue(40.0, "speedUp", "speech_speed", 7.0)],
    )
    report = build_report(session.root)
    assert report["slightly_off"] == []
    assert {p["metric"] for p in report["priorities"]} == {
        "speech_speed",
        "speech_volume",
        "cv_headGaze",
    }
    text = format_text(report)
    assert "A little off" not in text and "pick up the pace" in text
    page = write_report(session.root).read_text()
    assert "A little off" not in page and "Pick up the pace" in page


def test_out_of_range_most_of_the_talk_never_reads_nothing_was_far_off(tmp_path: Path) -> None:
    # "Nothing was far off, but:" directly above "above 180 wpm 65% of the time": a pace a
    # little too fast for most of the talk, never cued, too little for a cue's worth (200 wpm,
    # beyond the pace's 8 % error: 185 would be within it, said as such since session 25)
    session = talk(
        tmp_path / "t", 100, {"speech_speed": (range(100), lambda t: 200.0 if t < 65 else 170.0)}
    )
    report = build_report(session.root)
    assert [p["metric"] for p in report["priorities"]] == ["speech_speed"]
    text = format_text(report)
    assert "far off" not in text and "A little off" not in text
    assert "above the highest good value, 180 wpm, for 65 s" in text
    assert "Nothing was far off" not in summary_phrase(report)


def test_each_metric_says_over_how_much_of_the_talk_it_was_measured(tmp_path: Path) -> None:
    # The picture of a 54 s video stopped at 0:20: "gestures 100 %" and "Every metric stayed
    # in its ideal range. Well done." The camera here stops after 15 s of a 60 s talk, and
    # the pace has a 20 s silence (no sample) in the middle.
    session = talk(
        tmp_path / "t",
        60,
        {
            "speech_speed": ([t for t in range(60) if not 20 <= t < 40], lambda t: 160.0),
            "speech_volume": (range(60), lambda t: 66.0),
            "cv_headGaze": (range(14), lambda t: 0.0),  # the last holds its 2 s: to 0:15
        },
    )
    report = build_report(session.root)
    assert report["priorities"] == [] and report["slightly_off"] == []
    text = format_text(report)
    assert "Every metric stayed in its ideal range." not in text and "Well done" not in text
    assert "head pitch measured over 0:15 of 1:00" in text
    rows = {line.split()[0]: line for line in text.splitlines() if "of 1:00" in line}
    assert "0:15 of 1:00" in rows["head"] and "1:00 of 1:00" in rows["volume"]
    # the pace's last sample before the silence holds its staleness, then there is no data
    stale = float(report["metrics"]["speech_speed"]["stale_after_s"])
    covered = 40 - 1 + min(stale, 21.0)
    assert f"{int(covered) // 60}:{int(covered) % 60:02d} of 1:00" in rows["pace"]
    phrase = summary_phrase(report)
    assert "Well done" not in phrase and "head pitch" in phrase and "only part" in phrase
    page = write_report(session.root).read_text()
    assert "Well done" not in page and "head pitch measured over 0:15 of 1:00" in page


def test_the_wait_for_the_first_window_is_not_called_measuring_only_part_of_the_talk(
    tmp_path: Path,
) -> None:
    # Session 23, a student's own recordings: every clean talk ended "…but I measured your
    # pace and clarity for only part of the talk": the speech module's first values come
    # after its 10 s window fills (volume at 0:10, pace at 0:12), 96 s of a 108 s talk. A
    # first-time user read it as a fault. A real gap (the voice lost for 20 s) still is one.
    clean = talk(
        tmp_path / "clean",
        108,
        {
            "speech_speed": (range(12, 108), lambda t: 160.0),
            "speech_volume": (range(10, 108), lambda t: 66.0),
        },
    )
    report = build_report(clean.root)
    phrase = summary_phrase(report)
    assert "only part" not in phrase and "Well done" in phrase, phrase
    text = format_text(report)
    assert "stayed in its ideal range." in text and "measured over" not in text, text
    short = talk(  # volume from 0:10 of a minute: 83 % of the talk, all of it after 0:10
        tmp_path / "short",
        60,
        {
            "speech_speed": (range(12, 60), lambda t: 160.0),
            "speech_volume": (range(10, 60), lambda t: 66.0),
        },
    )
    phrase = summary_phrase(build_report(short.root))
    assert "only part" not in phrase and "Well done" in phrase, phrase
    brief = talk(  # a 25 s talk: pace from 0:12 is 13 s of the 15 s after the window (review)
        tmp_path / "brief",
        25,
        {
            "speech_speed": (range(12, 25), lambda t: 160.0),
            "speech_volume": (range(10, 25), lambda t: 66.0),
        },
    )
    phrase = summary_phrase(build_report(brief.root))
    assert "only part" not in phrase, phrase
    gap = talk(
        tmp_path / "gap",
        108,
        {
            "speech_speed": ([t for t in range(12, 108) if not 50 <= t < 70], lambda t: 160.0),
            "speech_volume": (range(10, 108), lambda t: 66.0),
        },
    )
    report = build_report(gap.root)
    assert "pace for only part of the talk" in summary_phrase(report)
    assert "pace measured over" in format_text(report)


def test_the_timeline_breaks_its_line_where_there_was_no_data(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The timelines drew a straight line across a 40 s silence: it looked measured.
    pytest.importorskip("matplotlib")
    from matplotlib.axes import Axes

    drawn: list[tuple[list[float], list[float]]] = []
    plot = Axes.plot

    def spy(self: Axes, *args: Any, **kw: Any) -> Any:
        if len(args) >= 2:
            drawn.append((list(args[0]), list(args[1])))
        return plot(self, *args, **kw)

    monkeypatch.setattr(Axes, "plot", spy)
    session = talk(
        tmp_path / "t",
        100,
        {"speech_speed": ([t for t in range(100) if not 30 <= t < 70], lambda t: 160.0)},
    )
    write_report(session.root)
    [(xs, ys)] = drawn
    # no segment of the line spans the silence: a break (NaN) between 0:29 and 1:10
    segments = [
        (a, b)
        for (a, ya), (b, yb) in pairwise(zip(xs, ys, strict=True))
        if not (math.isnan(ya) or math.isnan(yb))
    ]
    assert not any(a < 35.0 and b > 65.0 for a, b in segments)
    assert any(math.isnan(y) for y in ys)


def test_a_voice_first_heard_a_minute_in_is_said_with_the_time_used(tmp_path: Path) -> None:
    # Session 20, a tester: 60 s of silence, then 51 s of speech: "You used 1:51 of 2:00", and
    # nothing said that speech began at 1:00 (the robot said "1 min left" before a word).
    session = talk(
        tmp_path / "s",
        111,
        {
            "speech_activity": (range(1, 112), lambda t: 0.0 if t < 61 else 0.9),
            "speech_speed": (range(70, 112), lambda t: 160.0),
        },
    )
    session.config.write_text(dumps_config(Config(rules=(SPEED,), time=TimeSettings(120.0))))
    report = build_report(session.root)
    assert report["time"]["first_voice_s"] == 61.0
    text = format_text(report)
    assert "Your first words came 1 minute in, and the time counts from the start." in text
    # a voice from the start is not remarked on
    early = talk(
        tmp_path / "e",
        111,
        {
            "speech_activity": (range(1, 112), lambda t: 0.9),
            "speech_speed": (range(10, 112), lambda t: 160.0),
        },
    )
    assert "first_voice_s" not in build_report(early.root)["time"]
    assert "first words" not in format_text(build_report(early.root))


def _said_with_late_start(first: str, then: str) -> str:
    """The spoken summary of a talk whose voice began 61 s in, with two things to work on."""
    time_used = {"used_s": 111.0, "allocated_s": 120.0, "over_under_pct": -7.5}
    return summary_phrase(
        {
            "time": {**time_used, "first_voice_s": 61.0},
            "priorities": [{"advice": first}, {"advice": then}],
        }
    )


def test_the_spoken_summary_drops_whole_sentences_never_half_of_one() -> None:
    # Session 20: a long phrase was cut at 40 words, "…but I measured only part of."
    said = _said_with_late_start(
        "pick up the pace and say each sentence as if to the back row of the hall",
        "look up at your audience from your notes at the end of each sentence",
    )
    assert len(said.split()) <= 40
    assert said.endswith(("row of the hall.", "each sentence.")), said
    assert "first words" not in said  # the least important sentence went first


def test_the_late_first_words_are_the_first_sentence_left_out() -> None:
    # Session 20, review: the late-start sentence was dropped last, after "Then: …".
    said = _said_with_late_start(
        "pick up the pace a little and breathe between sentences", "look up at your audience"
    )
    assert "Then: look up at your audience." in said, said
    assert "first words" not in said
    assert len(said.split()) <= 40


@pytest.mark.parametrize(("last_voice", "still"), [(118, True), (60, False)])
def test_a_talk_the_time_limit_stopped_is_said_to_go_on_only_if_a_voice_was_still_heard(
    tmp_path: Path, last_voice: int, still: bool
) -> None:
    # Session 20, review: a microphone's module runs on after the speaker has finished, so a
    # live talk left running to the limit was told "You were still going" minutes after the
    # last word.
    session = talk(
        tmp_path / "s",
        120,
        {
            "speech_activity": (range(1, 121), lambda t: 0.9 if t <= last_voice else 0.0),
            "speech_speed": (range(30, last_voice + 1), lambda t: 160.0),
        },
    )
    session.config.write_text(dumps_config(Config(rules=(SPEED,), time=TimeSettings(90.0))))
    session.summary.write_text(
        json.dumps({"ended_at_s": 120.0, "stopped_at_time_limit": {"at_s": 120.0, "grace_s": 30.0}})
    )
    report = build_report(session.root)
    assert bool(report["time"].get("stopped_at_limit")) is still
    said = summary_phrase(report)
    assert said.startswith("You were still going") is still, said


# -- session 21, a tester's walkthrough ----------------------------------------------------------


def test_a_metric_out_of_range_for_a_little_of_the_talk_is_not_praised_as_in_range(
    tmp_path: Path,
) -> None:
    # pace under 140 wpm for 8 s of 42 s (19 %): too little to be "a little off", and the
    # report said "Every judged metric stayed in its ideal range" over the table that showed it
    steady = (range(42), lambda t: 66.0)
    pace = (range(42), lambda t: 125.0 if 30 <= t < 38 else 160.0)
    gaze = (range(42), lambda t: 0.0)
    session = talk(
        tmp_path / "t", 42, {"speech_speed": pace, "speech_volume": steady, "cv_headGaze": gaze}
    )
    write_report(session.root, config=CONFIG, plots=False)
    report = json.loads((session.root / "report" / "report.json").read_text())
    assert report["priorities"] == [] and report["slightly_off"] == []
    text = (session.root / "report" / "summary.txt").read_text()
    assert "stayed in its ideal range" not in text
    assert (
        "Every metric stayed in or near its ideal range: pace was under 140 wpm for 8 s "
        "(19% of the time it was measured)."
    ) in text
    page = (session.root / "report" / "report.html").read_text()
    assert "stayed in its ideal range" not in page and "under 140 wpm for 8 s" in page
    said = summary_phrase(report)
    assert "stayed in the ideal range" not in said
    assert said.endswith(
        "Your delivery stayed in or near the ideal range. Well done! "
        "Your pace was under its ideal range for 8 seconds."
    )


def test_praise_says_in_range_only_when_every_metric_was(tmp_path: Path) -> None:
    steady = (range(42), lambda t: 66.0)
    pace = (range(42), lambda t: 160.0)
    gaze = (range(42), lambda t: 0.0)
    session = talk(
        tmp_path / "t", 42, {"speech_speed": pace, "speech_volume": steady, "cv_headGaze": gaze}
    )
    write_report(session.root, config=CONFIG, plots=False)
    report = json.loads((session.root / "report" / "report.json").read_text())
    assert report["near_range"] == []
    assert "Every metric stayed in its ideal range." in format_text(report)
    assert summary_phrase(report).endswith("Your delivery stayed in the ideal range. Well done!")


def _music_intro(root: Path, *, reasons: bool) -> SessionDir:
    """A 2:03 rehearsal after 16 s of music, as the speech module wrote it (issue 11's
    student): no voice heard until 0:16, too little talk to time until 0:23, then the music
    next to the words until 0:54, when the pace comes; with the module's reason codes or (an
    older folder) without."""
    codes = {t: 2.0 for t in range(10, 16)}
    codes |= {t: 3.0 for t in range(16, 23)} | {t: 5.0 for t in range(23, 54)}
    values: dict[str, tuple[Iterable[int], Callable[[int], float]]] = {
        "speech_speed": (range(54, 123), lambda t: 160.0),
        "speech_volume": (range(16, 123), lambda t: 66.0),
        "speech_activity": (range(10, 123), lambda t: 0.0 if t < 16 else 0.9),
    }
    if reasons:
        values["speech_untimed_reason"] = (sorted(codes), codes.__getitem__)
    return talk(root, 123, values)


def test_a_pace_measured_over_part_of_the_talk_says_why_where_the_module_did(
    tmp_path: Path,
) -> None:
    # issue 11: "pace measured over 1:09 of 2:03" and the robot "…only part of the talk",
    # with the reason only in speech.log. The module's reason codes now say it.
    report = build_report(_music_intro(tmp_path / "m", reasons=True).root)
    text = format_text(report)
    assert (
        "pace measured over 1:09 of 2:03 (music or noise next to the words for 0:31, "
        "no voice for 0:16, too little speech yet to time for 0:07)"
    ) in text, text
    phrase = summary_phrase(report)
    assert phrase.endswith("only part of the talk. Music or noise was near your words."), phrase
    assert len(phrase.split()) <= 40
    page = write_report(report["session"]).read_text()
    assert "music or noise next to the words for 0:31" in page
    # an older folder, without the codes, keeps today's words
    old = build_report(_music_intro(tmp_path / "o", reasons=False).root)
    assert "pace measured over 1:09 of 2:03." in format_text(old)
    assert summary_phrase(old).endswith("only part of the talk.")
    # a clean talk: the codes of its first seconds (too little talk yet) are said nowhere
    clean = talk(
        tmp_path / "c",
        108,
        {
            "speech_speed": (range(12, 108), lambda t: 160.0),
            "speech_volume": (range(10, 108), lambda t: 66.0),
            "speech_untimed_reason": ([10, 11], lambda t: 3.0),
        },
    )
    report = build_report(clean.root)
    assert "too little" not in format_text(report) and "only part" not in summary_phrase(report)


def test_a_reason_for_no_pace_does_not_hold_past_its_modules_death() -> None:
    # session 24's review: the last reason line held up to the stale time into the no-data span
    # its module's death made, so a crash read as "music or noise next to the words"
    from prezence.report.build import untimed_seconds
    from prezence.samples import Sample

    reasons = [
        Sample("speech_untimed_reason", float(t), 2.0 if t < 16 else 5.0) for t in range(10, 20)
    ]
    got = untimed_seconds(reasons, [], 60.0, 60.0, [20.0], first_after_s=10.0)
    assert got == [{"code": 2, "s": 16.0}, {"code": 5, "s": 4.0}]


def test_a_cues_worth_of_deviation_is_advised_on_only_beyond_the_measuring_error(
    tmp_path: Path,
) -> None:
    # session 24's rule counted every reading out towards a cue's worth (600 %.s): head pitch
    # 3 degrees under -15 (30 % of its 10 degree scale) for 30 s of 100 is 900 %.s, and was
    # "look up", on readings each within the head pose's 5 degrees of the bound, with the
    # median in range. Since session 26 only readings beyond the error add up (a live cue on
    # them still lists it: the robot said it)
    gaze = (range(100), lambda t: -18.0 if 60 <= t < 90 else 0.0)
    session = talk(tmp_path / "t", 100, {"cv_headGaze": gaze})
    report = build_report(session.root)
    assert report["metrics"]["cv_headGaze"]["within_error_s"] == pytest.approx(30.0)
    assert report["priorities"] == []
    assert [n["metric"] for n in report["near_range"]] == ["cv_headGaze"]
    # 6 degrees under (beyond the error) for 20 s of 100 is 1200 %.s: worked on
    gaze = (range(100), lambda t: -21.0 if 60 <= t < 80 else 0.0)
    report = build_report(talk(tmp_path / "u", 100, {"cv_headGaze": gaze}).root)
    [pri] = report["priorities"]
    assert pri["metric"] == "cv_headGaze" and "look up" in pri["advice"]
