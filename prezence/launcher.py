"""``prezence up``: the design report's launcher. Input modules and the processor run in parallel.

Each input module is a separate process that writes its stream files into the session folder;
the coach tails those files (waking on file changes, not polling slowly), decides, and has the
robot perform cues. Modules are supervised: one that exits with an error, or writes nothing for
``hang_after_s``, is reported and restarted with exponential backoff while its metrics go stale
(the processor excludes them meanwhile); the talk goes on. Ctrl-C, or the allocated time plus a
grace period, stops everything cleanly and writes the summary.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shlex
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from prezence.backends.base import Backend
from prezence.clock import MonotonicClock
from prezence.coach import Coach, default_planner
from prezence.config.model import Config
from prezence.config.tomlconf import dumps_config
from prezence.processor import Decision, Processor, make_policy
from prezence.session import SessionDir
from prezence.streams.tail import MultiTailer
from prezence.summary import summarize_session

log = logging.getLogger(__name__)


@dataclass
class ModuleSpec:
    """An input module to run: a name, its command line, and the metrics it writes.

    ``{session}`` and ``{t0}`` in ``argv`` are replaced by the session folder and the talk's
    start (wall-clock epoch seconds) when the module starts.
    """

    name: str
    argv: list[str]
    metrics: tuple[str, ...] = ()
    #: True when the input is a file: a clean exit then means "input finished", not a crash.
    finite: bool = False

    @classmethod
    def parse(cls, text: str) -> ModuleSpec:
        """``NAME=COMMAND LINE`` (shell words): ``pace=python pace.py --out {session}``."""
        name, sep, cmd = text.partition("=")
        if not sep or not name.strip() or not cmd.strip():
            raise ValueError(f"--module wants NAME=COMMAND, got {text!r}")
        return cls(name.strip(), shlex.split(cmd))


@dataclass
class ModuleProcess:
    """One supervised module process."""

    spec: ModuleSpec
    session: Path
    t0_epoch: float
    log_file: IO[str]
    backoff_s: float = 1.0
    max_backoff_s: float = 30.0
    proc: subprocess.Popen[str] | None = None
    restarts: int = 0
    crashes: list[dict[str, Any]] = field(default_factory=list)
    next_start: float = 0.0
    finished: bool = False
    started_at: float = 0.0

    def argv(self) -> list[str]:
        return [
            a.replace("{session}", str(self.session)).replace("{t0}", f"{self.t0_epoch:.6f}")
            for a in self.spec.argv
        ]

    def start(self, now: float) -> None:
        self.proc = subprocess.Popen(
            self.argv(),
            stdout=self.log_file,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
            start_new_session=True,  # Ctrl-C in the terminal reaches the launcher only
        )
        self.started_at = now
        log.info("module %s started (pid %d)", self.spec.name, self.proc.pid)

    def check(self, now: float, *, hung: bool) -> str | None:
        """Restart after a crash or a hang; returns an event line for the live view, or None."""
        if self.finished:
            return None
        if self.proc is None:
            if now >= self.next_start:
                self.start(now)
                return f"module {self.spec.name} restarted (attempt {self.restarts})"
            return None
        rc = self.proc.poll()
        if rc is None and not hung:
            return None
        if rc == 0 and self.spec.finite:
            self.finished = True
            self.proc = None
            return f"module {self.spec.name} finished its input"
        why = f"exited with status {rc}" if rc is not None else "wrote nothing (hung); killed"
        if rc is None:
            self._kill()
        self.crashes.append({"t": round(now, 3), "why": why})
        self.restarts += 1
        delay = min(self.max_backoff_s, self.backoff_s * 2 ** (self.restarts - 1))
        self.next_start = now + delay
        self.proc = None
        log.warning("module %s %s; restarting in %.1f s", self.spec.name, why, delay)
        return f"module {self.spec.name} {why}; restart in {delay:.0f} s (metrics stale meanwhile)"

    def _kill(self) -> None:
        if self.proc is None:
            return
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        self.proc.wait()

    def stop(self, timeout_s: float = 3.0) -> None:
        """SIGINT, then SIGTERM, then SIGKILL."""
        p = self.proc
        if p is None or p.poll() is not None:
            return
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                os.killpg(p.pid, sig)
            except ProcessLookupError:
                return
            try:
                p.wait(timeout=timeout_s)
                return
            except subprocess.TimeoutExpired:
                continue
        self._kill()


@dataclass
class UpResult:
    session: SessionDir
    summary: dict[str, Any]
    events: list[str]


class LiveView:
    """The terminal view: each metric against its range, and every cue with its reason."""

    def __init__(
        self, config: Config, stream: IO[str] | None = None, *, tty: bool | None = None
    ) -> None:
        self.config = config
        self.out = stream or sys.stdout
        self.tty = self.out.isatty() if tty is None else tty
        self._last_status = -1.0

    def event(self, now: float, text: str) -> None:
        self._clear()
        print(f"{_mmss(now)}  {text}", file=self.out, flush=True)

    def decision(self, d: Decision) -> None:
        if d.cue is not None:
            self.event(d.t, f"CUE {d.cue.command:<12} {d.cue.reason}")
        elif self.tty and d.t - self._last_status >= 0.5:
            self._last_status = d.t
            parts = []
            for m in d.metrics:
                r = self.config.rule(m.metric)
                lo = "" if r.low is None else f"{r.low:g}"
                hi = "" if r.high is None else f"{r.high:g}"
                v = "--" if m.value is None else f"{m.value:.4g}"
                flag = "stale" if m.stale else ("OUT" if m.deviation > 0 else "ok")
                parts.append(f"{m.metric} {v} [{lo}..{hi}] {flag}")
            line = f"{_mmss(d.t)} {'busy' if d.busy else 'free'} | " + " | ".join(parts)
            self.out.write("\r\033[K" + line[:200])
            self.out.flush()

    def _clear(self) -> None:
        if self.tty:
            self.out.write("\r\033[K")


def _mmss(t: float) -> str:
    return f"{int(t // 60)}:{t % 60:04.1f}"


def up(
    config: Config,
    *,
    session_dir: Path,
    modules: Sequence[ModuleSpec],
    backend: Backend,
    policy: str = "weighted",
    speed_fraction: float = 0.6,
    grace_s: float = 30.0,
    duration_s: float | None = None,
    hang_after_s: float = 20.0,
    view: LiveView | None = None,
    stop: Callable[[], bool] | None = None,
) -> UpResult:
    """Run a live talk until Ctrl-C, ``duration_s``, or the allocated time plus ``grace_s``.

    Args:
        config: rules and settings (its allocated time ends the talk, plus ``grace_s``).
        session_dir: the session folder (created).
        modules: input modules to start and supervise.
        backend: an unopened robot backend.
        policy: conflict policy name.
        speed_fraction: gesture speed.
        grace_s: time after the allocated time before the talk is stopped.
        duration_s: stop after this long regardless (tests, fixed-length rehearsals).
        hang_after_s: a module whose files do not change for this long is restarted.
        view: the live terminal view (None: log only).
        stop: polled every loop; True ends the talk (tests, embedding).
    """
    session = SessionDir(Path(session_dir)).create()
    session.config.write_text(dumps_config(config))
    streams = {r.metric: session.stream(r.stream) for r in config.rules}
    tailer = MultiTailer(streams)
    clock = MonotonicClock()
    t0_epoch = time.time()
    session.write_meta(
        {"kind": "live", "t0_epoch": t0_epoch, "policy": policy, "backend": backend.name}
    )
    logs = (session.root / "modules.log").open("a", encoding="utf-8")
    procs = [ModuleProcess(m, session.root, t0_epoch, logs) for m in modules]
    processor = Processor(config, policy=make_policy(policy))
    events: list[str] = []
    end_at = duration_s
    if end_at is None and config.time.allocated_s is not None:
        end_at = config.time.allocated_s + grace_s
    dt = config.processor.decision_period_s
    interrupted = False
    backend.open()
    coach = Coach(processor, backend, session, planner=default_planner(speed_fraction))
    last_change = {m.spec.name: 0.0 for m in procs}
    sizes: dict[str, int] = {}
    try:
        for p in procs:
            p.start(0.0)
        next_tick = 0.0
        while True:
            now = clock.now()
            if (end_at is not None and now >= end_at) or (stop is not None and stop()):
                break
            if tailer.wait(max(0.0, min(dt, next_tick - now))):
                pass  # new data: decide now (cue latency), not at the next period
            now = clock.now()
            samples = tailer.poll(now)
            d = coach.tick(now, samples)
            next_tick = now + dt
            if view is not None:
                view.decision(d)
            for p in procs:
                changed = _module_wrote(p, streams, sizes)
                if changed or p.proc is None:
                    last_change[p.spec.name] = now
                hung = (
                    p.proc is not None
                    and hang_after_s > 0
                    and now - max(last_change[p.spec.name], p.started_at) > hang_after_s
                )
                ev = p.check(now, hung=hung)
                if ev:
                    events.append(f"{now:.1f} {ev}")
                    if view is not None:
                        view.event(now, ev)
    except KeyboardInterrupt:
        interrupted = True
        log.info("stopped by Ctrl-C")
    finally:
        for p in procs:
            p.stop()
        now = clock.now()
        try:
            coach.tick(now, tailer.poll(now))
            coach.drain(now, step_s=0.05, limit_s=10.0)
        finally:
            coach.close()
            tailer.close()
            backend.close()
            logs.close()
    talk_s = clock.now()
    summary = summarize_session(
        session,
        config,
        talk_s=talk_s,
        backend_stats=backend.stats(),
        extra={
            "kind": "live",
            "policy": policy,
            "backend": backend.name,
            "decisions": coach.decisions,
            "interrupted": interrupted,
            "modules": {p.spec.name: {"restarts": p.restarts, "crashes": p.crashes} for p in procs},
        },
    )
    return UpResult(session, summary, events)


def _module_wrote(p: ModuleProcess, streams: dict[str, Path], sizes: dict[str, int]) -> bool:
    """Whether any stream of this module grew since the last look (hang detection)."""
    metrics = p.spec.metrics or tuple(streams)
    grew = False
    for m in metrics:
        path = streams.get(m)
        if path is None:
            continue
        try:
            size = path.stat().st_size
        except FileNotFoundError:
            continue
        if size != sizes.get(m):
            sizes[m] = size
            grew = True
    return grew
