"""Session 15's walkthrough as a CI integrator: whole talks headless, gated on exit codes.

A CI runner stops a job at its time limit with SIGTERM; Python's default was to die at once:
``run`` left a folder without ``summary.json`` whose ``session.json`` gave the whole talk's
length, ``evaluate --jobs 2`` left its workers running. Ctrl-C on ``run`` said "scenario
expectations NOT met" (exit 3) for a talk cut short; on ``evaluate --jobs 1`` it cut one talk
short, scored it as a whole talk and went on (exit 0). ``--out`` under a file or without
permission was a traceback; two talks into one folder at once deleted each other's files with
exit 0; ``run --json`` exited 3 saying nowhere why.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from prezence.cli import EXIT_EXPECTATIONS, EXIT_INTERRUPTED, EXIT_TERMINATED, main
from prezence.evaluate import evaluate

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def _default_signals() -> None:
    """The child takes Ctrl-C and SIGTERM as a terminal's process does (not ignored)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _start(args: list[str], cwd: Path, **env: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "prezence.cli", *args],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=_default_signals,
        env={**os.environ, **env},
    )


def _wait_for(ok: Callable[[], bool], proc: subprocess.Popen[str], what: str) -> None:
    """Poll until ``ok()`` (the process must still run); a timeout only so that no test hangs."""
    deadline = time.monotonic() + 120
    while not ok():
        if proc.poll() is not None:
            pytest.fail(f"the process ended before {what}: {proc.communicate()}")
        if time.monotonic() > deadline:
            proc.kill()
            pytest.fail(f"no {what} within 120 s")
        time.sleep(0.05)


def _talking(folder: Path) -> Callable[[], bool]:
    """The talk's loop runs: its presenter has written samples."""
    return lambda: any(p.stat().st_size > 0 for p in folder.glob("streams/*.txt"))


def _realtime_run(tmp_path: Path, out: str, *extra: str) -> subprocess.Popen[str]:
    proc = _start(["run", "fast_talker", "--realtime", "--out", out, *extra], tmp_path)
    _wait_for(_talking(tmp_path / out), proc, "talk")
    return proc


def test_sigterm_ends_a_run_with_its_folder_written_and_exit_143(tmp_path: Path) -> None:
    proc = _realtime_run(tmp_path, "t")
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_TERMINATED, (out, err)
    assert "talk stopped by SIGTERM" in err and "scenario expectations not checked" in err
    assert "expectations NOT met" not in out and "expectations met" not in out
    summary = json.loads((tmp_path / "t/summary.json").read_text())
    assert summary["interrupted"] is True
    assert "post_talk" not in summary  # the robot says nothing more once told to stop
    meta = json.loads((tmp_path / "t/session.json").read_text())
    assert meta["talk_s"] == summary["talk_s"] < 600  # where it stopped, not the script's end
    assert (tmp_path / "t/report/report.html").is_file()


def test_ctrl_c_on_a_run_is_not_a_missed_expectation(tmp_path: Path) -> None:
    proc = _realtime_run(tmp_path, "c", "--no-report")
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_INTERRUPTED != EXIT_EXPECTATIONS, (out, err)
    assert "talk stopped by Ctrl-C" in err
    assert "NOT met" not in out
    assert json.loads((tmp_path / "c/summary.json").read_text())["interrupted"] is True


def _workers(pid: int) -> list[int]:
    """The pool's worker processes of ``pid`` (not multiprocessing's resource tracker, which
    ends by itself when its parent has gone)."""
    kids = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
            cmdline = (stat.parent / "cmdline").read_bytes()
        except OSError:
            continue
        if int(fields[1]) == pid and b"spawn_main" in cmdline:
            kids.append(int(stat.parent.name))
    return kids


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc")
def test_sigterm_ends_evaluate_with_its_workers_and_leaves_nothing(tmp_path: Path) -> None:
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    proc = _start(
        ["evaluate", "--seeds", "6", "--jobs", "2", "--scenarios", "fast_talker", "--out", "ev"],
        tmp_path,
        TMPDIR=str(tmp),
    )
    # both workers run a talk (each has its temporary session folder)
    _wait_for(lambda: len(list(tmp.glob("prezence-eval-*"))) >= 2, proc, "two talks")
    workers = _workers(proc.pid)
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == EXIT_TERMINATED, (out, err)
    assert "evaluation stopped" in err and "no tables written" in err
    assert not (tmp_path / "ev").exists()
    assert len(workers) == 2 and not [w for w in workers if _running(w)]
    assert not list(tmp.glob("prezence-eval-*"))  # the workers' talk folders went with them


def test_ctrl_c_in_a_one_process_evaluation_stops_it_not_one_talk(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from prezence.synthetic.runner import SyntheticSource

    poll = SyntheticSource.poll
    talks: list[int] = []

    def ctrl_c_in_the_second_talk(self: SyntheticSource, now: float) -> object:
        if id(self) not in talks:
            talks.append(id(self))
        if len(talks) == 2 and now >= 20.0:
            raise KeyboardInterrupt
        return poll(self, now)

    monkeypatch.setattr(SyntheticSource, "poll", ctrl_c_in_the_second_talk)
    with pytest.raises(KeyboardInterrupt):
        evaluate(["short_talk"], ["none"], 3, jobs=1)
    assert len(talks) == 2  # no third talk after the Ctrl-C


def test_a_one_process_evaluation_logs_as_its_workers_do(caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.WARNING)
    evaluate(["camera_dropout"], ["none"], 1, jobs=1)
    # the scenario's garbled lines were warned about per line, naming temporary files gone
    assert not [r for r in caplog.records if r.name == "prezence.streams.tail"]


def test_a_file_in_the_way_is_an_error_line_not_a_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "afile").write_text("mine\n")
    for argv in (
        ["run", "short_talk", "--out", str(tmp_path / "afile")],
        ["demo", "--out", str(tmp_path / "afile/sub")],
        [
            "evaluate",
            "--seeds",
            "1",
            "--scenarios",
            "short_talk",
            "--out",
            str(tmp_path / "afile/e"),
        ],
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        assert err.startswith("error: ") and "a file is in the way" in err, err
    assert (tmp_path / "afile").read_text() == "mine\n"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a read-only folder")
def test_a_read_only_parent_is_an_error_line_not_a_traceback(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        assert main(["run", "short_talk", "--out", str(ro / "s")]) == 2
        assert "no permission to write there" in capsys.readouterr().err
    finally:
        ro.chmod(0o755)


def test_a_second_talk_into_a_folder_in_use_is_refused_and_the_first_kept(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = _realtime_run(tmp_path, "same")
    try:
        before = sorted(p.name for p in (tmp_path / "same/streams").glob("*.txt"))
        assert main(["run", "fast_talker", "--seed", "3", "--out", str(tmp_path / "same")]) == 2
        assert "another prezence process is writing into this folder" in capsys.readouterr().err
        # the first talk's files are still there (the second would have deleted them)
        assert sorted(p.name for p in (tmp_path / "same/streams").glob("*.txt")) == before
    finally:
        first.send_signal(signal.SIGTERM)
        first.communicate(timeout=120)
    assert first.returncode == EXIT_TERMINATED
    meta = json.loads((tmp_path / "same/session.json").read_text())
    assert meta["seed"] == 0
    # the folder is free again once the first talk ended
    assert main(["run", "short_talk", "--out", str(tmp_path / "same")]) == 0


def test_run_json_says_on_stderr_why_it_failed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (SCENARIOS / "fast_talker.toml").read_text()
    assert "within_s = 60" in text
    mine = tmp_path / "mine.toml"
    mine.write_text(text.replace("within_s = 60", "within_s = 5"))
    assert main(["run", str(mine), "--json", "--out", str(tmp_path / "o")]) == EXIT_EXPECTATIONS
    out, err = capsys.readouterr()
    json.loads(out)  # stdout stays the JSON alone
    assert "scenario expectation NOT met: expected slowDown (speech_speed) between 3:00" in err


def test_the_report_command_printed_for_a_folder_with_spaces_can_be_pasted(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", "short_talk", "--out", "with space/s 1"]) == 0
    assert "prezence report 'with space/s 1')" in capsys.readouterr().out


def test_quiet_keeps_pybullets_banner_off_stderr(tmp_path: Path) -> None:
    pytest.importorskip("pybullet")
    proc = subprocess.run(
        [sys.executable, "-m", "prezence.cli", "-q", "run", "short_talk", "--backend", "sim"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    assert "scenario expectations met" in proc.stdout


def test_a_talk_dropped_unfinished_in_this_process_does_not_hold_its_folder(
    tmp_path: Path,
) -> None:
    """The Gymnasium environment's reset mid-episode drops a talk unfinished and starts the
    next one in the same folder: only another process's talk is kept out."""
    from prezence.backends.fake import FakeBackend
    from prezence.config.load import load_config
    from prezence.session import SessionDir
    from prezence.synthetic.runner import SyntheticSource
    from prezence.synthetic.scenario import load_scenario
    from prezence.talk import RunOptions, Talk

    config = load_config(None)
    source = SyntheticSource(load_scenario("short_talk"), config, seed=0)
    dropped = Talk(
        source,
        config=config,
        session=SessionDir(tmp_path / "ep"),
        backend=FakeBackend(),
        options=RunOptions.default(),
    )
    dropped.start()
    try:
        dropped.step(1.0)
        assert main(["run", "short_talk", "--out", str(tmp_path / "ep")]) == 0
    finally:  # as the environment drops an episode: its files closed, not finished
        assert dropped.coach is not None
        dropped.coach.close()
        dropped.source.stop()
        dropped.backend.close()


@pytest.mark.parametrize("argv", [["-q", "evaluate"], ["evaluate", "-q"]], ids=["before", "after"])
def test_evaluate_takes_quiet_before_or_after_its_name_and_keeps_stderr_for_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    grid = ["--seeds", "1", "--scenarios", "short_talk", "--policies", "none"]
    assert main([*argv, *grid, "--out", str(tmp_path / "ev")]) == 0
    out, err = capsys.readouterr()
    assert err == ""  # was 'error: unrecognized arguments: -q' after, the closing line before
    assert "| none |" in out
    assert (tmp_path / "ev/evaluation.csv").is_file()


def test_check_config_says_which_files_are_fine_when_another_is_not(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = tmp_path / "good.txt"
    good.write_text("speech_speed inRange 140 180 speedUp slowDown\n")
    bad = tmp_path / "bad.txt"
    bad.write_text("speech_speed inRange 140 180 speedUp slowDown\nspeech_volume mn 60 louder\n")
    assert main(["check-config", str(good), str(bad)]) == 1
    out, err = capsys.readouterr()
    assert out == f"{good}: ok\n"  # was nothing: a lint log could not tell which file passed
    assert err.startswith(f"{bad}:2:") and str(good) not in err


def test_a_talk_run_again_into_its_folder_leaves_no_report_of_the_earlier_talk(
    tmp_path: Path,
) -> None:
    out = tmp_path / "s"
    assert main(["-q", "run", "fast_talker", "--out", str(out)]) == 0
    assert "fast_talker" in (out / "report/summary.txt").read_text()
    assert main(["-q", "run", "quiet_speaker", "--out", str(out), "--no-report"]) == 0
    assert json.loads((out / "summary.json").read_text())["scenario"] == "quiet_speaker"
    assert not (out / "report").exists()  # was fast_talker's report beside quiet_speaker's files
    # a report/ folder of one's own in an --out no talk wrote is left alone: refused, as a
    # talk's report would be written into it and the next run would remove it whole (session
    # 21's second review)
    own = tmp_path / "own"
    (own / "report").mkdir(parents=True)
    (own / "report/notes.txt").write_text("mine\n")
    assert main(["-q", "run", "short_talk", "--out", str(own)]) == 2
    assert main(["-q", "run", "short_talk", "--out", str(own), "--no-report"]) == 2
    assert (own / "report/notes.txt").read_text() == "mine\n"
    assert sorted(p.name for p in own.iterdir()) == ["report"]


def test_a_replay_stopped_before_its_end_is_not_done(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C (or SIGTERM, which now ends a talk the same way) on ``replay``: exit 130 (143),
    never 0, which a CI gate would read as a replay done."""
    from prezence.talk import RecordedSource

    src = tmp_path / "src"
    assert main(["-q", "run", "fast_talker", "--out", str(src), "--no-report"]) == 0
    poll = RecordedSource.poll

    def ctrl_c_at_20_s(self: RecordedSource, now: float) -> object:
        if now >= 20.0:
            raise KeyboardInterrupt
        return poll(self, now)

    monkeypatch.setattr(RecordedSource, "poll", ctrl_c_at_20_s)
    capsys.readouterr()
    assert main(["replay", str(src), "--out", str(tmp_path / "rp"), "--no-report"]) == 130
    assert "stopped by Ctrl-C at 0:20.0" in capsys.readouterr().err
    assert json.loads((tmp_path / "rp/summary.json").read_text())["interrupted"] is True


def test_an_evaluation_never_writes_into_a_folder_another_process_is_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two nightly evaluations started together without --out both wrote into evaluation/:
    the second's tables replaced the first's, and both said they wrote them."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "evaluation").mkdir()
    holder = subprocess.Popen(  # another process holding evaluation/, as one evaluating does
        [
            sys.executable,
            "-c",
            "import fcntl, os, sys; fd = os.open('evaluation', os.O_RDONLY); "
            "fcntl.flock(fd, fcntl.LOCK_EX); print('held', flush=True); sys.stdin.read()",
        ],
        cwd=tmp_path,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline() == "held\n"
        grid = ["--seeds", "1", "--scenarios", "short_talk", "--policies", "none"]
        assert main(["-q", "evaluate", *grid]) == 0
        assert not any((tmp_path / "evaluation").iterdir())
        assert (tmp_path / "evaluation-2/evaluation.csv").is_file()
        capsys.readouterr()
        assert main(["-q", "evaluate", *grid, "--out", "evaluation"]) == 2
        assert "another prezence process is writing into this folder" in capsys.readouterr().err
    finally:
        holder.communicate("")


def test_run_into_a_folder_of_ones_own_files_refuses_rather_than_overwrite(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # session 21, a second walkthrough: `run demo --out .` in a project folder replaced the
    # user's own config.toml (a rules file kept under that name) without a word
    proj = tmp_path / "proj"
    proj.mkdir()
    (proj / "config.toml").write_text("my precious config\n")
    (proj / "notes.md").write_text("x\n")
    assert main(["-q", "run", "demo", "--out", str(proj), "--no-report"]) == 2
    assert "holds config.toml but no talk that Prezence made again" in capsys.readouterr().err
    assert (proj / "config.toml").read_text() == "my precious config\n"
    assert sorted(p.name for p in proj.iterdir()) == ["config.toml", "notes.md"]


def test_run_says_the_scenario_keeps_its_length_over_the_configs_allocated_time(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # session 21, a second walkthrough: `run fast_talker --config` with `allocated_s = 300`
    # said "time used 10:00.0 of 10:00.0" and nothing of the config's 300 s
    rules = Path(__file__).parents[2] / "prezence" / "config" / "defaults" / "rules.txt"
    cfg = tmp_path / "five.toml"
    cfg.write_text(f'format = 1\nrules_file = "{rules}"\n[time]\nallocated_s = 300\n')
    with caplog.at_level(logging.WARNING):
        argv = ["run", "fast_talker", "--config", str(cfg), "--out", str(tmp_path / "o")]
        assert main([*argv, "--no-report"]) == 0
    assert (
        "its allocated time (300 s) is not used: the scenario fast_talker allocates 600 s"
        in caplog.text
    )
    # a rules file sets no time: nothing of the user's is dropped, nothing to say
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        argv = ["run", "quiet_speaker", "--config", str(rules), "--out", str(tmp_path / "p")]
        assert main([*argv, "--no-report"]) == 0
    assert "allocated time" not in caplog.text
