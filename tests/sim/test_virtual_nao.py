"""The virtual NAO, driven over the NAOqi protocol from this process (the server runs in another).

Each assertion is about what a NAOqi client sees: joint angles, limits, errors, the order of
blocking calls (from the server's JSONL record, in its own clock), never wall-clock durations.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("pybullet")
qi = pytest.importorskip("qi")

from prezence.feedback.limits import load_limits  # noqa: E402
from sim.virtual_nao import spawn, stop_spawned  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
TOL = 0.03  # rad: PyBullet's position control settles within this


def start_server(*args: str, timeout_s: float = 60.0) -> tuple[subprocess.Popen[str], str]:
    return spawn(*args, timeout_s=timeout_s)


def stop_server(proc: subprocess.Popen[str]) -> None:
    stop_spawned(proc)


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    log_path = tmp_path_factory.mktemp("vnao") / "record.jsonl"
    proc, url = start_server("--port", "0", "--speech-log", str(log_path))
    session = qi.Session()
    session.connect(url)
    try:
        yield {
            "url": url,
            "log": log_path,
            "motion": session.service("ALMotion"),
            "tts": session.service("ALTextToSpeech"),
            "memory": session.service("ALMemory"),
            "leds": session.service("ALLeds"),
            "posture": session.service("ALRobotPosture"),
        }
    finally:
        session.close()
        stop_server(proc)


def records(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def test_chains_expand_in_naoqi_order(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    lim = load_limits()
    assert motion.getBodyNames("Head") == list(lim.expand("Head"))
    assert motion.getBodyNames("Body") == list(lim.chains["Body"])
    assert len(motion.getAngles("Body", True)) == 26


def test_get_limits_are_the_urdf_limits_as_float32(robot: dict[str, Any]) -> None:
    lim = load_limits()
    got = robot["motion"].getLimits("LArm")
    assert len(got) == 6
    for name, (lo, hi, vel, _torque) in zip(lim.expand("LArm"), got, strict=True):
        assert lo == pytest.approx(lim.lower[name], abs=1e-6)
        assert hi == pytest.approx(lim.upper[name], abs=1e-6)
        assert vel == pytest.approx(lim.velocity[name], abs=1e-5)


def test_angle_interpolation_reaches_its_keyframes(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    motion.angleInterpolation(
        ["HeadYaw", "HeadPitch"], [[0.4, 0.2], [-0.2]], [[0.3, 0.6], [0.6]], True
    )
    assert motion.getAngles(["HeadYaw", "HeadPitch"], True) == pytest.approx([0.2, -0.2], abs=TOL)
    # a chain name with one scalar per joint, relative to the current angles
    motion.angleInterpolation("Head", [0.1, 0.1], [0.3, 0.3], False)
    assert motion.getAngles("Head", True) == pytest.approx([0.3, -0.1], abs=TOL)


def test_targets_are_clipped_to_the_joint_range(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    motion.angleInterpolationWithSpeed("LShoulderRoll", 3.0, 1.0)
    upper = load_limits().upper["LShoulderRoll"]
    assert motion.getAngles("LShoulderRoll", True)[0] == pytest.approx(upper, abs=TOL)
    assert motion.getAngles("LShoulderRoll", False)[0] == pytest.approx(upper, abs=1e-6)


def test_set_angles_speed_is_capped_at_fraction_of_the_limit(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    motion.angleInterpolationWithSpeed("RShoulderPitch", 0.0, 1.0)
    fraction = 0.1
    cap = fraction * load_limits().velocity["RShoulderPitch"]
    t0 = time.monotonic()
    motion.setAngles("RShoulderPitch", 1.5, fraction)
    q1 = motion.getAngles("RShoulderPitch", True)[0]
    t1 = time.monotonic()
    # the call returned at once (reactive) and the joint is still on its way
    assert q1 < 1.5 - TOL
    # an upper bound only: a slow host makes the measured speed lower, never higher
    assert abs(q1) <= cap * (t1 - t0) + 0.05
    motion.setAngles("RShoulderPitch", 0.0, 1.0)  # retarget: it turns back


def test_second_blocking_call_on_busy_joints_waits(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    first = motion.angleInterpolation("LElbowYaw", -0.5, 0.4, True, _async=True)
    second = motion.angleInterpolation("LElbowYaw", 0.5, 0.4, True, _async=True)
    second.value(10_000)
    assert first.isFinished()
    recs = [r for r in records(robot["log"]) if r.get("joints") == ["LElbowYaw"]]
    (end_first,) = [r["t"] for r in recs if r["event"] == "end"][:1]
    starts = [r["t"] for r in recs if r["event"] == "start"]
    assert starts[1] >= end_first
    assert motion.getAngles("LElbowYaw", True)[0] == pytest.approx(0.5, abs=TOL)


def test_blocking_call_leaves_the_service_answering_and_can_be_killed(
    robot: dict[str, Any],
) -> None:
    motion = robot["motion"]
    long = motion.angleInterpolation("RWristYaw", 1.0, 30.0, True, _async=True)
    motion.getAngles("RWristYaw", True)
    assert long.isRunning()
    assert motion.areResourcesAvailable(["RWristYaw"]) is False
    motion.killTasksUsingResources(["RWristYaw"])
    long.wait(10_000)
    assert long.hasValue()
    assert motion.areResourcesAvailable(["RWristYaw"]) is True


def test_client_cancel_ends_the_task(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    fut = motion.angleInterpolation("LWristYaw", 1.0, 30.0, True, _async=True)
    motion.getAngles("LWristYaw", True)
    fut.cancel()
    fut.wait(10_000)
    assert fut.isCanceled()
    assert motion.areResourcesAvailable(["LWristYaw"]) is True


def test_say_is_recorded_and_sentences_queue(robot: dict[str, Any]) -> None:
    tts = robot["tts"]
    a = tts.say("Good pace.", _async=True)
    b = tts.say("Look up at your audience.", "English", _async=True)
    b.value(20_000)
    assert a.isFinished()
    said = [r for r in records(robot["log"]) if r["call"] == "say"]
    start_b = next(r["t"] for r in said if r["event"] == "start" and r["text"].startswith("Look"))
    end_a = next(r["t"] for r in said if r["event"] == "end" and r["text"] == "Good pace.")
    assert start_b >= end_a
    assert robot["memory"].getData("ALTextToSpeech/TextDone") == 1


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda m: m.setAngles("HeadYawn", 0.1, 0.1), "unknown joint or chain 'HeadYawn'"),
        (lambda m: m.angleInterpolation("HeadYaw", [0.1, 0.2], [0.5, 0.4], True), "increase"),
        (lambda m: m.setAngles(["HeadYaw", "HeadPitch"], [0.1], 0.1), "1 angles for 2 joints"),
        (lambda m: m.setAngles("HeadYaw", 0.1, 0.0), "fractionMaxSpeed must be > 0"),
    ],
    ids=["unknown-joint", "times-not-increasing", "shape-mismatch", "zero-speed"],
)
def test_bad_calls_reach_the_client_as_runtime_errors(
    robot: dict[str, Any], call: Any, message: str
) -> None:
    with pytest.raises(RuntimeError, match=message):
        call(robot["motion"])


def test_unknown_joint_error_suggests_the_name(robot: dict[str, Any]) -> None:
    with pytest.raises(RuntimeError, match="did you mean 'HeadYaw'"):
        robot["motion"].getAngles("HeadYawn", True)


def test_leds_posture_and_memory(robot: dict[str, Any]) -> None:
    robot["leds"].fadeRGB("FaceLeds", "red", 0.05)
    assert robot["leds"].getColor("FaceLeds") == 0xFF0000
    robot["leds"].fadeRGB("FaceLeds", 0.0, 0.0, 1.0, 0.05)
    assert robot["leds"].getColor("FaceLeds") == 0x0000FF
    assert robot["posture"].goToPosture("StandZero", 1.0) is True
    assert robot["motion"].getAngles("LShoulderPitch", True)[0] == pytest.approx(0.0, abs=TOL)
    robot["memory"].insertData("Prezence/test", 42)
    assert robot["memory"].getData("Prezence/test") == 42


def test_commands_to_unstiff_joints_are_ignored(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    before = motion.getAngles("RElbowYaw", True)[0]
    motion.setStiffnesses("RElbowYaw", 0.0)
    motion.angleInterpolation("RElbowYaw", before + 0.5, 0.3, True)
    assert motion.getAngles("RElbowYaw", True)[0] == pytest.approx(before, abs=TOL)
    motion.wakeUp()
    assert motion.getStiffnesses("RElbowYaw") == [1.0]


def test_a_taken_port_is_an_error(robot: dict[str, Any]) -> None:
    port = robot["url"].rsplit(":", 1)[1]
    done = subprocess.run(
        [sys.executable, "-m", "sim.virtual_nao", "--model", "kinematic", "--port", port],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2
    assert "Address already in use" in done.stderr
