"""Replay: the processor re-run over recorded module files reproduces or varies the talk."""

from __future__ import annotations

import json
import logging
import shutil
from pathlib import Path
from typing import Any

import pytest

from prezence.cli import main
from prezence.errors import ConfigError
from prezence.replay import replay
from prezence.synthetic.runner import run_talk
from prezence.talk import RunOptions


@pytest.fixture(scope="module")
def demo_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("talk") / "demo"
    run_talk("demo", out=out, seed=3, backend="fake")
    return out


def test_replay_with_same_policy_reproduces_the_decision_log(
    demo_session: Path, tmp_path: Path
) -> None:
    result = replay(
        demo_session,
        out=tmp_path / "r",
        options=RunOptions.default(policy="weighted"),
        backend="fake",
    )
    assert (tmp_path / "r" / "decisions.jsonl").read_bytes() == (
        demo_session / "decisions.jsonl"
    ).read_bytes()
    assert result.cues and result.summary["counts"]["cues"] == len(result.cues)


def test_replay_with_another_policy_changes_the_cues(demo_session: Path, tmp_path: Path) -> None:
    silent = replay(
        demo_session,
        out=tmp_path / "none",
        options=RunOptions.default(policy="none"),
        backend="fake",
    )
    assert silent.cues == []
    first = replay(
        demo_session,
        out=tmp_path / "first",
        options=RunOptions.default(policy="first_rule"),
        backend="fake",
    )
    assert first.cues
    assert first.summary["counts"]["false_alarms"] >= 0  # truth carried over from the recording


def test_replay_never_overwrites_the_recording(demo_session: Path) -> None:
    with pytest.raises(ConfigError, match="another folder"):
        replay(demo_session, out=demo_session, options=RunOptions.default())


def test_replay_of_a_folder_without_streams_names_it(tmp_path: Path) -> None:
    (tmp_path / "src").mkdir()
    with pytest.raises(ConfigError, match="no stream files"):
        replay(tmp_path / "src", out=tmp_path / "out", options=RunOptions.default())


def test_rules_whose_metrics_have_no_stream_show_the_streams_that_are_there(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Session 20: a rules file naming only a misspelt metric said "no stream files found" of a
    # folder holding the streams; the error now lists them and the close one.
    src = tmp_path / "rec" / "streams"
    src.mkdir(parents=True)
    for name in ("speech_speed", "speech_volume"):
        (src / f"{name}.txt").write_text("0 150.0\n1 150.0\n")
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_sped inRange 140 180 speedUp slowDown\n")
    argv = ["replay", str(src.parent), "--config", str(rules), "--out", str(tmp_path / "o")]
    assert main([*argv, "-q"]) == 2
    err = capsys.readouterr().err
    assert "holds speech_speed.txt, speech_volume.txt" in err, err
    assert "did you mean speech_speed.txt for speech_sped.txt?" in err, err


def test_replay_cli_on_plain_stream_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # files another tool wrote in the stream format, no session.json: talk length from the data
    src = tmp_path / "rec"
    src.mkdir()
    lines = "".join(f"{t} {240.0 if t > 20 else 160.0}\n" for t in range(0, 121))
    (src / "speech_speed.txt").write_text(lines)
    assert main(["replay", str(src), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "slowDown" in out


def test_replay_and_report_skip_values_outside_the_physical_range(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A module gone wrong writes 5000 wpm and a clarity of 7.5 (0..1): before, the coach cued
    # "5000 is 2678% above 180 wpm", 7.5 counted as in range and the summary said nothing.
    src = tmp_path / "rec"
    src.mkdir()
    (src / "speech_speed.txt").write_text(
        "".join(f"{t} {5000 if t % 10 < 5 else 160}\n" for t in range(0, 61))
    )
    (src / "speech_accuracy.txt").write_text("".join(f"{t} 7.5\n" for t in range(0, 61)))
    out = tmp_path / "out"
    assert main(["replay", str(src), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "slowDown" not in printed
    summary = json.loads((out / "summary.json").read_text())
    problems = summary["stream_problems"]
    assert (
        # the replay's byte-identical copy, inside its folder (session 15)
        "streams/speech_speed.txt:1: value 5000 is outside speech_speed's physical range 0..400"
        in problems
    )
    assert (
        "streams/speech_accuracy.txt:1: value 7.5 is outside speech_accuracy's physical range 0..1"
        in problems
    )
    assert summary["metrics"]["speech_speed"]["stream"]["malformed"] == 31  # 0-4, 10-14, … 60
    assert summary["metrics"]["speech_accuracy"]["samples"] == 0
    # the table's mean is the plausible values' (160), not 2663
    row = next(line for line in printed.splitlines() if line.startswith("speech_speed "))
    assert "160.00" in row.split()


def test_a_metric_of_your_own_gets_a_physical_range_from_its_rule(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # fidget.py --mode range of the walkthrough: -1e30 and 99999999 made the table's mean
    # -3.2e29 and the robot cued on 1e+08; a rule may now say what the metric can be.
    src = tmp_path / "rec"
    src.mkdir()
    rows = [f"{t} {6.0 if t % 20 < 12 else 1.0}\n" for t in range(0, 60)]
    rows[10:10] = ["10.1 -1e30\n", "10.2 99999999\n"]
    (src / "fidget_rate.txt").write_text("".join(rows))
    rules = tmp_path / "rules.txt"
    rules.write_text("fidget_rate max 3 gestureLess unit=1/min range=0..60\n")
    out = tmp_path / "out"
    assert main(["replay", str(src), "--config", str(rules), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "1e+08" not in printed and "e+29" not in printed
    row = next(line for line in printed.splitlines() if line.startswith("fidget_rate "))
    assert float(row.split()[3]) == pytest.approx((36 * 6.0 + 24 * 1.0) / 60, abs=0.01)
    problems = json.loads((out / "summary.json").read_text())["stream_problems"]
    assert problems == [
        "streams/fidget_rate.txt:11: value -1e+30 is outside fidget_rate's physical range 0..60",
        "streams/fidget_rate.txt:12: value 1e+08 is outside fidget_rate's physical range 0..60",
    ]


def test_replay_under_other_bands_drops_the_ground_truth(
    demo_session: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a narrower pace band: cues right under it were out of range for the recorded truth,
    # which would have called them false alarms
    rules = tmp_path / "narrow.txt"
    rules.write_text("speech_speed inRange 150 160 speedUp slowDown\n")
    out = tmp_path / "narrow"
    assert main(["replay", str(demo_session), "--out", str(out), "--config", str(rules)]) == 0
    assert "ground truth is not used" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert "bands differ" in summary["truth_dropped"]
    assert summary["counts"]["cues"] >= 1 and summary["counts"]["false_alarms"] == 0
    assert "truth_time_in_range" not in summary["metrics"]["speech_speed"]
    assert not (out / "truth.jsonl").exists()


def test_replay_under_the_same_bands_keeps_the_ground_truth(
    demo_session: Path, tmp_path: Path
) -> None:
    result = replay(
        demo_session, out=tmp_path / "r", options=RunOptions.default(policy="recent", report=True)
    )
    assert "truth_dropped" not in result.summary
    assert "truth_time_in_range" in result.summary["metrics"]["speech_speed"]
    assert (tmp_path / "r" / "truth.jsonl").read_bytes() == (
        demo_session / "truth.jsonl"
    ).read_bytes()
    assert result.report is not None
    assert json.loads((tmp_path / "r" / "report" / "report.json").read_text())["has_truth"]


def test_replay_cli_writes_the_report_with_the_time_allocated(tmp_path: Path) -> None:
    src = tmp_path / "rec"
    src.mkdir()
    (src / "speech_speed.txt").write_text("".join(f"{t} 160.0\n" for t in range(37)))
    out = tmp_path / "out"
    assert main(["replay", str(src), "--out", str(out), "--allocated", "36", "-q"]) == 0
    report = json.loads((out / "report" / "report.json").read_text())
    assert report["time"]["allocated_s"] == 36.0
    assert (out / "report" / "spoken.txt").read_text().startswith("You used 36 seconds of 36")
    out2 = tmp_path / "out2"
    assert main(["replay", str(src), "--out", str(out2), "--no-report"]) == 0
    assert not (out2 / "report").exists()


def test_replay_with_a_rules_file_keeps_the_time_the_recorded_talk_had(
    demo_session: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # Session 20: a 540 s talk replayed with a seed-format rules file (which has no time, so it
    # loads the default 600 s) read "1 % under" for "10 % over", its time cues moved, and
    # nothing said so. The time allocated is a fact of the talk, not a rule to try.
    src = tmp_path / "rec"
    shutil.copytree(demo_session, src)
    cfg = src / "config.toml"
    text = cfg.read_text()
    assert "allocated_s = 600.0" in text
    cfg.write_text(text.replace("allocated_s = 600.0", "allocated_s = 540.0"))
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_speed inRange 140 180\nspeech_volume min 60 louder\n")

    def replayed(source: Path, out: str, *extra: str) -> dict[str, Any]:
        argv = ["replay", str(source), "--config", str(rules), "--out", str(tmp_path / out)]
        assert main([*argv, *extra, "--no-report", "-q"]) == 0
        summary: dict[str, Any] = json.loads((tmp_path / out / "summary.json").read_text())
        return summary

    with caplog.at_level(logging.WARNING, logger="prezence.config.load"):
        summary = replayed(src, "a")
    assert summary["time"]["allocated_s"] == 540.0
    talk_s = summary["talk_s"]
    assert summary["time"]["over_under_pct"] == pytest.approx(100 * (talk_s - 540) / 540, abs=0.01)
    assert "had 540 s allocated; kept (the rules given say 600 s)" in caplog.text
    # --allocated still decides when given
    assert replayed(src, "b", "--allocated", "10m")["time"]["allocated_s"] == 600.0
    # the same from the session's streams/ folder, and for a report judged by the rules file
    assert replayed(src / "streams", "c")["time"]["allocated_s"] == 540.0
    from prezence.config.load import load_config
    from prezence.report.build import build_report

    report = build_report(src, config=load_config(rules))
    assert report["time"]["allocated_s"] == 540.0


def test_a_replay_of_a_talk_played_from_files_judges_no_cue_by_what_followed(
    demo_session: Path, tmp_path: Path
) -> None:
    # Session 20, review: `up` from files marks its cues as not heard, but a replay of it judged
    # them by what followed, as if the person in the recording had heard the robot.
    from prezence.report.build import build_report

    src = tmp_path / "rec"
    shutil.copytree(demo_session, src)
    meta = json.loads((src / "session.json").read_text())
    (src / "session.json").write_text(json.dumps({**meta, "kind": "live", "recorded_inputs": True}))
    out = tmp_path / "r"
    assert main(["replay", str(src), "--out", str(out), "--no-report", "-q"]) == 0
    report = build_report(out)
    assert "heard the recording's cues, not these" in report["effects_not_judged"]
    assert all(c.get("heard") is False for c in report["cues"] if c.get("metric"))


def test_a_replay_keeps_what_the_report_reads_beyond_the_rules(
    demo_session: Path, tmp_path: Path
) -> None:
    # Session 20, review: a replay copied the rules' streams only, so its report lost when the
    # voice was first heard ("Your first words came 1 minute in") and that the recorded talk
    # was cut at its time limit ("at least N% over").
    from prezence.report.build import build_report

    src = tmp_path / "rec"
    shutil.copytree(demo_session, src)
    talk_s = json.loads((src / "session.json").read_text())["talk_s"]
    end = int(talk_s)
    (src / "streams" / "speech_activity.txt").write_text(
        "".join(f"{t} {0.0 if t < 61 else 0.9}\n" for t in range(1, end + 1))
    )
    summary = json.loads((src / "summary.json").read_text())
    summary["stopped_at_time_limit"] = {"at_s": talk_s, "grace_s": 30.0}
    (src / "summary.json").write_text(json.dumps(summary))
    assert build_report(src)["time"]["first_voice_s"] == 61.0
    out = tmp_path / "r"
    assert main(["replay", str(src), "--out", str(out), "--no-report", "-q"]) == 0
    time_used = build_report(out)["time"]
    assert time_used["first_voice_s"] == 61.0
    assert time_used["stopped_at_limit"] is True


def test_a_replay_reports_all_its_recording_measured_and_keeps_the_module_notes(
    demo_session: Path, tmp_path: Path
) -> None:
    # Session 21, a tester's walkthrough: the replay of a video rehearsal copied only the
    # streams its rules read, so its report said "Head turns: not measured: no camera module
    # ran", and it dropped the speech module's note that the volume is an uncalibrated estimate
    # (speech.json) and the logs the report's notes point at.
    from prezence.report.build import build_report

    src = tmp_path / "rec"
    shutil.copytree(demo_session, src)
    talk_s = int(json.loads((src / "session.json").read_text())["talk_s"])
    yaw = "".join(f"{t} {25.0 if t % 60 < 10 else 0.0}\n" for t in range(1, talk_s))
    (src / "streams" / "cv_headYaw.txt").write_text(yaw)
    estimate = "an estimate: the microphone is not calibrated"
    (src / "speech.json").write_text(
        json.dumps({"format": 1, "estimate": {"speech_volume": estimate}})
    )
    (src / "speech.log").write_text("speech: WARNING: t=10 s: a line the notes point at\n")
    summary = json.loads((src / "summary.json").read_text())
    summary["module_failures"] = {"extra": "error: it could not open its input"}
    (src / "summary.json").write_text(json.dumps(summary))
    recorded = build_report(src)
    assert recorded["head"]["measured"] and recorded["head"]["turns_away"] > 0
    out = tmp_path / "r"
    assert main(["replay", str(src), "--out", str(out), "--no-report", "-q"]) == 0
    replayed = build_report(out)
    assert replayed["head"] == recorded["head"]
    assert (out / "streams" / "cv_headYaw.txt").read_text() == yaw
    notes = json.dumps(replayed)
    assert estimate in notes
    assert (out / "speech.log").read_text() == (src / "speech.log").read_text()
    assert json.loads((out / "summary.json").read_text())["module_failures"] == {
        "extra": "error: it could not open its input"
    }
    # a folder of stream files: a stream named after a metric is copied too, nothing else
    flat = tmp_path / "flat"
    flat.mkdir()
    for name in ("speech_speed.txt", "cv_headYaw.txt"):
        shutil.copyfile(src / "streams" / name, flat / name)
    (flat / "notes.txt").write_text("not a stream\n")
    assert main(["replay", str(flat), "--out", str(tmp_path / "f"), "--no-report", "-q"]) == 0
    assert build_report(tmp_path / "f")["head"]["turns_away"] == recorded["head"]["turns_away"]
    assert not (tmp_path / "f" / "streams" / "notes.txt").exists()


def test_replay_room_needs_rules(demo_session: Path, tmp_path: Path) -> None:
    room = tmp_path / "room.toml"
    room.write_text('format = 1\n[room]\nname = "hall"\n')
    argv = ["replay", str(demo_session), "--out", str(tmp_path / "r"), "--room", str(room)]
    assert main(argv) == 2


class FakeWall:
    """A wall clock for ``prezence.talk``: sleeping moves it on, nothing really waits."""

    def __init__(self) -> None:
        self.t = 100.0
        self.slept: list[float] = []

    def perf_counter(self) -> float:
        return self.t

    def sleep(self, s: float) -> None:
        self.slept.append(s)
        self.t += s


def test_replay_in_real_time_follows_the_wall_clock(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import prezence.talk

    src = tmp_path / "rec"
    src.mkdir()
    (src / "speech_speed.txt").write_text("".join(f"{t / 2} 160.0\n" for t in range(5)))
    wall = FakeWall()
    monkeypatch.setattr(prezence.talk, "time", wall)
    replay(src, out=tmp_path / "fast", options=RunOptions.default())
    assert wall.slept == []  # not paced: the fake robot needs no wall clock
    paced = replay(src, out=tmp_path / "paced", options=RunOptions.default(realtime=True))
    # every decision point (0.5 s apart over the 2 s recording) waited for the wall clock
    assert len(wall.slept) == 4 and sum(wall.slept) == pytest.approx(2.0)
    assert paced.summary["wall_s"] == pytest.approx(2.0)
    assert (tmp_path / "fast" / "decisions.jsonl").read_bytes() == (
        tmp_path / "paced" / "decisions.jsonl"
    ).read_bytes()


def test_a_real_time_backend_is_paced_without_being_named(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Pacing follows the backend's declared property, whatever the backend is called."""
    import prezence.talk
    from prezence.backends.fake import FakeBackend
    from prezence.config.load import load_config
    from prezence.samples import Sample
    from prezence.session import SessionDir
    from prezence.talk import RecordedSource, run_talk

    class SlowRobot(FakeBackend):
        name = "fake"  # the same name as the fake backend, which is never paced
        realtime = True

    wall = FakeWall()
    monkeypatch.setattr(prezence.talk, "time", wall)
    samples = [Sample("speech_speed", t / 2, 160.0) for t in range(5)]
    run_talk(
        RecordedSource(samples, talk_s=2.0),
        config=load_config(None),
        session=SessionDir(tmp_path / "s"),
        backend=SlowRobot(),
        options=RunOptions.default(),
    )
    assert sum(wall.slept) == pytest.approx(2.0)


@pytest.mark.parametrize("burst", [1, 5, 16, 17, 200])
def test_a_recording_gives_each_decision_point_exactly_its_new_samples(burst: int) -> None:
    """Every sample once, at the first point at or after its stamp, in recorded order,
    whether a point takes a few samples or a long burst (a module that wrote late)."""
    from prezence.samples import Sample
    from prezence.talk import RecordedSource

    stamps = [0.1 * k for k in range(40)] + [4.5] * burst + [4.5 + 0.25 * k for k in range(1, 9)]
    samples = [Sample("volume", t, float(i)) for i, t in enumerate(stamps)]
    src = RecordedSource(samples, talk_s=10.0)
    points = [0.5 * k for k in range(1, 21)]
    got = [list(src.poll(now)) for now in points]
    assert [s for batch in got for s in batch] == samples
    prev = -1.0
    for now, batch in zip(points, got, strict=True):
        assert all(prev < s.t <= now for s in batch)
        prev = now
    assert src.poll(100.0) == ()


def test_a_bad_stream_line_is_warned_about_once_naming_the_source(
    demo_session: Path, tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    src = tmp_path / "binstream"
    shutil.copytree(demo_session, src)
    with (src / "streams" / "speech_speed.txt").open("ab") as f:
        f.write(b"12\xff\xfe 160\n\x80\x81\n")
    out = tmp_path / "rp_x"
    with caplog.at_level(logging.WARNING):
        assert main(["replay", str(src), "--out", str(out)]) == 0
    assert (out / "report" / "report.html").is_file()  # the report read the copies too
    said = [r.getMessage() for r in caplog.records if "not UTF-8" in r.getMessage()]
    assert len(said) == 2, said
    assert all(m.startswith(f"{src / 'streams' / 'speech_speed.txt'}:") for m in said), said


def test_the_speech_modules_own_rates_carry_their_true_units(tmp_path: Path) -> None:
    # session 21, a second walkthrough: speech_articulation (words per speaking minute, about
    # 140) was labelled "syllables/s", so a report read "132 syllables/s" and a rule written
    # from the docs ("max 5") was out of range all the time; speech_speed_syllables (words per
    # minute from syllable nuclei) was "syllables/min", speech_loudness (LUFS) "dBFS"
    src = tmp_path / "rec"
    src.mkdir()
    for name, value in (("speech_articulation", 140.0), ("speech_speed_syllables", 150.0)):
        (src / f"{name}.txt").write_text("".join(f"{t} {value}\n" for t in range(1, 40)))
    rules = tmp_path / "rules.txt"
    rules.write_text(
        "speech_articulation inRange 120 200 speedUp slowDown\n"
        "speech_speed_syllables inRange 140 180 speedUp slowDown\n"
    )
    out = tmp_path / "r"
    assert main(["-q", "replay", str(src), "--out", str(out), "--config", str(rules)]) == 0
    metrics = json.loads((out / "summary.json").read_text())["metrics"]
    assert metrics["speech_articulation"]["unit"] == "wpm"
    assert metrics["speech_speed_syllables"]["unit"] == "wpm"
    assert "syllables/s" not in (out / "report" / "summary.txt").read_text()
    from prezence.metrics import METRICS

    assert METRICS["speech_loudness"].unit == "LUFS"


def test_replay_leaves_the_garbage_collector_as_it_found_it(
    demo_session: Path, tmp_path: Path
) -> None:
    # session 26: a replay pauses the collector while it reads and freezes what it read while
    # it replays; after it, cycles are collected again and nothing stays frozen
    import gc

    assert gc.isenabled() and gc.get_freeze_count() == 0
    replay(demo_session, out=tmp_path / "a", options=RunOptions.default(), backend="fake")
    assert gc.isenabled() and gc.get_freeze_count() == 0
    with pytest.raises(ConfigError):  # the recording given as its own output
        replay(demo_session, out=demo_session, options=RunOptions.default(), backend="fake")
    assert gc.isenabled() and gc.get_freeze_count() == 0
    gc.freeze()  # a process that froze its own objects keeps them frozen
    try:
        replay(demo_session, out=tmp_path / "b", options=RunOptions.default(), backend="fake")
        assert gc.get_freeze_count() > 0  # not unfrozen by the replay
    finally:
        gc.unfreeze()
