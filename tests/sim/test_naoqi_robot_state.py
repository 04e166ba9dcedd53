"""What NaoqiBackend leaves on the robot: the virtual NAO, over loopback, in another process.

The robot's own state before a talk (autonomous abilities, breathing, idle posture) must be
back after it, also after a reconnection; the arms and head must end at the neutral pose.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("pybullet")
qi = pytest.importorskip("qi")

from prezence.backends.naoqi import (  # noqa: E402
    AUTONOMOUS_ABILITIES,
    CLAIM_KEY,
    CLAIM_STALE_S,
    NaoqiBackend,
    neutral_targets,
)
from prezence.cli import main  # noqa: E402
from prezence.clock import MonotonicClock  # noqa: E402
from prezence.errors import BackendUnavailable  # noqa: E402
from prezence.feedback.gestures import build_trajectory  # noqa: E402
from prezence.feedback.limits import load_limits  # noqa: E402
from prezence.feedback.trajectory import Trajectory  # noqa: E402
from sim.virtual_nao import spawn, stop_spawned  # noqa: E402

TOL = 0.03  # rad


@pytest.fixture
def server() -> Iterator[tuple[subprocess.Popen[str], str]]:
    proc, url = spawn("--port", "0", timeout_s=60.0)
    yield proc, url
    if proc.poll() is None:
        stop_spawned(proc)


def robot_state(url: str) -> dict[str, Any]:
    """What a plain NAOqi script sees: abilities, breathing, idle posture."""
    session = qi.Session()
    session.connect(url)
    try:
        life = session.service("ALAutonomousLife")
        motion = session.service("ALMotion")
        return {
            **{a: life.getAutonomousAbilityEnabled(a) for a in AUTONOMOUS_ABILITIES},
            "breath": motion.getBreathEnabled("Body"),
            "idle": motion.getIdlePostureEnabled("Body"),
        }
    finally:
        session.close()


def robot_in_use(url: str) -> None:
    """Breathing and idle posture on, as on a robot in use (the abilities are on by default)."""
    session = qi.Session()
    session.connect(url)
    try:
        motion = session.service("ALMotion")
        motion.setBreathEnabled("Body", True)
        motion.setIdlePostureEnabled("Body", True)
    finally:
        session.close()


def test_autonomous_abilities_are_turned_off_during_the_talk_and_back_on_at_close(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    _, url = server
    robot_in_use(url)
    before = robot_state(url)
    assert all(before.values()), before
    with NaoqiBackend(url=url):
        during = robot_state(url)
        assert not any(during.values()), during  # nothing autonomous moves the joints
    assert robot_state(url) == before


def test_an_ability_already_off_stays_off(server: tuple[subprocess.Popen[str], str]) -> None:
    _, url = server
    session = qi.Session()
    session.connect(url)
    session.service("ALAutonomousLife").setAutonomousAbilityEnabled("BasicAwareness", False)
    session.close()
    with NaoqiBackend(url=url):
        pass
    after = robot_state(url)
    assert after["BasicAwareness"] is False
    assert after["SpeakingMovement"] is True


def test_the_robots_state_is_restored_at_close_after_a_reconnection(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    proc, url = server
    robot_in_use(url)
    before = robot_state(url)
    clock = MonotonicClock()
    backend = NaoqiBackend(
        url=url, heartbeat_s=0.2, call_timeout_s=0.5, reconnect_initial_s=0.1, reconnect_max_s=0.5
    )
    with backend:
        proc.send_signal(signal.SIGSTOP)  # the robot freezes (a Wi-Fi blip)
        try:
            end = time.monotonic() + 10.0
            while backend.connected and time.monotonic() < end:
                backend.advance(clock.now())
                time.sleep(0.05)
            assert not backend.connected
        finally:
            proc.send_signal(signal.SIGCONT)
        assert backend.wait_connected(20.0, clock.now)
        assert backend.stats()["connects"] == 2
    assert robot_state(url) == before


def read_angles(url: str, names: list[str]) -> list[float]:
    session = qi.Session()
    session.connect(url)
    try:
        return list(session.service("ALMotion").getAngles(names, True))
    finally:
        session.close()


def settle(backend: NaoqiBackend, clock: MonotonicClock, timeout_s: float = 20.0) -> None:
    """Advance until the backend is not busy (what the coach does between cues)."""
    end = time.monotonic() + timeout_s
    backend.advance(clock.now())
    while backend.busy and time.monotonic() < end:
        time.sleep(0.02)
        backend.advance(clock.now())
    assert not backend.busy


def test_a_gesture_killed_at_its_deadline_ends_at_the_neutral_pose(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    _, url = server
    names, neutral = neutral_targets()
    yaw0 = neutral[names.index("HeadYaw")]
    # far too fast for HeadYaw: the robot slows it down, so it misses its deadline and is killed
    fast = Trajectory("fast", ("HeadYaw",), (0.1,), ((yaw0 + 1.5,),), (yaw0,))
    clock = MonotonicClock()
    with NaoqiBackend(url=url, motion_margin_s=0.05) as backend:
        gesture = backend.play(fast, now=clock.now())
        settle(backend, clock)
        assert not gesture.ok and "no end within" in gesture.info["error"]
        assert backend.stats()["timeouts"] == 1
        assert read_angles(url, names) == pytest.approx(neutral, abs=TOL)  # not mid-gesture
        again = backend.play(fast, now=clock.now())  # planned from neutral, and it is there
        assert backend.wait_idle(20.0, clock.now)  # wait_idle waits for the return too
        assert read_angles(url, names) == pytest.approx(neutral, abs=TOL)
        assert not again.ok


def test_closing_mid_gesture_leaves_head_and_arms_at_the_neutral_pose(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    """A second Ctrl-C during the summary's gesture closes the backend mid-gesture."""
    _, url = server
    names, neutral = neutral_targets()
    traj = build_trajectory("encourage", speed_fraction=0.5, limits=load_limits())
    clock = MonotonicClock()
    backend = NaoqiBackend(url=url)
    with backend:
        gesture = backend.play(traj, now=clock.now())
        time.sleep(traj.duration / 2)
        assert read_angles(url, names) != pytest.approx(neutral, abs=TOL)
    assert gesture.done and not gesture.ok
    assert read_angles(url, names) == pytest.approx(neutral, abs=TOL)


def test_a_cue_running_when_the_robot_freezes_is_of_unknown_outcome_not_failed(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    """A frozen robot (Wi-Fi blip) may well finish the cue: the backend cannot know."""
    proc, url = server
    clock = MonotonicClock()
    backend = NaoqiBackend(
        url=url, heartbeat_s=0.2, call_timeout_s=0.5, reconnect_initial_s=0.1, reconnect_max_s=0.5
    )
    with backend:
        traj = build_trajectory("slow_down", speed_fraction=0.5, limits=load_limits())
        gesture = backend.play(traj, now=clock.now())
        phrase = backend.say("Slow down a little.", now=clock.now())
        proc.send_signal(signal.SIGSTOP)
        try:
            settle(backend, clock)
        finally:
            proc.send_signal(signal.SIGCONT)
        for m in (gesture, phrase):
            assert not m.ok and m.info["outcome"] == "unknown", m.info
            assert "robot lost" in m.info["error"]


def test_a_second_talk_on_the_same_robot_is_refused_naming_the_first(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    _, url = server
    first = NaoqiBackend(url=url)
    with first:
        second = NaoqiBackend(url=url)
        with pytest.raises(
            BackendUnavailable, match=r"in use by another Prezence talk \(pid "
        ) as e:
            second.open()
        assert f"pid {os.getpid()} on {socket.gethostname()}" in str(e.value)
        assert first.connected
    with NaoqiBackend(url=url) as third:  # the first removed its claim at close
        assert third.connected


def test_a_stale_claim_does_not_lock_the_robot(server: tuple[subprocess.Popen[str], str]) -> None:
    """A talk killed with SIGKILL leaves its claim; it stops being refreshed."""
    _, url = server
    session = qi.Session()
    session.connect(url)
    old = time.time() - 10 * CLAIM_STALE_S
    claim = {"id": "dead", "pid": 1, "host": "elsewhere", "started": old, "refreshed": old}
    session.service("ALMemory").insertData(CLAIM_KEY, json.dumps(claim))
    session.close()
    with NaoqiBackend(url=url) as backend:
        assert backend.connected


def test_a_cli_talk_on_a_robot_in_use_exits_2_naming_the_other_talk(
    server: tuple[subprocess.Popen[str], str],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    _, url = server
    with NaoqiBackend(url=url):
        argv = ["run", "short_talk", "--backend", "naoqi", "--robot", url]
        status = main([*argv, "--out", str(tmp_path / "s"), "--no-report"])
    assert status == 2
    err = capsys.readouterr().err
    assert "in use by another Prezence talk" in err and f"pid {os.getpid()}" in err


@pytest.mark.parametrize(("speed", "warned"), [("0.9", True), ("0.7", False)])
def test_a_speed_over_what_a_real_nao_keeps_up_with_is_warned_about(
    server: tuple[subprocess.Popen[str], str],
    tmp_path: Path,
    caplog: pytest.LogCaptureFixture,
    speed: str,
    warned: bool,
) -> None:
    _, url = server
    short = (Path(__file__).parents[2] / "scenarios" / "short_talk.toml").read_text()
    scenario = tmp_path / "quick.toml"  # short_talk cut to 3 s, its expectations left out
    scenario.write_text(
        short.split("[expect]")[0].replace('duration_s = "0:40"', 'duration_s = "0:03"')
    )
    argv = ["run", str(scenario), "--backend", "naoqi", "--robot", url, "--speed", speed]
    with caplog.at_level("WARNING"):
        main([*argv, "--out", str(tmp_path / "s"), "--no-report"])
    said = [r.getMessage() for r in caplog.records if "no-load" in r.getMessage()]
    assert len(said) == (1 if warned else 0), said
    if warned:
        assert "use --speed 0.7 or less on a real robot" in said[0]


def test_robot_options_on_the_command_line_reach_the_robot(
    server: tuple[subprocess.Popen[str], str], tmp_path: Path
) -> None:
    """docs/naoqi.md advises rest_on_close for long rehearsals: a CLI user can now ask for it."""
    _, url = server
    short = (Path(__file__).parents[2] / "scenarios" / "short_talk.toml").read_text()
    scenario = tmp_path / "quick.toml"
    scenario.write_text(
        short.split("[expect]")[0].replace('duration_s = "0:40"', 'duration_s = "0:03"')
    )
    argv = ["run", str(scenario), "--backend", "naoqi", "--robot", url]
    argv += ["--robot-option", "leds=on,rest_on_close=on", "--out", str(tmp_path / "s")]
    assert main([*argv, "--no-report"]) in (0, 3)
    session = qi.Session()
    session.connect(url)
    try:
        stiff = session.service("ALMotion").getStiffnesses("Body")
    finally:
        session.close()
    assert max(stiff) == 0.0  # rested: motors off


def test_a_bad_robot_option_exits_2_naming_the_known_ones(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["run", "short_talk", "--backend", "naoqi", "--robot", "tcp://127.0.0.1:9"]
    status = main([*argv, "--robot-option", "rest_on_clos=on", "--out", str(tmp_path / "s")])
    assert status == 2
    assert "rest_on_close" in capsys.readouterr().err
