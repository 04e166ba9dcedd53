"""Helpers shared by the input-module processes (``python -m prezence.modules.<name>``).

An input module is a separate process that reads one input (a file, a microphone, a camera)
and only appends samples to its stream files, ``SESSION/streams/<metric>.txt``, one
``<t> <value>`` line each (see :mod:`prezence.streams.writer`). ``t`` is seconds since the talk
began. The common command line is::

    --out SESSION      the session folder (its streams/ folder is created if needed)
    --t0 EPOCH         live input: wall time (time.time()) at which the talk began; a sample
                       captured at wall time w gets t = w - EPOCH. Default: when the module
                       started. Files use their own media time and ignore it.
    --realtime         file input: deliver the file at real-time pace, as a live input would
    -v / -q            more / less logging on stderr

Exit status: 0 done, 2 bad input or arguments (``error: FILE: what is wrong`` on stderr, no
traceback), as ``prezence``'s own command line does; 3 (:data:`CUT_SHORT_STATUS`) a file that
breaks off before its end (a truncated recording: ``warning: FILE: …`` on stderr), whose every
sample read has been analysed and written.

Heartbeat: when the launcher (``prezence up``, and ``prezence rehearse``) sets
:data:`HEARTBEAT_ENV` to a file's path, a module touches that file (:class:`Heartbeat`) about
once a second while it reads and analyses its input, so that a module that is working but has
nothing to write yet is not taken for a hung one.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from collections.abc import Iterable
from pathlib import Path
from types import TracebackType
from typing import Any

from prezence.errors import PrezenceError
from prezence.session import SessionDir
from prezence.streams.writer import StreamWriter

log = logging.getLogger(__name__)


class ModuleInputError(PrezenceError, ValueError):
    """An input module cannot read its input (a bad or missing file, no microphone).

    The message starts with the input's name, then says what is wrong and, where it can, how
    to fix it: ``talk.flac: the audio is damaged or truncated (…)``.

    Attributes:
        source: the file path, or a name such as ``mic``.
        reason: what is wrong.
    """

    def __init__(self, source: str | os.PathLike[str], reason: str) -> None:
        self.source = str(source)
        self.reason = reason
        super().__init__(f"{self.source}: {reason}")

    def __reduce__(self) -> tuple[Any, ...]:
        # picklable (a process pool sends errors back): Exception's own gives cls(message)
        return (type(self), (self.source, self.reason), self.__dict__)


#: The exit status of a module whose input file broke off before its end (a recording cut
#: short: a phone that died mid-talk, a copy stopped half-way) after it analysed and wrote
#: everything it could read: the streams are whole up to there. Not a failure: ``rehearse``
#: and ``up`` coach and report on what was read, and say the input was cut short.
CUT_SHORT_STATUS = 3


class InputCutShort(ModuleInputError):
    """The input file ends before its end: it breaks off mid-stream, or holds less than its
    header announces. Raised once everything read has been handed on.

    Attributes:
        read_s: seconds of the input that were read.
    """

    def __init__(self, source: str | os.PathLike[str], reason: str, read_s: float = 0.0) -> None:
        super().__init__(source, reason)
        self.read_s = float(read_s)


#: The environment variable holding the heartbeat file's path (``prezence.launcher`` sets it).
HEARTBEAT_ENV = "PREZENCE_HEARTBEAT"


class Heartbeat:
    """Touches the launcher's heartbeat file at most once per ``period_s``; else does nothing.

    Args:
        path: the file; default: ``$PREZENCE_HEARTBEAT``, and no heartbeat when that is unset.
        period_s: the least time between two touches, seconds.
    """

    def __init__(self, path: str | os.PathLike[str] | None = None, period_s: float = 1.0) -> None:
        if path is None:
            path = os.environ.get(HEARTBEAT_ENV) or None
        self.path = Path(path) if path is not None else None
        self.period_s = float(period_s)
        self._last = -float("inf")

    def beat(self) -> None:
        """Touch the file if ``period_s`` has passed since the last touch (cheap otherwise).

        A file that cannot be touched is logged once and then left alone: the heartbeat is a
        courtesy to the launcher, never a reason for the module to fail.
        """
        if self.path is None:
            return
        now = time.monotonic()
        if now - self._last < self.period_s:
            return
        self._last = now
        try:
            self.path.touch()
        except OSError as e:
            log.warning("cannot touch the heartbeat file %s (%s); no heartbeat", self.path, e)
            self.path = None


def add_common_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--out``, ``--t0``, ``--realtime``, ``-v`` and ``-q`` to a module's parser."""
    parser.add_argument("--out", required=True, type=Path, help="the session folder")
    parser.add_argument(
        "--t0",
        type=float,
        default=None,
        help="live input: wall time (time.time()) the talk began (default: module start)",
    )
    parser.add_argument(
        "--realtime", action="store_true", help="file input: pace it at real time, as if live"
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="debug logging")
    parser.add_argument("-q", "--quiet", action="store_true", help="warnings only")


#: A file played as if live that starts later than this after ``--t0`` is a restart mid-talk.
RESUME_AFTER_S = 1.0


def resume_offset(args: argparse.Namespace, *, now: float | None = None) -> float:
    """Where in its file a module played as if live starts (seconds; 0.0 from the beginning).

    A module restarted mid-talk (``--realtime`` with the talk's ``--t0``) continues the file at
    the talk's present, as a microphone or camera would, and stamps its samples on the talk's
    clock; starting again at 0 s would write times the coach has long passed, and its metrics
    would stay stale for the rest of the talk.

    Example:
        >>> ns = argparse.Namespace(realtime=True, t0=100.0)
        >>> resume_offset(ns, now=100.4), resume_offset(ns, now=130.0)
        (0.0, 30.0)
    """
    if not getattr(args, "realtime", False) or getattr(args, "t0", None) is None:
        return 0.0
    late = (time.time() if now is None else now) - float(args.t0)
    return late if late > RESUME_AFTER_S else 0.0


def setup_logging(module: str, args: argparse.Namespace) -> None:
    """Log to stderr as ``<module>: LEVEL: message`` (only for a module run as a process)."""
    level = logging.DEBUG if args.verbose else logging.WARNING if args.quiet else logging.INFO
    logging.basicConfig(level=level, format=f"{module}: %(levelname)s: %(message)s")


class StreamSet:
    """One open :class:`StreamWriter` per metric, in ``SESSION/streams/<metric>.txt``.

    Args:
        out: the session folder.
        metrics: the metric names this module writes.
        fresh: remove these metrics' old files first (a file analysed again replaces its
            earlier run; a live input appends).
    """

    def __init__(self, out: str | os.PathLike[str], metrics: Iterable[str], *, fresh: bool) -> None:
        self.session = SessionDir(Path(out))
        self.metrics = tuple(metrics)
        self.fresh = fresh
        self._writers: dict[str, StreamWriter] = {}

    def open(self) -> StreamSet:
        """Create ``streams/`` and open every file for appending."""
        self.session.streams.mkdir(parents=True, exist_ok=True)
        for m in self.metrics:
            path = self.session.stream(f"{m}.txt")
            # under the launcher ($PREZENCE_APPEND=1) a restart appends: the talk's record stays
            if self.fresh and path.exists() and os.environ.get("PREZENCE_APPEND") != "1":
                path.unlink()
            self._writers[m] = StreamWriter(path).open()
        return self

    def write(self, metric: str, t: float, value: float) -> None:
        """Append one sample to ``metric``'s file.

        Raises:
            KeyError: ``metric`` is not one this set was opened with.
            ValueError: ``t`` or ``value`` is not finite, or ``t`` < 0.
        """
        self._writers[metric].write(t, value)

    def close(self) -> None:
        """Close every file; a second call does nothing."""
        writers, self._writers = self._writers, {}
        for w in writers.values():
            w.close()

    def __enter__(self) -> StreamSet:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def report_error(module: str, err: PrezenceError | ValueError) -> int:
    """Print ``error: …`` for a failed module run and return its exit status: 2, or
    :data:`CUT_SHORT_STATUS` with ``warning: …`` for an input cut short (:class:`InputCutShort`),
    whose streams are whole up to where it broke off."""
    log.debug("%s failed", module, exc_info=err)
    if isinstance(err, InputCutShort):
        print(f"warning: {err}", file=sys.stderr)
        return CUT_SHORT_STATUS
    print(f"error: {err}", file=sys.stderr)
    return 2
