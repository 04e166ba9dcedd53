"""Real rehearsals end to end: a recording through the real modules and the coach, and
``prezence up`` fed by files as if live (no microphone or camera needed)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("av", reason='the speech module needs PyAV: pip install "prezence[speech]"')
pytest.importorskip(
    "pocketsphinx", reason='the speech module needs pocketsphinx: pip install "prezence[speech]"'
)
pytest.importorskip("cv2", reason='the vision module needs OpenCV: pip install "prezence[vision]"')

from prezence.cli import main  # noqa: E402
from prezence.errors import ConfigError  # noqa: E402
from prezence.metrics import WORD_WINDOW_REASONS, Untimed  # noqa: E402
from prezence.rehearse import module_commands, rehearse  # noqa: E402
from prezence.session import read_jsonl  # noqa: E402
from prezence.talk import RunOptions

HERE = Path(__file__).parent
FAST = HERE / "material" / "rate_225.flac"  # 225 wpm, festival voice, 17.6 s
GESTURES = HERE / "material_video" / "gestures.mp4"


def test_rehearse_a_recording_gives_a_session_and_a_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s"
    argv = ["rehearse", str(FAST), "--out", str(out), "--allocated", "20"]
    assert main([*argv, "--speech-args", "--hop 2 --calibration-db 93"]) == 0
    printed = capsys.readouterr().out
    # the report comes from the rehearse command itself
    page = out / "report" / "report.html"
    assert f"report: {page}" in printed and page.exists()
    report = json.loads((out / "report" / "report.json").read_text())
    assert report["time"]["allocated_s"] == 20.0  # --allocated: the clip is not judged vs 10 min
    # word-based values start once 10 s of talk is decoded: a 17.6 s clip at --hop 2 has two
    assert report["metrics"]["speech_speed"]["samples"] >= 2
    assert (out / "report" / "spoken.txt").read_text().startswith("You used ")
    summary = json.loads((out / "summary.json").read_text())
    m = summary["metrics"]["speech_speed"]
    assert 200.0 < m["p50"] < 250.0  # the recording's own pace, measured by the module
    # the speed line is the whole command's, the modules' analysis included (session 21, a
    # tester's walkthrough: it said "simulated 18 s in 0.03 s wall (600x real time)", the
    # coaching loop alone, for a command that took seconds)
    assert "simulated" not in printed
    line = next(ln for ln in printed.splitlines() if ln.startswith("rehearsed "))
    assert f"the modules' analysis {summary['analysis_wall_s']:.1f} s" in line
    assert f"the coaching {summary['wall_s']:.2f} s" in line
    # every decision point of the recording was taken; the log keeps those where something
    # changed, the first among them
    assert summary["decisions"] == int(round(summary["talk_s"] / 0.5))
    logged = read_jsonl(out / "decisions.jsonl")
    assert logged and logged[0]["t"] == 0.5 and len(logged) <= summary["decisions"]
    # --speech-args reached the module: one sample every 2 s
    lines = (out / "streams" / "speech_speed.txt").read_text().splitlines()
    ts = [float(ln.split()[0]) for ln in lines]
    gaps = [round(b - a, 3) for a, b in zip(ts, ts[1:], strict=False)]
    assert gaps[:-1] == [2.0] * (len(gaps) - 1) and gaps[-1] <= 2.0  # the last window is short


def test_rehearse_checks_module_settings_before_running(tmp_path: Path) -> None:
    assert (
        main(["rehearse", str(FAST), "--out", str(tmp_path / "s"), "--speech-args=--wndow 5"]) == 2
    )
    assert not (tmp_path / "s").exists()
    with pytest.raises(ConfigError, match="vision module, which does not run on an audio"):
        rehearse(
            FAST,
            out=tmp_path / "s",
            options=RunOptions.default(),
            module_args={"vision": ["--fps", "5"]},
        )


_FILLERS_MODULE = """
import argparse

from prezence.modules.audio_io import read_file
from prezence.modules.common import StreamSet, add_common_arguments

ap = argparse.ArgumentParser()
ap.add_argument("--audio", required=True)
add_common_arguments(ap)
args = ap.parse_args()
seconds = len(read_file(args.audio)) // 16000
with StreamSet(args.out, ["speech_fillers"], fresh=True) as streams:
    for t in range(1, seconds + 1):
        streams.write("speech_fillers", float(t), 9.0)
"""


def _add_the_fillers_records(
    monkeypatch: pytest.MonkeyPatch, hang_after_s: float | None = None
) -> None:
    """The two records of a metric added with its own module, ``fillers_stub`` (its hang
    limit ``hang_after_s``, by default that of ``--module``)."""
    from prezence import metrics

    hang = metrics.DEFAULT_HANG_S if hang_after_s is None else hang_after_s
    monkeypatch.setitem(
        metrics.INPUT_MODULES,
        "fillers",
        metrics.InputModule("fillers", "fillers_stub", "--audio", (), hang),
    )
    monkeypatch.setitem(
        metrics.METRICS,
        "speech_fillers",
        metrics.Metric(
            "speech_fillers",
            "fillers/min",
            "filler words",
            "fillers",
            1.0,
            advice={"above": "pause instead of saying 'um'"},
            physical_range=(0.0, 60.0),
        ),
    )


def test_a_metric_added_as_its_module_and_its_record_is_measured_coached_and_reported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 12: adding a metric is its module plus its record; nothing else is edited."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "fillers_stub.py").write_text(_FILLERS_MODULE)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(pkg), *sys.path]))
    _add_the_fillers_records(monkeypatch)
    rules = tmp_path / "rules.txt"  # the user's rules judge it: configuration, not code
    rules.write_text("speech_fillers max 6 above=slowDown\n")
    out = tmp_path / "s"
    argv = ["rehearse", str(FAST), "--out", str(out), "--config", str(rules), "--allocated", "20"]
    assert main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    m = summary["metrics"]["speech_fillers"]
    assert m["samples"] >= 15 and m["unit"] == "fillers/min" and m["time_in_range"] == 0.0
    text = (out / "report" / "summary.txt").read_text()
    assert "filler words" in text  # the record's label
    assert "pause instead of saying 'um'" in (out / "report" / "spoken.txt").read_text()


def test_up_starts_a_module_added_to_the_records_on_its_input(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``up --audio`` starts every module whose record reads audio, not the speech module only."""
    from prezence import launcher

    _add_the_fillers_records(monkeypatch)
    started: dict[str, launcher.ModuleSpec] = {}

    class Started(Exception):
        pass

    def fake_up(config: object, *, modules: list[launcher.ModuleSpec], **kw: object) -> None:
        started.update({m.name: m for m in modules})
        raise Started

    monkeypatch.setattr(launcher, "up", fake_up)
    with pytest.raises(Started):
        main(["up", "--audio", str(FAST), "--out", str(tmp_path / "live"), "-q"])
    assert list(started) == ["speech", "fillers"]
    fillers = started["fillers"]
    assert fillers.metrics == ("speech_fillers",) and fillers.finite
    assert fillers.argv[1:5] == ["-m", "fillers_stub", "--audio", str(FAST)]


def test_rehearse_refuses_what_is_not_a_recording(tmp_path: Path) -> None:
    notes = tmp_path / "notes.txt"
    notes.write_text("hello")
    with pytest.raises(ConfigError, match="notes.txt"):
        rehearse(notes, out=tmp_path / "s", options=RunOptions.default())


def test_rehearse_of_a_missing_file_names_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="nope.mp4: no such recording"):
        rehearse(tmp_path / "nope.mp4", out=tmp_path / "s", options=RunOptions.default())


@pytest.mark.slow
def test_up_with_file_inputs_runs_a_short_live_talk(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "live"
    argv = ["-q", "up", "--audio", str(FAST), "--video", str(GESTURES), "--backend", "fake"]
    assert main([*argv, "--duration", "19", "--out", str(out)]) == 0
    streams = out / "streams"
    assert (streams / "speech_speed.txt").read_text().strip()  # the speech module ran live
    # and the vision module: the body's gesture rate, or the fallback's under its own metric
    assert any(
        (streams / f).read_text().strip() for f in ("cv_gestures.txt", "cv_gestures_motion.txt")
    )
    decisions = read_jsonl(out / "decisions.jsonl")
    assert decisions
    # every decision point up to --duration was taken (the video runs longer than the audio)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["talk_s"] >= 18.0 and summary["decisions"] >= 36
    printed = capsys.readouterr().out
    assert "session folder" in printed
    assert 'robot: "You used ' in printed  # the post-talk summary (about 20 s of 10 minutes)
    assert (out / "report" / "report.html").exists()
    assert summary["modules"]["speech"]["restarts"] == 0  # its pauses are not hangs
    assert summary["modules"]["vision"]["restarts"] == 0


@pytest.mark.slow
def test_up_of_a_file_played_to_its_end_used_the_recordings_length(tmp_path: Path) -> None:
    # Session 21, a tester's walkthrough: `up --audio` of a 48.0 s file said "time used 0:50.6"
    # (the coach's clock ran on while the module started up and caught up), where `rehearse`
    # of the same file said 0:48.0: two time verdicts for one rehearsal.
    from prezence.rehearse import recording_length_s

    out = tmp_path / "live"
    argv = ["-q", "up", "--audio", str(FAST), "--backend", "fake", "--allocated", "20"]
    assert main([*argv, "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    length = recording_length_s(FAST)
    assert summary["talk_s"] > length  # the coach's clock, the module's start-up included
    assert summary["time"]["used_s"] == pytest.approx(length, abs=0.05)
    assert summary["time"]["over_under_pct"] == pytest.approx(100 * (length - 20) / 20, abs=0.3)
    # session 22: nor is any metric measured past the recording's end (its last value held on
    # the coach's clock: pace "0:55 of 1:01" in up, "0:50" in rehearse of the same file)
    for name, m in summary["metrics"].items():
        if m["samples"]:
            first = float((out / "streams" / f"{name}.txt").read_text().split()[0])
            assert m["in_range_s"] + m["out_of_range_s"] <= length - first + 0.05, name
    # the report (and the robot's spoken summary, made from it) and a replay say the same
    from prezence.report.build import build_report

    assert build_report(out)["time"]["used_s"] == pytest.approx(length, abs=0.05)
    # the robot said it too: its summary was made before summary.json was written
    said = summary["post_talk"]["phrase"].split(". ")[0]
    assert said == (out / "report" / "spoken.txt").read_text().split(". ")[0]
    assert said == "You used 17.6 seconds of 20 seconds, 12% under"
    assert main(["-q", "replay", str(out), "--out", str(tmp_path / "r"), "--no-report"]) == 0
    assert build_report(tmp_path / "r")["time"]["used_s"] == pytest.approx(length, abs=0.05)


def _cut_wav(tmp_path: Path) -> Path:
    """FAST as a WAV that breaks off two thirds in (11.7 s of its 17.6 s), as a phone that
    died mid-talk leaves it: the header still announces the whole."""
    import av

    full = tmp_path / "full.wav"
    with av.open(str(FAST)) as src, av.open(str(full), "w") as dst:
        out = dst.add_stream("pcm_s16le", rate=16000, layout="mono")
        resampler = av.AudioResampler(format="s16", layout="mono", rate=16000)
        for frame in src.decode(audio=0):
            for f in resampler.resample(frame):
                for packet in out.encode(f):
                    dst.mux(packet)
        for packet in out.encode(None):
            dst.mux(packet)
    cut = tmp_path / "cut.wav"
    cut.write_bytes(full.read_bytes()[: full.stat().st_size * 2 // 3])
    return cut


def test_a_recording_cut_short_is_coached_and_reported_on_what_was_read(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A truncated WAV (a phone that died mid-talk) was refused with exit 2 and nothing was
    # measured; a truncated mp3 was analysed but gave exit 2 and no report either.
    cut = _cut_wav(tmp_path)
    out = tmp_path / "s"
    assert main(["rehearse", str(cut), "--out", str(out), "--allocated", "20"]) == 0
    printed = capsys.readouterr().out
    assert (out / "report" / "report.html").exists()
    summary = json.loads((out / "summary.json").read_text())
    why = summary["modules"]["speech"]["cut_short"]
    assert why.startswith(f"{cut}: the WAV data is cut short")
    assert summary["module_failures"] == {}
    # the talk lasted as long as what was read, not the 17.6 s the header announces
    assert 11.0 < summary["talk_s"] < 12.5
    assert summary["metrics"]["speech_speed"]["samples"] >= 1  # it was measured
    assert f"note: module speech's input was cut short ({why})" in printed
    spoken = (out / "report" / "spoken.txt").read_text()
    assert "Your recording breaks off after 12 seconds, so I judged only that." in spoken
    assert "input was cut short" in (out / "report" / "report.html").read_text()


@pytest.mark.slow
def test_up_goes_on_to_the_report_when_its_input_file_is_cut_short(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `up --audio` on a truncated file stopped the talk with "error: the talk stopped: module
    # speech: …" and exit 2, as if the file could not be used at all, and wrote no report.
    cut = _cut_wav(tmp_path)
    out = tmp_path / "live"
    assert main(["-q", "up", "--audio", str(cut), "--backend", "fake", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert "error" not in summary
    speech = summary["modules"]["speech"]
    assert speech["cut_short"].startswith(f"{cut}: the WAV data is cut short")
    assert speech["crashes"] == [] and speech["restarts"] == 0
    assert (out / "report" / "report.html").exists()
    assert "input was cut short" in capsys.readouterr().out


def test_rehearse_reports_its_progress_through_the_recording(tmp_path: Path) -> None:
    seen: list[tuple[float, float]] = []
    rehearse(
        FAST,
        out=tmp_path / "s",
        options=RunOptions.default(report=False),
        modules=module_commands(FAST, tmp_path / "s"),
        progress=lambda done, total: seen.append((done, total)),
    )
    assert seen, "no progress was reported"
    total = seen[-1][1]
    assert 17.0 < total < 18.5  # the clip's own length, read from its container
    assert seen[-1][0] == total  # finished
    done = [d for d, _ in seen]
    assert all(0.0 <= d <= total for d in done)


def test_a_talk_that_ends_in_silence_used_the_whole_recording(tmp_path: Path) -> None:
    """Time used is the recording's length, not the last measured value's time (the speech
    module writes no pace in silence): 17.6 s of speech then 20 s of silence is 37.6 s."""
    import wave

    import numpy as np

    from prezence.modules.audio_io import read_file

    x = read_file(FAST)
    rec = tmp_path / "then_silence.wav"
    with wave.open(str(rec), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(16000)
        w.writeframes(np.concatenate([x, np.zeros(20 * 16000, np.int16)]).tobytes())
    length = (len(x) + 20 * 16000) / 16000
    out = tmp_path / "s"
    assert main(["rehearse", str(rec), "--out", str(out), "--allocated", "60", "-q"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["talk_s"] == pytest.approx(length, abs=0.05)
    report = json.loads((out / "report" / "report.json").read_text())
    assert report["complete"] is True
    assert report["time"]["used_s"] == pytest.approx(length, abs=0.05)
    assert "stopped early" not in (out / "report" / "report.html").read_text()
    # the pace stops with the speech; every decision point of the recording was still taken
    last = (out / "streams" / "speech_speed.txt").read_text().splitlines()[-1]
    assert float(last.split()[0]) < length - 10
    assert summary["decisions"] == int(round(length / 0.5))


def test_a_recording_no_module_can_read_leaves_no_folder_behind(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "not_audio.wav"
    bad.write_text("hello, this is text")
    out = tmp_path / "s"
    assert main(["rehearse", str(bad), "--out", str(out)]) == 2
    assert "not_audio.wav" in capsys.readouterr().err
    assert not out.exists()  # a second try, once the file is mended, is not refused
    empty = tmp_path / "empty.wav"
    empty.write_bytes(b"")
    assert main(["rehearse", str(empty), "--out", str(out)]) == 2
    assert "the recording is empty" in capsys.readouterr().err and not out.exists()


# -- session 14: up checks its files as rehearse does, before anything starts -----------------


def _random_wav(tmp_path: Path) -> Path:
    bad = tmp_path / "random.wav"
    bad.write_bytes(bytes(range(256)) * 40)  # not a RIFF header: no decoder reads it
    return bad


@pytest.mark.parametrize(
    ("option", "module", "extra"),
    [("--video", "cv2", "vision"), ("--audio", "pocketsphinx", "speech")],
    ids=["video without cv2", "audio without pocketsphinx"],
)
def test_up_without_the_module_extra_is_one_line_before_anything_starts(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    option: str,
    module: str,
    extra: str,
) -> None:
    monkeypatch.setitem(sys.modules, module, None)  # as if the extra were not installed
    media = GESTURES if option == "--video" else FAST
    out = tmp_path / "s"
    argv = ["-q", "up", option, str(media), "--backend", "fake", "--duration", "3"]
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f'pip install "prezence[{extra}]"' in err[0]
    assert err[0].startswith(f"error: {option} {media}: the {extra} module needs ")
    assert not out.exists()


def test_up_with_a_camera_and_no_cv2_names_the_vision_extra(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "cv2", None)
    assert main(["-q", "up", "--video", "cam", "--backend", "fake", "--duration", "1"]) == 2
    assert 'pip install "prezence[vision]"' in capsys.readouterr().err


@pytest.mark.parametrize(
    ("option", "name", "message"),
    [
        ("--audio", "random", "not an audio or video file the decoder can read"),
        ("--audio", "noaudio", "the file has no audio track"),
        ("--video", "random", "cannot be read as a video"),
    ],
    ids=["random bytes as audio", "a video with no audio track", "random bytes as video"],
)
def test_up_refuses_a_file_its_module_cannot_read_and_leaves_no_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], option: str, name: str, message: str
) -> None:
    media = _random_wav(tmp_path) if name == "random" else GESTURES
    out = tmp_path / "s"
    argv = ["up", option, str(media), "--backend", "fake", "--duration", "3", "--out", str(out)]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert f"error: {option} {media}: {message}" in captured.err
    assert "Errno" not in captured.err
    assert "time used" not in captured.out  # no results of a talk that never ran
    assert not out.exists()


def test_a_text_file_named_mp4_gives_one_error_line_without_the_decoders_own(
    tmp_path: Path,
) -> None:
    # Session 20, a tester: `up --video notes.mp4` (a text file) printed libav's raw
    # "[mov,mp4,m4a,3gp,3g2,mj2 @ 0x55…] moov atom not found" before the error line. A fresh
    # process: OpenCV's FFmpeg backend reads its log level once, when it first opens a file.
    pytest.importorskip("cv2")
    notes = tmp_path / "notes.mp4"
    notes.write_text("my speaker notes\n")
    out = tmp_path / "s"
    argv = ["up", "--video", str(notes), "--backend", "fake", "--duration", "3", "--out", str(out)]
    env = {k: v for k, v in os.environ.items() if k != "OPENCV_FFMPEG_LOGLEVEL"}
    p = subprocess.run(
        [sys.executable, "-m", "prezence", *argv], capture_output=True, text=True, env=env
    )
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert lines == [
        f"error: --video {notes}: cannot be read as a video (no video stream, e.g. "
        "a sound-only recording; a wrong format; or a truncated file)"
    ], p.stderr


def test_rehearse_a_folder_says_it_is_a_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "adir").mkdir()
    assert main(["rehearse", str(tmp_path / "adir"), "--out", str(tmp_path / "s")]) == 2
    assert f"error: {tmp_path / 'adir'}: is a folder; give a media file" in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


def test_rehearse_random_bytes_is_a_plain_message_with_error_said_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = _random_wav(tmp_path)
    assert main(["rehearse", str(bad), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert f"error: speech: {bad}: not an audio or video file the decoder can read (" in err
    assert "Errno" not in err and err.count("error:") == 1


def test_rehearse_a_video_without_cv2_names_the_vision_extra(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    # the modules are other processes: block cv2 there with a sitecustomize on PYTHONPATH
    blocker = tmp_path / "no_cv2"
    blocker.mkdir()
    (blocker / "sitecustomize.py").write_text("import sys\nsys.modules['cv2'] = None\n")
    path = os.environ.get("PYTHONPATH")
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(blocker), *([path] if path else [])]))
    assert main(["rehearse", str(GESTURES), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert 'vision: the vision module needs OpenCV (cv2): pip install "prezence[vision]"' in err
    assert "ModuleNotFoundError" not in err and err.count("error:") == 1


def _encode_as(src: Path, dst: Path, fmt: str, codec: str) -> None:
    """``src`` re-encoded by PyAV (ffmpeg) as a phone or a messaging app would save it."""
    import av

    from prezence.modules.audio_io import read_file

    x = read_file(src)
    with av.open(str(dst), "w", format=fmt) as out:
        stream = out.add_stream(codec, rate=48000 if codec == "libopus" else 16000)
        stream.layout = "mono"
        ctx = stream.codec_context
        resampler = av.AudioResampler(
            format=ctx.format.name, layout="mono", rate=ctx.sample_rate, frame_size=ctx.frame_size
        )
        frame = av.AudioFrame.from_ndarray(x.reshape(1, -1), format="s16", layout="mono")
        frame.sample_rate = 16000
        for f in [*resampler.resample(frame), *resampler.resample(None)]:
            for packet in stream.encode(f):
                out.mux(packet)
        for packet in stream.encode(None):
            out.mux(packet)


@pytest.mark.parametrize(
    ("suffix", "fmt", "codec"),
    [(".opus", "opus", "libopus"), (".aac", "adts", "aac"), (".aiff", "aiff", "pcm_s16be")],
)
def test_a_voice_note_or_recorder_file_is_rehearsed_not_refused_for_its_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], suffix: str, fmt: str, codec: str
) -> None:
    # A WhatsApp voice note (.opus), a recorder app's .aac, a Mac's .aiff: the decoder reads
    # them, yet `rehearse` said "not an audio or video file I know" from the name alone.
    note = tmp_path / f"voice note{suffix}"
    _encode_as(FAST, note, fmt, codec)
    out = tmp_path / "s"
    assert main(["rehearse", str(note), "--out", str(out), "-q"]) == 0, capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert 200.0 < summary["metrics"]["speech_speed"]["p50"] < 250.0  # 225 wpm, as the flac


def test_the_session_says_when_the_volume_is_not_calibrated(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The module's doc promised "the module says so in its log", but rehearse and up run it
    # with -q and the line was at info level: speech.log stayed empty, the volume in dB SPL
    # (dBFS + a guessed 90) looked measured.
    out = tmp_path / "s"
    assert main(["rehearse", str(FAST), "--out", str(out), "-q"]) == 0
    log = (out / "speech.log").read_text()
    assert "volume is not calibrated" in log and "--calibration-db" in log
    # session 17: the report and the printed table say it next to the figure, not only the log
    note = "an estimate: the microphone is not calibrated (dBFS + 90"
    summary = json.loads((out / "summary.json").read_text())
    assert summary["metrics"]["speech_volume"]["estimate"].startswith(note)
    assert f"Volume: {note}" in (out / "report" / "report.html").read_text()
    calibrated = tmp_path / "c"
    argv = ["rehearse", str(FAST), "--out", str(calibrated), "--speech-args", "--calibration-db 93"]
    capsys.readouterr()
    assert main(argv) == 0
    assert "not calibrated" not in (calibrated / "speech.log").read_text()
    assert (
        "estimate"
        not in json.loads((calibrated / "summary.json").read_text())["metrics"]["speech_volume"]
    )
    assert "an estimate" not in capsys.readouterr().out
    assert main(["rehearse", str(FAST), "--out", str(tmp_path / "t")]) == 0
    assert f"speech_volume: {note}" in capsys.readouterr().out


def _talk_wav(tmp_path: Path, name: str, *, snr_db: float | None, lowpass_hz: float | None) -> Path:
    """A ~60 s festival talk (the shipped sentences) with white noise or low-passed, as WAV."""
    import importlib.util
    import wave

    import numpy as np

    from prezence.modules.audio_io import read_file

    spec = importlib.util.spec_from_file_location(
        "make_test_audio", HERE.parents[1] / "tools" / "make_test_audio.py"
    )
    assert spec is not None and spec.loader is not None
    mta = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, mta)
    spec.loader.exec_module(mta)
    y, _ = mta.long_talk(read_file(HERE / "material" / "rate_175.flac"), min_s=60.0)
    x = np.asarray(y, dtype=np.float64)
    if snr_db is not None:
        x = mta.with_noise(y, snr_db, np.random.default_rng(5))
    if lowpass_hz is not None:
        spectrum = np.fft.rfft(x)
        spectrum[np.fft.rfftfreq(len(x), 1 / 16000) > lowpass_hz] = 0
        x = np.fft.irfft(spectrum, len(x))
    path = tmp_path / f"{name}.wav"
    with wave.open(str(path), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(16000)
        w.writeframes(np.clip(np.round(x), -32768, 32767).astype(np.int16).tobytes())
    return path


def test_in_a_noisy_room_the_robot_names_the_noise_and_a_replay_says_the_same(
    tmp_path: Path,
) -> None:
    # session 20's walkthrough: a stretch at SNR 5 dB read clarity 0.07-0.25 and the robot
    # said "Speak more clearly", blaming the articulation for the room's noise
    noisy = _talk_wav(tmp_path, "noisy", snr_db=5.0, lowpass_hz=None)
    out = tmp_path / "noisy_s"
    assert main(["-q", "rehearse", str(noisy), "--out", str(out), "--no-report"]) == 0
    assert (out / "streams" / "speech_snr.txt").read_text().strip()
    said = [c for c in read_jsonl(out / "cues.jsonl") if c["command"] == "articulate"]
    assert said, "a voice at SNR 5 dB reads low clarity and is cued"
    assert all(c["phrase"].startswith("This room is noisy or echoing") for c in said)
    assert all(c["params"]["snr_db"] < 15.0 for c in said)
    again = tmp_path / "replayed"
    assert main(["-q", "replay", str(out), "--out", str(again), "--no-report"]) == 0
    replayed = [c for c in read_jsonl(again / "cues.jsonl") if c["command"] == "articulate"]
    assert [(c["t"], c["phrase"], c["params"]) for c in replayed] == [
        (c["t"], c["phrase"], c["params"]) for c in said
    ]


def test_a_muffled_voice_in_a_quiet_room_is_still_asked_to_speak_clearly(tmp_path: Path) -> None:
    # low-passed at 800 Hz (a voice into a scarf): clarity falls, the room is quiet
    muffled = _talk_wav(tmp_path, "muffled", snr_db=None, lowpass_hz=800.0)
    out = tmp_path / "muffled_s"
    assert main(["-q", "rehearse", str(muffled), "--out", str(out), "--no-report"]) == 0
    said = [c for c in read_jsonl(out / "cues.jsonl") if c["command"] == "articulate"]
    assert said and all(c["phrase"] == "Speak more clearly." for c in said)
    assert all("noisy" not in c["params"] for c in said)


def test_a_rehearsal_stopped_while_analysing_stops_its_modules_and_says_what_it_holds(
    tmp_path: Path,
) -> None:
    # Session 21, a second walkthrough: SIGTERM or SIGINT to `rehearse` alone left its speech
    # module analysing on, orphaned, writing into the folder just said to be kept; and the
    # report then said "You used 1 minute 11 seconds of 10 minutes, 88% under" of a 3:42
    # recording of which 1:11 had been analysed.
    from prezence.rehearse import recording_length_s
    from prezence.report.build import build_report

    out = tmp_path / "s"
    pid_file = tmp_path / "module.pid"
    script = (
        "import os, sys, time, pathlib\n"
        f"pathlib.Path({str(pid_file)!r}).write_text(str(os.getpid()))\n"
        f"s = pathlib.Path({str(out / 'streams')!r})\n"
        "s.mkdir(parents=True, exist_ok=True)\n"
        "(s / 'speech_speed.txt').write_text(''.join(f'{t} 160.0\\n' for t in range(1, 6)))\n"
        "time.sleep(120)\n"
    )
    calls = []

    def progress(done: float, total: float) -> None:
        calls.append(done)
        if done >= 5.0:
            raise KeyboardInterrupt  # as a SIGINT to this process alone

    with pytest.raises(KeyboardInterrupt):
        rehearse(
            FAST,
            out=out,
            options=RunOptions.default(),
            modules={"slow": [sys.executable, "-c", script]},
            progress=progress,
        )
    pid = int(pid_file.read_text())
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)  # the module is gone, not orphaned
    meta = json.loads((out / "session.json").read_text())
    length = recording_length_s(FAST)
    assert meta["interrupted"] is True and meta["analysed_s"] == 5.0
    assert meta["talk_s"] == pytest.approx(length, abs=0.01)
    report = build_report(out)
    assert report["time"]["used_s"] == pytest.approx(length, abs=0.01)  # the recording's
    assert report["analysis_stopped_s"] == 5.0
    from prezence.report.speech import trouble_sentences

    assert trouble_sentences(report)[0].startswith(
        "the analysis of the recording was stopped at 0:05 of its 0:18"
    )


def test_the_robot_says_a_module_failed_in_a_rehearsal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Session 22 (a module author's walkthrough): a module of one's own that failed half way
    through a rehearsal was in ``summary.json``'s ``module_failures``, and the robot's closing
    words judged its metric as if it had been measured to the end."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    crashing = _FILLERS_MODULE.replace(
        "        streams.write(",
        "        if t > 8:\n            raise SystemExit('boom')\n" + "        streams.write(",
    )
    (pkg / "fillers_stub.py").write_text(crashing)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(pkg), *sys.path]))
    _add_the_fillers_records(monkeypatch)
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_fillers max 6 above=slowDown\n")
    out = tmp_path / "s"
    argv = ["rehearse", str(FAST), "--out", str(out), "--config", str(rules), "--allocated", "20"]
    assert main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert "fillers" in summary["module_failures"]
    said = summary["post_talk"]["phrase"]
    assert "I could not follow your filler words after 9 seconds" in said, said


#: ``fillers_stub`` that hangs: it writes five values (1-5 s), prints as it goes (its stdout),
#: then sleeps without a sign of life.
_HANGING_FILLERS_MODULE = """
import argparse, time

from prezence.modules.common import StreamSet, add_common_arguments

ap = argparse.ArgumentParser()
ap.add_argument("--audio", required=True)
add_common_arguments(ap)
args = ap.parse_args()
with StreamSet(args.out, ["speech_fillers"], fresh=True) as streams:
    for t in range(1, 6):
        streams.write("speech_fillers", float(t), 9.0)
        print(f"DEBUG t={t} rate=9.0", flush=True)
    time.sleep(600)
"""


def test_a_hung_module_is_killed_and_the_rehearsal_goes_on_saying_so(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
) -> None:
    # Session 22, a module author's walkthrough: `FILLERS_FAULT=hang prezence rehearse
    # um60.wav`: still waiting, in silence, 150 s later (the speech module had finished in
    # 8 s); `up` kills the same module after its 20 s hang limit.
    import signal

    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "fillers_stub.py").write_text(_HANGING_FILLERS_MODULE)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(pkg), *sys.path]))
    _add_the_fillers_records(monkeypatch, hang_after_s=2.0)
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_speed inRange 140 180 below=speedUp above=slowDown\n")
    rules.write_text(rules.read_text() + "speech_fillers max 6 above=slowDown\n")
    out = tmp_path / "s"
    argv = ["rehearse", str(FAST), "--out", str(out), "--config", str(rules), "--allocated", "20"]

    def waited_too_long(signum: int, frame: object) -> None:
        raise KeyboardInterrupt  # the rehearsal stops, and says so: exit 130, not 0

    previous = signal.signal(signal.SIGALRM, waited_too_long)
    signal.alarm(60)
    try:
        with caplog.at_level("WARNING", logger="prezence.rehearse"):
            status = main(argv)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    assert status == 0
    said = [r.getMessage() for r in caplog.records]
    assert (
        "waiting for module fillers: no sign of life for 1 s (at 5 s of the recording; "
        "killed as hung after 2 s)" in said
    ), said
    assert (
        "module fillers showed no sign of life for 2 s (hung); killed: it measured the "
        "recording up to 0:05.0; the rehearsal goes on with what was measured"
    ) in said
    summary = json.loads((out / "summary.json").read_text())
    hung = "showed no sign of life for 2 s (hung); killed"
    assert summary["module_failures"] == {"fillers": hung}
    assert summary["modules"]["fillers"] == {
        "restarts": 0,
        "crashes": [{"t": 5.0, "why": hung, "silent_since": 5.0}],
        "metrics": ["speech_fillers"],
    }
    # what was measured is kept: the speech module's streams, and the five values it wrote
    assert summary["metrics"]["speech_speed"]["samples"] >= 1
    fillers = summary["metrics"]["speech_fillers"]
    assert fillers["samples"] == 5
    talk = f"0:{summary['talk_s']:02.0f}"
    note = (
        "module fillers hung at 0:05 and was not restarted (showed no sign of "
        f"life for 2 s (hung); killed); speech_fillers were not measured from 0:05 to the end "
        f"({talk})"
    )
    assert f"note: {note}" in capsys.readouterr().out
    text = (out / "report" / "summary.txt").read_text()
    assert "module fillers hung at 0:05" in text and "not measured from 0:05 to the end" in text
    spoken = (out / "report" / "spoken.txt").read_text()
    assert "I could not follow your filler words after 5 seconds." in spoken
    # its prints, as `up` keeps them
    printed = (out / "fillers.log").read_text().splitlines()
    assert printed == [f"DEBUG t={t} rate=9.0" for t in range(1, 6)]


def test_a_rehearsal_keeps_each_modules_stdout_in_its_log(tmp_path: Path) -> None:
    # Session 22, a module author's walkthrough: `up` kept a module's prints in
    # `<module>.log`; `rehearse` threw them away (`fillers.log` empty, nothing on the terminal)
    prints = (
        "import pathlib, sys\n"
        f"s = pathlib.Path({str(tmp_path / 's' / 'streams')!r})\n"
        "s.mkdir(parents=True, exist_ok=True)\n"
        "(s / 'speech_speed.txt').write_text(''.join(f'{t} 160.0\\n' for t in range(1, 18)))\n"
        "for t in range(1, 4):\n"
        "    print(f'DEBUG t={t}')\n"
        "print('speech: WARNING: a warning of its own', file=sys.stderr)\n"
    )
    # a module that says its error and prints more afterwards: its error is still the message
    fails = (
        "import sys\n"
        "print('error: talk.wav: not a recording I can read', file=sys.stderr, flush=True)\n"
        "print('DEBUG giving up')\n"
        "sys.exit(2)\n"
    )
    result = rehearse(
        FAST,
        out=tmp_path / "s",
        options=RunOptions.default(),
        modules={
            "mine": [sys.executable, "-c", prints],
            "broken": [sys.executable, "-c", fails],
        },
    )
    log = (tmp_path / "s" / "mine.log").read_text().splitlines()
    assert sorted(log) == [
        "DEBUG t=1",
        "DEBUG t=2",
        "DEBUG t=3",
        "speech: WARNING: a warning of its own",
    ]
    assert "DEBUG giving up" in (tmp_path / "s" / "broken.log").read_text()
    assert result.summary["module_failures"] == {"broken": "talk.wav: not a recording I can read"}


_SILENT_MODULE = """
import argparse, time
from prezence.modules.common import StreamSet, add_common_arguments
ap = argparse.ArgumentParser()
ap.add_argument("--audio", required=True)
add_common_arguments(ap)
args = ap.parse_args()
with StreamSet(args.out, ["speech_fillers"], fresh=True) as streams:
    time.sleep(600)
"""


def test_a_module_hung_before_its_first_value_ran_and_is_said_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Session 22's review: a module killed as hung before it wrote a value was said twice,
    once as one that "could not run" (it ran), and "killed at 0:00" (the recording's clock
    stood there; it was killed 2 s later on the wall clock)."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "fillers_stub.py").write_text(_SILENT_MODULE)
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join([str(pkg), *sys.path]))
    _add_the_fillers_records(monkeypatch, hang_after_s=2.0)
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_fillers max 6 above=slowDown\n")
    out = tmp_path / "s"
    argv = ["rehearse", str(FAST), "--out", str(out), "--config", str(rules), "--allocated", "20"]
    assert main(argv) == 0
    printed = capsys.readouterr().out
    text = (out / "report" / "summary.txt").read_text()
    for said in (printed, text):
        assert "could not run" not in said, said
        assert "module fillers hung at 0:00 and was not restarted" in said, said
        assert "killed at 0:00" not in said


def _slides_video(path: Path, seconds: int = 30) -> Path:
    """A screencast-style video with no one in it: static coloured slides, 8 s each, no sound."""
    import cv2
    import numpy as np

    fps, w, h = 10, 160, 120
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (w, h))
    colours = [(200, 80, 40), (40, 160, 220), (90, 200, 90), (220, 220, 220)]
    for i in range(seconds * fps):
        frame = np.zeros((h, w, 3), np.uint8)
        frame[:] = colours[(i // (8 * fps)) % len(colours)]
        vw.write(frame)
    vw.release()
    return path


@pytest.mark.slow
@pytest.mark.parametrize("command", ["rehearse", "up"])
def test_the_frame_difference_fallback_gives_no_gesture_advice_on_a_video_with_no_one_in_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, command: str
) -> None:
    # Session 23, a tester's screencast (slides, no person, no vision env): the fallback's
    # 0 gestures/min was judged like the body's and the robot said "Use your hands more" at
    # 0:20.5, while the report called that source too unreliable to advise on.
    from prezence.modules.vision import mediapipe_available

    if mediapipe_available():
        pytest.skip("mediapipe is importable here: gestures come from the body")
    monkeypatch.setenv("PREZENCE_VISION_VENV", str(tmp_path / "no-vision-env"))
    video = _slides_video(tmp_path / "slides.mp4")
    out = tmp_path / "s"
    if command == "rehearse":
        argv = ["-q", "rehearse", str(video)]
    else:
        argv = ["-q", "up", "--video", str(video), "--backend", "fake"]
    assert main([*argv, "--allocated", "1m", "--out", str(out)]) == 0
    cues = read_jsonl(out / "cues.jsonl") if (out / "cues.jsonl").exists() else []
    assert not [c for c in cues if "gesture" in str(c.get("metric"))], cues
    # the fallback's rate is kept, under a metric of its own that no default rule judges
    assert (out / "streams" / "cv_gestures_motion.txt").read_text().strip()
    assert not (out / "streams" / "cv_gestures.txt").read_text().strip()
    summary = json.loads((out / "summary.json").read_text())
    gestures = summary["metrics"]["cv_gestures"]
    assert gestures["samples"] == 0 and gestures["measured"] is False
    assert "cv_gestures_motion" in gestures["not_measured_why"]
    text = (out / "report" / "summary.txt").read_text()
    assert "gestures: not measured: the pose model that counts gestures" in text
    assert "use your hands" not in (out / "report" / "spoken.txt").read_text().lower()


#: a library of one's own: unchecked for self-collision where PyBullet is not installed
OWN_GESTURES = (
    'format = 1\n[gestures.articulate]\ndescription = ""\n'
    "[[gestures.articulate.keyframes]]\npose = { LShoulderPitch = 20.0 }\n"
)


@pytest.mark.parametrize("command", ["rehearse", "up"])
def test_a_robot_refuses_unchecked_gestures_before_anything_is_analysed_or_written(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    command: str,
) -> None:
    # session 23's review: without PyBullet, `rehearse --backend naoqi` analysed the whole
    # recording, then the talk refused the gestures and left config.toml, speech.json,
    # speech.log and streams/ (no session.json); the same --out then "already exists"
    import prezence.launcher
    import prezence.rehearse
    from prezence.feedback import collision

    monkeypatch.setattr(collision, "pybullet_available", lambda: False)
    ran: list[str] = []
    monkeypatch.setattr(prezence.rehearse, "rehearse", lambda *a, **k: ran.append("rehearse"))
    monkeypatch.setattr(prezence.launcher, "up", lambda *a, **k: ran.append("up"))
    mine = tmp_path / "mine.toml"
    mine.write_text(OWN_GESTURES)
    out = tmp_path / "nb1"
    inputs = [str(FAST)] if command == "rehearse" else ["--audio", str(FAST)]
    robot = ["--backend", "naoqi", "--robot", "tcp://127.0.0.1:1"]  # a closed port
    argv = ["-q", command, *inputs, *robot, "--gestures", str(mine), "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {mine}: the self-collision of its gestures was not checked"), err
    assert "--allow-unchecked-collision" in err
    assert not ran and not out.exists()


@pytest.mark.parametrize("how", [["--language", "de"], ["--speech-args", "--language de"]])
def test_a_talk_said_to_be_in_another_language_gets_no_pace_or_clarity_and_is_told_why(
    tmp_path: Path, how: list[str]
) -> None:
    # Session 23's student rehearsed in German (a true 151 wpm): the English recogniser read
    # 212 wpm, trusted, and the robot said "slow down" twice. Saying the talk's language now
    # keeps the word-based metrics out; the volume is still measured.
    out = tmp_path / "s"
    assert main(["-q", "rehearse", str(FAST), "--out", str(out), "--allocated", "20", *how]) == 0
    streams = out / "streams"
    for metric in ("speech_speed", "speech_articulation", "speech_accuracy", "speech_clarity"):
        path = streams / f"{metric}.txt"
        assert not path.exists() or not path.read_text().strip(), metric
    assert (streams / "speech_volume.txt").read_text().strip()
    # each word window's reason code is the language, not a noise or a doubt (issue 11)
    lines = (streams / "speech_untimed_reason.txt").read_text().split()
    codes = {float(v) for v in lines[1::2]}
    assert Untimed.LANGUAGE in codes and not codes & WORD_WINDOW_REASONS, codes
    summary = json.loads((out / "summary.json").read_text())
    why = summary["metrics"]["speech_speed"]["not_measured_why"]
    assert "the talk is in 'de'" in why and "English talks only" in why
    assert summary["metrics"]["speech_accuracy"]["measured"] is False
    assert not any(c["metric"] == "speech_speed" for c in read_jsonl(out / "cues.jsonl"))
    page = (out / "report" / "report.html").read_text()
    assert "English talks only" in page
    said = (out / "report" / "spoken.txt").read_text()
    assert "English talks only" in said, said  # the robot says why, not only the report


def test_english_said_as_the_language_changes_nothing(tmp_path: Path) -> None:
    out = tmp_path / "s"
    argv = ["-q", "rehearse", str(FAST), "--out", str(out), "--allocated", "20"]
    assert main([*argv, "--language", "en-GB", "--no-report"]) == 0
    assert (out / "streams" / "speech_speed.txt").read_text().strip()


@pytest.mark.parametrize("speech_args", ["--language en", "--language=en", "--lang en"])
def test_language_given_twice_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], speech_args: str
) -> None:
    # the module was given both and the later (--speech-args's) won without a word
    out = tmp_path / "s"
    argv = ["-q", "rehearse", str(FAST), "--out", str(out), "--language", "de"]
    assert main([*argv, f"--speech-args={speech_args}"]) == 2
    err = capsys.readouterr().err
    assert "--language de and --speech-args" in err and "give it once" in err, err
    assert not out.exists()


def test_language_without_an_audio_input_is_refused(tmp_path: Path) -> None:
    argv = ["up", "--video", str(GESTURES), "--language", "de", "--out", str(tmp_path / "s")]
    assert main(argv) == 2


def test_a_phone_recording_cut_off_before_it_was_saved_is_said_to_be_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Session 23's student: a phone's .m4a whose recording stopped before its index was written
    # (moov, at the end) was called "not an audio or video file the decoder can read".
    import av
    import numpy as np

    whole = tmp_path / "talk.m4a"
    with av.open(str(whole), "w") as out:
        stream = out.add_stream("aac", rate=16000, layout="mono")
        tone = (3000 * np.sin(np.arange(16000 * 3) * 0.05)).astype(np.int16)
        frame = av.AudioFrame.from_ndarray(tone.reshape(1, -1), format="s16", layout="mono")
        frame.sample_rate = 16000
        for f in av.AudioResampler(format="fltp", layout="mono", rate=16000).resample(frame):
            for packet in stream.encode(f):
                out.mux(packet)
        for packet in stream.encode(None):
            out.mux(packet)
    cut = tmp_path / "cut.m4a"
    data = whole.read_bytes()
    moov = data.find(b"moov")
    assert moov > 0
    cut.write_bytes(data[: moov - 4])  # everything before the index: as if cut off
    status = main(["-q", "rehearse", str(cut), "--out", str(tmp_path / "s")])
    assert status == 2
    said = capsys.readouterr().err
    assert f"{cut}: not an audio or video file" in said and "cut off before it was saved" in said
