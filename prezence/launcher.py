"""``prezence up``: the design report's launcher. Input modules and the processor run in parallel.

Each input module is a separate process that writes its stream files into the session folder;
the coach tails those files (waking on file changes, not polling slowly), decides, and has the
robot perform cues. Modules are supervised: one that exits with an error is reported and
restarted with exponential backoff while its metrics go stale (the processor excludes them
meanwhile); the talk goes on. Ctrl-C, or the allocated time plus a grace period, stops
everything cleanly, writes the summary and (with ``report=True``) the report, and the robot
says the post-talk summary.

Hang detection is per module and only for a module whose :class:`ModuleSpec` sets
``hang_after_s``: it is killed and restarted when, while its process runs, it shows no sign of
life for that long. Signs of life, each looked at by that module's own table of file states:

- one of *its* stream files (``streams/<metric>.txt`` of its ``metrics``; every ``*.txt`` in
  ``streams/`` when it declares none) grew or was touched (size or modification time changed);
- its log, ``SESSION/<name>.log`` (its stdout and stderr), grew;
- its heartbeat file, ``SESSION/streams/.<name>.alive``, was touched. Its path is in the
  module's environment as :data:`HEARTBEAT_ENV`; a module that can go quiet for a long time
  touches it, say, every second to show it is alive.

The vision module writes every second and is restarted after :data:`DEFAULT_HANG_S` without
a sign of life; so is the speech module when it writes its voice-activity stream in silence too
(:data:`SPEECH_HEARTBEAT_METRIC`). A speech module that writes nothing while the presenter
pauses has no hang limit: a crash still restarts it, a pause does not.
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
from prezence.samples import MAX_AHEAD_S
from prezence.session import SessionDir
from prezence.streams.tail import MultiTailer
from prezence.summary import summarize_session

log = logging.getLogger(__name__)

#: The environment variable that holds a module's heartbeat file (see the module docstring).
HEARTBEAT_ENV = "PREZENCE_HEARTBEAT"
#: Hang limit of the vision module and of ``--module`` modules, seconds.
DEFAULT_HANG_S = 20.0
#: Modules are looked at (exit status, signs of life) at most this often, seconds.
SUPERVISE_PERIOD_S = 0.2
#: The exit status with which a module says it cannot use its input (a missing file, no
#: microphone): restarting cannot help, so the talk stops with the module's own message.
BAD_INPUT_STATUS = 2
#: A module that ran at least this long before it exited was healthy: its restart backoff
#: starts again from the first delay.
HEALTHY_RUN_S = 30.0
#: Set to ``1`` in every module's environment: open stream files for appending, never
#: replace them (a restarted module continues the talk's record).
APPEND_ENV = "PREZENCE_APPEND"
#: ``prctl`` option that sends the child a signal when its parent dies (Linux).
PR_SET_PDEATHSIG = 1

#: A stream the speech module writes every hop, in silence too (its heartbeat). A speech
#: module whose ``METRICS`` has it can be watched for hangs; one that writes nothing while the
#: presenter pauses cannot.
SPEECH_HEARTBEAT_METRIC = "speech_activity"
#: The metrics the vision module writes: ``prezence.modules.vision.METRICS``, written out here
#: because that module needs OpenCV to import (a test checks they agree).
VISION_METRICS: tuple[str, ...] = (
    "cv_headGaze",
    "cv_headYaw",
    "cv_facingAudience",
    "cv_gestures",
)


@dataclass
class ModuleSpec:
    """An input module to run: a name, its command line, and the metrics it writes.

    ``{session}`` and ``{t0}`` in ``argv`` are replaced by the session folder and the talk's
    start (wall-clock epoch seconds) when the module starts.
    """

    name: str
    argv: list[str]
    #: The metrics it writes (``streams/<metric>.txt``); empty: unknown, any stream file counts
    #: as its sign of life.
    metrics: tuple[str, ...] = ()
    #: True when the input is a file: a clean exit then means "input finished", not a crash.
    finite: bool = False
    #: Kill and restart it after this many seconds without a sign of life while it runs;
    #: None: never (only an exit restarts it).
    hang_after_s: float | None = None

    def __post_init__(self) -> None:
        if not self.name or "/" in self.name or self.name.startswith("."):
            raise ValueError(f"module name {self.name!r}: want a plain name such as 'speech'")
        if self.hang_after_s is not None and not self.hang_after_s > 0:
            raise ValueError(f"module {self.name}: hang_after_s must be > 0 or None")

    @classmethod
    def parse(cls, text: str, *, hang_after_s: float | None = DEFAULT_HANG_S) -> ModuleSpec:
        """``NAME[:METRIC,...]=COMMAND LINE`` (shell words), as ``--module`` takes it.

        Naming the metrics makes hang detection look at those stream files only.

        Example:
            >>> s = ModuleSpec.parse("pace:speech_speed=python pace.py --out {session}")
            >>> s.name, s.metrics, s.argv[-2:], s.hang_after_s
            ('pace', ('speech_speed',), ['--out', '{session}'], 20.0)
        """
        head, sep, cmd = text.partition("=")
        name, _, metrics = head.partition(":")
        if not sep or not name.strip() or not cmd.strip():
            raise ValueError(
                f"--module wants NAME=COMMAND or NAME:METRIC,...=COMMAND, got {text!r}"
            )
        try:
            argv = shlex.split(cmd)
        except ValueError as e:
            raise ValueError(f"--module {name.strip()}: {e} in {cmd!r}") from None
        ms = tuple(m.strip() for m in metrics.split(",") if m.strip())
        return cls(name.strip(), argv, metrics=ms, hang_after_s=hang_after_s)


def speech_module(audio: str, extra: Sequence[str] = ()) -> ModuleSpec:
    """The speech module on ``audio`` (``mic`` or a file played as if live), ``extra`` appended.

    Its metrics are the module's own ``METRICS``. It is watched for hangs
    (:data:`DEFAULT_HANG_S`) only when it writes :data:`SPEECH_HEARTBEAT_METRIC` in silence
    too; otherwise a pause would look like a hang, and only an exit restarts it.
    """
    from prezence.modules.speech import METRICS

    file_in = audio != "mic"
    argv = [sys.executable, "-m", "prezence.modules.speech", "--audio", audio]
    argv += ["--out", "{session}", "--t0", "{t0}"] + (["--realtime"] if file_in else [])
    return ModuleSpec(
        "speech",
        argv + list(extra),
        metrics=tuple(METRICS),
        finite=file_in,
        hang_after_s=DEFAULT_HANG_S if SPEECH_HEARTBEAT_METRIC in METRICS else None,
    )


def vision_module(video: str, extra: Sequence[str] = ()) -> ModuleSpec:
    """The vision module on ``video`` (``cam``, ``cam:N`` or a file played as if live)."""
    file_in = not video.startswith("cam")
    argv = [sys.executable, "-m", "prezence.modules.vision", "--video", video]
    argv += ["--out", "{session}", "--t0", "{t0}"] + (["--realtime"] if file_in else [])
    return ModuleSpec(
        "vision",
        argv + list(extra),
        metrics=VISION_METRICS,
        finite=file_in,
        hang_after_s=DEFAULT_HANG_S,
    )


@dataclass
class ModuleProcess:
    """One supervised module process, with its own log and its own view of its files."""

    spec: ModuleSpec
    session: Path
    t0_epoch: float
    log_file: IO[str]
    backoff_s: float = 1.0
    max_backoff_s: float = 30.0
    #: A run at least this long before a crash was healthy: the backoff starts again.
    healthy_after_s: float = HEALTHY_RUN_S
    proc: subprocess.Popen[str] | None = None
    restarts: int = 0
    crashes: list[dict[str, Any]] = field(default_factory=list)
    #: Crashes in a row since its last healthy run (the backoff's exponent).
    streak: int = 0
    #: Set when it exited with :data:`BAD_INPUT_STATUS`: its own message; it is not restarted.
    fatal: str | None = None
    next_start: float = 0.0
    finished: bool = False
    started_at: float = 0.0
    #: When it last showed a sign of life (talk seconds).
    last_life: float = 0.0
    #: (size, mtime_ns) of each file it was last seen with: this module's own table.
    seen: dict[Path, tuple[int, int]] = field(default_factory=dict)

    @property
    def heartbeat(self) -> Path:
        """``SESSION/streams/.<name>.alive``: touched by a module to show it is alive."""
        return self.session / "streams" / f".{self.spec.name}.alive"

    @property
    def log_path(self) -> Path:
        return Path(self.log_file.name)

    def argv(self) -> list[str]:
        return [
            a.replace("{session}", str(self.session)).replace("{t0}", f"{self.t0_epoch:.6f}")
            for a in self.spec.argv
        ]

    def start(self, now: float) -> None:
        self.heartbeat.parent.mkdir(parents=True, exist_ok=True)
        self.proc = subprocess.Popen(
            self.argv(),
            stdout=self.log_file,
            stderr=subprocess.STDOUT,
            stdin=subprocess.DEVNULL,
            text=True,
            env={**os.environ, HEARTBEAT_ENV: str(self.heartbeat), APPEND_ENV: "1"},
            start_new_session=True,  # Ctrl-C in the terminal reaches the launcher only
            preexec_fn=die_with_parent_hook(),  # and a killed coach leaves no module behind
        )
        self.started_at = now
        self.last_life = now
        log.info("module %s started (pid %d)", self.spec.name, self.proc.pid)

    def watched(self) -> list[Path]:
        """The files whose change shows this module is alive (see the module docstring)."""
        streams = self.session / "streams"
        if self.spec.metrics:
            files = [streams / f"{m}.txt" for m in self.spec.metrics]
        else:
            # stream files only: not the heartbeats of others, nor the coach's .stamps sidecars
            files = sorted(f for f in streams.glob("*.txt") if not f.name.startswith("."))
        return [*files, self.heartbeat, self.log_path]

    def alive_since_last_look(self) -> bool:
        """Whether any watched file changed since this module's last look (updates its table)."""
        changed = False
        for path in self.watched():
            try:
                st = path.stat()
            except FileNotFoundError:
                continue
            state = (st.st_size, st.st_mtime_ns)
            if self.seen.get(path) != state:
                self.seen[path] = state
                changed = True
        return changed

    def hung(self, now: float) -> bool:
        """Look at its files; True when it runs, has a hang limit and showed no life for it."""
        if self.alive_since_last_look():
            self.last_life = now
        limit = self.spec.hang_after_s
        if self.proc is None or limit is None:
            return False
        return now - max(self.last_life, self.started_at) > limit

    def check(self, now: float) -> str | None:
        """Restart after a crash or a hang; returns an event line for the live view, or None."""
        if self.finished:
            return None
        if self.proc is None:
            if now >= self.next_start:
                self.start(now)
                return f"module {self.spec.name} restarted (attempt {self.restarts})"
            return None
        hung = self.hung(now)
        rc = self.proc.poll()
        if rc is None and not hung:
            return None
        if rc == 0 and self.spec.finite:
            self.finished = True
            self.proc = None
            return f"module {self.spec.name} finished its input"
        if rc == BAD_INPUT_STATUS:
            self.fatal = self.last_error() or f"exited with status {rc} (bad input)"
            self.finished = True
            self.proc = None
            self.crashes.append({"t": round(now, 3), "why": self.fatal})
            log.error("module %s cannot use its input: %s", self.spec.name, self.fatal)
            return f"module {self.spec.name} cannot use its input: {self.fatal}; the talk stops"
        why = (
            f"exited with status {rc}"
            if rc is not None
            else f"showed no sign of life for {self.spec.hang_after_s:g} s (hung); killed"
        )
        if rc is None:
            self._kill()
        self.crashes.append({"t": round(now, 3), "why": why})
        self.restarts += 1
        if now - self.started_at >= self.healthy_after_s:
            self.streak = 0  # it had been running well: not a crash loop
        self.streak += 1
        delay = min(self.max_backoff_s, self.backoff_s * 2 ** (self.streak - 1))
        self.next_start = now + delay
        self.proc = None
        log.warning("module %s %s; restarting in %.1f s", self.spec.name, why, delay)
        return f"module {self.spec.name} {why}; restart in {delay:.0f} s (metrics stale meanwhile)"

    def last_error(self) -> str | None:
        """The module's own last ``error: …`` line in its log (else its last line), or None."""
        try:
            self.log_file.flush()
            with open(self.log_path, "rb") as f:
                f.seek(max(0, f.seek(0, os.SEEK_END) - 8192))
                lines = f.read().decode("utf-8", errors="replace").splitlines()
        except OSError:
            return None
        lines = [ln.strip() for ln in lines if ln.strip()]
        for ln in reversed(lines):
            if ln.startswith("error:"):
                return ln[len("error:") :].strip()
        return lines[-1] if lines else None

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


def die_with_parent_hook() -> Callable[[], None] | None:
    """A ``preexec_fn`` that has the kernel SIGKILL the child when the coach dies (Linux's
    ``prctl(PR_SET_PDEATHSIG)``), so a killed coach leaves no module holding the mic or the
    camera; None where that is not available (the modules then outlive a SIGKILLed coach)."""
    if not sys.platform.startswith("linux"):
        return None
    try:
        import ctypes

        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None
    parent = os.getpid()

    def hook() -> None:
        prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        if os.getppid() != parent:  # the coach died before the prctl: do not outlive it
            os._exit(1)

    return hook


@dataclass
class UpResult:
    """What a live talk leaves: its folder, its summary, the supervision events, the report."""

    session: SessionDir
    summary: dict[str, Any]
    events: list[str]
    #: ``report/report.html``, when the report was written.
    report: Path | None = None
    #: Why the talk stopped early: a module's own message about its input (None: it did not).
    error: str | None = None


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
    seed: int = 0,
    speed_fraction: float = 0.6,
    grace_s: float = 30.0,
    duration_s: float | None = None,
    view: LiveView | None = None,
    stop: Callable[[], bool] | None = None,
    report: bool = False,
) -> UpResult:
    """Run a live talk until Ctrl-C, ``duration_s``, or the allocated time plus ``grace_s``.

    After the talk the cue in progress finishes; with ``report`` the robot then says the
    post-talk summary (time used, the two things to work on first) with its summary gesture,
    and ``SESSION/report/`` is written. The robot's last moves are paced to the wall clock,
    except on the ``fake`` backend, which only keeps time and has nothing to watch.

    Args:
        config: rules and settings (its allocated time ends the talk, plus ``grace_s``).
        session_dir: the session folder (created).
        modules: input modules to start and supervise (names must differ: each has its own
            log, ``SESSION/<name>.log``, and heartbeat file).
        backend: an unopened robot backend.
        policy: conflict policy name.
        seed: for policies that use chance.
        speed_fraction: gesture speed.
        grace_s: time after the allocated time before the talk is stopped.
        duration_s: stop after this long regardless (tests, fixed-length rehearsals).
        view: the live terminal view (None: log only).
        stop: polled every loop; True ends the talk (tests, embedding).
        report: say the post-talk summary and write the report.

    Raises:
        ValueError: two modules have the same name.
    """
    names = [m.name for m in modules]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"two modules are called {', '.join(dup)}: give each its own name")
    target = SessionDir(Path(session_dir))
    if target.holds_recording():  # refused before the robot moves
        target.create()  # raises: a recording is never overwritten
    backend.open()  # an unreachable robot fails here, before a session folder is written
    try:
        session = target.create()
    except BaseException:
        backend.close()
        raise
    session.config.write_text(dumps_config(config))
    streams = {r.metric: session.stream(r.stream) for r in config.rules}
    tailer = MultiTailer(streams, max_ahead_s=MAX_AHEAD_S, record_stamps=True)
    clock = MonotonicClock()
    t0_epoch = time.time()
    meta: dict[str, Any] = {
        "kind": "live",
        "t0_epoch": t0_epoch,
        "policy": policy,
        "backend": backend.name,
    }
    session.write_meta(meta)
    logs = [(session.root / f"{m.name}.log").open("a", encoding="utf-8") for m in modules]
    procs = [
        ModuleProcess(m, session.root, t0_epoch, f) for m, f in zip(modules, logs, strict=True)
    ]
    processor = Processor(config, policy=make_policy(policy, seed=seed))
    events: list[str] = []
    end_at = duration_s
    if end_at is None and config.time.allocated_s is not None:
        end_at = config.time.allocated_s + grace_s
    dt = config.processor.decision_period_s
    interrupted = False

    def pace(t: float) -> None:
        time.sleep(max(0.0, t - clock.now()))

    paced = None if backend.name == "fake" else pace
    coach = Coach(processor, backend, session, planner=default_planner(speed_fraction))
    talk_s = 0.0
    post: dict[str, Any] | None = None
    ended = False  # the talk ended as planned or by Ctrl-C, not by an error
    error: str | None = None  # a module cannot use its input
    try:
        for p in procs:
            p.start(0.0)
        next_tick = 0.0
        next_look = 0.0
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
            if now < next_look:
                continue
            next_look = now + SUPERVISE_PERIOD_S
            for p in procs:
                ev = p.check(now)
                if ev:
                    events.append(f"{now:.1f} {ev}")
                    if view is not None:
                        view.event(now, ev)
            fatal = next((p for p in procs if p.fatal), None)
            if fatal is not None:
                error = f"module {fatal.spec.name}: {fatal.fatal}"
                break
            if procs and all(p.spec.finite and p.finished for p in procs):
                log.info("every input has ended: the talk ends")
                break
        ended = error is None
    except KeyboardInterrupt:
        interrupted = ended = True
        log.info("stopped by Ctrl-C")
    finally:
        for p in procs:
            p.stop()
        talk_s = clock.now()
        try:
            coach.tick(talk_s, tailer.poll(talk_s))
            end = coach.drain(talk_s, step_s=0.05, limit_s=10.0, pace=paced)
            session.write_meta({**meta, "talk_s": round(talk_s, 3)})
            if report and ended:
                post = _post_talk(coach, session, config, end, pace=paced)
        finally:
            coach.close()
            tailer.close()
            backend.close()
            for f in logs:
                f.close()
    summary = summarize_session(
        session,
        config,
        talk_s=talk_s,
        backend_stats=backend.stats(),
        live=tailer,
        processor=processor,
        extra={
            "kind": "live",
            "policy": policy,
            "backend": backend.name,
            "decisions": coach.decisions,
            "interrupted": interrupted,
            **({"error": error} if error is not None else {}),
            "modules": {p.spec.name: {"restarts": p.restarts, "crashes": p.crashes} for p in procs},
            **({"post_talk": post} if post is not None else {}),
        },
    )
    page = None
    if report and error is None:
        from prezence.report.build import write_report

        page = write_report(session.root, config=config)
    return UpResult(session, summary, events, page, error)


def _post_talk(
    coach: Coach,
    session: SessionDir,
    config: Config,
    now: float,
    *,
    pace: Callable[[float], None] | None,
) -> dict[str, Any] | None:
    """The robot says the post-talk summary (as a headless talk's robot does); its record.

    A second Ctrl-C skips it (None); the report is still written.
    """
    from prezence.report.build import build_report
    from prezence.report.speech import summary_phrase

    phrase = summary_phrase(build_report(session.root, config=config))
    try:
        return coach.post_talk(phrase, now, step_s=0.05, pace=pace)
    except KeyboardInterrupt:
        log.info("post-talk summary skipped (Ctrl-C)")
        return None
