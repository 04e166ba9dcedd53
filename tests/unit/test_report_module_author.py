"""What the summary, the report and the robot say when a module of one's own misbehaves: a
walkthrough of session 22 (a module author adds a filler-word counter), from hand-made session
folders (streams, summary.json) as the modules and the coach would leave them."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from prezence.config.model import Check, Config, Rule, TimeSettings
from prezence.config.tomlconf import dumps_config
from prezence.report import build_report, summary_phrase, write_report
from prezence.session import SessionDir
from prezence.summary import summarize_session

SPEED = Rule(
    "speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp", above="slowDown", unit="wpm"
)
VOLUME = Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder", unit="dB")
CONFIG = Config(rules=(SPEED, VOLUME), time=TimeSettings(allocated_s=60.0))


def folder(
    root: Path,
    streams: dict[str, list[tuple[float, float]] | None],
    *,
    talk_s: float,
    kind: str = "live",
    recorded: dict[str, Any] | None = None,
    cues: list[dict[str, Any]] | None = None,
    config: Config = CONFIG,
) -> SessionDir:
    """A finished talk's folder: the given stream files (None: the file is there, empty;
    others absent), its cues and the summary.json the coach wrote (``recorded``)."""
    session = SessionDir(root).create()
    session.config.write_text(dumps_config(config))
    meta: dict[str, Any] = {"kind": kind, "talk_s": talk_s, "policy": "weighted"}
    if kind == "rehearsal":
        meta["recording"] = "talk.wav"
    session.write_meta(meta)
    for metric, rows in streams.items():
        text = "".join(f"{t} {v}\n" for t, v in rows or ())
        session.stream(f"{metric}.txt").write_text(text)
    session.cues.write_text("".join(json.dumps(c) + "\n" for c in cues or ()))
    session.summary.write_text(json.dumps({"ended_at_s": talk_s, **(recorded or {})}))
    return session


def cue(t: float, command: str = "slowDown", metric: str = "speech_speed") -> dict[str, Any]:
    return {
        "t": t,
        "command": command,
        "metric": metric,
        "kind": "weighted",
        "reason": f"{metric} is above its band",
        "params": {},
        "onset": 5.0,
        "deviation": 20.0,
        "phrase": "Slow down a little.",
        "dropped": False,
    }


def steady(value: float, start: float, end: float) -> list[tuple[float, float]]:
    return [(float(t), value) for t in range(int(start), int(end))]


# -- finding 2: a cue just after a module died is not "stale" --------------------------------


def crashed_pace(root: Path) -> SessionDir:
    """Pace too fast from 5 s until its module crashed at 21 s (last value at 20 s, never back
    in range); a slowDown at 24.5 s, 3.5 s after the crash."""
    mods = {"speech": {"restarts": 0, "crashes": [{"t": 21.0, "why": "exited with status 1"}],
                       "metrics": ["speech_speed", "speech_volume"]}}  # fmt: skip
    streams = {
        "speech_speed": steady(160.0, 1, 5) + steady(200.0, 5, 21),
        "speech_volume": steady(66.0, 1, 21),
    }
    return folder(root, streams, talk_s=60.0, recorded={"modules": mods}, cues=[cue(24.5)])


def test_a_cue_after_its_module_died_is_not_judged_not_stale(tmp_path: Path) -> None:
    # session 22, finding 2: "STALE: back in range 3 s before" though the metric never came
    # back in range: it stopped being measured when its module died
    session = crashed_pace(tmp_path / "s")
    summary = summarize_session(
        session, CONFIG, talk_s=60.0, extra=json.loads(session.summary.read_text())
    )
    row = summary["cues"][0]
    assert row["cue_class"] == "unmeasured" and row["relevant"] is None
    assert row["not_measured_since"] == 21.0 and "ended_s_before" not in row
    assert summary["counts"]["stale"] == 0 and summary["counts"]["false_alarms"] == 0
    assert summary["counts"]["cues_unmeasured"] == 1
    write_report(session.root, plots=False)
    text = (session.report / "summary.txt").read_text()
    assert "STALE" not in text and "stale (cued" not in text
    assert "0:25  slowDown                         NOT JUDGED: not measured after 0:21" in text
    assert "1 not judged (cued while its metric was not measured" in text
    page = (session.report / "report.html").read_text()
    assert "not judged: not measured after 0:21" in page and "back in range" not in page
    report = json.loads((session.report / "report.json").read_text())
    c = report["cues"][0]
    assert c["unmeasured"] is True and c["stale"] is False and c["false_alarm"] is False
    assert "pace was not measured after 0:21, so whether it still was is not known" in c["why"]


def test_a_cue_after_the_metric_came_back_in_range_after_a_gap_is_stale_from_then(
    tmp_path: Path,
) -> None:
    # the module was restarted and its first value was in range: measured back in range then,
    # not when the last value out of range stopped holding
    mods = {"speech": {"restarts": 1, "crashes": [{"t": 21.0, "why": "exited with status 1"}],
                       "metrics": ["speech_speed"]}}  # fmt: skip
    streams = {
        "speech_speed": steady(200.0, 5, 21) + steady(160.0, 27, 60),
        "speech_volume": steady(66.0, 1, 60),
    }
    session = folder(
        tmp_path / "s", streams, talk_s=60.0, recorded={"modules": mods}, cues=[cue(29.0)]
    )
    row = build_report(session.root)["cues"][0]
    assert row["cue_class"] == "stale" and row["ended_s_before"] == 2.0


# -- findings 5 and 6: a judged metric with no value at all is named -------------------------

FILERS = Rule("speech_filers", Check.MAX, high=4.0, above="slowDown", unit="fillers/min")
FIDGET = Rule("fidget_rate", Check.MAX, high=4.0, above="slowDown", unit="/min")


def in_range_talk(root: Path, config: Config, **streams: list[tuple[float, float]] | None) -> Any:
    base: dict[str, list[tuple[float, float]] | None] = {
        "speech_speed": steady(160.0, 1, 60),
        "speech_volume": steady(66.0, 1, 60),
    }
    return folder(root, {**base, **streams}, talk_s=60.0, config=config)


def test_a_rule_on_a_metric_no_module_writes_is_named_not_praised(tmp_path: Path) -> None:
    # session 22, finding 5: a rule on a misspelled 'speech_filers' ended with "Everything I
    # could measure stayed in the ideal range. Well done!" and a headline that said nothing
    config = Config(rules=(SPEED, VOLUME, FILERS), time=TimeSettings(allocated_s=60.0))
    session = in_range_talk(tmp_path / "s", config)
    summary = summarize_session(session, config, talk_s=60.0)
    m = summary["metrics"]["speech_filers"]
    assert m["measured"] is False
    assert m["not_measured_why"].startswith(
        "no module wrote streams/speech_filers.txt (no shipped module writes 'speech_filers'"
    )
    write_report(session.root, plots=False)
    said = (session.report / "spoken.txt").read_text()
    assert "Well done" not in said and "Everything I could measure" not in said
    assert "I could not judge your speech_filers." in said
    text = (session.report / "summary.txt").read_text()
    assert "  Not measured at all, so not judged: speech_filers (see the notes)." in text
    assert "speech_filers: not measured: no module wrote streams/speech_filers.txt" in text
    page = (session.report / "report.html").read_text()
    assert "Not measured at all, so not judged: speech_filers" in page
    assert "Well done" not in page


def test_a_module_that_wrote_nothing_is_named_in_the_praise(tmp_path: Path) -> None:
    # session 22, finding 6: its file there and empty, the robot named only the metrics
    # measured in part ("Everything I could measure stayed in the ideal range, but …")
    config = Config(rules=(SPEED, VOLUME, FIDGET), time=TimeSettings(allocated_s=60.0))
    session = in_range_talk(tmp_path / "s", config, fidget_rate=None)
    report = build_report(session.root)
    said = summary_phrase(report)
    assert "Everything I could measure" not in said and "Well done" not in said
    assert said.endswith("Your pace and volume stayed in the ideal range; I could not judge "
                         "your fidget_rate.")  # fmt: skip
    write_report(session.root, plots=False)
    text = (session.report / "summary.txt").read_text()
    assert "  Not measured at all, so not judged: fidget_rate (see the notes)." in text
    assert "fidget_rate had no data from 0:00 to the end (1:00)" in text


def test_a_metric_with_no_value_is_named_beside_the_advice(tmp_path: Path) -> None:
    # the same with something to work on: the advice alone left it unsaid
    config = Config(rules=(SPEED, VOLUME, FIDGET), time=TimeSettings(allocated_s=60.0))
    session = in_range_talk(
        tmp_path / "s", config, speech_speed=steady(200.0, 1, 60), fidget_rate=None
    )
    said = summary_phrase(build_report(session.root))
    assert "I could not measure your fidget_rate. Work first on this: slow down." in said


def test_a_camera_metric_never_asked_for_is_not_named(tmp_path: Path) -> None:
    # a rehearsal of a sound file: the camera's metrics had no module to measure them, and
    # the robot does not list them after every audio rehearsal
    gaze = Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp", unit="deg")
    config = Config(rules=(SPEED, VOLUME, gaze), time=TimeSettings(allocated_s=60.0))
    session = in_range_talk(tmp_path / "s", config)
    said = summary_phrase(build_report(session.root))
    assert "head pitch" not in said and "could not" not in said


# -- finding 9: no "I stopped reminding you" to a speaker who heard no reminder --------------


def test_a_rehearsal_is_not_told_the_robot_stopped_reminding(tmp_path: Path) -> None:
    # session 22, finding 9: `rehearse` (coached after it was recorded) ended with "I stopped
    # reminding you about your filler words", to a speaker who heard no cue at all
    note = {"metric": "speech_speed", "command": "slowDown", "cues": 2, "t": 40.0, "value": 200.0,
            "phrase": "…"}  # fmt: skip
    streams = {"speech_speed": steady(200.0, 1, 60), "speech_volume": steady(66.0, 1, 60)}
    recorded = {"stopped_repeating": [note]}
    cues = [cue(10.0), cue(30.0)]
    session = folder(
        tmp_path / "r", streams, talk_s=60.0, kind="rehearsal", recorded=recorded, cues=cues
    )
    write_report(session.root, plots=False)
    said = (session.report / "spoken.txt").read_text()
    assert "stopped reminding" not in said
    assert "Your pace needed reminders again and again: work on it next time." in said
    page = (session.report / "report.html").read_text()
    assert "The robot stopped reminding" not in page
    assert "<b>pace</b> was cued 2 times without getting back in range" in page
    # a live talk's speaker heard them: said as before
    live = folder(tmp_path / "l", streams, talk_s=60.0, recorded=recorded, cues=cues)
    said = summary_phrase(build_report(live.root))
    assert "I stopped reminding you about your pace: work on it next time." in said


# -- finding 10: a module that failed in `rehearse` is said as `up` says a crash ------------


def test_a_module_failed_in_a_rehearsal_is_said_where_up_says_a_crash(tmp_path: Path) -> None:
    # session 22, finding 10: rehearse recorded module_failures, and the printed notes, the
    # report's summary.txt and the spoken summary said nothing of it; `up` says "I could not
    # follow your filler words after 21 seconds"
    from prezence.cli import format_timeline

    failures = {"speech": "boom: crashed"}
    streams = {"speech_speed": steady(160.0, 1, 21), "speech_volume": steady(66.0, 1, 21)}
    session = folder(
        tmp_path / "r",
        streams,
        talk_s=60.0,
        kind="rehearsal",
        recorded={"module_failures": failures, "kind": "rehearsal"},
    )
    recorded = {"kind": "rehearsal", "module_failures": failures, "ended_at_s": 60.0}
    summary = summarize_session(session, CONFIG, talk_s=60.0, extra=recorded)
    crash = summary["modules"]["speech"]["crashes"]
    # it died after its last value (0:20) and before the next was due (a value a second)
    assert crash == [{"t": 21.0, "why": "boom: crashed", "last_value_t": 20.0}]
    assert summary["metrics"]["speech_speed"]["lost"] == [
        {"module": "speech", "from": 21.0, "to": 60.0}
    ]
    assert (
        "note: module speech failed after its last value at 0:20 and was not restarted (boom: "
        "crashed); speech_speed was not measured from 0:21 to the end (1:00)"
        in format_timeline(summary)
    )
    write_report(session.root, plots=False)
    text = (session.report / "summary.txt").read_text()
    assert (
        "note: module speech failed after its last value at 0:20 and was not restarted (boom: "
        "crashed); pace was not measured from 0:21 to the end (1:00)" in text
    )
    said = (session.report / "spoken.txt").read_text()
    assert "I could not follow your pace and volume after 21 seconds." in said
    # the robot's words at the end of a rehearsal, before summary.json is written
    session.summary.unlink()
    report = build_report(session.root, ended=True, module_failures=failures)
    assert "I could not follow your pace and volume after 21 seconds." in summary_phrase(report)


# -- finding 11: times that went back are shown where unreadable lines are ------------------


def test_times_that_went_back_are_counted_and_shown_with_the_first(tmp_path: Path) -> None:
    # session 22, finding 11: summary.json's stream.out_of_order was 13, and the printed line
    # ("malformed samples 0"), stream_problems and the report said nothing of it
    from prezence.cli import format_timeline

    pace = steady(160.0, 1, 11) + [(9.0, 160.0), (8.0, 160.0), (7.0, 160.0)]
    streams = {"speech_speed": pace + steady(160.0, 11, 60), "speech_volume": steady(66.0, 1, 60)}
    session = folder(tmp_path / "r", streams, talk_s=60.0, kind="rehearsal")
    summary = summarize_session(session, CONFIG, talk_s=60.0, extra={"ended_at_s": 60.0})
    assert summary["counts"]["out_of_order"] == 3
    first = (
        "streams/speech_speed.txt:11: t=9 goes back from 10 (kept as written; 3 samples of "
        "speech_speed went back in time)"
    )
    assert summary["out_of_order_times"] == [first]
    out = format_timeline(summary)
    assert "malformed samples 0, out-of-order times 3, stale episodes" in out
    assert f"note: a module's clock went back: {first}" in out
    write_report(session.root, plots=False)
    said = (
        "3 samples in streams/speech_speed.txt went back in time and were kept as written (e.g. "
        "line 11: t=9 goes back from 10): a module's clock went wrong"
    )
    assert f"  note: {said}" in (session.report / "summary.txt").read_text()
    assert said.split(": a module")[0] in (session.report / "report.html").read_text()
    report = json.loads((session.report / "report.json").read_text())
    assert report["counts"]["out_of_order"] == 3
    assert report["out_of_order"] == [
        {
            "file": "streams/speech_speed.txt",
            "samples": 3,
            "example": "line 11: t=9 goes back from 10",
        }
    ]


# -- finding 14: a module that writes less often than its record declares -------------------


def test_a_module_slower_than_its_declared_cadence_is_said_with_its_stale_spans(
    tmp_path: Path,
) -> None:
    # session 22, finding 14: a module wrote a value every 10 s where its record declares one
    # every 2 s: five stale episodes, "longest out 6 s", and nothing said why
    from prezence.cli import format_timeline

    pace = [(float(t), 200.0) for t in range(0, 60, 10)]
    volume = [(float(t), 66.0) for t in range(0, 60)]
    session = folder(tmp_path / "s", {"speech_speed": pace, "speech_volume": volume}, talk_s=60.0)
    summary = summarize_session(session, CONFIG, talk_s=60.0)
    m = summary["metrics"]["speech_speed"]
    assert m["stale_episodes"] == 6  # after each value, the last one included
    assert m["slow_cadence"] == {"median_gap_s": 10.0, "declared_s": 2.0}
    assert "slow_cadence" not in summary["metrics"]["speech_volume"]
    said = "wrote a value every 10 s (median), where its record declares one every 2 s"
    assert said in format_timeline(summary)
    write_report(session.root, plots=False)
    assert said in (session.report / "summary.txt").read_text()
