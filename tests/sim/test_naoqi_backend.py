"""NaoqiBackend against the virtual NAO in another process, over loopback.

No wall-clock assertions: motions must complete and land where planned; a lost robot must fail
its motions, refuse cues and come back; an unreachable one must give BackendUnavailable.
"""

from __future__ import annotations

import re
import shutil
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("pybullet")
qi = pytest.importorskip("qi")

from prezence.backends.naoqi import TOO_FAST_TOLERANCE, NaoqiBackend, neutral_targets  # noqa: E402
from prezence.backends.registry import make_backend  # noqa: E402
from prezence.cli import main  # noqa: E402
from prezence.clock import MonotonicClock  # noqa: E402
from prezence.errors import BackendUnavailable, ConfigError, UnknownName  # noqa: E402
from prezence.feedback.gestures import build_trajectory  # noqa: E402
from prezence.feedback.limits import load_limits  # noqa: E402
from prezence.feedback.trajectory import Trajectory  # noqa: E402
from sim.virtual_nao import spawn, stop_spawned  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
TOL = 0.03  # rad

NOD = Trajectory(
    name="nod",
    joints=("HeadPitch", "HeadYaw"),
    times=(0.4, 0.8, 1.2),
    positions=((0.25, 0.0), (0.0, 0.1), (0.15, 0.2)),
    start=(0.0, 0.0),
)
SLOW = Trajectory(
    name="slow",
    joints=("LShoulderPitch",),
    times=(20.0,),
    positions=((0.5,),),
    start=(1.4,),
)


def start_server(*args: str, timeout_s: float = 60.0) -> tuple[subprocess.Popen[str], str]:
    return spawn(*args, timeout_s=timeout_s)


def stop_server(proc: subprocess.Popen[str], *, kill: bool = False) -> None:
    stop_spawned(proc, kill=kill)


@pytest.fixture
def server() -> Iterator[tuple[subprocess.Popen[str], str]]:
    proc, url = start_server("--port", "0")
    yield proc, url
    if proc.poll() is None:
        stop_server(proc)


def read_angles(url: str, names: list[str]) -> list[float]:
    session = qi.Session()
    session.connect(url)
    try:
        return list(session.service("ALMotion").getAngles(names, True))
    finally:
        session.close()


def test_plays_a_gesture_and_says_a_phrase(server: tuple[subprocess.Popen[str], str]) -> None:
    _, url = server
    clock = MonotonicClock()
    backend = make_backend("naoqi", url=url, leds=True)
    with backend:
        assert isinstance(backend, NaoqiBackend)
        gesture = backend.play(NOD, now=clock.now())
        phrase = backend.say("Good pace, keep going.", now=clock.now())
        assert backend.busy
        assert backend.wait_idle(10.0, clock.now)
        assert gesture.ok and phrase.ok, (gesture.info, phrase.info)
        assert gesture.done and phrase.done
        assert read_angles(url, list(NOD.joints)) == pytest.approx(NOD.positions[-1], abs=TOL)
        stats = backend.stats()
    assert stats["connects"] == 1 and stats["failed"] == 0 and stats["dropped"] == 0


def test_open_moves_head_and_arms_to_the_library_neutral_pose(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    _, url = server
    names, neutral = neutral_targets()
    assert names[:2] == ["HeadYaw", "HeadPitch"] and "RHand" in names and len(names) == 14
    session = qi.Session()  # leave the robot somewhere else, as a plain script might
    session.connect(url)
    try:
        motion = session.service("ALMotion")
        motion.wakeUp()
        motion.angleInterpolationWithSpeed(
            ["HeadYaw", "LShoulderPitch", "RElbowRoll"], [0.6, 0.3, 1.2], 1.0
        )
    finally:
        session.close()
    assert read_angles(url, names) != pytest.approx(neutral, abs=TOL)
    with NaoqiBackend(url=url) as backend:
        assert backend.connected
        assert read_angles(url, names) == pytest.approx(neutral, abs=TOL)


def test_too_fast_counts_gestures_over_the_robots_own_velocity_limits(
    server: tuple[subprocess.Popen[str], str],
) -> None:
    limits = load_limits()
    yaw_limit = limits.velocity["HeadYaw"]
    # the library at 100 % of the URDF limits: some joint peaks exactly at its limit
    full = build_trajectory("encourage", speed_fraction=1.0, limits=limits)
    ratios = full.peak_velocities() / [limits.velocity[j] for j in full.joints]
    assert max(ratios) == pytest.approx(1.0)
    # 0.2 s segments: a 0.2 s ramp each way, so the peak is twice the mean speed
    under = Trajectory("under", ("HeadYaw",), (0.2,), ((0.8,),), (0.0,))  # 8.0 rad/s peak
    over = Trajectory("over", ("HeadYaw",), (0.2,), ((1.0,),), (0.0,))  # 10 rad/s; mean 5
    assert under.peak_velocities()[0] < yaw_limit < over.peak_velocities()[0]
    assert over.peak_velocities()[0] > yaw_limit * (1 + TOO_FAST_TOLERANCE)
    clock = MonotonicClock()
    with NaoqiBackend(url=server[1]) as backend:
        for traj, expected in ((full, 0), (under, 0), (over, 1)):
            backend.play(traj, now=clock.now())
            assert backend.wait_idle(10.0, clock.now)
            assert backend.stats()["too_fast"] == expected, traj.name


def test_unknown_joint_is_refused_before_sending(server: tuple[subprocess.Popen[str], str]) -> None:
    bad = Trajectory("bad", ("HeadYawn",), (0.5,), ((0.1,),), (0.0,))
    with NaoqiBackend(url=server[1]) as backend, pytest.raises(UnknownName, match="HeadYaw"):
        backend.play(bad, now=0.0)


def test_lost_robot_fails_motions_drops_cues_and_reconnects() -> None:
    clock = MonotonicClock()
    proc, url = start_server("--port", "0")
    port = url.rsplit(":", 1)[1]
    backend = NaoqiBackend(url=url, reconnect_initial_s=0.1, reconnect_max_s=0.5, heartbeat_s=0.2)
    try:
        backend.open()
        gesture = backend.play(SLOW, now=clock.now())
        phrase = backend.say("Slow down a little, you are rushing.", now=clock.now())
        stop_server(proc, kill=True)  # the robot goes away mid-cue
        assert backend.wait_idle(10.0, clock.now)
        assert not gesture.ok and not phrase.ok
        assert "robot lost" in gesture.info["error"] or "Session closed" in gesture.info["error"]
        assert not backend.connected
        assert not backend.busy  # nothing is held for later: the coach may go on
        with pytest.raises(BackendUnavailable, match="dropped"):
            backend.play(NOD, now=clock.now())
        assert not backend.wait_connected(0.5, clock.now)  # nobody listens yet

        proc, url2 = start_server("--port", port)  # the robot comes back on the same address
        assert url2 == url
        assert backend.wait_connected(20.0, clock.now)
        again = backend.play(NOD, now=clock.now())
        assert backend.wait_idle(10.0, clock.now)
        assert again.ok
        assert read_angles(url, list(NOD.joints)) == pytest.approx(NOD.positions[-1], abs=TOL)
        stats = backend.stats()
        assert stats["connects"] == 2
        assert stats["disconnects"] == 1
        assert stats["dropped"] == 1
        assert stats["failed"] == 2
    finally:
        backend.close()
        if proc.poll() is None:
            stop_server(proc)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def test_closed_port_is_unavailable() -> None:
    backend = NaoqiBackend(url=f"tcp://127.0.0.1:{free_port()}", connect_timeout_s=2.0)
    with pytest.raises(BackendUnavailable, match=r"no NAOqi robot at .*refused"):
        backend.open()


def test_silent_host_is_unavailable_after_the_deadline() -> None:
    # a TCP server that accepts and never speaks qi: libqi alone would wait for ever
    with socket.socket() as listener:
        listener.bind(("127.0.0.1", 0))
        listener.listen(4)
        port = listener.getsockname()[1]
        backend = NaoqiBackend(url=f"tcp://127.0.0.1:{port}", connect_timeout_s=0.5)
        with pytest.raises(BackendUnavailable, match="no answer within 0.5 s"):
            backend.open()


def test_missing_qi_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "qi", None)
    backend = NaoqiBackend(url="tcp://127.0.0.1:9559")
    with pytest.raises(BackendUnavailable, match=r'pip install "prezence\[naoqi\]"'):
        backend.open()


def native_stacks(pid: int) -> str:
    """Every thread's native stack of a live process, by gdb if it is installed."""
    gdb = shutil.which("gdb")
    if gdb is None:
        return "(no gdb: no native stacks)"
    try:
        got = subprocess.run(
            [gdb, "-p", str(pid), "-batch", "-ex", "thread apply all bt 30"],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired) as e:  # the failure must still be said
        return f"(gdb gave no stacks: {e})"
    # where ptrace is not allowed (a non-root user, ptrace_scope 1) gdb says so on stderr
    return got.stdout[-20000:] + got.stderr[-2000:]


def test_plain_naoqi_client_runs_unchanged(server: tuple[subprocess.Popen[str], str]) -> None:
    client = subprocess.Popen(
        [
            sys.executable,
            str(Path(__file__).with_name("naoqi_client_example.py")),
            f"--qi-url={server[1]}",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        out, err = client.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        # seen once in a whole-suite run (README, "Not done"): the client printed every line,
        # then did not exit. Keep its threads' stacks, which name where it waits, then fail.
        try:
            stacks = native_stacks(client.pid)
        finally:
            client.kill()
        out, err = client.communicate()
        pytest.fail(f"the client did not exit within 60 s\n{out}{err}\n{stacks}")
    assert client.returncode == 0, out + err
    values = {k: float(v) for k, v in re.findall(r"^(\w+ \w+): (\S+)$", out, re.M)}
    assert values["setAngles HeadYaw"] == pytest.approx(0.3, abs=TOL)
    assert values["angleInterpolation HeadYaw"] == pytest.approx(0.0, abs=TOL)
    assert values["angleInterpolation HeadPitch"] == pytest.approx(0.1, abs=TOL)
    assert "said: Hello, I am NAO." in out


@pytest.mark.parametrize(
    ("url", "said"),
    [
        ("tcp://127.0.0.1:99999", "the port must be a number from 1 to 65535, got '99999'"),
        ("tcp://127.0.0.1:9559/x", "the port must be a number from 1 to 65535, got '9559/x'"),
        ("http://127.0.0.1:9559", "the scheme must be tcp://, not http://"),
        ("tcps://127.0.0.1:9503", "tcps:// (NAOqi 2.9+, with an authenticator) is not supported"),
        ("tcp://:9559", "no host name or address"),
    ],
)
def test_a_robot_url_libqi_would_misread_is_refused_before_connecting(url: str, said: str) -> None:
    # libqi reads a port it cannot parse as none and connects to 9559: another robot, or
    # Choregraphe's virtual one, would have been coached
    with pytest.raises(ConfigError) as e:
        NaoqiBackend(url=url)
    assert said in str(e.value) and url in str(e.value)


def test_a_host_or_host_port_url_is_completed_with_naoqis_port() -> None:
    assert NaoqiBackend(url="192.168.1.12").url == "tcp://192.168.1.12:9559"
    assert NaoqiBackend(url=" 192.168.1.12:9600 ").url == "tcp://192.168.1.12:9600"
    assert NaoqiBackend(url="tcp://[::1]").url == "tcp://[::1]:9559"


def test_a_talk_with_a_misread_robot_url_exits_2_and_leaves_no_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s"
    argv = ["run", "short_talk", "--backend", "naoqi", "--robot", "tcp://127.0.0.1:99999"]
    assert main([*argv, "--out", str(out)]) == 2
    assert "error: robot URL tcp://127.0.0.1:99999: the port must be" in capsys.readouterr().err
    assert not out.exists()


def test_connecting_prints_nothing_on_stdout(server: tuple[subprocess.Popen[str], str]) -> None:
    # libqi logs to stdout; a talk's --json summary or timeline must be all that is there
    script = (
        "import sys; from prezence.backends.naoqi import NaoqiBackend\n"
        "with NaoqiBackend(url=sys.argv[1]) as b: pass\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script, server[1]],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == ""
