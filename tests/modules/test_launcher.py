"""``prezence up``: modules and processor in parallel, supervised, in real time (a few seconds)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

from prezence.backends.fake import FakeBackend
from prezence.config.model import Check, Config, ProcessorSettings, Rule, TimeSettings
from prezence.launcher import (
    DEFAULT_HANG_S,
    SPEECH_HEARTBEAT_METRIC,
    VISION_METRICS,
    LiveSource,
    ModuleProcess,
    ModuleSpec,
    speech_module,
    up,
    vision_module,
)
from prezence.session import read_jsonl
from prezence.talk import RunOptions

PACE = Path(__file__).with_name("pace_module.py")
BEAT = Path(__file__).with_name("beat_module.py")
JUNK = Path(__file__).with_name("junk_module.py")

CONFIG = Config(
    rules=(Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown"),),
    processor=ProcessorSettings(
        threshold=40.0, stale_after_s=1.0, refractory_s=60.0, praise_after_s=0
    ),
    time=TimeSettings(allocated_s=None),
)


def pace(*extra: str) -> ModuleSpec:
    argv = [sys.executable, str(PACE), "--out", "{session}", "--t0", "{t0}", "--wpm", "260", *extra]
    return ModuleSpec("pace", argv, metrics=("speech_speed",))


def beat(name: str, *extra: str, hang_after_s: float | None = 1.0) -> ModuleSpec:
    argv = [sys.executable, str(BEAT), "--out", "{session}", "--t0", "{t0}", *extra]
    metrics = (extra[extra.index("--metric") + 1],) if "--metric" in extra else ()
    return ModuleSpec(name, argv, metrics=metrics, hang_after_s=hang_after_s)


@pytest.mark.slow
def test_up_runs_modules_and_coaches_live(tmp_path: Path) -> None:
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[pace()],
        backend=FakeBackend(time_scale=0.01),  # the spoken summary ends at once
        duration_s=4.0,
        options=RunOptions.default(report=True),
    )
    cues = read_jsonl(tmp_path / "s" / "cues.jsonl")
    assert [c["command"] for c in cues] == ["slowDown"]
    assert result.summary["metrics"]["speech_speed"]["samples"] >= 10
    assert result.summary["modules"]["pace"]["restarts"] == 0
    # after the talk: the robot says the summary, and the report is written
    post = result.summary["post_talk"]
    assert post["ok"] and post["phrase"].startswith("You spoke for")
    # 4 s of pace is under MIN_JUDGED_S: the cue was given live, but no advice after it
    assert "too short for me to judge" in post["phrase"]
    assert result.report == tmp_path / "s" / "report" / "report.html"
    assert result.report.exists()
    spoken = (tmp_path / "s" / "report" / "spoken.txt").read_text().strip()
    assert spoken == post["phrase"]


@pytest.mark.slow
def test_a_talk_the_time_limit_stops_says_the_time_used_is_a_lower_bound(tmp_path: Path) -> None:
    # Session 20, a tester: a 360 s file played with --allocated 5m stopped at 5:30 (the
    # allocated time plus the grace) and the report said "You used 5 and a half minutes of 5
    # minutes, 10% over", the console "+10.1%": nothing said the last 30 s were cut. And the
    # cues of a talk whose inputs are files were judged by what followed them, as if the
    # person in the recording had heard the robot.
    from dataclasses import replace

    from prezence.cli import format_timeline
    from prezence.report.build import build_report

    config = replace(CONFIG, time=TimeSettings(allocated_s=4.0, warn_at_s_left=()))
    recorded = replace(pace(), finite=True)  # an input file, still playing at the limit
    result = up(
        config,
        session_dir=tmp_path / "s",
        modules=[recorded],
        backend=FakeBackend(time_scale=0.01),
        grace_s=2.0,
        options=RunOptions.default(report=True),
    )
    t = result.summary["time"]
    assert t["stopped_at_limit"] is True
    assert 6.0 <= t["used_s"] < 9.0 and t["over_under_pct"] > 0
    assert "or more: stopped at the time limit" in format_timeline(result.summary)
    report = build_report(tmp_path / "s")
    assert report["time"]["stopped_at_limit"] is True
    spoken = (tmp_path / "s" / "report" / "spoken.txt").read_text()
    assert spoken.startswith("You were still going when the coach stopped at"), spoken
    assert "at least" in result.summary["post_talk"]["phrase"]
    assert (
        "still going when the time limit stopped"
        in (tmp_path / "s" / "report" / "report.html").read_text()
    )
    assert "inputs were recordings played as if live" in report["effects_not_judged"]
    cues = [c for c in report["cues"] if c.get("metric") == "speech_speed"]
    assert cues and all(c.get("heard") is False for c in cues), report["cues"]


@pytest.mark.slow
def test_up_skips_values_outside_the_physical_range_and_says_where(tmp_path: Path) -> None:
    # The walkthrough's bad_speed.py: 5000 wpm was cued as "2678 % above 180 wpm" and the
    # summary's stream problems were empty.
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[pace("--wpm", "5000")],
        backend=FakeBackend(time_scale=0.01),
        duration_s=2.0,
        options=RunOptions.default(report=False),
    )
    assert read_jsonl(tmp_path / "s" / "cues.jsonl") == []
    speed = result.summary["metrics"]["speech_speed"]
    assert speed["samples"] == 0 and speed["stream"]["malformed"] >= 10
    # named inside the session folder, as the report names it (session 15)
    assert result.summary["stream_problems"][0] == (
        "streams/speech_speed.txt:1: value 5000 is outside speech_speed's physical range 0..400"
    )


@pytest.mark.slow
def test_the_printed_summary_the_report_and_a_replay_count_the_same_unreadable_lines(
    tmp_path: Path,
) -> None:
    # session 14: 246 unreadable lines printed at the end of the talk, 205 in the report and
    # 41 "samples stamped after the end": the coach skips a line stamped ahead of its clock,
    # a reading afterwards had no clock and took it as a sample (5 s ahead) or as after the end
    import json

    from prezence.cli import format_timeline
    from prezence.replay import replay

    argv = [sys.executable, str(JUNK), "--out", "{session}", "--t0", "{t0}"]
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[ModuleSpec("junk", argv, metrics=("speech_speed",))],
        backend=FakeBackend(time_scale=0.01),
        duration_s=2.0,
        options=RunOptions.default(report=True),
    )
    speed = result.summary["metrics"]["speech_speed"]
    n = speed["stream"]["malformed"]
    assert n >= 10
    assert f"note: {n} unreadable lines of speech_speed skipped" in format_timeline(result.summary)
    text = (tmp_path / "s" / "report" / "summary.txt").read_text()
    assert f"note: {n} unreadable lines in streams/speech_speed.txt were skipped" in text
    assert "stamped after the end" not in text
    report = json.loads((tmp_path / "s" / "report" / "report.json").read_text())
    read = report["metrics"]["speech_speed"]
    assert read["samples"] == speed["samples"] == speed["stream"]["samples"]
    assert read["p90"] == speed["p90"] == 160.0  # no 230 written 5 s ahead
    options = RunOptions.default(report=True)
    again = replay(tmp_path / "s", out=tmp_path / "r", options=options, backend="fake")
    assert again.summary["metrics"]["speech_speed"]["stream"]["malformed"] == n
    assert f"{n} unreadable lines" in (tmp_path / "r" / "report" / "summary.txt").read_text()


@pytest.mark.slow
def test_two_healthy_modules_writing_different_streams_are_never_restarted(
    tmp_path: Path,
) -> None:
    # Each module is judged by its own files: one module's look must not use up the other's
    # growth (with a shared table the second always looked silent and was killed).
    speech = beat("speech", "--metric", "speech_speed", hang_after_s=1.0)
    vision = beat("vision", "--metric", "cv_gestures", "--value", "6", hang_after_s=1.0)
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[speech, vision],
        backend=FakeBackend(),
        duration_s=3.5,  # more than three hang limits
        options=RunOptions.default(),
    )
    assert result.summary["modules"] == {
        "speech": {"restarts": 0, "crashes": []},
        "vision": {"restarts": 0, "crashes": []},
    }
    assert not result.events
    for metric in ("speech_speed", "cv_gestures"):
        lines = (tmp_path / "s" / "streams" / f"{metric}.txt").read_text().splitlines()
        assert len(lines) >= 25  # both wrote all along


@pytest.mark.slow
def test_only_a_module_with_a_hang_limit_and_no_sign_of_life_is_restarted(
    tmp_path: Path,
) -> None:
    modules = [
        beat("writer", "--metric", "speech_speed"),
        # no sample, but touches its heartbeat file
        beat("pausing", "--heartbeat-only", "--metric", "speech_volume"),
        beat("quiet", "--silent", hang_after_s=None),  # no hang limit: never killed for it
        beat("stuck", "--silent", "--metric", "cv_gestures"),  # hung: writes nothing
    ]
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=modules,
        backend=FakeBackend(),
        duration_s=3.0,
        options=RunOptions.default(),
    )
    mods = result.summary["modules"]
    assert {n: m["restarts"] for n, m in mods.items() if n != "stuck"} == {
        "writer": 0,
        "pausing": 0,
        "quiet": 0,
    }
    assert mods["stuck"]["restarts"] >= 1
    assert "no sign of life for 1 s (hung); killed" in mods["stuck"]["crashes"][0]["why"]
    assert (tmp_path / "s" / "streams" / ".pausing.alive").exists()
    assert (tmp_path / "s" / "stuck.log").exists()  # one log per module


def test_hang_is_judged_on_the_talk_clock(tmp_path: Path) -> None:
    """A silent module with a 1 s limit: alive at 0.9 s, killed at 1.2 s of talk time (the
    times are given, so no wall clock decides it)."""
    spec = ModuleSpec(
        "stuck",
        [sys.executable, "-c", "import time; time.sleep(60)"],
        metrics=("cv_gestures",),
        hang_after_s=1.0,
    )
    (tmp_path / "streams").mkdir()
    with (tmp_path / "stuck.log").open("a") as log:
        proc = ModuleProcess(spec, tmp_path, 0.0, log)
        proc.start(0.0)
        try:
            assert proc.check(0.5) is None and proc.check(0.9) is None
            (tmp_path / "streams" / "cv_gestures.txt").write_text("0.9 5\n")  # a sign of life
            assert proc.check(1.5) is None  # 0.6 s since it wrote: alive
            event = proc.check(2.6)  # 1.1 s without a sign of life
            assert event is not None and "hung" in event
            # it stopped measuring when it was last seen alive (the report's "hung at")
            why = proc.crashes[0]["why"]
            assert proc.crashes == [{"t": 2.6, "why": why, "silent_since": 1.5}]
            assert proc.proc is None and proc.next_start == 2.6 + 1.0  # restart after backoff
        finally:
            proc.stop(timeout_s=0.5)
            if proc.proc is not None:
                proc.proc.kill()


def test_built_in_module_specs() -> None:
    from prezence.modules import speech as speech_mod

    speech = speech_module("talk.wav", ["--window", "5"])
    assert speech.argv[-2:] == ["--window", "5"] and "--realtime" in speech.argv
    assert speech.finite and speech.metrics == speech_mod.METRICS
    # watched for hangs only if it writes in pauses too; else a pause would look like a hang
    beats = SPEECH_HEARTBEAT_METRIC in speech_mod.METRICS
    assert speech.hang_after_s == (DEFAULT_HANG_S if beats else None)
    mic = speech_module("mic")
    assert not mic.finite and "--realtime" not in mic.argv
    vision = vision_module("cam:1", ["--audience-yaw", "12"])
    assert vision.argv[-2:] == ["--audience-yaw", "12"] and not vision.finite
    assert vision.metrics == VISION_METRICS and vision.hang_after_s == DEFAULT_HANG_S


def test_vision_metric_list_matches_the_module() -> None:
    pytest.importorskip("cv2")
    from prezence.modules import vision

    assert vision.METRICS == VISION_METRICS


def test_two_modules_of_the_same_name_are_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="two modules are called pace"):
        up(
            CONFIG,
            session_dir=tmp_path / "s",
            modules=[pace(), pace()],
            backend=FakeBackend(),
            options=RunOptions.default(),
        )


def test_two_modules_writing_one_metric_are_refused_before_anything_starts(tmp_path: Path) -> None:
    # Session 22's module-author walkthrough: the speech module (from --audio) and a --module
    # of one's own both declared speech_speed; their lines interleaved in one stream file.
    mine = ModuleSpec.parse("mypace:speech_speed,my_metric=python pace.py --out {session}")
    with pytest.raises(ValueError, match=r"one stream \(speech_speed by pace and mypace\)"):
        up(
            CONFIG,
            session_dir=tmp_path / "s",
            modules=[pace(), mine],
            backend=FakeBackend(),
            options=RunOptions.default(),
        )
    assert not (tmp_path / "s").exists()
    # a module of one's own that lists a metric twice is no second writer (a review)
    twice = ModuleSpec.parse("mine:my_a,my_a=python pace.py --out {session}")
    LiveSource([twice], end_at=None)


@pytest.mark.slow
def test_crashed_module_is_restarted_and_the_talk_completes(tmp_path: Path) -> None:
    marker = tmp_path / "crashed"
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[pace("--crash-after", "5", "--marker", str(marker))],
        backend=FakeBackend(),
        duration_s=5.0,
        options=RunOptions.default(),
    )
    assert marker.exists()
    mod = result.summary["modules"]["pace"]
    assert mod["restarts"] == 1 and "status 3" in mod["crashes"][0]["why"]
    assert any("restarted" in e for e in result.events)
    samples = [
        float(ln.split()[0])
        for ln in (tmp_path / "s/streams/speech_speed.txt").read_text().splitlines()
    ]
    assert samples[-1] > mod["crashes"][0]["t"] + 1.0  # it wrote again after the restart
    assert (tmp_path / "s" / "summary.json").exists()


@pytest.mark.slow
@pytest.mark.parametrize(
    "beside", [False, True], ids=["the only module naming none", "beside another naming none"]
)
def test_a_crashed_module_that_names_no_metrics_loses_the_metrics_it_wrote(
    tmp_path: Path, beside: bool
) -> None:
    # session 14: --module NAME=CMD crashed, the crash was said, but no metric was 'not
    # measured from X': the launcher knew no metric of a module that named none
    from prezence.cli import format_timeline

    marker = tmp_path / "crashed"
    crashing = ModuleSpec("pace", pace("--crash-after", "5", "--marker", str(marker)).argv)
    other = ModuleSpec("beat", beat("beat", "--metric", "cv_gestures").argv)
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[crashing, other] if beside else [crashing],
        backend=FakeBackend(time_scale=0.01),
        duration_s=5.0,
        options=RunOptions.default(report=True),
    )
    mod = result.summary["modules"]["pace"]
    assert "status 3" in mod["crashes"][0]["why"]
    printed = format_timeline(result.summary)
    text = (tmp_path / "s" / "report" / "summary.txt").read_text()
    if not beside:  # the stream files no other module names are its own
        assert mod["metrics"] == ["speech_speed"]
        (lost,) = result.summary["metrics"]["speech_speed"]["lost"]
        assert lost["module"] == "pace" and lost["from"] < lost["to"] < 5.0
        assert "and was restarted; speech_speed was not measured from 0:0" in printed
        assert "and was restarted; pace was not measured from 0:0" in text
        assert "I could not follow your pace for " in result.summary["post_talk"]["phrase"]
    else:  # which of speech_speed.txt and cv_gestures.txt is whose: not known, and said
        assert "metrics" not in mod and "lost" not in result.summary["metrics"]["speech_speed"]
        said = "which metrics it measures is not known, so none is marked as lost (name them: "
        said += "--module pace:METRIC,...=COMMAND)"
        assert said in printed and said in text
        phrase = result.summary["post_talk"]["phrase"]
        stopped = r"Your pace module stopped after \d+ seconds?, so I may have missed something"
        assert re.search(stopped, phrase)


def test_module_spec_parse() -> None:
    spec = ModuleSpec.parse("pace=python pace.py --out {session}")
    assert spec.name == "pace" and spec.argv == ["python", "pace.py", "--out", "{session}"]
    assert spec.metrics == () and spec.hang_after_s == DEFAULT_HANG_S
    spec = ModuleSpec.parse("pace:speech_speed,speech_volume=python pace.py")
    assert spec.name == "pace" and spec.metrics == ("speech_speed", "speech_volume")
    with pytest.raises(ValueError, match="NAME=COMMAND"):
        ModuleSpec.parse("no command here")
    with pytest.raises(ValueError, match="No closing quotation"):
        ModuleSpec.parse("pace=python 'pace.py")
    with pytest.raises(ValueError, match="plain name"):
        ModuleSpec.parse("../x=python pace.py")


def test_a_module_command_not_on_path_is_an_error_and_leaves_no_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from prezence.cli import main

    out = tmp_path / "m_nocmd"
    argv = ["up", "--module", "x=nonexistent_cmd_zz --out {session}", "--duration", "8"]
    assert main([*argv, "--out", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "error: module x: command 'nonexistent_cmd_zz' not found on PATH" in err
    assert "Traceback" not in err
    assert not out.exists()  # the retry, once the command is mended, is not refused
    assert main([*argv, "--out", str(out), "-q"]) == 2
    assert "already exists" not in capsys.readouterr().err


def test_a_module_command_that_cannot_start_stops_the_talk_with_its_name(tmp_path: Path) -> None:
    # made from {session}, so only known when it starts: fatal, as a bad input is, not a crash
    spec = ModuleSpec("x", ["{session}/nothere", "--out", "{session}"])
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[spec],
        backend=FakeBackend(time_scale=0.01),
        options=RunOptions.default(),
        duration_s=8.0,
    )
    assert result.error is not None
    assert result.error.startswith("module x: cannot start command ")
    assert "nothere" in result.error and "No such file" in result.error
    assert result.summary["modules"]["x"]["restarts"] == 0


def test_a_module_that_dies_at_start_every_time_is_given_up_with_its_error(
    tmp_path: Path,
) -> None:
    """A module that fails the same way at every start (an import error) is not restarted for
    the whole talk: after MAX_QUICK_EXITS quick exits in a row it is given up, and says why."""
    from prezence.launcher import MAX_QUICK_EXITS, QUICK_EXIT_S

    crash = "import sys; print(\"ModuleNotFoundError: No module named 'cv2'\"); sys.exit(1)"
    spec = ModuleSpec("vision", [sys.executable, "-c", crash], metrics=("cv_gestures",))
    (tmp_path / "streams").mkdir()
    with (tmp_path / "vision.log").open("a") as log:
        proc = ModuleProcess(spec, tmp_path, 0.0, log)
        now = 0.0
        proc.start(now)
        events: list[str] = []
        while not proc.finished:
            assert proc.proc is not None
            proc.proc.wait()
            now += QUICK_EXIT_S / 4  # it died well within its first seconds
            events.append(proc.check(now) or "")
            if not proc.finished:
                now = proc.next_start
                assert "restarted" in (proc.check(now) or "")
            assert len(events) <= MAX_QUICK_EXITS
        assert len(proc.crashes) == MAX_QUICK_EXITS and proc.restarts == MAX_QUICK_EXITS - 1
        assert proc.gave_up is not None and proc.proc is None
        assert events[-1] == f"module vision {proc.gave_up}"
        assert f"{MAX_QUICK_EXITS} times in a row; not restarted again" in proc.gave_up
        assert "No module named 'cv2'" in proc.gave_up
        assert proc.check(now + 100.0) is None and proc.proc is None  # never started again


def test_the_talk_goes_on_while_a_module_is_left_and_stops_when_none_is(tmp_path: Path) -> None:
    from prezence.launcher import LiveSource

    specs = [ModuleSpec("speech", ["x"]), ModuleSpec("vision", ["y"])]
    source = LiveSource(specs, end_at=None)
    with (tmp_path / "a.log").open("a") as log:
        source.procs = [ModuleProcess(s, tmp_path, 0.0, log) for s in specs]
        source.procs[1].gave_up = "exited within 2 s of starting 5 times in a row"
        source.procs[1].finished = True
        assert not source.ended(20.0)  # speech still listens
        source.procs[0].gave_up = "exited within 2 s of starting 5 times in a row"
        source.procs[0].finished = True
        assert source.ended(30.0)
        assert source.error == "module speech exited within 2 s of starting 5 times in a row"


#: A module playing a "file": ``N`` samples of ``METRIC`` half a second apart at real-time
#: pace, stamped on the file's own clock (0.5 … N/2 s), then, ``LINGER`` seconds later (the
#: speech module's last decoding takes seconds), exit 0 at the file's end.
_PLAYS_A_FILE = """
import sys, time
from pathlib import Path

out, n, metric, linger = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3], float(sys.argv[4])
(out / "streams").mkdir(parents=True, exist_ok=True)
with open(out / "streams" / f"{metric}.txt", "a") as f:
    for i in range(1, n + 1):
        time.sleep(0.5)
        f.write(f"{i * 0.5} 160.0\\n")
        f.flush()
print("played to the end")
time.sleep(linger)
"""

#: A live module of one's own that stops by itself: it writes on the talk's clock for
#: ``SECONDS``, then exits 0.
_STOPS_BY_ITSELF = """
import sys, time
from pathlib import Path

out, t0, seconds = Path(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
(out / "streams").mkdir(parents=True, exist_ok=True)
start = time.time()
with open(out / "streams" / "speech_speed.txt", "a") as f:
    while time.time() - start < seconds:
        f.write(f"{time.time() - t0:.3f} 160.0\\n")
        f.flush()
        time.sleep(0.1)
"""


@pytest.mark.slow
def test_a_module_of_ones_own_that_exits_0_at_its_files_end_ends_the_talk(
    tmp_path: Path,
) -> None:
    # Session 22, a module author's walkthrough: `up --audio um60.wav --module "fill:…
    # --audio um60.wav"`: the module's exit 0 at the end of its file was taken for a crash
    # ("exited with status 0; restarting in 1.0 s" … "16.0 s"), the talk ran to the allocated
    # time plus the grace, and the robot said "You used 1 and a half minutes of 1 minute, 50%
    # over" of a 61 s recording.
    from prezence.cli import format_timeline

    script = tmp_path / "play.py"
    script.write_text(_PLAYS_A_FILE)
    spec = ModuleSpec.parse(
        f"play:speech_speed={sys.executable} {script} {{session}} 6 speech_speed 0"
    )
    # the built-in module on the same file, still finishing its analysis 2.5 s after its end
    builtin = ModuleSpec(
        "speech",
        [sys.executable, str(script), "{session}", "6", "speech_volume", "2.5"],
        metrics=("speech_volume",),
        finite=True,
    )
    result = up(
        CONFIG.with_allocated(5.0),
        session_dir=tmp_path / "s",
        modules=[spec, builtin],
        backend=FakeBackend(time_scale=0.01),
        grace_s=10.0,
        options=RunOptions.default(report=True),
    )
    summary = result.summary
    mod = summary["modules"]["play"]
    assert mod["restarts"] == 0 and mod["crashes"] == []
    assert not any("restart" in e or "status 0" in e for e in result.events), result.events
    assert "stopped_at_time_limit" not in summary and 5.5 <= summary["talk_s"] < 15.0
    # the file's length is the time used: its newest stamp, not the coach's clock
    assert summary["recording_s"] == 3.0
    assert summary["time"]["used_s"] == 3.0 and summary["time"]["over_under_pct"] == -40.0
    printed = format_timeline(summary)
    assert "time used 0:03.0 of 0:05.0 (-40.0%)" in printed, printed
    # it ended with its file, as the other module did: nothing to say about it
    assert "crashed" not in printed and "ended (exit 0)" not in printed
    assert summary["post_talk"]["phrase"].startswith("You used 3 seconds of 5 seconds, 40% under")
    assert (tmp_path / "s" / "play.log").read_text() == "played to the end\n"


@pytest.mark.slow
def test_a_module_that_exits_0_while_the_others_go_on_ended_and_is_not_restarted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # A live talk (no file): a module of one's own that stops by itself is neither a crash nor
    # restarted; the log, the live view's event and the printed notes say it ended, and that
    # its metrics are not measured from then. The other module goes on, and so does the talk.
    from prezence.cli import format_timeline

    script = tmp_path / "stops.py"
    script.write_text(_STOPS_BY_ITSELF)
    stops = ModuleSpec.parse(f"stops:speech_speed={sys.executable} {script} {{session}} {{t0}} 2.5")
    with caplog.at_level("WARNING", logger="prezence.launcher"):
        result = up(
            CONFIG,
            session_dir=tmp_path / "s",
            modules=[stops, beat("beat", "--metric", "cv_gestures")],
            backend=FakeBackend(time_scale=0.01),
            duration_s=7.0,
            options=RunOptions.default(),
        )
    summary = result.summary
    mod = summary["modules"]["stops"]
    assert mod["restarts"] == 0 and mod["crashes"] == []
    assert 2.0 <= mod["ended_t"] <= 4.5 and mod["metrics"] == ["speech_speed"]
    assert summary["talk_s"] >= 6.5  # the talk went on with the other module
    assert "recording_s" not in summary  # a live talk: its clock is the time used
    ended = "module stops ended (exit 0); its metrics are not measured from then"
    assert [e.split(" ", 1)[1] for e in result.events] == [ended]
    said = [r.getMessage() for r in caplog.records]
    assert any(
        re.fullmatch(
            r"module stops ended \(exit 0\) at 0:0\d\.\d; its metrics are not "
            r"measured from then",
            m,
        )
        for m in said
    ), said
    printed = format_timeline(summary)
    note = (
        r"note: module stops ended \(exit 0\) at 0:0\d while the talk went on; speech_speed "
        r"was not measured from then"
    )
    assert re.search(note, printed), printed
    assert "crashed" not in printed and "restarted" not in printed


def _played_file(allocated_s: float, tmp_path: Path, grace_s: float = 10.0) -> dict:
    """``up`` of one "file" (speech_speed 0.5 … 3.0 s, then 2 s of decoding before its
    exit 0) with ``allocated_s`` and ``grace_s``: the summary."""
    args = ["6", "speech_speed", "2.0"]
    return _up_of_a_file(tmp_path, _PLAYS_A_FILE, args, ("speech_speed",), allocated_s, grace_s)


def _up_of_a_file(
    tmp_path: Path,
    script_text: str,
    args: list[str],
    metrics: tuple[str, ...],
    allocated_s: float,
    grace_s: float,
) -> dict:
    """``up`` of one finite speech module, ``script_text`` run with ``{session}`` and
    ``args``: the summary."""
    script = tmp_path / "module.py"
    script.write_text(script_text)
    spec = ModuleSpec(
        "speech", [sys.executable, str(script), "{session}", *args], metrics=metrics, finite=True
    )
    result = up(
        CONFIG.with_allocated(allocated_s),
        session_dir=tmp_path / "s",
        modules=[spec],
        backend=FakeBackend(time_scale=0.01),
        grace_s=grace_s,
        options=RunOptions.default(report=True),
    )
    return result.summary


@pytest.mark.slow
def test_a_recording_that_ends_within_its_time_limit_is_not_stopped_at_it(tmp_path: Path) -> None:
    # Session 23's verification: `up --audio en150.wav --allocated 32 --grace 31` (62.4 s) was
    # stopped at 1:03 on the coach's clock, before the file's end, and told "You were still
    # going when the coach stopped … at least 98% over". The limit is on the recordings' clock.
    summary = _played_file(2.0, tmp_path, grace_s=1.5)  # the file's 3.0 s within 3.5
    assert summary["talk_s"] > 3.5  # the coach's clock passed the limit
    assert not summary.get("stopped_at_time_limit")
    assert summary["time"]["used_s"] == 3.0 and summary.get("recording_s") == 3.0
    assert summary["post_talk"]["phrase"].startswith("You used 3 seconds of 2 seconds, 50% over")


@pytest.mark.slow
def test_a_recording_that_ends_on_time_gets_no_overtime_cue(tmp_path: Path) -> None:
    # Session 23, a student's own recordings: `up --audio de60.wav --allocated 1m` on a
    # 60.00 s file: the robot said "You are over time" at 1:00.5 on the talk's clock (the
    # file was then at about 0:58: the module had started late), then "You used 1 minute of
    # 1 minute, right on time". The time cues follow the recording's own clock.
    summary = _played_file(3.0, tmp_path)
    assert summary["talk_s"] > 4.0  # the talk's clock ran well past 3 s
    assert summary["time"]["used_s"] == 3.0
    assert [c["command"] for c in summary["cues"]] == []
    assert summary["post_talk"]["phrase"].startswith("You used 3 seconds of 3 seconds, right on")


@pytest.mark.slow
def test_a_recording_longer_than_its_time_is_still_told_it_is_over(tmp_path: Path) -> None:
    # the recording's clock passes the allocated 2 s at its 2.5 s sample: one overtime cue
    summary = _played_file(2.0, tmp_path)
    assert [c["command"] for c in summary["cues"]] == ["overtime"]
    assert summary["time"]["used_s"] == 3.0
    assert summary["post_talk"]["phrase"].startswith("You used 3 seconds of 2 seconds, 50% over")


#: A module playing a "file" that ends in silence: ``speech_speed`` (judged) 0.5 … ``SPEECH``
#: s, and ``speech_activity`` (no rule judges it: the speech module writes it alone in a
#: pause) 0.5 … ``N``/2 s, half a second apart at real-time pace, then exit 0 at its end.
_ENDS_IN_SILENCE = """
import sys, time
from pathlib import Path

out, n, speech = Path(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3])
(out / "streams").mkdir(parents=True, exist_ok=True)
with open(out / "streams" / "speech_speed.txt", "a") as pace, open(
    out / "streams" / "speech_activity.txt", "a"
) as act:
    for i in range(1, n + 1):
        time.sleep(0.5)
        t = i * 0.5
        if t <= speech:
            pace.write(f"{t} 160.0\\n")
            pace.flush()
        act.write(f"{t} {0.9 if t <= speech else 0.0}\\n")
        act.flush()
time.sleep(0.5)
"""


def _played_file_ending_in_silence(allocated_s: float, tmp_path: Path) -> dict:
    """``up`` of one "file": spoken to 3.0 s, silent to 6.0 s, with ``allocated_s``: the
    summary."""
    metrics = ("speech_speed", "speech_activity")
    return _up_of_a_file(tmp_path, _ENDS_IN_SILENCE, ["12", "3.0"], metrics, allocated_s, 10.0)


@pytest.mark.slow
def test_a_recording_that_runs_over_in_silence_is_told_it_is_over(tmp_path: Path) -> None:
    # Session 23, a review: the recordings' clock was the newest stamp of the streams the
    # rules judge, which stop in a pause (the speech module writes only speech_activity), so
    # `up --audio tail.wav --allocated 40` of 30.5 s of speech and 25 s of silence gave no cue,
    # then "You used 55.5 seconds of 40 seconds, 39% over."
    summary = _played_file_ending_in_silence(4.0, tmp_path)
    assert summary["time"]["used_s"] == 6.0
    assert [c["command"] for c in summary["cues"]] == ["overtime"]
    assert 4.0 <= summary["cues"][0]["t"] < summary["talk_s"]
    assert summary["post_talk"]["phrase"].startswith("You used 6 seconds of 4 seconds, 50% over")


@pytest.mark.slow
@pytest.mark.parametrize(
    ("silent", "allocated_s", "commands"),
    [(False, 3.0, []), (True, 4.0, ["overtime"])],
    ids=["ends-on-time", "over-in-silence"],
)
def test_a_replay_of_an_up_of_recordings_makes_its_time_decisions(
    silent: bool, allocated_s: float, commands: list[str], tmp_path: Path
) -> None:
    # Session 23, a review: a replay ran its clock to the live talk's talk_s (the coach's
    # clock, past the recording's end) and judged the time on it, so the replay of a 3.0 s
    # recording with 3 s allocated, which got no cue live, gave `0:03.5 overtime`.
    from prezence.replay import replay

    live = (_played_file_ending_in_silence if silent else _played_file)(allocated_s, tmp_path)
    assert [c["command"] for c in live["cues"]] == commands
    replayed = replay(tmp_path / "s", out=tmp_path / "r", options=RunOptions.default(report=True))
    again = replayed.summary
    assert [c["command"] for c in again["cues"]] == commands
    assert again["time"]["used_s"] == live["time"]["used_s"]
    assert again["post_talk"]["phrase"] == live["post_talk"]["phrase"]
