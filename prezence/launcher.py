"""``prezence up``: the design report's launcher. Input modules and the processor run in parallel.

Each input module is a separate process that writes its stream files into the session folder;
the coach tails those files (waking on file changes, not polling slowly), decides, and has the
robot perform cues. Modules are supervised: one that exits with an error is reported and
restarted with exponential backoff while its metrics go stale (the processor excludes them
meanwhile); the talk goes on. One that exits with status 0 has finished: it is not restarted
(a file played to its end, or a module of one's own that stopped by itself, said in the log
and the printed notes), and the talk ends when every module has ended. One that exits with an
error within :data:`QUICK_EXIT_S` of starting :data:`MAX_QUICK_EXITS` times in a row is given
up (it fails the same way each time), with its last error; the talk stops when no module is
left. Ctrl-C, or the allocated time plus a grace
period, stops everything cleanly, writes the summary and (with ``report=True``) the report, and
the robot says the post-talk summary.

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
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from prezence.backends.base import Backend
from prezence.config.model import Config
from prezence.errors import PrezenceError
from prezence.metrics import DEFAULT_HANG_S, INPUT_MODULES
from prezence.modules.common import CUT_SHORT_STATUS
from prezence.samples import MAX_AHEAD_S, Sample
from prezence.session import SessionDir
from prezence.streams.tail import MultiTailer, newest_stamp
from prezence.talk import RunOptions, SourceBase, View, WallClock, run_talk

log = logging.getLogger(__name__)

#: The environment variable that holds a module's heartbeat file (see the module docstring).
HEARTBEAT_ENV = "PREZENCE_HEARTBEAT"
#: Modules are looked at (exit status, signs of life) at most this often, seconds.
SUPERVISE_PERIOD_S = 0.2
#: How often (talk seconds) an ``up`` of recordings looks at the newest stamp of every stream
#: file, the recordings' clock (:meth:`LiveSource.time_used`).
CLOCK_LOOK_S = 0.5
#: The exit status with which a module says it cannot use its input (a missing file, no
#: microphone): restarting cannot help, so the talk stops with the module's own message.
BAD_INPUT_STATUS = 2
#: A module that ran at least this long before it exited was healthy: its restart backoff
#: starts again from the first delay.
HEALTHY_RUN_S = 30.0
#: A module that exits this soon after it started did not get going (an import error, a bad
#: option): seconds.
QUICK_EXIT_S = 2.0
#: After this many quick exits in a row a module is not restarted again: it fails the same
#: way each time (a missing library, say), and restarting it for the whole talk cannot help.
MAX_QUICK_EXITS = 5
#: Set to ``1`` in every module's environment: open stream files for appending, never
#: replace them (a restarted module continues the talk's record).
APPEND_ENV = "PREZENCE_APPEND"
#: ``prctl`` option that sends the child a signal when its parent dies (Linux).
PR_SET_PDEATHSIG = 1

#: A stream the speech module writes every hop, in silence too (its heartbeat): its record's
#: ``heartbeat_metric``. A speech module whose ``METRICS`` has it can be watched for hangs; one
#: that writes nothing while the presenter pauses cannot.
SPEECH_HEARTBEAT_METRIC = INPUT_MODULES["speech"].heartbeat_metric
#: The metrics the vision module writes, from the metric records (a test checks they are
#: ``prezence.modules.vision.METRICS``, which needs OpenCV to import).
VISION_METRICS: tuple[str, ...] = INPUT_MODULES["vision"].metrics


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
    #: True when the input is a file (the built-in modules on ``--audio FILE``, ``--video
    #: FILE``). Any module's clean exit (status 0) means it has finished, not crashed; a
    #: module not known to read a file that exits 0 is said to have ended (its metrics are
    #: not measured from then), and only a file's end can be cut short (status 3).
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

    def command_problem(self) -> str | None:
        """Why its command cannot be started (not on ``PATH``, no such file, not
        executable), or None when it can be.

        Example:
            >>> print(ModuleSpec("x", ["no_cmd_zz"]).command_problem())
            module x: command 'no_cmd_zz' not found on PATH; check its --module command line
            >>> ModuleSpec("py", [sys.executable, "talk.py"]).command_problem() is None
            True
        """
        cmd = self.argv[0] if self.argv else ""
        if not cmd or "{session}" in cmd or "{t0}" in cmd:
            return None  # made when it starts: looked at then
        fix = "check its --module command line"
        if os.sep not in cmd and (os.altsep is None or os.altsep not in cmd):
            if shutil.which(cmd) is None:
                return f"module {self.name}: command {cmd!r} not found on PATH; {fix}"
            return None
        path = Path(cmd)
        if not path.is_file():
            return f"module {self.name}: command {cmd!r}: no such file; {fix}"
        if not os.access(path, os.X_OK):
            return f"module {self.name}: command {cmd!r} is not executable; {fix}"
        return None


def _module(name: str, source: str, extra: Sequence[str], metrics: tuple[str, ...]) -> ModuleSpec:
    rec = INPUT_MODULES[name]
    hang = rec.hang_after_s
    if rec.heartbeat_metric is not None and rec.heartbeat_metric not in metrics:
        hang = None  # it may write nothing while the presenter pauses: no hang limit
    return ModuleSpec(
        name,
        rec.argv(source) + list(extra),
        metrics=metrics,
        finite=not rec.is_live(source),
        hang_after_s=hang,
    )


def speech_module(audio: str, extra: Sequence[str] = ()) -> ModuleSpec:
    """The speech module on ``audio`` (``mic`` or a file played as if live), ``extra`` appended.

    Its metrics are the module's own ``METRICS``. It is watched for hangs
    (:data:`DEFAULT_HANG_S`) only when it writes :data:`SPEECH_HEARTBEAT_METRIC` in silence
    too; otherwise a pause would look like a hang, and only an exit restarts it.
    """
    from prezence.modules.speech import METRICS

    return _module("speech", audio, extra, tuple(METRICS))


def vision_module(video: str, extra: Sequence[str] = ()) -> ModuleSpec:
    """The vision module on ``video`` (``cam``, ``cam:N`` or a file played as if live)."""
    return _module("vision", video, extra, VISION_METRICS)


def modules_on(
    option: str, source: str, extra: Mapping[str, Sequence[str]] | None = None
) -> list[ModuleSpec]:
    """Every input module whose record reads ``option`` (``--audio``, ``--video``), on
    ``source``: the speech module for ``--audio``, and any module added to
    :data:`prezence.metrics.INPUT_MODULES` that reads the same input.

    Args:
        extra: per module name, words appended to its command line.
    """
    extra = extra or {}
    out = []
    for name, rec in INPUT_MODULES.items():
        if rec.input_option != option:
            continue
        words = extra.get(name, ())
        out.append(
            speech_module(source, words)
            if name == "speech"
            else _module(name, source, words, rec.metrics)
        )
    return out


def heartbeat_file(session: Path, name: str) -> Path:
    """``SESSION/streams/.<name>.alive``: the file module ``name`` touches to show it is alive
    (its path is in the module's environment as :data:`HEARTBEAT_ENV`)."""
    return session / "streams" / f".{name}.alive"


def stream_files(session: Path, metrics: Sequence[str]) -> list[Path]:
    """A module's stream files: ``streams/<metric>.txt`` of its ``metrics``; when it names
    none, every stream file there now (not the heartbeats, nor the coach's ``.stamps``)."""
    streams = session / "streams"
    if metrics:
        return [streams / f"{m}.txt" for m in metrics]
    return sorted(f for f in streams.glob("*.txt") if not f.name.startswith("."))


def files_changed(paths: Sequence[Path], seen: dict[Path, tuple[int, int]]) -> bool:
    """Whether any of ``paths`` changed (size or modification time) since ``seen``, a
    module's own table of file states, which is updated; a missing file is no change."""
    changed = False
    for path in paths:
        try:
            st = path.stat()
        except FileNotFoundError:
            continue
        state = (st.st_size, st.st_mtime_ns)
        if seen.get(path) != state:
            seen[path] = state
            changed = True
    return changed


def hang_why(limit_s: float) -> str:
    """What a module killed as hung is recorded with (``crashes[].why``; the report reads
    "(hung)" in it as a hang)."""
    return f"showed no sign of life for {limit_s:g} s (hung); killed"


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
    #: Exits within :data:`QUICK_EXIT_S` of its start, in a row.
    quick_exits: int = 0
    #: Set when it was given up after :data:`MAX_QUICK_EXITS` quick exits: why, with its
    #: last error; it is not restarted, and the talk goes on with the other modules.
    gave_up: str | None = None
    next_start: float = 0.0
    finished: bool = False
    #: Set when it exited with :data:`CUT_SHORT_STATUS`: its input file broke off before its
    #: end (its own warning); everything it read was measured, and it has finished.
    cut_short: str | None = None
    #: Set (talk seconds) when a module not known to read a file exited with status 0: it has
    #: ended by itself, and is neither a crash nor restarted (session 22: a ``--module``
    #: playing a file was restarted five times at its end, and the talk ran to the time limit).
    ended_t: float | None = None
    started_at: float = 0.0
    #: When it last showed a sign of life (talk seconds).
    last_life: float = 0.0
    #: (size, mtime_ns) of each file it was last seen with: this module's own table.
    seen: dict[Path, tuple[int, int]] = field(default_factory=dict)

    @property
    def heartbeat(self) -> Path:
        """``SESSION/streams/.<name>.alive``: touched by a module to show it is alive."""
        return heartbeat_file(self.session, self.spec.name)

    @property
    def log_path(self) -> Path:
        return Path(self.log_file.name)

    def argv(self) -> list[str]:
        return [
            a.replace("{session}", str(self.session)).replace("{t0}", f"{self.t0_epoch:.6f}")
            for a in self.spec.argv
        ]

    def start(self, now: float) -> None:
        """Start its process; a command that cannot be started (gone since :func:`up` looked,
        or made from ``{session}``) is fatal, as a bad input is: restarting cannot help."""
        self.heartbeat.parent.mkdir(parents=True, exist_ok=True)
        argv = self.argv()
        try:
            self.proc = subprocess.Popen(
                argv,
                stdout=self.log_file,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                text=True,
                env={**os.environ, HEARTBEAT_ENV: str(self.heartbeat), APPEND_ENV: "1"},
                start_new_session=True,  # Ctrl-C in the terminal reaches the launcher only
                preexec_fn=die_with_parent_hook(),  # and a killed coach leaves no module behind
            )
        except OSError as e:
            self.fatal = f"cannot start command {argv[0]!r}: {e.strerror or e}"
            self.finished = True
            self.proc = None
            self.crashes.append({"t": round(now, 3), "why": self.fatal})
            log.error("module %s %s", self.spec.name, self.fatal)
            return
        self.started_at = now
        self.last_life = now
        log.info("module %s started (pid %d)", self.spec.name, self.proc.pid)

    def watched(self) -> list[Path]:
        """The files whose change shows this module is alive (see the module docstring)."""
        return [*stream_files(self.session, self.spec.metrics), self.heartbeat, self.log_path]

    def alive_since_last_look(self) -> bool:
        """Whether any watched file changed since this module's last look (updates its table)."""
        return files_changed(self.watched(), self.seen)

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
        if rc == 0:
            self.finished = True
            self.proc = None
            if self.spec.finite:
                return f"module {self.spec.name} finished its input"
            self.ended_t = round(now, 3)
            log.warning(
                "module %s ended (exit 0) at %s; its metrics are not measured from then",
                self.spec.name,
                clock_text(now),
            )
            return f"module {self.spec.name} ended (exit 0); its metrics are not measured from then"
        if rc == CUT_SHORT_STATUS and self.spec.finite:
            self.cut_short = (
                self.last_error(prefix="warning:") or f"exited with status {rc} (input cut short)"
            )
            self.finished = True
            self.proc = None
            log.warning("module %s: its input is cut short: %s", self.spec.name, self.cut_short)
            return (
                f"module {self.spec.name} finished its input, which is cut short: {self.cut_short}"
            )
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
            else hang_why(self.spec.hang_after_s or 0.0)
        )
        crash: dict[str, Any] = {"t": round(now, 3), "why": why}
        if rc is None:
            self._kill()
            # it stopped measuring when it went silent, not when the limit ran out
            crash["silent_since"] = round(max(self.last_life, self.started_at), 3)
        self.crashes.append(crash)
        quick = rc is not None and now - self.started_at < QUICK_EXIT_S
        self.quick_exits = self.quick_exits + 1 if quick else 0
        if self.quick_exits >= MAX_QUICK_EXITS:
            last = self.last_error()
            self.gave_up = (
                f"exited within {QUICK_EXIT_S:g} s of starting {self.quick_exits} times in a "
                f"row; not restarted again" + (f" (its last error: {last})" if last else "")
            )
            self.finished = True
            self.proc = None
            log.error("module %s %s", self.spec.name, self.gave_up)
            return f"module {self.spec.name} {self.gave_up}"
        self.restarts += 1
        if now - self.started_at >= self.healthy_after_s:
            self.streak = 0  # it had been running well: not a crash loop
        self.streak += 1
        delay = min(self.max_backoff_s, self.backoff_s * 2 ** (self.streak - 1))
        self.next_start = now + delay
        self.proc = None
        log.warning("module %s %s; restarting in %.1f s", self.spec.name, why, delay)
        return f"module {self.spec.name} {why}; restart in {delay:.0f} s (metrics stale meanwhile)"

    def last_error(self, prefix: str = "error:") -> str | None:
        """The module's own last ``error: …`` line (``prefix``) in its log, without the prefix
        (else its last line), or None."""
        try:
            self.log_file.flush()
            with open(self.log_path, "rb") as f:
                f.seek(max(0, f.seek(0, os.SEEK_END) - 8192))
                lines = f.read().decode("utf-8", errors="replace").splitlines()
        except OSError:
            return None
        lines = [ln.strip() for ln in lines if ln.strip()]
        for ln in reversed(lines):
            if ln.startswith(prefix):
                return ln[len(prefix) :].strip()
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


def clock_text(t: float) -> str:
    """Talk seconds as ``m:ss.s``.

    Example:
        >>> clock_text(90.0), clock_text(5.25)
        ('1:30.0', '0:05.2')
    """
    return f"{int(t // 60)}:{t % 60:04.1f}"


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


class LiveSource(SourceBase):
    """Live input modules as a sample source: started with the talk, supervised while it
    runs (see the module docstring), their stream files tailed as they grow.

    Args:
        modules: the modules to run (names must differ).
        end_at: talk seconds after which the talk ends (None: until stopped).
        grace_s: ``end_at`` is the allocated time plus this grace (None: a fixed length): a
            talk still going on there was cut by the time limit, and the summary says so.
    """

    kind = "live"

    def __init__(
        self,
        modules: Sequence[ModuleSpec],
        *,
        end_at: float | None,
        grace_s: float | None = None,
    ) -> None:
        names = [m.name for m in modules]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"two modules are called {', '.join(dup)}: give each its own name")
        # Two writers of one stream file would interleave their lines (each goes back in time
        # against the other's, so half are dropped as malformed) and the coach would judge one
        # metric from two sources (session 22's module-author walkthrough).
        writers: dict[str, list[str]] = {}
        for m in modules:
            for metric in dict.fromkeys(m.metrics):  # a metric a module lists twice is one
                writers.setdefault(metric, []).append(m.name)
        shared = {k: v for k, v in writers.items() if len(v) > 1}
        if shared:
            said = "; ".join(f"{k} by {' and '.join(v)}" for k, v in sorted(shared.items()))
            raise ValueError(
                f"two modules would write one stream ({said}): start one of them, or give the "
                "module of your own another metric name"
            )
        self.modules = list(modules)
        self.end_at = end_at
        self.grace_s = grace_s
        #: the time limit stopped the talk while an input still went on
        self.stopped_at_limit = False
        self.t0_epoch = 0.0
        self.procs: list[ModuleProcess] = []
        self._logs: list[IO[str]] = []
        self._tailer: MultiTailer | None = None
        self._streams: Path | None = None
        self._next_look = 0.0
        self._stopped = False
        #: every input is a file played as if live (``session.json``'s ``recorded_inputs``)
        self._recorded = bool(self.modules) and all(m.finite for m in self.modules)
        #: the newest stamp :meth:`poll` gave, and the newest in any stream file at the last
        #: look (the recordings' clock, when every input is one, is the newer of the two)
        self._newest = 0.0
        self._written = 0.0
        self._next_clock_look = 0.0

    @property
    def talk_s(self) -> float | None:
        return None

    def start(self, session: SessionDir, config: Config) -> None:
        self._streams = session.streams
        streams = {r.metric: session.stream(r.stream) for r in config.rules}
        self._tailer = MultiTailer(
            streams, max_ahead_s=MAX_AHEAD_S, record_stamps=True, ranges=config.value_ranges()
        )
        self.t0_epoch = time.time()
        self._logs = [
            (session.root / f"{m.name}.log").open("a", encoding="utf-8") for m in self.modules
        ]
        self.procs = [
            ModuleProcess(m, session.root, self.t0_epoch, f)
            for m, f in zip(self.modules, self._logs, strict=True)
        ]
        for p in self.procs:
            p.start(0.0)

    def meta(self) -> dict[str, Any]:
        # Every input a file played as if live: the person in it could not hear the robot
        # (the report then judges no cue by what followed it, as for a rehearsal).
        recorded = self._recorded
        return {"t0_epoch": self.t0_epoch, **({"recorded_inputs": True} if recorded else {})}

    def poll(self, now: float) -> Sequence[Sample]:
        assert self._tailer is not None
        samples = self._tailer.poll(now)
        if samples:
            self._newest = max(self._newest, max(s.t for s in samples))
        return samples

    def time_used(self, now: float) -> float | None:
        """When every input is a file played as if live: the newest stamp the modules wrote,
        the recordings' own clock (None, the talk's clock, otherwise).

        The talk's clock runs ahead of the recordings' while the modules start up and on
        after their end (the module on a 60.00 s file finished at 1:02.5), and the time
        used is the recordings' length (:meth:`recording_s`). Session 23: with --allocated 1m
        the robot said "You are over time" at 1:00.5, then "You used 1 minute of 1 minute,
        right on time". On the recordings' clock a time warning falls where the recording
        reaches it, and a recording that ends within its time gets no overtime cue.

        Every stream counts, not only those :meth:`poll` reads (the rules'): in a pause the
        speech module writes ``speech_activity`` alone, and the video fallback without the
        vision env ``cv_gestures_motion``, which no rule judges. On the rules' streams alone
        the clock stopped in silence: a recording that ran over in a pause was never told
        (session 23's review: 30.5 s of speech and 25 s of silence with --allocated 40 got
        no cue, then "You used 55.5 seconds of 40 seconds, 39% over"). The other files'
        newest stamps are read every :data:`CLOCK_LOOK_S` (their last 4 kB), as
        :meth:`recording_s` reads them; a stamp the coach would skip as ahead of its clock
        counts for nothing.
        """
        if not self._recorded:
            return None
        if now >= self._next_clock_look and self._streams is not None:
            self._next_clock_look = now + CLOCK_LOOK_S
            written = newest_stamp(self._streams, max_t=now + MAX_AHEAD_S)
            self._written = max(self._written, written)
        return max(self._newest, self._written)

    def wait(self, timeout_s: float) -> bool:
        assert self._tailer is not None
        return bool(self._tailer.wait(timeout_s))

    def ended(self, now: float) -> bool:
        clock = now
        if self.grace_s is not None and self._recorded:
            # the time limit (allocated + grace) on the recordings' clock, as the time warnings
            # and the time used: on the coach's clock, which runs ahead of the recordings', a
            # 62.4 s file with 32 + 31 s was stopped at 1:03 before its end and told "you were
            # still going … at least 98% over" (session 23's verification)
            clock = self.time_used(now) or 0.0
        if self.end_at is not None and clock >= self.end_at:
            going_on = [p for p in self.procs if not p.finished]
            if self.grace_s is not None and going_on and not self.stopped_at_limit:
                # Session 20: a 360 s file played with --allocated 5m stopped at 5:30 and was
                # reported as "5:30 used, 10 % over", nothing said it was cut.
                self.stopped_at_limit = True
                log.warning(
                    "the talk reached the allocated time plus the %g s grace (%s) and was "
                    "stopped while %s still went on: the time used is at least that "
                    "(--grace gives more time)",
                    self.grace_s,
                    clock_text(self.end_at),
                    ", ".join(p.spec.name for p in going_on),
                )
            return True
        fatal = next((p for p in self.procs if p.fatal), None)
        if fatal is not None:
            self.error = f"module {fatal.spec.name}: {fatal.fatal}"
            return True
        if self.procs and all(p.gave_up for p in self.procs):
            # nothing is left to listen to: the talk stops, with the first module's reason
            p = self.procs[0]
            self.error = f"module {p.spec.name} {p.gave_up}"
            return True
        if self.procs and all(p.finished for p in self.procs):
            # a file played to its end, a module that exited 0, one given up: nothing is left
            # to listen to (session 22: a --module that exited 0 at its file's end was
            # restarted, and the talk ran on to the time limit)
            gave_up = any(p.gave_up for p in self.procs)
            log.info("every input has ended%s: the talk ends", " or was given up" * gave_up)
            return True
        return False

    def events(self, now: float) -> list[str]:
        if now < self._next_look:
            return []
        self._next_look = now + SUPERVISE_PERIOD_S
        return [ev for p in self.procs if (ev := p.check(now))]

    def finish_input(self) -> None:
        for p in self.procs:
            p.stop()

    def stop(self) -> None:
        if self._stopped:
            return
        self._stopped = True
        self.finish_input()
        if self._tailer is not None:
            self._tailer.finish()  # the modules are gone: a torn last line is a bad one
            self._tailer.close()
        for f in self._logs:
            f.close()

    def tailer(self) -> MultiTailer | None:
        return self._tailer

    def recording_s(self) -> float | None:
        """How long the recordings lasted when every input ended by itself (a file played to
        its end; a module of one's own that exited 0, as one playing a file does at its end):
        the newest stamp the modules wrote, on the recordings' own clock; None otherwise.

        The talk's own clock runs on while the modules start up and catch up (a 48 s file
        ended the talk at 50.6 s), so that is not the time the presenter used.
        """
        if (
            not self.procs
            or self._streams is None
            or self.stopped_at_limit
            or self.error is not None
            or not all(p.finished and not p.gave_up for p in self.procs)
        ):
            return None
        newest = newest_stamp(self._streams)
        return round(newest, 3) if newest > 0.0 else None

    def written_by(self, spec: ModuleSpec) -> tuple[str, ...] | None:
        """The metrics ``spec``'s module writes: those it names, else found by elimination.

        A module started as ``NAME=COMMAND`` names none. The stream files in ``streams/``
        that no module names as its own were then written by it when it is the only module
        that names none (the built-in modules name all of theirs); with two or more such
        modules nothing says which wrote which: None.
        """
        if spec.metrics:
            return spec.metrics
        if sum(1 for p in self.procs if not p.spec.metrics) != 1 or self._streams is None:
            return None
        named = {m for p in self.procs for m in p.spec.metrics}
        found = (f.stem for f in self._streams.glob("*.txt") if not f.name.startswith("."))
        return tuple(sorted(m for m in found if m not in named))

    def summary_extra(self) -> dict[str, Any]:
        modules: dict[str, Any] = {}
        for p in self.procs:
            rec: dict[str, Any] = {"restarts": p.restarts, "crashes": p.crashes}
            if p.gave_up:
                rec["gave_up"] = p.gave_up
            if p.cut_short:
                rec["cut_short"] = p.cut_short
            if p.ended_t is not None:
                rec["ended_t"] = p.ended_t
            if p.crashes or p.ended_t is not None:
                # which metrics a crash (or its end) took with it (the report says when they
                # were lost); none recorded: not known (the report says so)
                metrics = self.written_by(p.spec)
                if metrics is not None:
                    rec["metrics"] = list(metrics)
            modules[p.spec.name] = rec
        return {
            "kind": "live",
            **({"error": self.error} if self.error is not None else {}),
            **({"recording_s": r_s} if (r_s := self.recording_s()) is not None else {}),
            "modules": modules,
            **(
                {"stopped_at_time_limit": {"at_s": self.end_at, "grace_s": self.grace_s}}
                if self.stopped_at_limit
                else {}
            ),
        }


def up(
    config: Config,
    *,
    session_dir: Path,
    modules: Sequence[ModuleSpec],
    backend: Backend,
    options: RunOptions,
    grace_s: float = 30.0,
    duration_s: float | None = None,
    view: View | None = None,
    stop: Callable[[], bool] | None = None,
) -> UpResult:
    """Run a live talk until Ctrl-C, ``duration_s``, or the allocated time plus ``grace_s``.

    The talk runs through the one loop (:func:`prezence.talk.run_talk`) on the wall clock,
    with the modules as its sample source. After the talk the cue in progress finishes; with
    ``options.report`` the robot then says the post-talk summary (time used, the two things to
    work on first) with its summary gesture, and ``SESSION/report/`` is written.

    Args:
        config: rules and settings (its allocated time ends the talk, plus ``grace_s``).
        session_dir: the session folder (created).
        modules: input modules to start and supervise (names must differ: each has its own
            log, ``SESSION/<name>.log``, and heartbeat file).
        backend: an unopened robot backend.
        options: policy, seed, gesture speed, report.
        grace_s: time after the allocated time before the talk is stopped.
        duration_s: stop after this long regardless (tests, fixed-length rehearsals).
        view: the live terminal view (None: log only): an object with ``decision(d)`` and
            ``event(now, text)``.
        stop: polled every loop; True ends the talk (tests, embedding).

    Raises:
        ValueError: two modules have the same name, or declare the same metric.
        PrezenceError: a module's command cannot be started (not on ``PATH``, no such file,
            not executable): said before the robot opens or the folder is written.
    """
    problems = [p for m in modules if (p := m.command_problem())]
    if problems:
        raise PrezenceError("; ".join(problems))
    end_at = duration_s
    limit_grace: float | None = None
    if end_at is None and config.time.allocated_s is not None:
        end_at = config.time.allocated_s + grace_s
        limit_grace = grace_s
    source = LiveSource(modules, end_at=end_at, grace_s=limit_grace)
    target = SessionDir(Path(session_dir))
    if target.holds_recording():  # refused before the robot moves
        target.create()  # raises: a recording is never overwritten
    run = run_talk(
        source,
        config=config,
        session=target,
        backend=backend,
        options=options,
        clock=WallClock(config.processor.decision_period_s),
        view=view,
        stop=stop,
    )
    return UpResult(run.session, run.summary, run.events, run.report, source.error)
