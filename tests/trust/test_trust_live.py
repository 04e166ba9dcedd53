"""Issue 13, live talks: fail fast and clearly, modules die with the coach, reports survive.

These run ``prezence up`` with tiny modules in real time (a few seconds each).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from prezence.backends.fake import FakeBackend
from prezence.cli import main
from prezence.config.model import Check, Config, ProcessorSettings, Rule, TimeSettings
from prezence.launcher import BAD_INPUT_STATUS, ModuleProcess, ModuleSpec, up
from prezence.talk import RunOptions

ROOT = Path(__file__).resolve().parents[2]
PACE = ROOT / "tests" / "modules" / "pace_module.py"
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}

CONFIG = Config(
    rules=(Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown"),),
    processor=ProcessorSettings(threshold=40.0, stale_after_s=1.0, praise_after_s=0),
    time=TimeSettings(allocated_s=None),
)


def _cli(*args: str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "prezence", *args],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=timeout,
    )


# -- inputs checked before the talk -------------------------------------------------------------


def test_a_missing_audio_file_is_an_error_before_anything_starts(tmp_path: Path) -> None:
    p = _cli("up", "--audio", str(tmp_path / "nothere.wav"), "--out", str(tmp_path / "s"))
    assert p.returncode == 2
    assert "nothere.wav: no such file" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "s").exists()


def test_robot_without_the_naoqi_backend_is_an_error(tmp_path: Path) -> None:
    rc = main(["up", "--module", "x=true", "--robot", "tcp://127.0.0.1:9559", "-q"])
    assert rc == 2


def test_a_closed_robot_port_is_a_clear_error(tmp_path: Path) -> None:
    with socket.socket() as s:  # a port that was free a moment ago: nothing listens on it
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    p = _cli(
        "up", "--module", "x=true", "--backend", "naoqi", "--robot", f"tcp://127.0.0.1:{port}",
        "--out", str(tmp_path / "s"),
    )  # fmt: skip
    assert p.returncode == 2 and "nothing listens" in p.stderr
    assert not (tmp_path / "s").exists()


def test_a_silent_robot_port_is_a_clear_error_and_leaves_no_folder(tmp_path: Path) -> None:
    pytest.importorskip("qi")
    with socket.socket() as srv:  # accepts connections (the kernel does) but never speaks
        srv.bind(("127.0.0.1", 0))
        srv.listen(4)
        port = srv.getsockname()[1]
        p = _cli(
            "up", "--module", "x=true", "--backend", "naoqi", "--robot",
            f"tcp://127.0.0.1:{port}", "--out", str(tmp_path / "s"),
        )  # fmt: skip
    assert p.returncode == 2 and "no answer" in p.stderr
    assert not (tmp_path / "s").exists()


# -- supervision ---------------------------------------------------------------------------------


@pytest.mark.slow
def test_a_module_with_bad_input_stops_the_talk_with_its_own_message(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text(
        "import sys\nprint('error: talk.wav: the audio is damaged', file=sys.stderr)\n"
        f"sys.exit({BAD_INPUT_STATUS})\n"
    )
    p = _cli("up", "--module", f"bad={sys.executable} {bad}", "--out", str(tmp_path / "s"))
    assert p.returncode == 2
    assert "module bad: talk.wav: the audio is damaged" in p.stderr
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert summary["modules"]["bad"]["restarts"] == 0
    assert (tmp_path / "s" / "bad.log").read_text().count("error:") == 1  # started once
    assert "post_talk" not in summary  # no "well done" from the robot


@pytest.mark.slow
def test_with_file_inputs_the_talk_ends_when_they_end(tmp_path: Path) -> None:
    script = tmp_path / "short.py"
    script.write_text(
        "import sys, time\nfrom pathlib import Path\n"
        "p = Path(sys.argv[1]) / 'streams' / 'speech_speed.txt'\n"
        "for i in range(10):\n"
        "    with p.open('a') as f: f.write(f'{i * 0.2:.1f} 160\\n')\n"
        "    time.sleep(0.2)\n"
    )
    spec = ModuleSpec("file", [sys.executable, str(script), "{session}"], finite=True)
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[spec],
        backend=FakeBackend(time_scale=0.01),
        options=RunOptions.default(),
        duration_s=60.0,
    )
    talk_s = result.summary["talk_s"]
    assert talk_s < 30.0
    meta = json.loads((tmp_path / "s" / "session.json").read_text())
    assert meta["talk_s"] == pytest.approx(talk_s, abs=1e-3)  # one time figure


def test_restart_backoff_resets_after_a_healthy_run(tmp_path: Path) -> None:
    crash = ModuleSpec("c", [sys.executable, "-c", "raise SystemExit(3)"])
    with open(tmp_path / "c.log", "a") as log:
        mp = ModuleProcess(crash, tmp_path, time.time(), log, healthy_after_s=10.0)
        delays = []
        now = 0.0
        for ran in (0.5, 0.5, 0.5, 20.0, 0.5):  # three quick crashes, a long run, a crash
            mp.start(now)
            assert mp.proc is not None
            mp.proc.wait()
            now += ran
            mp.check(now)
            delays.append(round(mp.next_start - now, 3))
            now = mp.next_start
    assert delays == [1.0, 2.0, 4.0, 1.0, 2.0]


@pytest.mark.slow
def test_a_sigkilled_coach_leaves_no_module_and_an_intact_recording(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    mod = tmp_path / "mod.py"
    mod.write_text(
        "import os, sys, time\nfrom pathlib import Path\n"
        f"Path({str(pids)!r}).open('a').write(f'{{os.getpid()}}\\n')\n"
        "p = Path(sys.argv[1]) / 'streams' / 'speech_speed.txt'\n"
        "i = 0\n"
        "while True:\n"
        "    with p.open('a') as f: f.write(f'{i * 0.1:.1f} 200\\n')\n"
        "    i += 1; time.sleep(0.1)\n"
    )
    s = tmp_path / "s"
    coach = subprocess.Popen(
        [sys.executable, "-m", "prezence", "up", "-q", "--no-report", "--out", str(s),
         "--module", f"m:speech_speed={sys.executable} {mod} {{session}}"],
        env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    stream = s / "streams" / "speech_speed.txt"
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and (not stream.exists() or stream.stat().st_size < 200):
        time.sleep(0.1)
    assert stream.exists() and stream.stat().st_size >= 200
    coach.send_signal(signal.SIGKILL)
    coach.wait()
    (pid,) = [int(x) for x in pids.read_text().split()]
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and _alive(pid):
        time.sleep(0.05)
    assert not _alive(pid), "the module outlived the coach"
    lines = stream.read_text().splitlines()
    assert len(lines) >= 20 and all(ln.endswith(" 200") for ln in lines)
    # the report is rebuilt from what was recorded; its length is the recorded one
    assert main(["report", str(s), "-q"]) == 0
    report = json.loads((s / "report" / "report.json").read_text())
    assert 1.0 < report["talk_s"] < 60.0
    assert report["metrics"]["speech_speed"]["samples"] >= 20


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie (dead, not yet reaped by init) counts as gone
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"
