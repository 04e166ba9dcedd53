"""The virtual NAO, driven over the NAOqi protocol from this process (the server runs in another).

Each assertion is about what a NAOqi client sees: joint angles, limits, errors, the order of
blocking calls (from the server's JSONL record, in its own clock), never wall-clock durations.
Timing is checked further down on a virtual NAO in this process whose clock the test steps.
"""

from __future__ import annotations

import itertools
import json
import logging
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
qi = pytest.importorskip("qi")

from prezence.feedback.limits import load_limits  # noqa: E402
from prezence.feedback.trajectory import Trajectory  # noqa: E402
from sim.virtual_nao import (  # noqa: E402
    SPEECH_LOGGER,
    ALMotion,
    ALTextToSpeech,
    KinematicNao,
    VirtualNao,
    min_segment_time,
    plan_keyframes,
    serve,
    spawn,
    stop_spawned,
)

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


@pytest.mark.parametrize(
    ("port", "said"),
    [
        ("taken", "the port is in use (Address already in use: another virtual NAO, NAOqi or "),
        ("70000", "port must be in 0..65535, got 70000"),
    ],
)
def test_sim_serve_on_a_taken_or_impossible_port_says_so_in_one_line(
    robot: dict[str, Any], port: str, said: str
) -> None:
    if port == "taken":
        port = robot["url"].rsplit(":", 1)[1]
    done = subprocess.run(
        [sys.executable, "-m", "prezence", "sim", "serve", "--model", "kinematic", "--port", port],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 2, done.stderr
    lines = [x for x in done.stderr.splitlines() if x.strip() and "pybullet build" not in x]
    assert len(lines) == 1, done.stderr  # no traceback, no boost source path
    assert lines[0].startswith("error: ") and said in lines[0]
    assert ".hpp" not in lines[0]


def test_angle_interpolation_clips_keyframes_like_set_angles(robot: dict[str, Any]) -> None:
    motion = robot["motion"]
    lim = load_limits()
    # head anti-collision: HeadPitch 0.5 is not allowed at HeadYaw 2.0
    motion.angleInterpolation(["HeadYaw", "HeadPitch"], [[2.0], [0.5]], [[0.8], [0.8]], True)
    pitch_max = lim.head_pitch_range(2.0)[1]
    assert motion.getAngles("HeadPitch", False)[0] == pytest.approx(pitch_max, abs=1e-6)
    assert motion.getAngles("HeadPitch", True)[0] == pytest.approx(pitch_max, abs=TOL)
    motion.angleInterpolation("Head", [0.0, 0.0], [0.5, 0.5], True)
    # one motor for both hips
    motion.angleInterpolation("LHipYawPitch", [-0.3], [0.6], True)
    assert motion.getAngles(["LHipYawPitch", "RHipYawPitch"], True) == pytest.approx(
        [-0.3, -0.3], abs=TOL
    )
    motion.angleInterpolation("LHipYawPitch", [0.0], [0.6], True)


# -- in this process, on a clock the test drives: timing in simulated seconds --------------------

DT = 0.01


@pytest.fixture(params=["pybullet", "kinematic"])
def manual(request: pytest.FixtureRequest) -> Iterator[VirtualNao]:
    """A virtual NAO without its real-time thread: the test steps it with ``tick``."""
    nao = VirtualNao(model=request.param)
    nao.start(realtime=False)
    nao.tick(0.5)  # settle
    yield nao
    nao.stop()


def run(nao: VirtualNao, seconds: float, joints: list[str]) -> list[tuple[float, list[float]]]:
    """Step ``seconds`` in ``DT`` ticks; the joints' angles after each tick."""
    out = []
    end = nao.now + seconds
    while nao.now < end - 1e-9:
        nao.tick(nao.now + DT)
        out.append((nao.now, nao.model.positions(joints)))
    return out


def ended_at(nao: VirtualNao, fut: Any, within: float) -> float:
    """Step until ``fut`` is finished; the simulated time it finished."""
    end = nao.now + within
    while not fut.isFinished():
        assert nao.now < end, "the call did not return"
        nao.tick(nao.now + DT)
    return nao.now


def arrival(samples: list[tuple[float, float]], final: float, tol: float = 0.01) -> float:
    """When the samples come within ``tol`` of ``final`` for good."""
    return max((t for t, q in samples if abs(q - final) > tol), default=samples[0][0])


def one_joint_plan(start: float, final: float, duration: float) -> Trajectory:
    return Trajectory("plan", ("j",), (duration,), ((final,),), (start,))


def test_reference_nod_follows_each_joints_time_list(manual: VirtualNao) -> None:
    motion = ALMotion(manual)
    t0 = manual.now
    fut = motion.angleInterpolation(
        ["HeadPitch", "HeadYaw"],
        [[0.25, 0.0, 0.25, 0.0], [0.0]],
        [[0.3, 0.6, 0.9, 1.2], [1.2]],
        True,
    )
    samples = dict(run(manual, 1.2, ["HeadPitch", "HeadYaw"]))
    for key_t, want in ((0.3, 0.25), (0.6, 0.0), (0.9, 0.25), (1.2, 0.0)):
        t = min(samples, key=lambda s: abs(s - (t0 + key_t)))
        assert samples[t][0] == pytest.approx(want, abs=TOL)
    assert all(abs(yaw) < TOL for _, yaw in samples.values())
    assert ended_at(manual, fut, 0.1) == pytest.approx(t0 + 1.2, abs=DT + 1e-9)


def test_overlapping_calls_on_other_joints_both_arrive_on_time(manual: VirtualNao) -> None:
    motion = ALMotion(manual)
    t0 = manual.now
    yaw0 = manual.model.positions(["HeadYaw"])[0]
    first = motion.angleInterpolation("HeadYaw", [-0.8], [1.5], True)
    head = run(manual, 0.1, ["HeadYaw", "LShoulderPitch"])
    arm0 = manual.model.positions(["LShoulderPitch"])[0]
    second = motion.angleInterpolation("LShoulderPitch", [0.5], [1.0], True)
    samples = head + run(manual, 2.0, ["HeadYaw", "LShoulderPitch"])
    for k, (start, q0, final, duration, fut) in enumerate(
        [(t0, yaw0, -0.8, 1.5, first), (t0 + 0.1, arm0, 0.5, 1.0, second)]
    ):
        plan = one_joint_plan(q0, final, duration)
        want = arrival([(t, float(plan.sample(t)[0])) for t in np.arange(0, 2, 0.001)], final)
        got = arrival([(t - start, q[k]) for t, q in samples if t >= start], final)
        assert got == pytest.approx(want, abs=0.03 * duration)
        assert fut.isFinished()


def test_keyframes_are_clipped_like_set_angles_targets(manual: VirtualNao) -> None:
    motion = ALMotion(manual)
    lim = load_limits()
    motion.angleInterpolation(["HeadYaw", "HeadPitch"], [[2.0], [0.5]], [[0.8], [0.8]], True)
    run(manual, 1.0, [])
    assert motion.getAngles("HeadPitch", False)[0] == pytest.approx(
        lim.head_pitch_range(2.0)[1], abs=1e-6
    )
    assert motion.getAngles("HeadPitch", True)[0] <= lim.head_pitch_range(2.0)[1] + TOL
    # HeadYaw left out of the call: its current angle sets the HeadPitch range
    motion.angleInterpolation("HeadPitch", [-0.6], [0.5], True)
    run(manual, 0.7, [])
    assert motion.getAngles("HeadPitch", True)[0] == pytest.approx(
        lim.head_pitch_range(2.0)[0], abs=TOL
    )
    motion.angleInterpolation("RHipYawPitch", [-0.3, 0.2], [0.5, 1.0], True)
    hips = run(manual, 1.2, ["LHipYawPitch", "RHipYawPitch"])
    assert all(left == pytest.approx(right, abs=TOL) for _, (left, right) in hips)
    assert hips[-1][1] == pytest.approx([0.2, 0.2], abs=TOL)


def test_too_fast_keyframes_are_slowed_down_to_the_velocity_limit(
    manual: VirtualNao, caplog: pytest.LogCaptureFixture
) -> None:
    motion = ALMotion(manual)
    limit = load_limits().velocity["HeadYaw"]
    yaw0 = manual.model.positions(["HeadYaw"])[0]
    t0 = manual.now
    with caplog.at_level(logging.WARNING, logger="sim.virtual_nao"):
        fut = motion.angleInterpolation("HeadYaw", [2.0], [0.1], True)
    (warning,) = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert "HeadYaw asked for" in warning and f"over its limit of {limit:.3g} rad/s" in warning
    samples = [(t0, yaw0), *((t, q[0]) for t, q in run(manual, 0.1, ["HeadYaw"]))]
    end = ended_at(manual, fut, 2.0)
    assert end - t0 == pytest.approx(min_segment_time(2.0 - yaw0, limit), abs=DT + 1e-9)
    # it returns when the joint is there, and the joint never went faster than its limit
    assert motion.getAngles("HeadYaw", True)[0] == pytest.approx(2.0, abs=TOL)
    samples += [(t, q[0]) for t, q in run(manual, 0.2, ["HeadYaw"])]
    speeds = [abs(b - a) / (tb - ta) for (ta, a), (tb, b) in itertools.pairwise(samples)]
    assert max(speeds) <= limit * 1.05


def test_plan_keyframes_slows_down_only_the_stretch_that_is_too_fast() -> None:
    lim = load_limits()
    pose = dict.fromkeys(lim.names, 0.0)
    plan = plan_keyframes(
        lim, ["HeadYaw", "HeadPitch"], [[1.0], [0.1, 0.0]], [[0.1], [0.1, 1.1]], pose
    )
    slow = min_segment_time(1.0, lim.velocity["HeadYaw"])
    # the shared key moves to where HeadYaw can be; the 1 s segment after it keeps its length
    assert [len(ts) for ts in plan.times] == [1, 2]
    assert [*plan.times[0], *plan.times[1]] == pytest.approx([slow, slow, slow + 1.0])
    assert (plan.asked_s, plan.duration_s) == pytest.approx((1.1, slow + 1.0))
    assert plan.capped is not None and plan.capped[0] == "HeadYaw"
    assert plan.capped[1:] == pytest.approx((1.0 / 0.05, lim.velocity["HeadYaw"]))
    fine = plan_keyframes(lim, ["HeadYaw"], [[0.5]], [[1.0]], pose)
    assert fine.times == ((1.0,),) and fine.capped is None


def test_each_phrase_said_is_logged(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    nao = VirtualNao(model="kinematic", speech_log=tmp_path / "said.jsonl")
    nao.start(realtime=False)
    try:
        tts = ALTextToSpeech(nao)
        with caplog.at_level(logging.INFO, logger=SPEECH_LOGGER):
            first = tts.say1("Good pace.")
            second = tts.say2("Look up at your audience.", "English")
        ended_at(nao, second, 10.0)
        assert first.isFinished()
    finally:
        nao.stop()
    said = [r.getMessage() for r in caplog.records if r.name == SPEECH_LOGGER]
    assert len(said) == 2
    assert said[0].endswith("Good pace.") and said[1].endswith("Look up at your audience.")
    # docs/naoqi.md shows the second line as the server prints it
    docs = (REPO / "docs" / "naoqi.md").read_text()
    assert f"INFO {SPEECH_LOGGER}: {said[1]}\n" in docs
    recs = [r for r in records(tmp_path / "said.jsonl") if r["call"] == "say"]
    assert [(r["event"], r["text"]) for r in recs] == [
        ("start", "Good pace."),
        ("end", "Good pace."),
        ("start", "Look up at your audience."),
        ("end", "Look up at your audience."),
    ]


def test_serve_takes_the_model_and_the_speech_log(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    log_path = tmp_path / "said.jsonl"
    with (
        caplog.at_level(logging.INFO, logger=SPEECH_LOGGER),
        serve("127.0.0.1", 0, model="kinematic", speech_log=log_path) as server,
    ):
        assert isinstance(server.robot.model, KinematicNao)
        session = qi.Session()
        session.connect(server.url)
        try:
            session.service("ALTextToSpeech").say("Slow down.")
        finally:
            session.close()
    assert any(r.getMessage().endswith("Slow down.") for r in caplog.records)
    assert [r["event"] for r in records(log_path) if r.get("text") == "Slow down."] == [
        "start",
        "end",
    ]


@pytest.mark.parametrize("how", ["python -m sim.virtual_nao", "prezence sim serve"])
def test_ctrl_c_after_a_client_came_ends_the_server_cleanly(how: str, tmp_path: Path) -> None:
    """Once a NAOqi client had come and gone, libqi's threads made the interpreter's exit
    abort (``terminate called without an active exception``, exit 134) after a clean close,
    about every other time: three servers each."""
    import signal

    # a client in a process of its own, gone just before the Ctrl-C (as a talk that ended)
    client = (
        "import qi, sys; s = qi.Session(); s.connect(sys.argv[1]); "
        "print(s.service('ALMotion').getAngles(['HeadYaw'], True)); "
        "s.service('ALTextToSpeech').say('hello'); s.close()"
    )
    for attempt in range(3):
        said = tmp_path / f"said{attempt}.jsonl"
        if how == "python -m sim.virtual_nao":
            proc, url = spawn("--port", "0", "--model", "kinematic", "--speech-log", str(said))
        else:
            proc = subprocess.Popen(
                [sys.executable, "-m", "prezence", "sim", "serve", "--port", "0"]
                + ["--model", "kinematic", "--speech-log", str(said)],
                cwd=REPO,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                text=True,
            )
            assert proc.stdout is not None
            line = proc.stdout.readline()  # the first line it prints
            assert line.startswith("listening on "), line
            url = line.split()[-1]
        subprocess.run([sys.executable, "-c", client, url], capture_output=True, check=True)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=30) == 0, f"attempt {attempt}: exit {proc.returncode}"
        if proc.stdout is not None:
            proc.stdout.close()
        # the record was written through to its end: the sentence started and finished
        assert [(r["event"], r["text"]) for r in records(said) if r.get("call") == "say"] == [
            ("start", "hello"),
            ("end", "hello"),
        ]
