"""``prezence rehearse``: a recorded rehearsal (phone video or audio) gives the same session folder
and report as a live talk.

The input modules run over the recording as fast as the machine allows (in parallel, one
process each), writing stream files stamped with the recording's own time; then the coach runs
over those files on the recording's clock, exactly as it does on a live talk's files.

Each module's stdout and stderr go to ``SESSION/<module>.log``, as in ``prezence up``. A module
is watched for hangs as ``up`` watches it (:mod:`prezence.launcher`): one whose record has a
hang limit (a module of one's own without a record: :data:`prezence.metrics.DEFAULT_HANG_S`)
and shows no sign of life for that long, wall-clock (its stream files, its log and its
heartbeat file, ``$PREZENCE_HEARTBEAT``, stay as they were), is killed; the rehearsal goes on
with what was measured, and the module is recorded as ``up`` records a hang (``modules``), so
that the printed notes, the report and the robot's summary say it hung and what it left
unmeasured.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import logging
import os
import shlex
import subprocess
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from prezence.config.load import load_config
from prezence.config.model import Config
from prezence.config.tomlconf import dumps_config
from prezence.errors import ConfigError, PrezenceError
from prezence.launcher import (
    HEARTBEAT_ENV,
    die_with_parent_hook,
    files_changed,
    hang_why,
    heartbeat_file,
    stream_files,
)
from prezence.metrics import DEFAULT_HANG_S, INPUT_MODULES
from prezence.modules.common import CUT_SHORT_STATUS
from prezence.replay import (
    ReplayResult,
    find_streams,
    merge_readings,
    process_recorded,
    read_streams,
)
from prezence.session import MAX_TALK_S, SessionDir
from prezence.streams.tail import newest_stamp, newest_stamp_of
from prezence.talk import RunOptions, Terminated

log = logging.getLogger(__name__)

#: What phones and recorders save a talk as; the decoder (ffmpeg) reads them all. WhatsApp's
#: voice notes are .opus, many recorder apps write .aac, .amr (older phones) or .aiff.
AUDIO_EXT = {
    ".wav",
    ".flac",
    ".mp3",
    ".ogg",
    ".oga",
    ".opus",
    ".m4a",
    ".aac",
    ".aif",
    ".aiff",
    ".amr",
    ".wma",
}
VIDEO_EXT = {".mp4", ".mov", ".mkv", ".avi", ".webm"}


#: The input each built-in module needs on its command line (to check extra settings).
_MODULE_INPUT = {name: m.input_option for name, m in INPUT_MODULES.items()}


def module_args(option: str, module: str, text: str | None) -> list[str]:
    """The shell words of ``--speech-args "…"``, checked with the module's own parser.

    Each word must be an option of ``python -m prezence.modules.<module>`` with a valid value,
    so that a typo stops the command at once rather than every module run. When the module
    cannot be imported here (its extra is not installed) the words are only split.

    Args:
        option: the command-line option, for messages (``--speech-args``).
        module: ``speech`` or ``vision``.
        text: the option's value (None or empty: no words).

    Raises:
        PrezenceError: unbalanced quotes, an unknown option or a bad value; the message names
            the option and the word.

    Example:
        >>> module_args("--speech-args", "speech", "--window 5 --calibration-db 93")
        ['--window', '5', '--calibration-db', '93']
    """
    if not text:
        return []
    try:
        words = shlex.split(text)
    except ValueError as e:
        raise PrezenceError(f"{option} {text!r}: {e}") from None
    try:
        mod = importlib.import_module(f"prezence.modules.{module}")
    except ImportError as e:
        log.debug("%s not checked: %s", option, e)
        return words
    parser: argparse.ArgumentParser = mod.build_parser()
    parser.exit_on_error = False
    usage = f"python -m prezence.modules.{module} -h lists them"
    try:
        _, rest = parser.parse_known_args([_MODULE_INPUT[module], "x", "--out", "x", *words])
    except argparse.ArgumentError as e:
        raise PrezenceError(f"{option}: {e} ({usage})") from None
    except SystemExit:  # -h, or an error argparse reports itself
        raise PrezenceError(
            f"{option} {text!r}: not valid for the {module} module ({usage})"
        ) from None
    if rest:
        raise PrezenceError(f"{option}: the {module} module has no option {rest[0]!r} ({usage})")
    for w in words:
        if w in ("--audio", "--video", "--out", "--t0", "--realtime"):
            raise PrezenceError(f"{option}: {w} is set by prezence itself; leave it out")
    return words


def module_commands(
    recording: Path,
    session: Path,
    *,
    realtime: bool = False,
    extra: Mapping[str, Sequence[str]] | None = None,
) -> dict[str, list[str]]:
    """The module command lines for a recording: every input module that reads audio (speech)
    for an audio file, and those that read video too (vision) for a video file, from the input
    module records (:data:`prezence.metrics.INPUT_MODULES`): a module added there runs here.

    Args:
        recording: the audio or video file.
        session: the session folder the modules write into.
        realtime: have the modules read the file at real-time pace.
        extra: per module name, words appended to its command line (``--window 5``).

    Raises:
        ConfigError: the file's extension is not one of a recording, or ``extra`` names a
            module that does not run on it (vision settings for an audio file).
    """
    ext = recording.suffix.lower()
    if ext not in AUDIO_EXT | VIDEO_EXT:
        known = ", ".join(sorted(AUDIO_EXT | VIDEO_EXT))
        raise ConfigError(
            f"not an audio or video file I know (extensions: {known})", path=recording
        )
    reads = {"--audio", "--video"} if ext in VIDEO_EXT else {"--audio"}
    names = [n for n, m in INPUT_MODULES.items() if m.input_option in reads]
    cmds = {
        n: INPUT_MODULES[n].offline_argv(str(recording), str(session), realtime=realtime)
        for n in names
    }
    for name, words in (extra or {}).items():
        if not words:
            continue
        if name not in cmds:
            raise ConfigError(
                f"settings for the {name} module, which does not run on an audio recording",
                path=recording,
            )
        cmds[name] += list(words)
    return cmds


#: How often the progress of a rehearsal's modules is read, and their signs of life looked
#: at (seconds).
PROGRESS_PERIOD_S = 0.25


@dataclass
class _Watched:
    """One rehearsal module's supervision: its signs of life, as ``up`` looks at them."""

    name: str
    session: Path
    #: the metrics it writes (its record's); empty: not known, every stream file counts
    metrics: tuple[str, ...]
    #: kill it after this many seconds without a sign of life; None: never
    hang_after_s: float | None
    #: when it last showed a sign of life (``time.monotonic()``)
    last_life: float
    #: where in the recording it had got then: the newest time in its streams
    stamp: float = 0.0
    #: said once that it has been silent a while
    warned: bool = False
    #: set when it was killed as hung: its record, as ``up`` writes a hang
    hang: dict[str, Any] | None = None
    seen: dict[Path, tuple[int, int]] = field(default_factory=dict)

    def streams(self) -> list[Path]:
        return stream_files(self.session, self.metrics)

    def look(self, now: float, proc: subprocess.Popen[str]) -> None:
        """Look at its files; kill it when it has been silent past its hang limit."""
        log_path = self.session / f"{self.name}.log"
        files = [*self.streams(), heartbeat_file(self.session, self.name), log_path]
        if files_changed(files, self.seen):
            self.last_life, self.warned = now, False
            self.stamp = newest_stamp_of(self.streams())
        limit = self.hang_after_s
        silent = now - self.last_life
        if limit is None or proc.poll() is not None:
            return
        if silent > limit:
            with contextlib.suppress(OSError):
                proc.kill()
            proc.wait()
            why = hang_why(limit)
            # on the recording's clock: it stopped measuring where it went silent
            at = round(self.stamp, 3)
            self.hang = {"t": at, "why": why, "silent_since": at}
            log.warning(
                "module %s %s: it measured the recording up to %s; the rehearsal goes on "
                "with what was measured",
                self.name,
                why,
                f"{int(at // 60)}:{at % 60:04.1f}",
            )
        elif silent >= limit / 2 and not self.warned:
            self.warned = True
            log.warning(
                "waiting for module %s: no sign of life for %.0f s (at %.0f s of the "
                "recording; killed as hung after %g s)",
                self.name,
                silent,
                self.stamp,
                limit,
            )


def _hang_limit(name: str) -> float | None:
    """A rehearsal module's hang limit: its record's (a module of one's own without a record:
    :data:`DEFAULT_HANG_S`, as ``up --module``)."""
    rec = INPUT_MODULES.get(name)
    if rec is None:
        return DEFAULT_HANG_S
    if rec.heartbeat_metric is not None and rec.heartbeat_metric not in rec.metrics:
        return None  # it may write nothing for a long while: as `up`, no hang limit
    return rec.hang_after_s


def _module_line(text: str, prefix: str) -> str:
    """A module's own last ``prefix`` line in its log (``error:``, ``warning:``), without the
    prefix; else its last line; "" for an empty log. Its stdout is in the log too."""
    lines = [ln.strip() for ln in text.splitlines() if ln.strip()]
    for ln in reversed(lines):
        if ln.startswith(prefix):
            return ln[len(prefix) :].strip()
    return lines[-1] if lines else ""


def _stop_modules(procs: Mapping[str, subprocess.Popen[str]], wait_s: float = 3.0) -> None:
    """End the modules still running: SIGTERM, then SIGKILL for those not gone in ``wait_s``."""
    for p in procs.values():
        if p.poll() is None:
            with contextlib.suppress(OSError):
                p.terminate()
    deadline = time.monotonic() + wait_s
    for p in procs.values():
        try:
            p.wait(timeout=max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            with contextlib.suppress(OSError):
                p.kill()
            p.wait()


def _analysed(
    watched: Mapping[str, _Watched], procs: Mapping[str, subprocess.Popen[str]], session: SessionDir
) -> float:
    """How far the analysis has got: where the slowest module still running is (the newest
    time in its streams), so that a module that lags or hangs holds the progress where it is;
    the newest time in any stream when no running module's streams are known."""
    running = [w for n, w in watched.items() if procs[n].poll() is None and w.metrics]
    if not running:
        return newest_stamp(session.streams)
    return min(newest_stamp_of(w.streams()) for w in running)


def _remove_what_we_wrote(session: SessionDir, *, logs: Sequence[str]) -> None:
    """Remove the files a failed rehearsal wrote (config, module logs, empty streams) and the
    folder if that empties it."""
    for path in [session.config, *(session.root / n for n in logs)]:
        path.unlink(missing_ok=True)
    for path in session.streams.glob("*"):
        if path.is_file() and path.stat().st_size == 0:
            path.unlink()
    for folder in (session.streams, session.root):
        with contextlib.suppress(OSError):  # not empty: something else is in it, keep it
            folder.rmdir()


def recording_length_s(recording: Path) -> float:
    """The recording's length in seconds from its container (0.0 when it cannot be read)."""
    try:
        import av

        with av.open(str(recording)) as c:
            return float(c.duration) / 1e6 if c.duration else 0.0
    except Exception:  # noqa: BLE001 - only a progress bar's total depends on it
        return 0.0


def rehearse(
    recording: Path,
    *,
    out: Path,
    options: RunOptions,
    config: Config | None = None,
    backend: str = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    modules: dict[str, list[str]] | None = None,
    module_args: Mapping[str, Sequence[str]] | None = None,
    allocated_s: float | None = None,
    progress: Callable[[float, float], None] | None = None,
) -> ReplayResult:
    """Analyse ``recording`` with the input modules, then coach over the result.

    Args:
        recording: an audio or video file.
        out: the session folder (created).
        options: policy, seed, gesture speed, pacing (``realtime``: at the recording's pace on
            the wall clock), report.
        config: rules and settings (None: the built-in configuration).
        backend: robot backend name; ``backend_kwargs`` go to its constructor.
        modules: the module command lines (None: :func:`module_commands`).
        module_args: per module name, words appended to its command line.
        allocated_s: the time allocated, seconds (None keeps the config's); a 36 s clip is
            then not judged against ten minutes.
        progress: told ``(seconds analysed, recording length)`` while the modules run (the
            newest time in their streams; the length is 0.0 when it cannot be read).

    Raises:
        ConfigError: the recording is missing or of an unknown kind.
        PrezenceError: every module failed (their messages are included).
    """
    recording = Path(recording)
    if recording.is_dir():
        raise ConfigError("is a folder; give a media file", path=recording)
    if not recording.is_file():
        raise ConfigError("no such recording", path=recording)
    if recording.stat().st_size == 0:
        raise ConfigError("the recording is empty", path=recording)
    config = config or load_config(None)
    if allocated_s is not None:
        config = config.with_allocated(allocated_s)
    cmds = (
        modules if modules is not None else module_commands(recording, Path(out), extra=module_args)
    )
    session = SessionDir(Path(out)).create()
    session.config.write_text(dumps_config(config))
    logs = {name: (session.root / f"{name}.log").open("w") for name in cmds}
    started = time.perf_counter()
    procs: dict[str, subprocess.Popen[str]] = {}
    total = recording_length_s(recording)
    watched = {
        name: _Watched(
            name,
            session.root,
            INPUT_MODULES[name].metrics if name in INPUT_MODULES else (),
            _hang_limit(name),
            time.monotonic(),
        )
        for name in cmds
    }
    try:
        for name, argv in cmds.items():
            procs[name] = subprocess.Popen(
                argv,
                # its stdout too, as `up` keeps it (session 22: a module's debug prints
                # vanished in rehearse)
                stdout=logs[name],
                stderr=subprocess.STDOUT,
                text=True,
                env={**os.environ, HEARTBEAT_ENV: str(heartbeat_file(session.root, name))},
                preexec_fn=die_with_parent_hook(),  # a killed coach leaves no module behind
            )
            watched[name].last_life = time.monotonic()
        while any(p.poll() is None for p in procs.values()):
            # Session 22: a hung module of one's own was waited for in silence, for ever
            now = time.monotonic()
            for name, w in watched.items():
                w.look(now, procs[name])
            if progress is not None:
                progress(min(_analysed(watched, procs, session), total or MAX_TALK_S), total)
            time.sleep(PROGRESS_PERIOD_S)
    except KeyboardInterrupt as e:
        # Session 21, a second walkthrough: a SIGTERM or SIGINT to this process alone left the
        # modules analysing on, writing into the folder just said to be kept.
        # what the folder holds, written first (a second Ctrl-C while the modules stop must
        # not lose it): the recording's length is the time used; its figures cover the part
        # analysed (the report says so, and "measured over 1:11 of 3:42")
        analysed = newest_stamp(session.streams)
        session.write_meta(
            {
                "kind": "rehearsal",
                "recording": str(recording),
                "talk_s": round(max(total, analysed), 3),
                "interrupted": True,
                "analysed_s": round(analysed, 3),
            }
        )
        _stop_modules(procs)
        log.warning(
            "stopped by %s while the modules analysed the recording (%.0f s of %.0f s "
            "analysed); what they measured is kept in %s: `prezence report %s` reports on it",
            "SIGTERM" if isinstance(e, Terminated) else "Ctrl-C",
            analysed,
            total,
            session.root,
            session.root,
        )
        raise
    finally:
        for f in logs.values():
            f.close()
    analysis_wall_s = time.perf_counter() - started
    if progress is not None:
        progress(total, total)
    failures: dict[str, str] = {}
    cut_short: dict[str, str] = {}
    hangs = {name: w.hang for name, w in watched.items() if w.hang is not None}
    for name, p in procs.items():
        err = (session.root / f"{name}.log").read_text(errors="replace")
        if name in hangs:
            failures[name] = hangs[name]["why"]  # said when it was killed
        elif p.returncode == CUT_SHORT_STATUS:
            # a recording that breaks off (a phone that died mid-talk): the module analysed
            # all of it that could be read, so the talk is coached and reported on that
            cut_short[name] = _module_line(err, "warning:") or "the input was cut short"
            log.warning("the recording is cut short: %s", cut_short[name])
        elif p.returncode != 0:
            # the module's own "error: …" line: the CLI says "error:" once, before them all
            failures[name] = _module_line(err, "error:") or f"exit status {p.returncode}"
    # a hung module that measured something is no failure to run: the rehearsal goes on
    ran = {n for n, h in hangs.items() if watched[n].stamp > 0.0}
    if len(failures) - len(ran) == len(procs):
        if not any(f.stat().st_size for f in session.streams.glob("*")):
            # Nothing was measured: leave no half-made folder that a second try, once the
            # file is mended, would be refused for. The error carries the modules' messages.
            _remove_what_we_wrote(session, logs=[f"{n}.log" for n in cmds])
        raise PrezenceError("; ".join(f"{n}: {m}" for n, m in failures.items()))
    for name, msg in failures.items():
        if name not in hangs:
            log.warning("module %s failed: %s", name, msg)
    paths = find_streams(session.root, config)
    readings = read_streams(paths, max_t=MAX_TALK_S, ranges=config.value_ranges())
    samples = merge_readings(readings)
    # The talk lasted as long as the recording, not up to its last measured value: a talk that
    # ends in silence (or a module that stopped measuring) still used that time.
    # A recording cut short lasted until it broke off, not as long as its header announces.
    heard = total if total > 0 and not cut_short else newest_stamp(session.streams)
    talk_s = max(samples[-1].t if samples else 0.0, min(heard, MAX_TALK_S))
    extra: dict[str, Any] = {
        "kind": "rehearsal",
        "recording": str(recording),
        "module_failures": failures,
        # the modules' analysis, most of a rehearsal's time (wall_s is the coaching's alone)
        "analysis_wall_s": round(analysis_wall_s, 3),
    }
    if cut_short or hangs:  # recorded as `up` records its modules, for the report's notes
        extra["modules"] = {
            **{n: {"restarts": 0, "crashes": [], "cut_short": m} for n, m in cut_short.items()},
            **{
                n: {
                    "restarts": 0,
                    "crashes": [h],
                    # which metrics it left unmeasured (not known: the report says so)
                    **({"metrics": list(watched[n].metrics)} if watched[n].metrics else {}),
                }
                for n, h in hangs.items()
            },
        }
    return process_recorded(
        session,
        config,
        samples,
        talk_s=talk_s,
        options=options,
        backend=backend,
        backend_kwargs=backend_kwargs,
        kind="rehearsal",
        readings=readings,
        meta={"recording": str(recording)},
        extra=extra,
    )
