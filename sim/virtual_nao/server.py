"""Serving the virtual NAO: a standalone qi session with the services registered
(:func:`serve`), a server in another process (:func:`spawn`, :func:`stop_spawned`) and the
``python -m sim.virtual_nao`` command line (:func:`main`).
"""

from __future__ import annotations

import argparse
import logging
import queue
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path
from types import FrameType, TracebackType
from typing import Any

import qi

from sim.virtual_nao.robot import VirtualNao
from sim.virtual_nao.services import (
    SPEECH_LOGGER,
    ALAutonomousLife,
    ALLeds,
    ALMemory,
    ALMotion,
    ALRobotPosture,
    ALTextToSpeech,
)

log = logging.getLogger("sim.virtual_nao")  # the package's logger, as before the split


# -- serving -------------------------------------------------------------------------------------


class VirtualNaoServer:
    """A running virtual NAO: a standalone qi session with the services registered.

    Attributes:
        url: where clients connect (``tcp://127.0.0.1:PORT``; the real port when 0 was asked).
        robot: the simulated robot behind the services.
    """

    def __init__(self, session: Any, robot: VirtualNao, url: str) -> None:
        self.session = session
        self.robot = robot
        self.url = url
        self._closed = False

    def close(self) -> None:
        """Disconnect the clients, stop the clock and the model; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self.session.close()
        self.robot.stop()

    def __enter__(self) -> VirtualNaoServer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def serve(
    host: str = "127.0.0.1",
    port: int = 9559,
    gui: bool = False,
    *,
    speech_log: Path | str | None = None,
    model: str = "pybullet",
    rate_hz: float = 100.0,
) -> VirtualNaoServer:
    """Start a virtual NAO listening on ``tcp://host:port`` (port 0 picks a free one).

    Args:
        host: address to listen on.
        port: TCP port; 0 picks a free one (see the returned server's ``url``).
        gui: show the PyBullet window (``model="pybullet"`` only).
        speech_log: JSONL file that records every phrase said and every motion (start and
            end), appended to; None records nothing. The phrases are logged at INFO on
            :data:`SPEECH_LOGGER` either way.
        model: ``"pybullet"`` (the PyBullet NAO) or ``"kinematic"`` (no physics).
        rate_hz: rate of the real-time clock loop.

    Raises:
        ValueError: an unknown model or a port out of range.
        RuntimeError: the port is taken (libqi's "Address already in use").
    """
    if not 0 <= port <= 65535:
        raise ValueError(f"port must be in 0..65535, got {port}")
    robot = VirtualNao(model=model, gui=gui, speech_log=speech_log, rate_hz=rate_hz)
    robot.start()
    session = qi.Session()
    try:
        try:
            session.listenStandalone(f"tcp://{host}:{port}")
        except RuntimeError as e:
            raise RuntimeError(_listen_error(host, port, str(e))) from e
        motion = ALMotion(robot)
        session.registerService("ALMotion", motion)
        session.registerService("ALTextToSpeech", ALTextToSpeech(robot))
        session.registerService("ALLeds", ALLeds(robot))
        session.registerService("ALRobotPosture", ALRobotPosture(robot, motion))
        session.registerService("ALMemory", ALMemory(robot))
        session.registerService("ALAutonomousLife", ALAutonomousLife(robot))
    except RuntimeError:
        session.close()
        robot.stop()
        raise
    url = next((e for e in session.endpoints() if e.startswith("tcp://")), session.endpoints()[0])
    log.info("virtual NAO listening on %s (model %s)", url, model)
    return VirtualNaoServer(session, robot, url)


def _listen_error(host: str, port: int, error: str) -> str:
    """libqi's two-line "error when listening" (with a boost source path) as one plain line."""
    where = f"cannot listen on tcp://{host}:{port}"
    if "already in use" in error:
        return (
            f"{where}: the port is in use (Address already in use: another virtual NAO, NAOqi "
            "or Choregraphe?); choose another port, or 0 for a free one"
        )
    if "assign requested address" in error:
        return f"{where}: {host} is not an address of this machine"
    lines = [x.strip() for x in error.splitlines() if x.strip()]
    detail = lines[-1] if lines else "unknown error"  # the cause, after libqi's heading
    return f"{where}: {detail.split(' [')[0]}"


def spawn(*args: str, timeout_s: float = 60.0) -> tuple[subprocess.Popen[str], str]:
    """Start ``python -m sim.virtual_nao ARGS`` in another process; return it and its URL.

    Use ``--port 0`` to let the OS pick a free port. Stop it with ``proc.terminate()``.

    Raises:
        RuntimeError: it did not print its ``listening on`` line within ``timeout_s``.
    """
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.virtual_nao", *args],
        cwd=Path(__file__).resolve().parents[2],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    lines: queue.Queue[str] = queue.Queue()
    out = proc.stdout
    assert out is not None  # noqa: S101 - stdout=PIPE

    def pump() -> None:
        for x in out:
            lines.put(x)

    threading.Thread(target=pump, daemon=True).start()
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            line = lines.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            break
        if line.startswith("listening on "):
            return proc, line.split()[-1]
    proc.kill()
    proc.wait()
    raise RuntimeError("the virtual NAO did not start")


def stop_spawned(proc: subprocess.Popen[str], *, kill: bool = False) -> None:
    """Stop a virtual NAO started with :func:`spawn` (SIGTERM, or SIGKILL: a robot lost)."""
    if proc.poll() is None:
        proc.kill() if kill else proc.terminate()
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    if proc.stdout is not None:
        proc.stdout.close()


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m sim.virtual_nao", description="Serve a virtual NAO over the NAOqi protocol."
    )
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=9559, help="0 picks a free port (default 9559)")
    p.add_argument("--gui", action="store_true", help="show the PyBullet window")
    p.add_argument("--model", choices=("pybullet", "kinematic"), default="pybullet")
    p.add_argument("--speech-log", type=Path, help="JSONL record of speech and motions")
    p.add_argument("--rate", type=float, default=100.0, help="clock loop rate in Hz")
    p.add_argument("-v", "--verbose", action="store_true", help="show libqi's and our info logs")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Serve until SIGTERM or Ctrl-C; prints ``listening on URL`` first (flushed).

    The phrases said are logged on stderr (``SPEECH_LOGGER`` at INFO) unless the root logger is
    quieter than WARNING.
    """
    args = build_parser().parse_args(argv)
    # libqi logs to stdout; keep stdout for the "listening on" line unless asked
    qi.logging.setLevel(qi.logging.INFO if args.verbose else qi.logging.ERROR)
    if not logging.getLogger().handlers:
        logging.basicConfig(
            level=logging.INFO if args.verbose else logging.WARNING,
            format="%(levelname)s %(name)s: %(message)s",
            stream=sys.stderr,
        )
    if logging.getLogger().getEffectiveLevel() <= logging.WARNING:
        # the robot has no voice here: show what it says unless logging was made quieter
        logging.getLogger(SPEECH_LOGGER).setLevel(logging.INFO)
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        server = serve(
            args.host,
            args.port,
            args.gui,
            speech_log=args.speech_log,
            model=args.model,
            rate_hz=args.rate,
        )
    except (RuntimeError, OSError, ValueError) as e:  # port taken or out of range; log unwritable
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        print(f"listening on {server.url}", flush=True)
        while not stop.wait(0.5):
            pass
    finally:
        server.close()
        for s, h in previous.items():
            signal.signal(s, h)
    return 0
