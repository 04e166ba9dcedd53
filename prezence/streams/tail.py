"""Following module stream files while they grow, and reading them whole afterwards.

:class:`StreamTailer` follows one file. Each :meth:`StreamTailer.poll` costs one ``stat`` when
nothing changed; when the file grew it opens it, reads only the new bytes (from the offset it
reached last time) and returns the samples of the *complete* lines among them. What it copes with:

- **partial last line**: bytes after the last newline are kept until the newline arrives.
- **blank lines**: skipped silently (they still count for line numbers).
- **bad lines** (garbage, more than two fields, NaN/inf, negative ``t``, invalid UTF-8, a line
  longer than :data:`MAX_LINE_BYTES`, a value outside the metric's physical range when the
  tailer is given one: 5000 wpm is a module gone wrong, not a fast talker): skipped and counted
  as ``malformed``; each is logged once as a warning with ``file:line: reason`` (the first
  :data:`MAX_LOGGED_PROBLEMS` per stream, then one notice) and the last ``max_problems`` are
  kept as :class:`StreamProblem` for the summary. Nothing in a file's content makes ``poll``
  raise.
- **missing file**: no error; ``missing`` counts each time the file is found absent (at the start
  or after it was deleted), and reading starts when it appears.
- **truncated file** (size below the offset read so far, or the last bytes before that offset
  (up to :data:`REWRITE_CHECK_BYTES`) are no longer the ones read there, i.e. the file was
  rewritten in place): reading restarts at byte 0 and ``truncations`` is counted. A rewrite that
  leaves those bytes and the size exactly as they were cannot be seen by any reader that does
  not re-read the whole file; writers append, so this is an accepted blind spot.
- **replaced file** (another inode at the path, e.g. after ``os.replace``): reading restarts at
  byte 0 of the new file and ``replaced`` is counted. The tailer does not keep files open (so a
  writer can replace one on any OS); unread bytes of the old file are therefore lost.
- **bare ``<value>`` lines** (the seed's format): stamped with the ``now`` given to ``poll``
  (a live talk: the coach reads each line as it is written). With ``record_stamps`` (the coach
  sets it), each stamp is also appended as ``<line> <t>`` to the sidecar file
  ``<stream>.stamps`` (:func:`stamps_path`), so that :func:`read_stream` gives those lines the
  same times afterwards and the report and replay see what the coach saw. Read afterwards
  (:func:`read_stream` with no ``now``: ``rehearse``, ``replay``, ``report``), a bare line the
  sidecar gives no time cannot be placed in time: it is a bad line (``no time stamp: …``),
  not a sample of the instant the file happened to be read at.
- **a time ahead of the reader's clock**, when the tailer is given ``max_ahead_s`` (the coach
  gives :data:`prezence.samples.MAX_AHEAD_S`): a line stamped more than that after the ``now``
  given to ``poll`` is a bad line like the others (skipped, counted as malformed, logged with
  ``file:line``). :func:`read_stream` has no clock: with ``record_stamps`` the coach notes each
  such line in the sidecar (``<line> ahead <now>``), and :func:`read_stream` skips the lines
  noted there with the same reason, so the summary, the report and a replay count and leave
  out what the coach did (a line 5 s ahead was a sample to the report, and one 1e5 s ahead a
  sample "stamped after the end of the talk", while the coach had skipped both as unreadable).
- **timestamps going backwards**: the sample is kept as written and ``out_of_order`` counts it
  (a sample whose ``t`` is below the previous sample's of the same stream). Ordering and
  staleness are the processor's business; the count is for the summary. After a truncation or
  replacement the comparison starts afresh.

Line numbers are 1-based and stay right across polls; they restart at 1 with the file.

:class:`MultiTailer` follows several metrics. Its :meth:`MultiTailer.wait` blocks until a watched
file changes or a timeout passes, so a live loop wakes on new data instead of polling slowly.
On Linux it uses inotify through a small ``ctypes`` wrapper around libc (no dependency): one watch
per parent directory (files may not exist yet, and ``os.replace`` swaps inodes). Elsewhere, or
when inotify is not available, a directory cannot be watched yet (it does not exist) or the
watch limit is reached, it falls back to ``stat`` polling every ``poll_interval_s`` (5 ms).

:func:`read_stream` reads a whole file at once (report, replay) through the same code.
"""

from __future__ import annotations

import ctypes
import errno
import logging
import math
import os
import select
import stat
import struct
import sys
import time
from collections import deque
from collections.abc import Iterable, Mapping
from dataclasses import asdict, dataclass
from itertools import repeat
from operator import attrgetter
from pathlib import Path
from types import TracebackType
from typing import Any, Literal, NamedTuple, Protocol

import numpy as np

from prezence.samples import Sample
from prezence.streams.codec import StreamLineError, parse_line

__all__ = [
    "MAX_LINE_BYTES",
    "MAX_LOGGED_PROBLEMS",
    "MultiTailer",
    "StreamProblem",
    "StreamTailer",
    "TailStats",
    "WatchMode",
    "inotify_available",
    "read_stream",
    "stamps_path",
]

log = logging.getLogger(__name__)

#: A longer line is malformed (a valid one is under 60 bytes); it also bounds the bytes kept
#: while waiting for a newline, should a file that is not a stream be followed by mistake.
MAX_LINE_BYTES = 4096
#: A read at least this long is first tried in one go (:meth:`StreamTailer._feed_bulk`).
BULK_MIN_BYTES = 1 << 16
#: Bad lines logged as warnings per stream; the rest are counted and kept, not logged.
MAX_LOGGED_PROBLEMS = 20
#: The most one poll reads (bytes); :func:`read_stream` reads at most :data:`MAX_STREAM_BYTES`.
MAX_READ_BYTES = 16 * 1024 * 1024
#: The most :func:`read_stream` reads of one file: ~100x a 3-hour talk's stream at 10 Hz.
MAX_STREAM_BYTES = 256 * 1024 * 1024
#: How many of the bytes before the read offset are compared to find a file rewritten in place.
REWRITE_CHECK_BYTES = 64

WatchMode = Literal["auto", "inotify", "poll"]


@dataclass(frozen=True, slots=True)
class TailStats:
    """Counters of one stream, for the summary and the report.

    Attributes:
        samples: samples returned.
        malformed: lines skipped as unreadable (blank lines are not counted).
        truncations: restarts because the file shrank or was rewritten in place.
        replaced: restarts because another file took the path.
        out_of_order: samples whose ``t`` is below the previous sample's (kept anyway).
        missing: times the file was found absent (at the start, or after being deleted).
    """

    samples: int = 0
    malformed: int = 0
    truncations: int = 0
    replaced: int = 0
    out_of_order: int = 0
    missing: int = 0
    #: samples stamped after the talk's end (plus a margin), skipped: a module's clock gone wrong
    beyond_talk: int = 0

    def to_dict(self) -> dict[str, int]:
        return asdict(self)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> TailStats:
        return cls(**{k: int(d.get(k, 0)) for k in cls.__dataclass_fields__})


class StreamProblem(NamedTuple):
    """One skipped line: a ``(path, line, reason)`` tuple; ``str()`` gives ``path:line: reason``."""

    path: str
    line: int
    reason: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.reason}"


def _key(st: os.stat_result) -> tuple[int, ...]:
    return (st.st_dev, st.st_ino, st.st_size, st.st_ctime_ns)


def _check_now(now: float) -> float:
    f = float(now)
    if not math.isfinite(f):
        raise ValueError(f"now must be finite, got {now!r}")
    return f


class StreamTailer:
    """Follows one stream file; see the module docstring for what it copes with.

    Not thread-safe: poll from one thread.

    Args:
        path: the stream file (it need not exist yet).
        metric: the metric name given to the samples.
        max_problems: how many recent :class:`StreamProblem` to keep.
        max_ahead_s: skip (as malformed) lines stamped more than this after ``poll``'s ``now``;
            None keeps them.
        record_stamps: append the time given to each bare-value line to :func:`stamps_path`.
        max_t: samples stamped after this are skipped and counted as ``beyond_talk``.
        value_range: ``(lo, hi)``: a value outside it is a bad line (skipped, counted as
            malformed, logged with ``file:line``); None accepts every finite value. Callers
            give the rule's :attr:`~prezence.config.model.Rule.value_range`.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        metric: str,
        *,
        max_problems: int = 100,
        max_ahead_s: float | None = None,
        record_stamps: bool = False,
        max_t: float | None = None,
        value_range: tuple[float, float] | None = None,
    ) -> None:
        if not metric:
            raise ValueError("metric must be a non-empty name")
        if max_problems < 0:
            raise ValueError(f"max_problems must be >= 0, got {max_problems!r}")
        self.path = Path(path)
        self.metric = metric
        self.max_ahead_s = max_ahead_s
        #: samples stamped after this (the talk's end plus a margin) are skipped and counted
        self.max_t = max_t
        if value_range is not None and not value_range[0] <= value_range[1]:
            raise ValueError(f"value_range must be (lo, hi) with lo <= hi, got {value_range!r}")
        #: values outside this are skipped as bad lines; None: any finite value
        self.value_range = value_range
        self._vlo, self._vhi = value_range if value_range is not None else (-math.inf, math.inf)
        self._beyond = 0
        self._stamps_out = stamps_path(self.path) if record_stamps else None
        self._stamps_in: dict[int, float] = {}  # read_stream: line -> recorded stamp
        self._ahead_in: dict[int, float] = {}  # read_stream: line -> clock it was ahead of
        self._name = str(self.path)
        self._problems: deque[StreamProblem] = deque(maxlen=max_problems)
        self._logged = 0
        # counters
        self._samples = 0
        self._malformed = 0
        self._truncations = 0
        self._replaced = 0
        self._out_of_order = 0
        self._first_back: StreamProblem | None = None  # the first t that went back
        self._missing = 0
        # position in the current file
        self._ident: tuple[int, int] | None = None  # (st_dev, st_ino) being read; None: none
        self._absent = False  # the absence was already counted
        self._unreadable: tuple[int, ...] | None = None  # stat key of what could not be read
        self._reset_position()

    def _reset_position(self) -> None:
        self._offset = 0  # bytes consumed, pending included
        self._line_no = 0  # complete lines consumed
        self._pending = b""  # bytes after the last newline
        self._skipping = False  # dropping the rest of an over-long line
        self._tail = b""  # the bytes before offset (up to REWRITE_CHECK_BYTES)
        self._last_t: float | None = None

    # -- public -----------------------------------------------------------------------------

    def poll(self, now: float) -> list[Sample]:
        """Return the samples of the complete lines appended since the last poll.

        Args:
            now: the reader's time (seconds since the talk began), given to bare-value lines.

        Raises:
            ValueError: ``now`` is NaN or infinite.
        """
        return self._poll(_check_now(now))

    def changed(self) -> bool:
        """True when :meth:`poll` has something to look at: the file appeared, vanished, was
        replaced, or its size differs from what was read. One ``stat``; reads nothing."""
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            return self._ident is not None or not self._absent
        except OSError:
            return False  # reported by poll()
        if _key(st) == self._unreadable:
            return False
        return (st.st_dev, st.st_ino) != self._ident or st.st_size != self._offset

    def finish(self) -> None:
        """End of stream: an unterminated last line is dropped and reported as malformed.

        Every writer ends its lines, so such bytes are a line torn by a crash and may hold a
        truncated number (``12.5 15`` of ``12.5 153.25``); they are never parsed.
        """
        if self._pending or self._skipping:
            self._problem(self._line_no + 1, "incomplete last line (no newline), ignored")
            self._pending = b""
            self._skipping = False

    def stats(self) -> TailStats:
        """The counters so far."""
        return TailStats(
            samples=self._samples,
            malformed=self._malformed,
            truncations=self._truncations,
            replaced=self._replaced,
            out_of_order=self._out_of_order,
            missing=self._missing,
            beyond_talk=self._beyond,
        )

    def problems(self) -> list[StreamProblem]:
        """The most recent skipped lines, oldest first."""
        return list(self._problems)

    def first_out_of_order(self) -> StreamProblem | None:
        """The first sample whose ``t`` went back (kept, and counted as ``out_of_order``), as
        ``file:line: t=… goes back from …``; None when none did."""
        return self._first_back

    @property
    def line_no(self) -> int:
        """Complete lines read from the current file."""
        return self._line_no

    def __repr__(self) -> str:
        return f"StreamTailer({self._name!r}, {self.metric!r}, offset={self._offset})"

    # -- reading ----------------------------------------------------------------------------

    def _poll(self, now: float | None) -> list[Sample]:
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            self._on_missing()
            return []
        except OSError as e:
            self._on_error(e, None)
            return []
        if self._unreadable is not None:
            if _key(st) == self._unreadable:
                return []  # still the thing that failed: do not retry (and log) at every poll
            self._unreadable = None
        if not stat.S_ISREG(st.st_mode):
            # a FIFO would block the open, a device (a link to /dev/zero) never ends
            why = "not a regular file (a FIFO, a device or a folder?)"
            self._on_error(OSError(0, why), _key(st))
            return []
        ident = (st.st_dev, st.st_ino)
        if ident != self._ident:
            self._adopt(ident)
        elif st.st_size == self._offset:
            return []  # the common case: nothing new, one stat
        elif st.st_size < self._offset:
            self._restart_truncated(f"file shrank from {self._offset} to {st.st_size} bytes")
        try:
            fd = os.open(self.path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
            with os.fdopen(fd, "rb") as f:
                fst = os.fstat(f.fileno())
                if not stat.S_ISREG(fst.st_mode):  # swapped for a FIFO since the stat
                    raise OSError(0, "not a regular file (a FIFO, a device or a folder?)")
                if (fst.st_dev, fst.st_ino) != self._ident:  # replaced since the stat
                    self._adopt((fst.st_dev, fst.st_ino))
                if fst.st_size < self._offset:
                    self._restart_truncated(f"file shrank to {fst.st_size} bytes")
                data = self._read_new(f)
        except FileNotFoundError:
            self._on_missing()
            return []
        except OSError as e:
            self._on_error(e, _key(st))
            return []
        return self._feed(data, now) if data else []

    def _read_new(self, f: Any) -> bytes:
        # At most MAX_READ_BYTES a poll: the rest is read at the next one (a stream file that
        # grows without end cannot exhaust memory).
        if self._offset == 0:
            return bytes(f.read(MAX_READ_BYTES))
        # Read from a few bytes early: if they are not the ones read there before, the file was
        # rewritten in place (truncated, then grew past our offset between two polls).
        n = len(self._tail)
        f.seek(self._offset - n)
        data = bytes(f.read(MAX_READ_BYTES + n))
        if data[:n] == self._tail:
            return data[n:]
        self._restart_truncated("file rewritten in place")
        f.seek(0)
        return bytes(f.read(MAX_READ_BYTES))

    def _adopt(self, ident: tuple[int, int]) -> None:
        if self._ident is not None:
            self._replaced += 1
            log.info("%s: replaced by another file; reading from the start", self._name)
        elif self._absent:
            log.info("%s: appeared", self._name)
        if self._ident is not None:
            self._record_restart()
        self._ident = ident
        self._absent = False
        self._reset_position()

    def _restart_truncated(self, why: str) -> None:
        self._truncations += 1
        log.info("%s: %s; reading from the start", self._name, why)
        self._reset_position()
        self._record_restart()

    def _record_restart(self) -> None:
        # Line numbers start again: stamps recorded so far belong to the old content.
        if self._stamps_out is not None and self._stamps_out.exists():
            with open(self._stamps_out, "a", encoding="utf-8") as f:
                f.write("restart\n")

    def _on_missing(self) -> None:
        if self._ident is not None:
            self._record_restart()
        if self._ident is not None or not self._absent:
            self._missing += 1
            if self._ident is not None:
                log.warning("%s: file disappeared", self._name)
            else:
                log.debug("%s: does not exist (yet)", self._name)
        self._ident = None
        self._absent = True
        self._reset_position()

    def _on_error(self, e: OSError, key: tuple[int, ...] | None) -> None:
        # Unreadable (permissions, a directory at the path…): report it like a missing file,
        # so that a live talk goes on with the other modules. It is tried again once its stat
        # changes (ctime moves on chmod and on writes).
        if self._ident is not None or not self._absent:
            self._missing += 1
            log.warning("%s: cannot be read: %s", self._name, e.strerror or e)
        self._unreadable = key
        self._ident = None
        self._absent = True
        self._reset_position()

    # -- parsing (shared by poll and read_stream) -------------------------------------------

    def _warn_beyond(self, line_no: int, t: float, max_t: float) -> None:
        log.warning(
            "%s:%d: t=%g is after the talk's end (%.1f s); skipped (further ones only counted)",
            self._name,
            line_no,
            t,
            max_t,
        )

    def _feed_bulk(self, complete: bytes, now: float | None) -> list[Sample] | None:
        """A large read (a whole file replayed, a module that wrote a lot at once) in one go,
        when every line is exactly ``<t> <value>`` with one space, both finite numbers, in time
        order and within the clock limits, except for a tail stamped after the talk's end
        (counted, as the line-by-line way does). None when any of that does not hold: then
        the line-by-line way reads it and says what is wrong with which line.
        """
        raw = np.frombuffer(complete, dtype=np.uint8)
        newlines = np.flatnonzero(raw == 10)
        spaces = np.flatnonzero(raw == 32)
        n = len(newlines) + 1
        # one space per line, strictly inside it, and no other whitespace or control byte
        if len(spaces) != n or np.count_nonzero(raw <= 32) != len(newlines) + n:
            return None
        starts = np.empty(n, dtype=np.int64)
        starts[0] = 0
        starts[1:] = newlines + 1
        ends = np.empty(n, dtype=np.int64)
        ends[:-1] = newlines
        ends[-1] = len(complete)
        if not (
            np.all(spaces > starts)
            and np.all(spaces + 1 < ends)
            and int((ends - starts).max()) <= MAX_LINE_BYTES
        ):
            return None
        try:
            floats = list(map(float, complete.split()))
        except ValueError:
            return None
        values = np.array(floats, dtype=np.float64)
        ts = values[0::2]
        vs = values[1::2]
        lo = 0.0 if self._last_t is None else max(0.0, self._last_t)
        if not (np.isfinite(values).all() and ts[0] >= lo and np.all(ts[1:] >= ts[:-1])):
            return None
        if self.value_range is not None and not (vs.min() >= self._vlo and vs.max() <= self._vhi):
            return None  # a value outside the physical range: the line-by-line way names it
        max_t = self.max_t
        if self.max_ahead_s is not None and now is not None and ts[-1] > now + self.max_ahead_s:
            return None  # ahead of the talk clock: the line-by-line way names the lines
        keep = n
        if max_t is not None and ts[-1] > max_t:
            keep = int(np.searchsorted(ts, max_t, side="right"))
            if self._beyond == 0:
                self._warn_beyond(self._line_no + keep + 1, float(ts[keep]), max_t)
            self._beyond += n - keep
        self._line_no += n
        if keep:
            self._last_t = float(ts[keep - 1])
        # tuple.__new__ makes each Sample in C (Sample(...) runs the named tuple's __new__, a
        # Python function): the same objects in half the time, 108k of them in a 6-hour replay
        rows = zip(repeat(self.metric), floats[0 : 2 * keep : 2], floats[1 : 2 * keep : 2])
        return list(map(tuple.__new__, repeat(Sample), rows))

    def _feed(self, data: bytes, now: float | None) -> list[Sample]:
        self._offset += len(data)
        # Only the last bytes matter: never copy a whole (possibly large) read to keep them.
        self._tail = (self._tail + data[-REWRITE_CHECK_BYTES:])[-REWRITE_CHECK_BYTES:]
        buf = self._pending + data if self._pending else data
        cut = buf.rfind(b"\n")
        if cut < 0:
            self._keep_pending(buf)
            return []
        complete, rest = buf[:cut], buf[cut + 1 :]
        # Plain ASCII without "_": float() alone decides each field (parse_line's other checks
        # cannot fail), so lines take the short path below; a bad one still goes to parse_line
        # for its reason.
        plain = complete.isascii() and b"_" not in complete
        if plain and not self._skipping and len(complete) >= BULK_MIN_BYTES and not self._ahead_in:
            bulk = self._feed_bulk(complete, now)
            if bulk is not None:
                self._samples += len(bulk)
                self._keep_pending(rest)
                return bulk
        try:
            lines: Iterable[str | bytes] = complete.decode("utf-8").split("\n")
        except UnicodeDecodeError:
            lines = complete.split(b"\n")  # decode line by line to find the bad ones
        out: list[Sample] = []
        append = out.append
        metric = self.metric
        ahead = self.max_ahead_s
        max_t = self.max_t
        last_t = self._last_t
        recorded = self._stamps_in
        skipped_ahead = self._ahead_in
        vlo, vhi = self._vlo, self._vhi
        stamped: list[str] = []
        t: float | None
        if plain and not self._skipping and isinstance(lines, list):
            # The common case first: well-formed, in-order lines within the clock limits are
            # taken here; the first other line and everything after it go the general way.
            hi = math.inf if max_t is None else max_t
            if ahead is not None and now is not None:
                hi = min(hi, now + ahead)
            lo = -math.inf if last_t is None else last_t
            done = 0
            todo = lines
            if skipped_ahead:  # stop before the next line the coach skipped
                nxt = min((n for n in skipped_ahead if n > self._line_no), default=None)
                if nxt is not None:
                    todo = lines[: nxt - self._line_no - 1]
            for line in todo:
                fields = line.split()
                if len(fields) != 2 or len(line) > MAX_LINE_BYTES:
                    break
                try:
                    tf = float(fields[0])
                    value = float(fields[1])
                except ValueError:
                    break
                # x - x == 0.0 is false for inf and nan (a t of inf passes lo <= tf <= inf)
                if not (lo <= tf <= hi and tf - tf == 0.0 and tf >= 0.0 and value - value == 0.0):
                    break
                if not vlo <= value <= vhi:
                    break
                lo = tf
                append(Sample(metric, tf, value))
                done += 1
            if done:
                self._line_no += done
                last_t = lo
                lines = lines[done:]
        for raw in lines:
            self._line_no += 1
            if self._skipping:  # the end of an over-long line
                self._skipping = False
                self._problem(self._line_no, f"line longer than {MAX_LINE_BYTES} bytes")
                continue
            if isinstance(raw, bytes):
                try:
                    line = raw.decode("utf-8")
                except UnicodeDecodeError as e:
                    self._problem(self._line_no, f"not UTF-8: {e.reason} at byte {e.start + 1}")
                    continue
            else:
                line = raw
            if len(line) > MAX_LINE_BYTES:
                self._problem(self._line_no, f"line longer than {MAX_LINE_BYTES} bytes")
                continue
            fields = line.split() if plain else None
            if fields is not None and len(fields) == 2:
                try:
                    t = float(fields[0])
                    value = float(fields[1])
                except ValueError:
                    fields = None
                else:  # x - x == 0.0 is false for inf and nan
                    if not (t >= 0.0 and t - t == 0.0 and value - value == 0.0):
                        fields = None
            if fields is None or len(fields) != 2:
                if not line or line.isspace():
                    continue
                try:
                    t, value = parse_line(line)
                except StreamLineError as e:
                    self._problem(self._line_no, e.reason)
                    continue
            if not vlo <= value <= vhi:
                self._problem(
                    self._line_no,
                    f"value {value:g} is outside {metric}'s physical range {vlo:g}..{vhi:g}",
                )
                continue
            if t is None:  # bare value: stamped by the reader
                if self._line_no in recorded:
                    t = recorded[self._line_no]
                elif now is not None:
                    t = now
                else:
                    # read afterwards (rehearse, replay, report) with no time the coach gave
                    # it: when it was measured cannot be known
                    self._problem(self._line_no, _no_time_reason(line))
                    continue
                if self._stamps_out is not None:
                    stamped.append(f"{self._line_no} {t!r}\n")
            elif ahead is not None and now is not None and t > now + ahead:
                self._problem(self._line_no, _ahead_reason(t, now))
                if self._stamps_out is not None:  # so that a later reading skips it too
                    stamped.append(f"{self._line_no} ahead {now!r}\n")
                continue
            elif skipped_ahead and self._line_no in skipped_ahead:
                self._problem(self._line_no, _ahead_reason(t, skipped_ahead[self._line_no]))
                continue
            if max_t is not None and t > max_t:
                self._beyond += 1
                if self._beyond == 1:
                    self._warn_beyond(self._line_no, t, max_t)
                continue
            if last_t is not None and t < last_t:
                self._out_of_order += 1
                if self._out_of_order == 1:
                    reason = f"t={t:g} goes back from {last_t:g}"
                    self._first_back = StreamProblem(self._name, self._line_no, reason)
                    log.warning(
                        "%s:%d: t=%r goes back from %r (kept; further ones only counted)",
                        self._name,
                        self._line_no,
                        t,
                        last_t,
                    )
            last_t = t
            append(Sample(metric, t, value))
        self._last_t = last_t
        self._samples += len(out)
        if stamped and self._stamps_out is not None:
            try:
                with open(self._stamps_out, "a", encoding="utf-8") as f:
                    f.writelines(stamped)
            except OSError as e:  # the talk goes on; only the later rebuild loses the times
                log.warning("%s: cannot record stamps: %s", self._stamps_out, e.strerror or e)
        self._keep_pending(rest)  # after the lines: they end an over-long line being skipped
        return out

    def _keep_pending(self, rest: bytes) -> None:
        if self._skipping:
            return  # still inside an over-long line: drop its bytes
        if len(rest) > MAX_LINE_BYTES:
            self._skipping = True
            self._pending = b""
        else:
            self._pending = rest

    def _problem(self, line_no: int, reason: str) -> None:
        self._malformed += 1
        self._problems.append(StreamProblem(self._name, line_no, reason))
        self._logged += 1
        if self._logged <= MAX_LOGGED_PROBLEMS:
            log.warning("%s:%d: %s; line skipped", self._name, line_no, reason)
            if self._logged == MAX_LOGGED_PROBLEMS:
                log.warning("%s: further bad lines are counted but not logged", self._name)


def _no_time_reason(line: str) -> str:
    shown = line.strip()
    shown = shown if len(shown) <= 40 else shown[:40] + "…"
    return (
        f"no time stamp: {shown!r} (write '<t> <value>': only a live coach can time a bare value)"
    )


def _ahead_reason(t: float, now: float) -> str:
    return f"t={t:g} is ahead of the talk clock ({now:.3f} s)"


def stamps_path(path: str | os.PathLike[str]) -> Path:
    """The sidecar of a stream file where the coach keeps what it alone knew of its lines:
    the times it gave to bare-value lines (``<line> <t>``) and the lines it skipped as ahead
    of its clock (``<line> ahead <now>``); ``restart`` when the file began again."""
    p = Path(path)
    return p.with_name(p.name + ".stamps")


def _read_stamps(path: Path) -> tuple[dict[int, float], dict[int, float]]:
    """From a stamps sidecar, for the file's current content (after the last ``restart``):
    ``line -> t`` given to bare values, and ``line -> now`` of the lines skipped as ahead of
    the clock ``now``; unreadable lines in it are ignored."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return {}, {}
    out: dict[int, float] = {}
    ahead: dict[int, float] = {}
    for line in text.splitlines():
        if line == "restart":
            out.clear()
            ahead.clear()
            continue
        parts = line.split()
        into = out
        if len(parts) == 3 and parts[1] == "ahead":
            into, parts = ahead, [parts[0], parts[2]]
        try:
            n, t = int(parts[0]), float(parts[1])
        except (IndexError, ValueError):
            continue
        if math.isfinite(t):
            into[n] = t
    return out, ahead


def read_stream(
    path: str | os.PathLike[str],
    metric: str,
    *,
    now: float | None = None,
    problems: list[StreamProblem] | None = None,
    max_t: float | None = None,
    value_range: tuple[float, float] | None = None,
    out_of_order: list[StreamProblem] | None = None,
) -> tuple[list[Sample], TailStats]:
    """Read a whole stream file at once (report, replay, rebuild after a crash).

    Same parsing as :meth:`StreamTailer.poll` (it is one poll), followed by
    :meth:`StreamTailer.finish`: an unterminated last line is ignored and counted as malformed.
    Lines the coach skipped as ahead of its clock (noted in :func:`stamps_path`) are skipped
    and counted as malformed here too.
    A missing file gives no samples and ``missing == 1``.

    Args:
        path: the stream file.
        metric: the metric name given to the samples.
        now: the time given to bare ``<value>`` lines that have no recorded stamp (see
            :func:`stamps_path`); None: such a line is skipped and counted as malformed
            (``no time stamp: …``): read after the fact, nothing says when it was measured.
        problems: if given, the skipped lines (up to 100) are appended to it.
        max_t: samples stamped after this are skipped and counted as ``beyond_talk``.
        value_range: values outside ``(lo, hi)`` are skipped as malformed lines (see
            :class:`StreamTailer`); None accepts every finite value.
        out_of_order: if given, the first sample whose ``t`` went back (kept) is appended
            to it (:meth:`StreamTailer.first_out_of_order`).

    A path that is not a regular file (a FIFO, a device) gives no samples (``missing == 1``)
    and is never opened; at most :data:`MAX_STREAM_BYTES` are read.

    Returns:
        The samples in file order, and the counters.
    """
    tailer = StreamTailer(path, metric, max_t=max_t, value_range=value_range)
    tailer._stamps_in, tailer._ahead_in = _read_stamps(stamps_path(path))
    at = None if now is None else _check_now(now)
    samples = tailer._poll(at)
    while tailer._offset < MAX_STREAM_BYTES and tailer.changed():
        before = tailer._offset
        samples += tailer._poll(at)
        if tailer._offset <= before:
            break
    tailer.finish()
    if problems is not None:
        problems += tailer.problems()
    back = tailer.first_out_of_order()
    if out_of_order is not None and back is not None:
        out_of_order.append(back)
    return samples, tailer.stats()


# -- waiting for changes -----------------------------------------------------------------------


class _Watcher(Protocol):
    def block(self, timeout_s: float) -> bool:
        """Return when a watched name may have changed (True), or after at most ``timeout_s``
        (False: the caller must look for itself)."""

    def close(self) -> None: ...


class _PollWatcher:
    """No notifications: sleep one interval, then the caller stats the files."""

    def __init__(self, interval_s: float) -> None:
        self.interval_s = interval_s

    def block(self, timeout_s: float) -> bool:
        time.sleep(min(timeout_s, self.interval_s))
        return False

    def close(self) -> None:
        pass


# From <sys/inotify.h>; identical on every Linux architecture.
_IN_MODIFY = 0x002
_IN_ATTRIB = 0x004
_IN_CLOSE_WRITE = 0x008
_IN_MOVED_FROM = 0x040
_IN_MOVED_TO = 0x080
_IN_CREATE = 0x100
_IN_DELETE = 0x200
_IN_DELETE_SELF = 0x400
_IN_MOVE_SELF = 0x800
_IN_Q_OVERFLOW = 0x4000
_IN_IGNORED = 0x8000
_IN_ONLYDIR = 0x01000000
_DIR_MASK = (
    _IN_MODIFY
    | _IN_ATTRIB
    | _IN_CLOSE_WRITE
    | _IN_MOVED_FROM
    | _IN_MOVED_TO
    | _IN_CREATE
    | _IN_DELETE
    | _IN_DELETE_SELF
    | _IN_MOVE_SELF
    | _IN_ONLYDIR
)
_EVENT = struct.Struct("iIII")  # wd, mask, cookie, len; then len bytes of NUL-padded name


def _libc() -> Any:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        init1 = libc.inotify_init1
        add = libc.inotify_add_watch
    except (OSError, AttributeError):
        return None
    init1.argtypes = [ctypes.c_int]
    init1.restype = ctypes.c_int
    add.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_uint32]
    add.restype = ctypes.c_int
    return libc


_LIBC: Any = _libc()


def inotify_available() -> bool:
    """True where :class:`MultiTailer` can use inotify (Linux with a libc that has it)."""
    return _LIBC is not None


class _InotifyWatcher:
    """Watches directories for changes to given names; dirs that cannot be watched are polled."""

    def __init__(self, names: Mapping[str, set[str]], interval_s: float) -> None:
        fd = _LIBC.inotify_init1(os.O_NONBLOCK | os.O_CLOEXEC)
        if fd < 0:
            err = ctypes.get_errno()
            raise OSError(err, f"inotify_init1: {os.strerror(err)}")
        self._fd: int | None = fd
        self._names = names  # directory -> file names in it
        self._wd: dict[int, str] = {}
        self._unwatched = set(names)
        self.interval_s = interval_s
        self._poller = select.poll()
        self._poller.register(fd, select.POLLIN)
        self.refresh()

    def refresh(self) -> None:
        """Try again to watch directories that could not be watched (they did not exist)."""
        if self._fd is None:
            return
        for d in sorted(self._unwatched):
            wd = _LIBC.inotify_add_watch(self._fd, os.fsencode(d), _DIR_MASK)
            if wd >= 0:
                self._wd[wd] = d
                self._unwatched.discard(d)
            else:
                err = ctypes.get_errno()
                if err not in (errno.ENOENT, errno.ENOTDIR):
                    log.debug("inotify cannot watch %s (%s): polling it", d, os.strerror(err))

    def block(self, timeout_s: float) -> bool:
        fd = self._fd
        if fd is None:
            raise ValueError("the watcher is closed")
        self.refresh()
        if self._unwatched:
            timeout_s = min(timeout_s, self.interval_s)
        deadline = time.monotonic() + timeout_s
        while True:
            remaining = deadline - time.monotonic()
            # Poll even with no time left, so that block(0) consumes what is queued.
            if not self._poller.poll(max(0, math.ceil(remaining * 1000))):
                return False
            if self._drain(fd):
                return True
            if remaining <= 0:
                return False

    def _drain(self, fd: int) -> bool:
        """Read the queued events; True if one may concern a watched name."""
        relevant = False
        while True:
            try:
                buf = os.read(fd, 64 * 1024)
            except BlockingIOError:
                return relevant
            pos = 0
            while pos + _EVENT.size <= len(buf):
                wd, mask, _cookie, n = _EVENT.unpack_from(buf, pos)
                name = buf[pos + _EVENT.size : pos + _EVENT.size + n].rstrip(b"\0")
                pos += _EVENT.size + n
                if mask & _IN_Q_OVERFLOW:
                    relevant = True
                    continue
                d = self._wd.get(wd)
                if d is None:
                    continue
                if mask & _IN_IGNORED:  # the directory went away: poll it until it is back
                    del self._wd[wd]
                    self._unwatched.add(d)
                    relevant = True
                elif not name or os.fsdecode(name) in self._names[d]:
                    relevant = True

    def close(self) -> None:
        fd, self._fd = self._fd, None
        if fd is not None:
            self._poller.unregister(fd)
            os.close(fd)


class MultiTailer:
    """Follows the stream files of several metrics.

    Not thread-safe: call :meth:`poll` and :meth:`wait` from one thread. :meth:`close` (or
    ``with``) releases the inotify descriptor, which the first :meth:`wait` creates.

    Args:
        streams: metric name -> stream file.
        watch: how :meth:`wait` learns of changes: ``"inotify"`` (Linux), ``"poll"`` (``stat``
            every ``poll_interval_s``) or ``"auto"`` (inotify where available).
        poll_interval_s: the polling interval where nothing notifies.
        max_problems: recent problems kept per stream.
        max_ahead_s: lines stamped more than this after ``poll``'s ``now`` are skipped as
            malformed (see :class:`StreamTailer`); None keeps them.
        record_stamps: record the times given to bare-value lines (see :func:`stamps_path`).
        ranges: metric -> ``(lo, hi)``: values outside are skipped as bad lines (see
            :class:`StreamTailer`); a metric not in it accepts every finite value.

    Example::

        with MultiTailer(streams) as tails:
            while talking:
                tails.wait(0.5)
                processor.step(clock.now(), tails.poll(clock.now()))
    """

    def __init__(
        self,
        streams: Mapping[str, str | os.PathLike[str]],
        *,
        watch: WatchMode = "auto",
        poll_interval_s: float = 0.005,
        max_problems: int = 100,
        max_ahead_s: float | None = None,
        record_stamps: bool = False,
        ranges: Mapping[str, tuple[float, float]] | None = None,
    ) -> None:
        if watch not in ("auto", "inotify", "poll"):
            raise ValueError(f"watch must be 'auto', 'inotify' or 'poll', got {watch!r}")
        if watch == "inotify" and not inotify_available():
            raise ValueError("watch='inotify' needs Linux with inotify; use 'auto' or 'poll'")
        if not poll_interval_s > 0 or not math.isfinite(poll_interval_s):
            raise ValueError(f"poll_interval_s must be > 0, got {poll_interval_s!r}")
        self._tailers = {
            m: StreamTailer(
                p,
                m,
                max_problems=max_problems,
                max_ahead_s=max_ahead_s,
                record_stamps=record_stamps,
                value_range=(ranges or {}).get(m),
            )
            for m, p in streams.items()
        }
        self.watch = watch
        self.poll_interval_s = poll_interval_s
        self._watcher: _Watcher | None = None
        self._closed = False

    @property
    def tailers(self) -> Mapping[str, StreamTailer]:
        """The per-metric tailers."""
        return self._tailers

    def poll(self, now: float) -> list[Sample]:
        """New samples of every metric, sorted by ``t`` (ties keep the metrics' order).

        Raises:
            ValueError: ``now`` is NaN or infinite.
        """
        now = _check_now(now)
        out: list[Sample] = []
        for tailer in self._tailers.values():
            out.extend(tailer._poll(now))
        out.sort(key=attrgetter("t"))
        return out

    def stats(self) -> dict[str, TailStats]:
        """Counters per metric."""
        return {m: t.stats() for m, t in self._tailers.items()}

    def problems(self) -> list[StreamProblem]:
        """Recent skipped lines, stream by stream (in the metrics' order), oldest first."""
        return [p for t in self._tailers.values() for p in t.problems()]

    def changed(self) -> bool:
        """True when some stream has something new for :meth:`poll` (see
        :meth:`StreamTailer.changed`)."""
        return any(t.changed() for t in self._tailers.values())

    def wait(self, timeout_s: float) -> bool:
        """Block until a watched file changes or ``timeout_s`` passes.

        Returns at once when a file already changed since the last :meth:`poll`. Events that
        :meth:`poll` has already consumed do not wake it.

        Args:
            timeout_s: the longest wait in seconds (>= 0; ``math.inf`` waits for ever).

        Returns:
            True if a file changed (call :meth:`poll`), False on timeout.

        Raises:
            ValueError: a negative or NaN timeout, or the tailer is closed.
        """
        if not timeout_s >= 0:
            raise ValueError(f"timeout_s must be >= 0, got {timeout_s!r}")
        if self._closed:
            raise ValueError("MultiTailer is closed")
        watcher = self._get_watcher()
        deadline = time.monotonic() + timeout_s
        while True:
            # Checked after the watches exist, so a change between this check and the block
            # leaves an event queued and no wake-up is lost.
            if self.changed():
                return True
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return False
            watcher.block(min(remaining, 3600.0))

    def finish(self) -> None:
        """End of every stream (see :meth:`StreamTailer.finish`): a line left unterminated is
        counted as :func:`read_stream` counts it afterwards."""
        for tailer in self._tailers.values():
            tailer.finish()

    def close(self) -> None:
        """Release the watcher; a second call does nothing."""
        self._closed = True
        w, self._watcher = self._watcher, None
        if w is not None:
            w.close()

    def __enter__(self) -> MultiTailer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _get_watcher(self) -> _Watcher:
        if self._watcher is None:
            self._watcher = self._make_watcher()
        return self._watcher

    def _make_watcher(self) -> _Watcher:
        if self.watch == "poll" or (self.watch == "auto" and not inotify_available()):
            return _PollWatcher(self.poll_interval_s)
        names: dict[str, set[str]] = {}
        for t in self._tailers.values():
            # The directory as written, and the real one if a symlink leads elsewhere.
            for p in {os.path.abspath(t.path), os.path.realpath(t.path)}:
                d, name = os.path.split(p)
                names.setdefault(d, set()).add(name)
        try:
            return _InotifyWatcher(names, self.poll_interval_s)
        except OSError as e:
            if self.watch == "inotify":
                raise
            log.warning("inotify unavailable (%s); polling stream files instead", e)
            return _PollWatcher(self.poll_interval_s)


def newest_stamp(streams: Path, *, max_t: float = math.inf) -> float:
    """The newest sample time in any stream file of ``streams`` (0.0 when none): how far the
    modules have got. Only each file's last lines are read (4 kB), and only ``<t> <value>``
    lines count: a ``<value>`` line has no time of its own (the coach stamps it, in a
    ``.stamps`` file), and its value is not one. Stamps after ``max_t`` are passed over (a
    line the coach skips as ahead of its clock is no time the modules reached)."""
    return newest_stamp_of(streams.glob("*.txt"), max_t=max_t)


def newest_stamp_of(paths: Iterable[Path], *, max_t: float = math.inf) -> float:
    """:func:`newest_stamp` of the stream files ``paths`` (those missing count as empty): how
    far one module has got."""
    newest = 0.0
    for path in paths:
        try:
            with path.open("rb") as f:
                f.seek(max(0, path.stat().st_size - 4096))
                lines = f.read().split(b"\n")
        except OSError:
            continue
        for line in reversed(lines[:-1] if len(lines) > 1 else lines):
            fields = line.split()
            if len(fields) != 2:
                continue
            try:
                t = float(fields[0])
            except ValueError:
                continue
            if math.isfinite(t) and t <= max_t:
                newest = max(newest, t)
                break
    return newest
