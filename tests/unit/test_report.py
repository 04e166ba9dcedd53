"""The post-speech report, rebuilt from a hand-made session folder (no simulator)."""

from __future__ import annotations

import base64
import json
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from prezence.config.model import Check, Config, Rule, TimeSettings
from prezence.config.tomlconf import dumps_config
from prezence.errors import ConfigError
from prezence.report import build_report, summary_phrase, write_report
from prezence.report.build import cue_effect, deviation_seconds, rank_priorities
from prezence.report.speech import MAX_SPOKEN_WORDS, format_text
from prezence.samples import Sample
from prezence.session import SessionDir

SPEED = Rule(
    "speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp", above="slowDown", unit="wpm"
)
VOLUME = Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder", unit="dB")
GAZE = Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp", unit="deg")
CONFIG = Config(rules=(SPEED, VOLUME, GAZE), time=TimeSettings(allocated_s=100.0))


def speed(t: int) -> float:
    """Too fast (216 wpm, 20 % above) from 20 s to 60 s; slows down after a cue at 40 s."""
    if 20 <= t < 40:
        return 216.0
    if 40 <= t < 60:
        return 190.0
    return 160.0


def gaze(t: int) -> float:
    """A short glance down (10 s at -20 deg: 50 %) from 70 s."""
    return -20.0 if 70 <= t < 80 else 0.0


def make_session(
    root: Path,
    *,
    seconds: int = 110,
    talk_s: float | None = 110.0,
    cues: list[dict[str, object]] | None = None,
) -> SessionDir:
    """A session of ``seconds`` of 1 Hz samples for three metrics, as the runner writes it."""
    session = SessionDir(root).create()
    session.config.write_text(dumps_config(CONFIG))
    meta: dict[str, object] = {"scenario": "handmade", "seed": 3, "policy": "weighted"}
    if talk_s is not None:
        meta["talk_s"] = talk_s
    session.write_meta(meta)
    lines = {
        "speech_speed": [f"{t} {speed(t)}" for t in range(1, seconds + 1)],
        "speech_volume": [f"{t} 66.0" for t in range(1, seconds + 1)],
        "cv_headGaze": [f"{t} {gaze(t)}" for t in range(1, seconds + 1)],
    }
    for metric, rows in lines.items():
        session.stream(f"{metric}.txt").write_text("\n".join(rows) + "\n")
    if cues is None:
        cues = [
            {
                "t": 40.0,
                "command": "slowDown",
                "metric": "speech_speed",
                "kind": "weighted",
                "reason": "speech_speed 216 is 20% above 180 wpm",
                "params": {},
                "onset": 20.0,
                "deviation": 20.0,
                "phrase": "Slow down a little.",
                "planned_s": 3.0,
                "measured_s": 3.0,
                "dropped": False,
            },
            {
                "t": 80.0,
                "command": "timeLeft",
                "metric": None,
                "kind": "time",
                "reason": "...",
                "params": {"minutes": 1},
                "onset": 80.0,
                "deviation": 0.0,
                "weight": float("inf"),
                "phrase": "One minute left.",
                "dropped": False,
            },
        ]
    with session.cues.open("w") as f:
        for c in cues:
            f.write(json.dumps(c) + "\n")
    return session


@pytest.fixture
def session(tmp_path: Path) -> SessionDir:
    return make_session(tmp_path / "talk")


def test_time_used_is_compared_with_time_allocated(session: SessionDir) -> None:
    report = build_report(session.root)
    assert report["time"]["used_s"] == 110.0
    assert report["time"]["allocated_s"] == 100.0
    assert report["time"]["over_under_pct"] == pytest.approx(10.0)
    assert report["complete"] is True


def test_metric_figures_come_from_the_stream_files(session: SessionDir) -> None:
    m = build_report(session.root)["metrics"]["speech_speed"]
    assert m["out_of_range_s"] == pytest.approx(40.0)
    assert m["longest_out_of_range_s"] == pytest.approx(40.0)
    assert m["deviation_s"]["above"] == pytest.approx(20 * 20.0 + 20 * 100 * 10 / 180, rel=1e-3)
    assert m["low"] == 140 and m["high"] == 180 and m["label"] == "pace"


def test_priorities_are_what_was_cued_or_off_by_a_cues_worth(session: SessionDir) -> None:
    pri = build_report(session.root)["priorities"]
    # pace: 40 s out, ~15 % on average, and cued; head pitch: 10 s out at 50 % (500 %·s,
    # less than the 600 %·s a cue takes) and never cued: not the first thing to work on.
    assert [p["metric"] for p in pri] == ["speech_speed"]
    assert pri[0]["advice"] == "slow down"


def test_priorities_rank_deviation_times_duration() -> None:
    dev = {
        "speech_speed": {"below": 0.0, "above": 700.0},
        "cv_headGaze": {"below": 2500.0, "above": 0.0},
        "speech_volume": {"below": 900.0, "above": 0.0},
    }
    pri = rank_priorities(CONFIG, dev, talk_s=600.0)
    assert [p["metric"] for p in pri] == ["cv_headGaze", "speech_volume"]
    assert pri[0]["advice"] == "look up at your audience"
    assert pri[1]["advice"] == "speak louder"


def test_a_glance_away_is_no_priority_unless_the_coach_cued_it() -> None:
    # about a second looking down at 50 % past the band: 31 %·s over a 48 s clip
    dev = {"cv_headGaze": {"below": 31.0, "above": 0.0}}
    assert rank_priorities(CONFIG, dev, talk_s=48.0) == []
    cued = rank_priorities(CONFIG, dev, talk_s=48.0, cued={"cv_headGaze"})
    assert [p["metric"] for p in cued] == ["cv_headGaze"]


def test_a_cue_records_latency_and_whether_the_presenter_improved(session: SessionDir) -> None:
    cue = build_report(session.root)["cues"][0]
    assert cue["latency_s"] == pytest.approx(20.0)
    # 30 s before: 10 s in range, 20 s at 20 %; after: 20 s at 5.6 %, 10 s in range.
    assert cue["deviation_before"] == pytest.approx(20.0 * 20 / 30, abs=1e-3)
    assert cue["deviation_after"] == pytest.approx(100 * 10 / 180 * 20 / 30, abs=1e-3)
    assert cue["improved"] is True


def test_cue_effect_says_no_change_when_the_deviation_stays() -> None:
    ss = [Sample("speech_speed", float(t), 216.0) for t in range(60)]
    assert cue_effect(SPEED, ss, 30.0)["improved"] is False


def test_deviation_seconds_does_not_depend_on_the_sample_rate() -> None:
    slow = [Sample("speech_speed", float(t), 198.0) for t in range(0, 20, 2)]
    fast = [Sample("speech_speed", t / 4, 198.0) for t in range(0, 80)]
    a = deviation_seconds(SPEED, slow, 20.0, 6.0)
    b = deviation_seconds(SPEED, fast, 20.0, 6.0)
    assert a == b == {"below": 0.0, "above": pytest.approx(200.0)}


def test_rank_priorities_leaves_out_metrics_that_stayed_in_range() -> None:
    dev = {"speech_speed": {"below": 0.0, "above": 0.0}, "speech_volume": {"below": 605.0}}
    assert [p["metric"] for p in rank_priorities(CONFIG, dev, talk_s=60.0)] == ["speech_volume"]


def test_a_torn_last_cue_line_is_ignored(tmp_path: Path) -> None:
    session = make_session(tmp_path / "t")
    with session.cues.open("a") as f:
        f.write('{"t": 90.0, "command": "lookU')
    report = build_report(session.root)
    assert [c["command"] for c in report["cues"]] == ["slowDown", "timeLeft"]


def test_talk_length_is_the_last_sample_without_session_json(tmp_path: Path) -> None:
    session = make_session(tmp_path / "t", seconds=95, talk_s=None)
    assert build_report(session.root)["time"]["used_s"] == 95.0


def test_a_record_that_stops_early_is_reported_as_incomplete(tmp_path: Path) -> None:
    session = make_session(tmp_path / "t", seconds=50, talk_s=110.0)
    session.cues.write_text(session.cues.read_text().splitlines()[0] + "\n")  # the cue at 40 s
    report = build_report(session.root)
    assert report["complete"] is False
    assert report["talk_s"] == 50.0
    assert report["metrics"]["speech_volume"]["no_data_s"] == pytest.approx(1.0)


def test_a_talk_the_coach_ran_to_its_end_is_complete_though_its_metrics_stop(
    tmp_path: Path,
) -> None:
    # the presenter fell silent at 50 s of a 110 s talk the coach ran to its end
    session = make_session(tmp_path / "t", seconds=50, talk_s=110.0)
    session.cues.write_text(session.cues.read_text().splitlines()[0] + "\n")
    ended = build_report(session.root, ended=True)
    assert ended["complete"] is True and ended["time"]["used_s"] == 110.0
    # read back later: a finished talk's summary.json says when it ended
    session.summary.write_text(json.dumps({"ended_at_s": 110.0}))
    report = build_report(session.root)
    assert report["complete"] is True and report["time"]["used_s"] == 110.0
    assert "stopped early" not in summary_phrase(report)


def test_praise_needs_something_measured() -> None:
    time = {"used_s": 60.0, "allocated_s": 60.0, "over_under_pct": 0.0}
    nothing = {"speech_speed": {"samples": 0}, "cv_headGaze": {"samples": 0}}
    phrase = summary_phrase({"time": time, "priorities": [], "metrics": nothing})
    assert "Well done" not in phrase and "could not measure" in phrase
    text = format_text(
        {
            "time": time,
            "priorities": [],
            "metrics": nothing,
            "session": "s",
            "cues": [],
            "counts": {},
        }
    )
    assert "Nothing was measured" in text and "ideal range" not in text
    # head pitch not asked for (no camera module ran: measured false, as the report has it)
    some = {"speech_speed": {"samples": 30}, "cv_headGaze": {"samples": 0, "measured": False}}
    phrase = summary_phrase({"time": time, "priorities": [], "metrics": some})
    assert "Everything I could measure stayed in the ideal range" in phrase
    # its module ran and wrote nothing (session 22): named, no praise for everything
    some["cv_headGaze"] = {"samples": 0, "label": "head pitch"}
    phrase = summary_phrase({"time": time, "priorities": [], "metrics": some})
    assert phrase.endswith(
        "Your speech_speed stayed in the ideal range; I could not judge your head pitch."
    )
    every = {"speech_speed": {"samples": 30}, "cv_headGaze": {"samples": 30}}
    phrase = summary_phrase({"time": time, "priorities": [], "metrics": every})
    assert "Your delivery stayed in the ideal range" in phrase


def _fifty_second_talk(tmp_path: Path, **values: Callable[[int], float]) -> SessionDir:
    """A finished 50 s talk with no cue: one sample a second (t = 1..50) per metric given."""
    session = SessionDir(tmp_path / "t").create()
    session.config.write_text(dumps_config(CONFIG))
    session.write_meta({"talk_s": 50.0})
    for metric, value in values.items():
        session.stream(f"{metric}.txt").write_text(
            "".join(f"{t} {value(t):.1f}\n" for t in range(1, 51))
        )
    session.cues.write_text("")
    return session


def test_a_pace_a_little_under_all_talk_is_not_praised_as_in_range(tmp_path: Path) -> None:
    # A real reader at ~133 wpm for a 50 s clip: 5 % under the band nearly all the time adds
    # up to less than one cue's worth, but "everything stayed in the ideal range, well done"
    # was false; and out of its band for most of the talk, it is no "a little off" either
    # (session 20). 5 % is within the pace's 8 % measurement error, so since session 25 it is
    # said as that, with the advice if it felt slow: neither praise nor a fact.
    session = _fifty_second_talk(
        tmp_path,
        speech_speed=lambda t: 150.0 if t < 10 else 133.0,
        speech_volume=lambda t: 66.0,
        cv_headGaze=lambda t: 0.0,
    )
    report = build_report(session.root, ended=True)
    assert report["slightly_off"] == [] and report["priorities"] == []
    [edge] = report["at_edge"]
    assert edge["metric"] == "speech_speed" and edge["side"] == "below"
    phrase = summary_phrase(report)
    assert "Well done" not in phrase and "stayed in the ideal range" not in phrase
    assert "pick up the pace a little" in phrase
    text = format_text(report)
    assert "stayed in its ideal range" not in text and "far off" not in text
    assert "your pace read 133 wpm at its median, 5% under the lowest good value, 140 wpm" in text
    html = write_report(session.root).read_text()
    assert "Well done" not in html and "our pace read 133 wpm at its median, 5% under" in html


def test_a_pace_a_little_under_for_a_while_is_a_little_off(tmp_path: Path) -> None:
    # under the band for 30 % of the talk, 11 % under (more than the pace's 8 % measurement
    # error): too little to work on, too much to praise
    session = _fifty_second_talk(
        tmp_path,
        speech_speed=lambda t: 150.0 if t <= 35 else 125.0,
        speech_volume=lambda t: 66.0,
        cv_headGaze=lambda t: 0.0,
    )
    report = build_report(session.root, ended=True)
    assert report["priorities"] == []
    [off] = report["slightly_off"]
    assert off["metric"] == "speech_speed" and off["side"] == "below"
    assert off["share_out"] == pytest.approx(14 / 49, abs=0.01)  # t = 36..49, of 1..50
    pct = f"{100 * off['share_out']:.0f}%"
    phrase = summary_phrase(report)
    assert "Well done" not in phrase and "stayed in the ideal range" not in phrase
    assert f"Nothing was far off, but your pace was a little under the ideal range {pct}" in phrase
    assert "pick up the pace" in phrase
    text = format_text(report)
    assert "stayed in its ideal range" not in text
    assert f"your pace was below 140 wpm {pct} of the time" in text


def test_a_short_glance_away_still_leaves_the_praise(tmp_path: Path) -> None:
    # out of range 2 % of the time: neither a priority nor "a little off"; praised, but as
    # "in or near" (session 21: "stayed in the ideal range" contradicted the table's 98 %)
    session = _fifty_second_talk(
        tmp_path,
        speech_speed=lambda t: 150.0,
        speech_volume=lambda t: 66.0,
        cv_headGaze=lambda t: -25.0 if t == 30 else 0.0,  # beyond the head pose's 5 degrees
    )
    report = build_report(session.root, ended=True)
    assert report["priorities"] == [] and report["slightly_off"] == []
    said = summary_phrase(report)
    assert "Your delivery stayed in or near the ideal range. Well done!" in said
    assert "Your head pitch was under its ideal range for 1 second." in said


def test_missing_folder_raises_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such session folder"):
        build_report(tmp_path / "nope")


def test_summary_phrase_names_time_and_the_two_priorities(tmp_path: Path) -> None:
    session = make_session(tmp_path / "t")
    with session.cues.open("a") as f:  # the glance down was cued: it is the second priority
        look_up = {
            "t": 75.0,
            "command": "lookUp",
            "metric": "cv_headGaze",
            "kind": "weighted",
            "reason": "cv_headGaze -20 is 50% below -15 deg",
            "params": {},
            "onset": 70.0,
            "deviation": 50.0,
            "phrase": "Look up.",
            "planned_s": 3.0,
            "measured_s": 3.0,
            "dropped": False,
        }
        f.write(json.dumps(look_up) + "\n")
    phrase = summary_phrase(build_report(session.root))
    assert "10% over" in phrase
    assert "slow down" in phrase and "look up at your audience" in phrase
    assert len(phrase.split()) <= MAX_SPOKEN_WORDS


def test_summary_phrase_never_rambles() -> None:
    report = {
        "time": {"used_s": 60.0, "allocated_s": 60.0, "over_under_pct": 0.0},
        "priorities": [{"advice": "word " * 30}, {"advice": "other " * 30}],
    }
    assert len(summary_phrase(report).split()) <= MAX_SPOKEN_WORDS


def test_write_report_writes_every_output(session: SessionDir) -> None:
    page = write_report(session.root)
    folder = session.report
    assert page == folder / "report.html"
    data = json.loads((folder / "report.json").read_text(), parse_constant=_no_constants)
    assert data["priorities"][0]["metric"] == "speech_speed"
    assert "slow down" in (folder / "spoken.txt").read_text()
    assert "Work on" in (folder / "summary.txt").read_text()
    html = page.read_text()
    assert 'src="http' not in html and "<link" not in html  # self-contained


def test_report_page_inlines_its_plots(session: SessionDir) -> None:
    pytest.importorskip("matplotlib")
    html = write_report(session.root).read_text()
    images = re.findall(r'src="data:image/png;base64,([A-Za-z0-9+/=]+)"', html)
    assert len(images) == 1 + len(CONFIG.rules)  # the summary chart and one timeline each
    assert all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in images)
    assert (session.report / "timeline_speech_speed.png").is_file()


def _no_constants(name: str) -> object:
    raise ValueError(f"report.json holds {name}, which is not JSON")


def test_without_matplotlib_the_page_has_tables_only(
    session: SessionDir, monkeypatch: pytest.MonkeyPatch
) -> None:
    from prezence.report import plots

    monkeypatch.setattr(plots, "available", lambda: False)
    html = write_report(session.root).read_text()
    assert "<img" not in html and "<table>" in html
    assert not list(session.report.glob("*.png"))


def test_a_report_without_plots_says_how_to_draw_them_and_report_draws_them(
    session: SessionDir,
) -> None:
    pytest.importorskip("matplotlib")
    write_report(session.root)  # an earlier build with plots: none of them may stay behind
    html = write_report(session.root, plots=False).read_text()
    assert "<img" not in html and "<table>" in html
    assert f"prezence report {session.root}" in html and "--plots" in html
    assert not list(session.report.glob("*.png"))
    html = write_report(session.root).read_text()  # what `prezence report DIR` does
    assert html.count('src="data:image/png;base64,') == 1 + len(CONFIG.rules)
    assert "No plots" not in html


def test_a_metric_without_data_says_no_data_instead_of_an_empty_plot(tmp_path: Path) -> None:
    session = make_session(tmp_path / "t")
    session.stream("cv_headGaze.txt").write_text("")  # the vision module ran, wrote nothing
    report = build_report(session.root)
    assert report["metrics"]["cv_headGaze"]["time_in_range"] is None
    assert report["metrics"]["cv_headGaze"]["data"] == "no data"
    page = write_report(session.root)
    html = page.read_text()
    assert "no data" in html and "not measured" not in html
    assert "no data" in (session.report / "summary.txt").read_text()
    if (session.report / "summary.png").exists():  # with matplotlib
        assert not (session.report / "timeline_cv_headGaze.png").exists()
        assert (session.report / "timeline_speech_speed.png").exists()


def test_a_metric_no_module_wrote_says_not_measured(tmp_path: Path) -> None:
    session = make_session(tmp_path / "t")
    session.stream("cv_headGaze.txt").unlink()  # no camera module ran
    report = build_report(session.root)
    assert report["metrics"]["cv_headGaze"]["data"] == "not measured"
    html = write_report(session.root).read_text()
    assert "not measured" in html
    if (session.report / "summary.png").exists():  # with matplotlib
        assert not (session.report / "timeline_cv_headGaze.png").exists()
        assert (session.report / "timeline_speech_speed.png").exists()


def test_summary_chart_draws_no_bar_for_a_metric_without_data() -> None:
    pytest.importorskip("matplotlib")
    from prezence.report import plots

    report = {
        "talk_s": 36.0,
        "metrics": {
            "a": {"label": "pace", "time_in_range": 0.5, "deviation_s": {"above": 30.0}},
            "b": {"label": "gaze", "time_in_range": None, "deviation_s": {}},
        },
    }
    assert plots.summary_png(report)[:4] == b"\x89PNG"


def test_time_axis_ticks_follow_the_talk_length() -> None:
    from prezence.report.plots import tick_step

    assert tick_step(36.0) == 5.0  # a 36 s clip: 0:00, 0:05 … 0:35, not "0:00" only
    assert tick_step(600.0) == 60.0
    assert 3 <= 36.0 / tick_step(36.0) <= 10 and 3 <= 3000 / tick_step(3000.0) <= 10


def test_report_finds_stream_files_at_the_folder_root(tmp_path: Path) -> None:
    # files another tool wrote, as replay takes them: no streams/ folder, no session.json
    src = tmp_path / "rec"
    src.mkdir()
    (src / "speech_speed.txt").write_text("".join(f"{t} 200.0\n" for t in range(60)))
    report = build_report(src)
    assert report["metrics"]["speech_speed"]["samples"] == 60
    assert report["priorities"][0]["advice"] == "slow down"


def test_report_of_a_folder_without_streams_or_session_says_so(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no stream files found"):
        build_report(tmp_path)


@pytest.mark.parametrize(
    ("used", "allocated", "pct", "said"),
    [
        (588.0, 600.0, -2.0, "You used 9 minutes 48 seconds of 10 minutes, 2% under."),
        (612.0, 600.0, 2.0, "You used 10 minutes 12 seconds of 10 minutes, 2% over."),
        (597.0, 600.0, -0.5, "You used 10 minutes of 10 minutes, right on time."),
        (540.0, 600.0, -10.0, "You used 9 minutes of 10 minutes, 10% under."),
        (33.0, 36.0, -8.3, "You used 33 seconds of 36 seconds, 8% under."),
        # session 21: short_talk (2:10 allocated) said "40 seconds of 2 minutes, 69% under"
        (40.0, 130.0, -69.2, "You used 40 seconds of 2 minutes 10 seconds, 69% under."),
        (460.0, 600.0, -23.3, "You used 7 minutes 40 seconds of 10 minutes, 23% under."),
    ],
)
def test_time_sentence_words_agree_with_the_percentage(
    used: float, allocated: float, pct: float, said: str
) -> None:
    from prezence.report.speech import time_sentence

    t = {"used_s": used, "allocated_s": allocated, "over_under_pct": pct}
    assert time_sentence({"time": t}) == said


FIDGET = Rule("fidget_rate", Check.MAX, high=3.0, above="gestureLess", unit="1/min")


def crashed_module_session(root: Path, crashes: list[dict[str, object]]) -> SessionDir:
    """A 45 s live talk whose module wrote fidget_rate 6/min (twice the limit) for 6 s, then
    died (``crashes``, as the launcher records them in summary.json)."""
    session = SessionDir(root).create()
    config = Config(rules=(FIDGET,), time=TimeSettings(allocated_s=60.0))
    session.config.write_text(dumps_config(config))
    session.write_meta({"kind": "live", "talk_s": 45.0})
    session.stream("fidget_rate.txt").write_text("".join(f"{t} 6.0\n" for t in range(6)))
    modules = {"fidget": {"restarts": len(crashes), "crashes": crashes, "metrics": ["fidget_rate"]}}
    session.summary.write_text(json.dumps({"ended_at_s": 45.0, "modules": modules}))
    return session


def test_a_crashed_module_is_reported_and_its_last_value_not_held_as_measured(
    tmp_path: Path,
) -> None:
    # session 13: the report never said the module crashed 6 times; its last value was held
    # 6 s past the crash and made 'Work first on this: lower fidget_rate'
    crashes = [{"t": t, "why": "exited with status 1"} for t in (5.7, 7.2, 9.7, 14.3, 22.8, 39.3)]
    session = crashed_module_session(tmp_path / "s", crashes)
    page = write_report(session.root).read_text()
    text = (session.report / "summary.txt").read_text()
    said = (
        "module fidget crashed 6 times (first at 0:06) and was restarted; fidget_rate was "
        "not measured from 0:06 to the end (0:45)"
    )
    assert f"note: {said}" in text
    assert f"M{said[1:]}." in page
    report = build_report(session.root)
    assert report["metrics"]["fidget_rate"]["out_of_range_s"] == pytest.approx(5.7)
    assert report["priorities"] == []  # 5.7 s measured: no priority on held, stale data
    assert "Work first" not in summary_phrase(report)
    # 5.7 s measured is under MIN_JUDGED_S (walk 2, item 9): no advice on it either
    assert "100% of the 6 s" not in summary_phrase(report)
    assert "I measured too little of your delivery to judge it" in summary_phrase(report)


def test_the_spoken_summary_says_what_it_could_not_follow_after_a_module_died(
    tmp_path: Path,
) -> None:
    # session 14: the robot said 'Your delivery stayed in the ideal range. Well done!' after
    # the module died at 0:06 of a 45 s talk; the printed summary and the report said it died
    session = crashed_module_session(tmp_path / "s", [{"t": 5.7, "why": "exited with status 1"}])
    session.stream("fidget_rate.txt").write_text("".join(f"{t} 1.0\n" for t in range(6)))
    write_report(session.root)
    assert (session.report / "spoken.txt").read_text() == (
        "You used 45 seconds of 1 minute, 25% under. I could not follow your fidget_rate after "
        "6 seconds. I measured too little of your delivery to judge it.\n"
    )
    session.stream("fidget_rate.txt").write_text("".join(f"{t} 6.0\n" for t in range(6)))
    said = summary_phrase(build_report(session.root))
    assert said == (
        "You used 45 seconds of 1 minute, 25% under. I could not follow your fidget_rate after "
        "6 seconds. I measured too little of your delivery to judge it."
    )  # 6 s measured: under MIN_JUDGED_S, so no advice (walk 2, item 9)
    assert len(said.split()) <= MAX_SPOKEN_WORDS


def test_what_it_could_not_follow_is_said_within_the_word_limit() -> None:
    # the least important parts make room for it: the second thing to work on, then what
    # the coach stopped reminding of
    lost = [{"metric": "cv_gestures", "from": 65.0, "to": 600.0}]
    report: dict[str, Any] = {
        "talk_s": 600.0,
        "time": {"used_s": 600.0, "allocated_s": 600.0, "over_under_pct": 0.0},
        "modules": [{"module": "vision", "lost": lost}],
        "stopped_repeating": [{"metric": "speech_volume"}],
        "priorities": [{"advice": "slow down"}, {"advice": "look up at your audience"}],
    }
    said = (
        "You used 10 minutes of 10 minutes, right on time. I could not follow your gestures "
        "after 1 minute. I stopped reminding you about your volume: work on it next time. "
        "Work first on this: slow down."
    )
    assert summary_phrase(report) == said
    report["priorities"][0]["advice"] = "slow down and breathe between your main points"
    assert summary_phrase(report) == (
        "You used 10 minutes of 10 minutes, right on time. I could not follow your gestures "
        "after 1 minute. Work first on this: slow down and breathe between your main points."
    )
    report["modules"] = []  # nothing lost: said as before, the second advice too
    assert summary_phrase(report).endswith("Then: look up at your audience.")


def test_a_hung_module_is_reported_from_when_it_went_silent(tmp_path: Path) -> None:
    why = "showed no sign of life for 20 s (hung); killed"
    session = crashed_module_session(tmp_path / "s", [{"t": 25.3, "why": why, "silent_since": 5.3}])
    write_report(session.root)
    text = (session.report / "summary.txt").read_text()
    assert (
        "module fidget hung at 0:05 (killed at 0:25) and was restarted; fidget_rate was not "
        "measured from 0:05 to the end (0:45)" in text
    )
    assert build_report(session.root)["metrics"]["fidget_rate"]["out_of_range_s"] == 5.3


def test_a_restarted_module_is_measured_again_when_it_writes_again(tmp_path: Path) -> None:
    session = crashed_module_session(tmp_path / "s", [{"t": 5.7, "why": "exited with status 1"}])
    with session.stream("fidget_rate.txt").open("a") as f:
        f.write("".join(f"{t} 1.0\n" for t in range(12, 45)))
    write_report(session.root)
    text = (session.report / "summary.txt").read_text()
    assert "fidget_rate was not measured from 0:06 to 0:12;" not in text  # no trailing ';'
    assert text.count("not measured from 0:06 to 0:12") == 1


def test_a_module_silent_again_after_its_restart_is_in_the_not_measured_note(
    tmp_path: Path,
) -> None:
    # session 21, a second walkthrough: a module restarted after a hang fell silent again for
    # less than its hang limit: "stale episodes 2", but the note named only the hang
    from prezence.cli import format_timeline
    from prezence.summary import summarize_session

    why = "showed no sign of life for 20 s (hung); killed"
    hang = {"t": 25.3, "why": why, "silent_since": 5.3}
    session = crashed_module_session(tmp_path / "s", [hang])
    with session.stream("fidget_rate.txt").open("a") as f:  # back at 0:30, silent 0:35-0:44
        f.write("".join(f"{t} 1.0\n" for t in [*range(30, 36), 44]))
    hung = (
        "module fidget hung at 0:05 (killed at 0:25) and was restarted; fidget_rate was not "
        "measured from 0:05 to 0:30"
    )
    # the processor's default: a value holds 6 s, so 0:35's holds to 0:41
    again = (
        "fidget_rate went stale (module fidget wrote no new value for over 6 s) after 0:35: "
        "not measured from 0:41 to 0:44"
    )
    write_report(session.root)
    text = (session.report / "summary.txt").read_text()
    assert f"note: {hung}\n" in text and f"note: {again}\n" in text
    assert f"{again[0].upper()}{again[1:]}." in (session.report / "report.html").read_text()
    assert build_report(session.root)["counts"]["stale_episodes"] == 2
    # what `up` prints at the end of the talk: the count and the note agree
    modules = json.loads(session.summary.read_text())["modules"]
    config = Config(rules=(FIDGET,), time=TimeSettings(allocated_s=60.0))
    printed = format_timeline(
        summarize_session(session, config, talk_s=45.0, extra={"modules": modules})
    )
    assert "stale episodes 2," in printed
    assert f"note: {hung}\n" in printed and f"note: {again}" in printed


def test_unreadable_stream_lines_are_counted_per_file_in_the_report(tmp_path: Path) -> None:
    # session 13: 205 bad lines were skipped in silence; only 41 late stamps were mentioned
    session = crashed_module_session(tmp_path / "s", [])
    with session.stream("fidget_rate.txt").open("a") as f:
        f.write("hello world\nnan nan\n12 inf\n-5 7\n1e300 2\n")
    page = write_report(session.root).read_text()
    text = (session.report / "summary.txt").read_text()
    said = "4 unreadable lines in streams/fidget_rate.txt were skipped (e.g. line 7: t is not"
    assert said in text and said in page
    assert "1 sample stamped after the end of the talk (fidget_rate)" in text


@pytest.mark.parametrize("damage", ["torn last line", "bad middle line"])
def test_a_damaged_cue_line_is_skipped_named_and_said_in_the_report(
    tmp_path: Path, damage: str, caplog: pytest.LogCaptureFixture
) -> None:
    # session 13: a torn last line vanished in silence; a bad 4th line blocked the report
    session = make_session(tmp_path / "t")
    lines = session.cues.read_text().splitlines(keepends=True)
    if damage == "torn last line":
        lines[-1] = lines[-1][:-40]
        line_no = 2
    else:
        lines.insert(1, '{"t": 60.0, "comm\n')
        line_no = 2
    recorded = "".join(lines)
    session.cues.write_text(recorded)
    page = write_report(session.root).read_text()
    text = (session.report / "summary.txt").read_text()
    where = f"cues.jsonl:{line_no}: not a JSON line"
    assert any(where in r.getMessage() and "skipped" in r.getMessage() for r in caplog.records)
    said = f"a damaged record line was left out, so a cue may be missing: {where}"
    assert said in text
    assert f"A{said[1:]}" in page
    kept = ["slowDown"] if damage == "torn last line" else ["slowDown", "timeLeft"]
    assert [c["command"] for c in build_report(session.root)["cues"]] == kept
    assert session.cues.read_text() == recorded  # the record is never rewritten


def test_a_cue_cut_short_and_an_unsaid_summary_are_marked_in_the_report(tmp_path: Path) -> None:
    # session 13 (NAOqi, robot lost 0.5 s into a 2.8 s cue): shown as given, and the summary
    # the robot never said as 'What the robot says'
    session = make_session(tmp_path / "t")
    lines = session.cues.read_text().splitlines()
    cut = json.loads(lines[0])
    cut.update(ok=False, measured_s=0.5, gesture_error="robot lost: disconnected")
    session.cues.write_text("\n".join([json.dumps(cut), *lines[1:]]) + "\n")
    post = {"t": 110.0, "phrase": "You used…", "ok": False, "drop_reason": "robot is lost"}
    session.summary.write_text(json.dumps({"ended_at_s": 110.0, "post_talk": post}))
    page = write_report(session.root).read_text()
    text = (session.report / "summary.txt").read_text()
    assert "note: 1 cue cut short (0:40 slowDown: robot lost: disconnected)" in text
    assert "note: the robot did not say its summary after the talk (robot is lost)" in text
    assert "CUT SHORT: robot lost: disconnected; back in range after 20 s" in text
    assert '<span class="fa">cut short: robot lost: disconnected</span>' in page
    assert "What the robot says" not in page
    assert 'What the robot was to say, <b class="fa">not said</b> (robot is lost)' in page


def test_a_cue_and_a_summary_running_when_the_robot_was_lost_are_of_unknown_outcome(
    tmp_path: Path,
) -> None:
    # session 22 (NAOqi, robot frozen 5 s mid-cue; it finished the cue): 'CUT SHORT' and
    # 'not said' stated what the robot did not do
    session = make_session(tmp_path / "t")
    lines = session.cues.read_text().splitlines()
    cue = json.loads(lines[0])
    lost = "robot lost: no heartbeat answer within 2 s"
    for p in ("gesture", "speech"):
        cue.update({f"{p}_ok": False, f"{p}_error": lost, f"{p}_outcome": "unknown"})
    cue.update(ok=False, measured_s=3.0)
    session.cues.write_text("\n".join([json.dumps(cue), *lines[1:]]) + "\n")
    post = {"t": 110.0, "phrase": "You used…", "ok": False, "speech_ok": False}
    post.update(speech_error=lost, speech_outcome="unknown")
    session.summary.write_text(json.dumps({"ended_at_s": 110.0, "post_talk": post}))
    page = write_report(session.root).read_text()
    text = (session.report / "summary.txt").read_text()
    assert "CUT SHORT" not in text and "did not say its summary" not in text
    assert f"OUTCOME UNKNOWN: robot lost during the cue ({lost})" in text
    assert "note: 1 cue of unknown outcome: the robot may have given it in full" in text
    assert "whether it said it is unknown" in text
    assert "cut short" not in page and "not said" not in page
    assert "outcome unknown: robot lost during the cue" in page
    assert 'What the robot was saying when it was lost, <b class="fa">outcome unknown</b>' in page


def test_a_dropped_cue_is_marked_as_not_given_and_not_judged(tmp_path: Path) -> None:
    # session 15, analysis walkthrough: a cue the robot dropped (robot lost) was listed as
    # given, "back in range after 20 s; the presenter reacted", and counted as a correction
    session = make_session(tmp_path / "t")
    lines = session.cues.read_text().splitlines()
    cue = json.loads(lines[0])
    for k in ("planned_s", "measured_s"):
        del cue[k]
    cue.update(dropped=True, drop_reason="robot lost: disconnected", ok=False)
    session.cues.write_text("\n".join([json.dumps(cue), *lines[1:]]) + "\n")
    report = build_report(session.root)
    row = report["cues"][0]
    assert row["dropped"] is True and row["improved"] is None and row["effect"] is None
    assert report["counts"]["cues_judged"] == 0 and report["counts"]["cues_dropped"] == 1
    text = format_text(report)
    assert "0:40  slowDown" in text and "DROPPED, not given: robot lost: disconnected" in text
    assert "back in range" not in text and "correction" not in text
    assert "1 not given: the robot dropped it" in text
    assert "note: the robot did not give 1 cue the coach chose (0:40 slowDown: robot lost" in text
    page = write_report(session.root).read_text()
    assert '<span class="fa">not given: robot lost: disconnected</span>' in page
    assert '<span class="fa">dropped, not given: robot lost: disconnected</span>' in page


# -- session 14: what the report may claim of a cue --------------------------------------------


def _cue(
    t: float, command: str = "slowDown", metric: str | None = "speech_speed"
) -> dict[str, object]:
    return {
        "t": t,
        "command": command,
        "metric": metric,
        "kind": "weighted",
        "reason": "r",
        "params": {},
        "onset": 20.0,
        "deviation": 20.0,
        "dropped": False,
    }


def test_the_cues_of_a_recorded_rehearsal_are_not_judged(tmp_path: Path) -> None:
    # the coach chose them after the recording was made: nobody heard them
    session = make_session(tmp_path / "t")
    session.write_meta({"kind": "rehearsal", "recording": "talk.mp4", "talk_s": 110.0})
    report = build_report(session.root)
    cue = report["cues"][0]
    assert cue["heard"] is False and cue["improved"] is None and cue["effect"] is None
    assert report["counts"]["cues_judged"] == 0 and report["counts"]["cues_not_heard"] == 1
    text = format_text(report)
    assert "what followed 1 correction is not judged: a recorded rehearsal" in text
    assert "back in range" not in text


def test_no_correction_judged_says_nothing_of_corrections(tmp_path: Path) -> None:
    # the walkthrough: 'after 0 of 0 corrections you got better'
    session = make_session(tmp_path / "t", cues=[_cue(80.0, "timeLeft", None)])
    text = format_text(build_report(session.root))
    assert "0 of 0" not in text and "correction" not in text and "got better" not in text
    assert "  1 cue\n" in text


def test_a_cue_just_after_the_problem_ended_is_stale_as_measured(tmp_path: Path) -> None:
    # no ground truth (a live talk): judged on the recorded values by the evaluation's
    # definitions; pace is back in range from 60 s, so a slowDown at 65 s is stale, at 100 s
    # a false alarm, and neither has a delay 'after onset'
    session = make_session(tmp_path / "t", cues=[_cue(40.0), _cue(65.0), _cue(100.0)])
    report = build_report(session.root)
    kinds = [c["cue_class"] for c in report["cues"]]
    assert kinds == ["relevant", "stale", "false_alarm"]
    assert report["counts"]["false_alarms"] == 1 and report["counts"]["stale"] == 1
    assert [c["latency_s"] for c in report["cues"]] == [20.0, None, None]
    assert report["cues"][1]["ended_s_before"] == pytest.approx(5.0)
    text = format_text(report)
    assert "1:05  slowDown                         STALE: back in range 5 s before" in text
    assert "1:40  slowDown                         FALSE ALARM: it was in range" in text


def test_cue_times_round_halves_alike(tmp_path: Path) -> None:
    # session 15, analysis walkthrough: the printed timeline's 5:25.5 and 8:42.5 were "5:26"
    # and "8:42" in the report (halves rounded to even): one rounded up, the other down
    session = make_session(
        tmp_path / "t", cues=[_cue(25.5), _cue(42.5, "lookUp", "cv_headGaze"), _cue(58.5)]
    )
    text = format_text(build_report(session.root))
    rows = [line.split()[0] for line in text.splitlines() if line.startswith("     0:")]
    assert rows == ["0:26", "0:43", "0:59"]
    # and the delays alike: 58.5 s after the onset at 20 s is 39 s (':.0f' gave 38)
    assert "0:59  slowDown     39 s after onset" in text
    page = write_report(session.root).read_text()
    assert all(f"<tr><td>{t}</td>" in page for t in rows)


def test_samples_the_coach_left_out_are_counted_in_the_report_as_in_the_summary(
    tmp_path: Path,
) -> None:
    # session 15, analysis walkthrough: summary.json counted the samples the processor left
    # out (late, ahead of its clock), report.json's counts said 0 and had no per-metric figure
    session = make_session(tmp_path / "t")
    drops = {"speech_speed": {"dropped": {"late": 3, "ahead": 2}}}
    session.summary.write_text(json.dumps({"ended_at_s": 110.0, "metrics": drops}))
    report = build_report(session.root)
    assert report["counts"]["dropped_samples"] == 5
    assert report["metrics"]["speech_speed"]["dropped"] == {"late": 3, "ahead": 2}
    # a damaged record is not believed
    drops["speech_speed"]["dropped"]["late"] = "many"  # type: ignore[index]
    session.summary.write_text(json.dumps({"ended_at_s": 110.0, "metrics": drops}))
    assert build_report(session.root)["counts"]["dropped_samples"] == 0


def test_a_time_warning_is_not_shown_as_coming_after_an_onset(tmp_path: Path) -> None:
    # session 15, analysis walkthrough: "8:00  timeLeft  0 s after onset" (a time warning
    # follows no problem; its latency is 0 by design) next to the corrections' real delays
    session = make_session(tmp_path / "t")
    text = format_text(build_report(session.root))
    (warning,) = [line for line in text.splitlines() if "timeLeft" in line]
    assert "after onset" not in warning
    assert "20 s after onset" in next(line for line in text.splitlines() if "slowDown" in line)
    page = write_report(session.root).read_text()
    row = page[page.index("<td>1:20</td>") :].split("</tr>")[0]
    assert "<td>0 s</td>" not in row and "<td>–</td>" in row


def test_the_short_talk_says_the_allocation_it_measures_the_percentage_against(
    tmp_path: Path,
) -> None:
    # session 21, a tester: `prezence run short_talk` (2:10 allocated, 40 s used) said "You used
    # 40 seconds of 2 minutes, 69% under": 69 % is of 130 s; of 2 minutes it would be 67 %
    from prezence.synthetic.runner import run_talk

    run_talk("short_talk", out=tmp_path / "t", backend="fake", report=True, plots=False)
    said = (tmp_path / "t" / "report" / "spoken.txt").read_text()
    assert said.startswith("You used 40 seconds of 2 minutes 10 seconds, 69% under.")
