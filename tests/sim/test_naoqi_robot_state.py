"""What NaoqiBackend leaves on the robot: the virtual NAO, over loopback, in another process.

The robot's own state before a talk (autonomous abilities, breathing, idle posture) must be
back after it, also after a reconnection; the arms and head must end at the neutral pose.
"""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Iterator
from typing import Any

import pytest

pytest.importorskip("pybullet")
qi = pytest.importorskip("qi")

from prezence.backends.naoqi import AUTONOMOUS_ABILITIES, NaoqiBackend  # noqa: E402
from prezence.clock import MonotonicClock  # noqa: E402
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
