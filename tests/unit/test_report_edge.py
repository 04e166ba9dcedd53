"""Issue 11, session 25: a metric whose median reading lies out of its band by less than the
measurement's error is not stated as out.

Session 24's tester: a true 143 wpm read 138.5 (53 % of the time under 140) and the report
said "Work first on this: pick up the pace"; festival ked at 175 read 183 and a reader at 173
read 177 (p50 181), both told "slow down". The pace is measured to 8 % (140 - 8 % = 128.8,
180 + 8 % = 194.4), head pitch to 5 degrees (-15 - 5 = -20).
"""

from __future__ import annotations

import html
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from prezence.cli import main
from prezence.config.model import Check, Config, Rule, TimeSettings
from prezence.config.tomlconf import dumps_config
from prezence.report import build_report, summary_phrase, write_report
from prezence.report.speech import format_text
from prezence.session import SessionDir

SPEED = Rule(
    "speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp", above="slowDown", unit="wpm"
)
GAZE = Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp", unit="degrees")
CONFIG = Config(rules=(SPEED, GAZE), time=TimeSettings(allocated_s=None))

#: a pace that reads around its median ``m``: the same scatter for every median, a window in
#: eight 3 % under it and one in eight 3 % over (the readings of a real voice vary)
SCATTER = (0.97, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.03)


def around(m: float) -> Callable[[int], float]:
    return lambda t: round(m * SCATTER[t % len(SCATTER)], 1)


def talk(
    root: Path,
    talk_s: int,
    pace: Callable[[int], float] | None = None,
    gaze: Callable[[int], float] | None = None,
    *,
    rules: Config = CONFIG,
    cues: list[dict[str, object]] | None = None,
) -> SessionDir:
    """A finished talk: one pace and one head-pitch value a second (gaze level when none)."""
    session = SessionDir(root).create()
    session.config.write_text(dumps_config(rules))
    session.write_meta({"talk_s": float(talk_s), "kind": "live"})
    gaze = gaze or (lambda t: 0.0)
    streams = {"cv_headGaze": gaze, **({"speech_speed": pace} if pace else {})}
    for metric, value in streams.items():
        text = "".join(f"{t} {value(t)}\n" for t in range(talk_s))
        session.stream(f"{metric}.txt").write_text(text)
    session.cues.write_text("".join(json.dumps(c) + "\n" for c in cues or ()))
    session.summary.write_text(json.dumps({"ended_at_s": float(talk_s)}))
    return session


def said(session: SessionDir) -> tuple[dict[str, Any], str, str, str]:
    """The report, its text, its page and what the robot says."""
    report = build_report(session.root)
    page = html.unescape(write_report(session.root).read_text())
    return report, format_text(report), page, summary_phrase(report)


@pytest.mark.parametrize("median", [136.0, 138.5])
def test_a_pace_whose_median_reads_under_the_band_by_less_than_the_error_is_not_told_as_fact(
    tmp_path: Path, median: float
) -> None:
    # a 10-minute talk: its deviation adds up to more than a cue's worth (600 %.s), and it is
    # under 140 for over half its time, yet no reading is 8 % under 140
    report, text, page, phrase = said(talk(tmp_path / "t", 600, around(median)))
    assert report["priorities"] == [] and report["slightly_off"] == []
    [edge] = report["at_edge"]
    assert edge["metric"] == "speech_speed" and edge["side"] == "below"
    assert edge["median"] == pytest.approx(median)
    assert "Work first" not in phrase and "Work on, first" not in text
    assert "Well done" not in phrase and "stayed in" not in text
    want = (
        f"your pace read {median:.0f} wpm at its median, "
        f"{100 * (140 - median) / 140:.0f}% under the lowest good value, 140 wpm: within "
        "the measurement's error (8%), so it may well have been in range"
    )
    assert want in text and "if it felt slow, pick up the pace a little" in text
    assert "Nothing was clearly off, but:" in text
    assert want[1:] in page and "Work on first</h2>" in page
    assert phrase.endswith(
        "Nothing was clearly off. Your pace read just under its ideal range, within my "
        "measuring error: it may have been fine. If it felt slow, pick up the pace a little."
    )


@pytest.mark.parametrize("median", [183.0, 186.0])
def test_a_pace_whose_median_reads_over_the_band_by_less_than_the_error_is_not_told_as_fact(
    tmp_path: Path, median: float
) -> None:
    # festival ked at a true 175 read 183; a reader at 173 read 177, p50 181
    report, text, page, phrase = said(talk(tmp_path / "t", 600, around(median)))
    assert report["priorities"] == []
    [edge] = report["at_edge"]
    assert edge["side"] == "above" and edge["advice"] == "slow down"
    assert f"your pace read {median:.0f} wpm at its median" in text
    assert "over the highest good value, 180 wpm" in text
    assert "if it felt fast, slow down a little" in text
    assert "Work first" not in phrase and "If it felt fast, slow down a little." in phrase


@pytest.mark.parametrize(("median", "side"), [(120.0, "below"), (128.0, "below"), (195.0, "above")])
def test_a_pace_whose_median_reads_beyond_the_error_is_still_the_first_thing_to_work_on(
    tmp_path: Path, median: float, side: str
) -> None:
    report, text, _page, phrase = said(talk(tmp_path / "t", 600, around(median)))
    [pri] = report["priorities"]
    assert pri["metric"] == "speech_speed" and pri["side"] == side
    assert not report.get("at_edge")
    advice = "pick up the pace" if side == "below" else "slow down"
    assert phrase.endswith(f"Work first on this: {advice}.")
    assert "measuring error" not in text


def test_a_pace_in_the_band_is_praised(tmp_path: Path) -> None:
    report, text, _page, phrase = said(talk(tmp_path / "t", 600, around(142.0)))
    assert report["priorities"] == [] and not report.get("at_edge")
    assert "Well done" in phrase and "may have been fine" not in phrase
    assert "Work first" not in phrase and "at its median" not in text


def test_head_pitch_whose_median_reads_under_its_band_by_less_than_the_error(
    tmp_path: Path,
) -> None:
    # head pitch at -18 degrees all talk: 3 degrees under -15, its error is 5 degrees
    report, text, _page, phrase = said(talk(tmp_path / "t", 600, around(160.0), lambda t: -18.0))
    assert report["priorities"] == []
    [edge] = report["at_edge"]
    assert edge["metric"] == "cv_headGaze"
    assert (
        "your head pitch read -18 degrees at its median, 3 degrees under the lowest good value, "
        "-15 degrees: within the measurement's error (5 degrees)"
    ) in text
    assert "if it felt like you were looking down, look up at your audience a little" in text
    assert "Work first" not in phrase and "if it felt low" not in text
    assert phrase.endswith(
        "it may have been fine. If it felt like you were looking down, look up at your "
        "audience a little."
    )
    # 21 degrees under the level is 6 under -15: beyond the error, worked on as before
    report, _text, _page, phrase = said(talk(tmp_path / "u", 600, around(160.0), lambda t: -21.0))
    assert [p["metric"] for p in report["priorities"]] == ["cv_headGaze"]
    assert phrase.endswith("Work first on this: look up at your audience.")


def test_a_metric_clearly_out_comes_first_and_the_edge_is_said_after_it(tmp_path: Path) -> None:
    # pace at 138.5 (within the error), head pitch at -30 (15 degrees past -15): the head is
    # the first thing to work on; the pace is not ranked over it, nor listed to work on
    report, text, page, phrase = said(talk(tmp_path / "t", 600, around(138.5), lambda t: -30.0))
    assert [p["metric"] for p in report["priorities"]] == ["cv_headGaze"]
    assert [e["metric"] for e in report["at_edge"]] == ["speech_speed"]
    assert "pick up the pace" not in phrase.split("Work first on this:")[1].split(".")[0]
    assert (
        phrase.startswith("You spoke for 10 minutes")
        and (
            "Work first on this: look up at your audience. Your pace read just under its ideal "
            "range, within my measuring error."
        )
        in phrase
    )
    assert "May have been in range (out by no more than the measuring error):" in text
    assert text.index("look up at your audience") < text.index("your pace read 138 wpm")
    assert page.index("Look up at your audience") < page.index("Your pace read 138 wpm")


def test_readings_beyond_the_error_for_much_of_the_talk_are_still_advised_on(
    tmp_path: Path,
) -> None:
    # the median reads 139 (within the error), but 40 % of the talk read 110: out by far more
    # than the error, a cue's worth and more of it: still the thing to work on
    def pace(t: int) -> float:
        return 110.0 if t % 10 < 4 else 139.0

    report, _text, _page, phrase = said(talk(tmp_path / "t", 600, pace))
    assert report["metrics"]["speech_speed"]["p50"] == pytest.approx(139.0)
    assert [p["metric"] for p in report["priorities"]] == ["speech_speed"]
    assert not report.get("at_edge")
    assert "Work first on this: pick up the pace." in phrase


def test_a_cued_or_strict_metric_keeps_its_rules_at_the_edge(tmp_path: Path) -> None:
    cue = {
        "t": 100.0,
        "command": "speedUp",
        "metric": "speech_speed",
        "kind": "weighted",
        "reason": "...",
        "params": {},
        "onset": 90.0,
        "deviation": 2.0,
        "phrase": "...",
        "dropped": False,
    }
    report, _t, _p, phrase = said(talk(tmp_path / "t", 600, around(138.5), cues=[cue]))
    assert [p["metric"] for p in report["priorities"]] == ["speech_speed"]
    assert not report.get("at_edge")
    strict = Config(
        rules=(
            Rule("speech_speed", Check.IN_RANGE, low=140, high=180, strict=True, unit="wpm"),
            GAZE,
        ),
        time=TimeSettings(allocated_s=None),
    )
    report, _t, _p, _s = said(talk(tmp_path / "u", 600, around(138.5), rules=strict))
    assert [p["metric"] for p in report["priorities"]] == ["speech_speed"]


def test_a_folder_with_an_old_summary_json_gets_the_same_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a folder whose summary.json was written before the figures this reads (no p50, no
    # within_error_s): `prezence report` rebuilds them from its streams
    session = talk(tmp_path / "t", 600, around(138.5))
    old = {
        "ended_at_s": 600.0,
        "metrics": {"speech_speed": {"samples": 600, "time_in_range": 0.125, "mean": 138.4}},
    }
    session.summary.write_text(json.dumps(old))
    assert main(["report", str(session.root)]) == 0
    out = capsys.readouterr().out
    assert "your pace read 138 wpm at its median" in out and "Work on, first" not in out
    spoken = (session.root / "report" / "spoken.txt").read_text()
    assert "If it felt slow, pick up the pace a little." in spoken
    saved = json.loads((session.root / "report" / "report.json").read_text())
    assert saved["at_edge"][0]["metric"] == "speech_speed"


def test_readings_on_both_sides_each_within_the_error_are_not_told_as_fact(
    tmp_path: Path,
) -> None:
    # session 25's review: the median reads 160, in the band, but a third of the talk read
    # 130 and a third 185, each within the pace's 8 % of its bound (128.8, 194.4). Out for
    # two thirds of the time, it was "Work first on this: pick up the pace, but at times slow
    # down": out half the time says the median is out only when it is out on one side
    report, text, page, phrase = said(talk(tmp_path / "t", 120, lambda t: (130, 185, 160)[t % 3]))
    assert report["metrics"]["speech_speed"]["p50"] == pytest.approx(160.0)
    assert report["priorities"] == [] and report["slightly_off"] == []
    assert "Work first" not in phrase and "Work on, first" not in text
    [near] = report["near_range"]
    assert near["metric"] == "speech_speed" and near["within_error_s"] == pytest.approx(80.0, 1)
    assert "in or near the ideal range" in phrase and "by less than my measuring error" in phrase
    assert "pick up the pace" not in page
    # readings beyond the error on both sides for over half the talk are still worked on
    report, _text, page, phrase = said(talk(tmp_path / "u", 120, lambda t: (120, 200, 160)[t % 3]))
    assert [p["metric"] for p in report["priorities"]] == ["speech_speed"]
    assert "where it read in its range, only those count towards half the time" in page


@pytest.mark.parametrize(
    ("median", "words"),
    [
        # 7.86 % under: "8% under the lowest good value, 140 wpm: less than the measurement's
        # error (8%)" read as out by the error itself
        (129.0, "129 wpm at its median, 7.9% under the lowest good value, 140 wpm: within"),
        # 0.3 % under: "under 1% under the lowest good value"
        (139.6, "139.6 wpm at its median, less than 1% under the lowest good value, 140 wpm"),
    ],
)
def test_how_far_a_median_at_the_edge_read_is_said_in_figures_that_agree(
    tmp_path: Path, median: float, words: str
) -> None:
    _report, text, _page, _phrase = said(talk(tmp_path / "t", 600, lambda t: median))
    assert f"your pace read {words}" in text


def test_head_pitch_at_the_edge_after_a_rules_offset_says_the_offset_once(
    tmp_path: Path,
) -> None:
    # a camera set 3 degrees low (offset=3): -21 measured is -18 as judged. The report said
    # "3 degrees after the rule's offset of +3 under the lowest good value, -15 degrees after
    # the rule's offset of +3"
    gaze = Rule("cv_headGaze", Check.MIN, low=-15, scale=10, unit="degrees", offset=3.0)
    rules = Config(rules=(SPEED, gaze), time=TimeSettings(allocated_s=None))
    session = talk(tmp_path / "t", 600, around(160.0), lambda t: -21.0, rules=rules)
    _report, text, _page, _phrase = said(session)
    assert (
        "your head pitch read -18 degrees at its median, 3 degrees under the lowest good value, "
        "-15 degrees after the rule's offset of +3: within the measurement's error (5 degrees)"
    ) in text


def test_a_median_at_the_edge_a_little_off_beyond_the_error_names_the_part_within_it(
    tmp_path: Path,
) -> None:
    # session 25's review: a 100 s talk, its median read 138 (within the error of 140); a
    # quarter of it read 125 (beyond the error), five eighths 138. Listed as a little off for
    # that quarter, it was said as "your pace was a little under the ideal range 87% of the
    # time: pick up the pace", as if all of that were known to be under
    def pace(t: int) -> float:
        return float((138, 125, 150, 138, 138, 125, 138, 138)[t % 8])

    report, text, page, phrase = said(talk(tmp_path / "t", 100, pace))
    assert report["metrics"]["speech_speed"]["p50"] == pytest.approx(138.0)
    assert report["priorities"] == [] and not report.get("at_edge")
    [off] = report["slightly_off"]
    assert off["share_out"] == pytest.approx(0.25, abs=0.02)
    assert off["within_error_s"] == pytest.approx(62.0, abs=2.0)
    assert "below 140 wpm 87% of the time, 1:02 of it by less than the measurement's error" in text
    assert "1:02 of it by less than the measurement's error (8%)" in page
    assert phrase.endswith(
        "your pace was a little under the ideal range by more than my measuring error for 25% "
        "of the time: pick up the pace."
    )


def test_a_side_out_only_within_the_error_is_not_advised_beside_one_beyond_it(
    tmp_path: Path,
) -> None:
    # session 25's review: a pace read 132 (within the error of 140) three quarters of a talk
    # and 200 (beyond that of 180) a quarter. A little off (100 s) or to work on (600 s) for
    # the quarter over 180, it was "pick up the pace, but at times slow down": the side it
    # could not tell from in range came first, and was advised on as fact
    def pace(t: int) -> float:
        return 200.0 if t % 8 in (3, 6) else 132.0

    report, text, page, phrase = said(talk(tmp_path / "t", 100, pace))
    [off] = report["slightly_off"]
    assert off["side"] == "above" and off["advice"] == "slow down"
    assert off["sides"][1]["within_error"] is True and "advice" not in off["sides"][1]
    assert (
        "your pace was above 180 wpm 25% and below 140 wpm 75% (all by less than the "
        "measurement's error, 8%) of the time (slow down)"
    ) in text
    assert "pick up the pace" not in text and "pick up the pace" not in page
    assert phrase.endswith(
        "your pace was a little over the ideal range by more than my measuring error for 25% of "
        "the time: slow down."
    )
    report, text, _page, phrase = said(talk(tmp_path / "u", 600, pace))
    [pri] = report["priorities"]
    assert pri["side"] == "above" and pri["advice"] == "slow down"
    assert (
        "below the lowest good value, 140 wpm, for 450 s (all by less than the measurement's "
        "error, 8%)"
    ) in text
    assert phrase.endswith("Work first on this: slow down.")


def test_a_second_thing_to_work_on_is_said_before_a_median_at_the_edge(tmp_path: Path) -> None:
    # session 25's review: with two things to work on, one the coach stopped reminding of, and
    # a pace at the edge, the robot's 40 words kept "Your pace read just under its ideal
    # range, within my measuring error." and left out "Then: speak louder." and "I stopped
    # reminding you about your head pitch", things known to be out
    volume = Rule("speech_volume", Check.MIN, low=60, scale=6, below="speakLouder", unit="dB SPL")
    rules = Config(rules=(SPEED, GAZE, volume), time=TimeSettings(allocated_s=600.0))
    session = talk(tmp_path / "t", 600, around(138.5), lambda t: -30.0, rules=rules)
    session.stream("speech_volume.txt").write_text("".join(f"{t} 57.0\n" for t in range(600)))
    stopped = [{"metric": "cv_headGaze", "command": "lookUp", "t": 300.0}]
    session.summary.write_text(json.dumps({"ended_at_s": 600.0, "stopped_repeating": stopped}))
    report, _text, _page, phrase = said(session)
    assert [p["metric"] for p in report["priorities"]] == ["cv_headGaze", "speech_volume"]
    assert [e["metric"] for e in report["at_edge"]] == ["speech_speed"]
    assert "Work first on this: look up at your audience. Then: speak louder." in phrase
    assert "within my measuring error" not in phrase and len(phrase.split()) <= 40


def test_a_side_out_for_a_moment_is_not_said_as_zero_percent(tmp_path: Path) -> None:
    # session 25's review: a pace under 140 for 30 s of 100 (a little off) and over 180 for
    # 0.3 s read "your pace was below 140 wpm 30% and above 180 wpm 0% of the time", and the
    # robot "a little under the ideal range 30% and over it 0% of the time"
    session = talk(tmp_path / "t", 100, lambda t: 120.0 if t < 30 else 160.0)
    lines = session.stream("speech_speed.txt").read_text().splitlines()
    lines.insert(60, "59.7 200.0")
    session.stream("speech_speed.txt").write_text("\n".join(lines) + "\n")
    report, text, page, phrase = said(session)
    [off] = report["slightly_off"]
    assert off["sides"][1]["out_s"] == pytest.approx(0.3)
    assert "below 140 wpm 30% and above 180 wpm less than 1% of the time" in text
    assert "above 180 wpm less than 1% of the time" in page and " 0%" not in text
    assert "a little under the ideal range 30% and over it less than 1% of the time" in phrase


def test_a_side_of_a_thing_to_work_on_out_for_a_moment_is_not_said_as_zero_seconds(
    tmp_path: Path,
) -> None:
    # "your pace was below the lowest good value, 140 wpm, for 600 s and above the highest
    # good value, 180 wpm, for 0 s in all"
    session = talk(tmp_path / "t", 600, lambda t: 120.0)
    lines = session.stream("speech_speed.txt").read_text().splitlines()
    lines[300:301] = ["299.7 200.0", "300 120.0"]
    session.stream("speech_speed.txt").write_text("\n".join(lines) + "\n")
    report, text, page, _phrase = said(session)
    [pri] = report["priorities"]
    assert [x["side"] for x in pri["sides"]] == ["below", "above"]
    assert "above the highest good value, 180 wpm, for under 1 s in all" in text
    assert "for 0 s" not in text and "for 0 s" not in page


@pytest.mark.parametrize(("median", "side"), [(128.8, "below"), (194.4, "above")])
def test_a_median_exactly_at_the_error_is_at_the_edge_on_either_side(
    tmp_path: Path, median: float, side: str
) -> None:
    # 8 % of 140 is 128.8 and of 180 is 194.4: both within the error, as the summary counts
    # them (within_error_s). 194.4 all talk was "Work first on this: slow down", since
    # 194.4 - 180 is 14.400000000000006 in floating point, over the 14.4 margin
    report, text, _page, phrase = said(talk(tmp_path / "t", 600, lambda t: median))
    assert report["metrics"]["speech_speed"]["within_error_s"] == pytest.approx(600.0)
    assert report["priorities"] == []
    [edge] = report["at_edge"]
    assert edge["side"] == side and edge["off_pct"] == pytest.approx(8.0)
    assert "Work first" not in phrase and "Work on, first" not in text
    assert "8.0% " + ("under" if side == "below" else "over") in text
    assert "within the measurement's error (8%)" in text


def test_a_median_at_the_edge_is_said_to_the_tenth_when_how_far_out_is(tmp_path: Path) -> None:
    # "your pace read 129 wpm at its median, 8.0% under ... 140 wpm" (129 is 7.9 % under);
    # "your head pitch read -20 degrees at its median, 4.8 degrees under ... -15 degrees"
    _report, text, page, _phrase = said(talk(tmp_path / "p", 600, lambda t: 128.8))
    assert "your pace read 128.8 wpm at its median, 8.0% under the lowest good value" in text
    assert "our pace read 128.8 wpm at its median, 8.0% under" in page
    gaze = Rule("cv_headGaze", Check.MIN, low=-15, scale=10, unit="degrees", offset=-3.3)
    rules = Config(rules=(SPEED, gaze), time=TimeSettings(allocated_s=None))
    session = talk(tmp_path / "g", 600, around(160.0), lambda t: -16.5, rules=rules)
    _report, text, _page, _phrase = said(session)
    assert "your head pitch read -19.8 degrees at its median, 4.8 degrees under" in text
    # a whole median, or one said beside a whole figure, reads as before
    _report, text, _page, _phrase = said(talk(tmp_path / "w", 600, lambda t: 129.0))
    assert "your pace read 129 wpm at its median, 7.9% under" in text
    _report, text, _page, _phrase = said(talk(tmp_path / "a", 600, around(136.0)))
    assert "your pace read 136 wpm at its median, 3% under" in text


def test_of_two_sides_both_within_the_error_neither_is_said_to_be_the_only_one(
    tmp_path: Path,
) -> None:
    # one side beyond the error, the other within it: the side within it is marked so (the
    # session 25 tester's pair, 136 and 184 by turns, each within the error, is no longer
    # listed at all: see the next test)
    report, _text, _page, _phrase = said(
        talk(tmp_path / "u", 600, lambda t: 200.0 if t % 8 in (3, 6) else 132.0)
    )
    [pri] = report["priorities"]
    assert [x.get("within_error", False) for x in pri["sides"]] == [False, True]


def test_readings_within_the_error_add_up_to_no_cues_worth_when_the_median_is_in_range(
    tmp_path: Path,
) -> None:
    # session 25's tester: 136 and 184 wpm by turns for 10 minutes (median 160, every reading
    # within the pace's 8 % of its bound) was "Work first on this: pick up the pace, but at
    # times slow down": the cue's-worth rule added up readings the module cannot tell from
    # ones in range
    report, text, page, phrase = said(talk(tmp_path / "t", 600, lambda t: 136.0 + 48 * (t % 2)))
    assert report["priorities"] == [] and report["slightly_off"] == []
    assert "Work first" not in phrase and "Work on, first" not in text
    assert "pick up the pace" not in page and "slow down" not in page
    [near] = report["near_range"]
    assert near["metric"] == "speech_speed" and near["within_error_s"] == pytest.approx(600.0, 1)
    assert "by less than my measuring error" in phrase
    # the same deviation-seconds from readings beyond the error (a tenth of the talk 14 %
    # under 140 against a quarter 5.7 % under it, 857 %·s each, median 160) is still a
    # thing to work on
    within = talk(tmp_path / "w", 600, lambda t: 132.0 if t % 4 == 0 else 160.0)
    beyond = talk(tmp_path / "b", 600, lambda t: 120.0 if t % 10 == 0 else 160.0)
    assert build_report(within.root)["priorities"] == []
    [pri] = build_report(beyond.root)["priorities"]
    assert pri["metric"] == "speech_speed" and pri["side"] == "below"


def test_the_page_counts_one_metric_measured_in_the_singular(tmp_path: Path) -> None:
    # a head pitch alone (no pace stream): the page's card read "1 metrics measured"
    _report, _text, page, _phrase = said(talk(tmp_path / "t", 600, None, lambda t: -18.0))
    assert "1 metric measured" in page and "1 metrics" not in page
    _report, _text, page, _phrase = said(talk(tmp_path / "u", 600, around(160.0)))
    assert "2 metrics measured" in page


@pytest.mark.parametrize(
    ("used", "said"),
    [
        (59.6, "You spoke for 1 minute."),  # was "60 seconds"
        (75.0, "You spoke for 1 and a half minutes."),  # was "1 minute": round(2.5) is 2
        (105.0, "You spoke for 2 minutes."),
        (40.2, "You spoke for 40 seconds."),
        (21600.0, "You spoke for 6 hours."),  # was "360 minutes"
        (5460.0, "You spoke for 1 hour 31 minutes."),  # was "91 minutes"
    ],
)
def test_a_length_is_spoken_rounded_as_a_listener_rounds_and_in_hours_past_one(
    used: float, said: str
) -> None:
    from prezence.report.speech import mmss, time_sentence

    assert time_sentence({"time": {"used_s": used, "allocated_s": None}}) == said
    # and written: "6:00:00", not "360:00" (which widened the report's table)
    assert mmss(21600.0) == "6:00:00" and mmss(3599.4) == "59:59"


def test_a_time_used_of_an_allocation_past_an_hour_is_said_in_hours(tmp_path: Path) -> None:
    # session 26's tester: "You used 66 minutes 39 seconds of 60 minutes, 11% over", and the
    # page's "time used 66:39 ... the 60:00 allocated"
    from prezence.report.speech import time_sentence

    time = {"used_s": 3999.0, "allocated_s": 3600.0, "over_under_pct": 11.1}
    assert time_sentence({"time": time}) == (
        "You used 1 hour 6 minutes 39 seconds of 1 hour, 11% over."
    )
    config = Config(rules=(SPEED, GAZE), time=TimeSettings(allocated_s=3600))
    _report, _text, page, _phrase = said(talk(tmp_path / "t", 3999, around(160.0), rules=config))
    assert "1:06:39" in page and "66:39" not in page.replace("1:06:39", "")


def test_a_cued_metric_advises_the_side_the_robot_cued(tmp_path: Path) -> None:
    # session 25's "Not done": the coach cued "slow down" on 200 wpm (a fifth of the talk,
    # beyond the pace's 8 %); the rest read 132 (within the error of 140). The report ordered
    # a cued metric's sides by their whole deviation and said "Work first on this: pick up
    # the pace, but at times slow down", the opposite of what the robot had said
    def pace(t: int) -> float:
        return 200.0 if t % 10 in (3, 6) else 132.0

    cue = {"t": 40.0, "command": "slowDown", "metric": "speech_speed", "kind": "weighted"}
    report, text, page, phrase = said(talk(tmp_path / "t", 600, pace, cues=[cue]))
    [pri] = report["priorities"]
    assert pri["side"] == "above" and pri["advice"] == "slow down"
    assert pri["sides"][1]["side"] == "below" and pri["sides"][1].get("within_error") is True
    assert "Work first on this: slow down." in phrase and "pick up the pace" not in phrase
    assert "pick up the pace" not in text
    # cued on the side within the error too: both advised, as the robot said both
    both = [cue, {**cue, "t": 300.0, "command": "speedUp"}]
    report, _text, _page, phrase = said(talk(tmp_path / "u", 600, pace, cues=both))
    [pri] = report["priorities"]
    assert all(x.get("advice") for x in pri["sides"]), pri["sides"]
    # cued only "pick up the pace" (the live coach weighs readings within the error too):
    # advised as the robot said it, after the side beyond the error
    up = [{**cue, "command": "speedUp"}]
    report, _text, _page, phrase = said(talk(tmp_path / "v", 600, pace, cues=up))
    [pri] = report["priorities"]
    assert pri["advice"] == "slow down, but at times pick up the pace"


def test_a_side_cued_once_early_does_not_outrank_a_talk_mostly_out_on_the_other(
    tmp_path: Path,
) -> None:
    # session 26's tester: 220 wpm for the first minute (cued "slow down" at 0:32), then 125
    # (beyond the error under 140) most of the rest: "Work first on this: slow down, but at
    # times pick up the pace", for a talk too slow 405 s against 60 s too fast
    def pace(t: int) -> float:
        return 220.0 if t < 60 else (125.0 if t % 4 < 3 else 150.0)

    cue = {"t": 32.0, "command": "slowDown", "metric": "speech_speed", "kind": "weighted"}
    report, _text, _page, phrase = said(talk(tmp_path / "t", 600, pace, cues=[cue]))
    [pri] = report["priorities"]
    assert pri["advice"] == "pick up the pace, but at times slow down", pri
    assert "Work first on this: pick up the pace, but at times slow down." in phrase


@pytest.mark.parametrize(
    "cue",
    [
        # dropped: the speaker never heard it (tester's c1)
        {"command": "speedUp", "dropped": True, "ok": False},
        # cued on a side this report's band does not find out (a replay under 140-150 wpm
        # cued "slow down" at 165; reported under 140-180: tester's b8)
        {"command": "slowDown"},
        # a command neither side's, as after a rule changed since
        {"command": "hurry"},
    ],
)
def test_a_cue_that_was_not_heard_or_is_on_no_side_out_does_not_list_readings_within_the_error(
    tmp_path: Path, cue: dict[str, object]
) -> None:
    # 136 wpm (within the 8 % error of 140) half the time, 160 the other: in or near range;
    # such a cue made it "Work first on this: pick up the pace"
    cues = [{"t": 40.0, "metric": "speech_speed", "kind": "weighted", **cue}]
    report, _text, _page, phrase = said(
        talk(tmp_path / "t", 600, lambda t: 136.0 if t % 2 else 160.0, cues=cues)
    )
    assert report["priorities"] == [], report["priorities"]
    assert "Work first" not in phrase and "by less than my measuring error" in phrase
