"""The session folder: everything a talk leaves behind, and the one place that names its files.

::

    SESSION/
      session.json        what ran: scenario, seed, backend, config file, format version
      config.toml         the effective configuration (rebuild and replay use it)
      gestures.toml       only with a gesture library of one's own (--gestures): a copy of it
      streams/<metric>.txt   one append-only file per module, "<t> <value>" per line
      streams/<metric>.txt.stamps  only for bare "<value>" lines (the time the coach gave
                          each) and lines the coach skipped as stamped ahead of its clock
      decisions.jsonl     a JSON line per decision point where a cue is chosen or something changes
      cues.jsonl          one JSON line per cue the robot performed, with its outcome
      truth.jsonl         synthetic talks only: when each metric was really out of range
      summary.json        per-metric and per-cue figures for the talk
      report/             the post-speech report (HTML, PNG, JSON)

The module files are the record: the report is rebuilt from ``streams/`` and ``cues.jsonl``,
so a crash loses nothing that was written.
"""

from __future__ import annotations

import errno
import json
import logging
import math
import os
import shutil
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from prezence.errors import ConfigError, PrezenceError

log = logging.getLogger(__name__)

SESSION_FORMAT = 1
#: The largest session.json / JSONL file read whole (a 3-hour talk's decisions.jsonl is ~10 MB).
MAX_JSON_BYTES = 256 * 1024 * 1024


def read_regular(path: Path, *, limit: int = MAX_JSON_BYTES) -> bytes:
    """The bytes of ``path``, which must be a regular file of at most ``limit`` bytes.

    A FIFO, a device (a link to ``/dev/zero``) or a folder is refused before it is opened, so
    nothing blocks and nothing unbounded is read.

    Raises:
        ConfigError: not a regular file, too big, or unreadable (the message names it).
        FileNotFoundError: it does not exist.
    """
    st = os.stat(path)
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError("not a regular file (a FIFO, a device or a folder?)", path=path)
    if st.st_size > limit:
        raise ConfigError(f"{st.st_size} bytes, more than the {limit} read", path=path)
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    with os.fdopen(fd, "rb") as f:
        data = f.read(limit + 1)
    if len(data) > limit:
        raise ConfigError(f"more than the {limit} bytes read", path=path)
    return data


def read_json_object(path: Path) -> dict[str, Any]:
    """A JSON file that must hold one object; a clear :class:`ConfigError` otherwise."""
    try:
        text = read_regular(path).decode("utf-8")
        data = json.loads(text)
    except UnicodeDecodeError as e:
        raise ConfigError(f"not UTF-8 text ({e.reason})", path=path) from None
    except json.JSONDecodeError as e:
        raise ConfigError(
            f"not valid JSON ({e.msg}; truncated?)", path=path, line=e.lineno, col=e.colno
        ) from None
    except RecursionError:
        raise ConfigError("JSON nested too deeply", path=path) from None
    except OSError as e:
        raise ConfigError(f"cannot read it ({e.strerror or e})", path=path) from None
    if not isinstance(data, dict):
        raise ConfigError(f"expected a JSON object {{...}}, found {type(data).__name__}", path=path)
    return data


@dataclass(frozen=True)
class SessionDir:
    """Paths inside one session folder."""

    root: Path

    @property
    def meta(self) -> Path:
        return self.root / "session.json"

    @property
    def config(self) -> Path:
        return self.root / "config.toml"

    @property
    def gestures(self) -> Path:
        """The copy of the gesture library of one's own the talk played (``--gestures``)."""
        return self.root / "gestures.toml"

    @property
    def streams(self) -> Path:
        return self.root / "streams"

    @property
    def decisions(self) -> Path:
        return self.root / "decisions.jsonl"

    @property
    def cues(self) -> Path:
        return self.root / "cues.jsonl"

    @property
    def truth(self) -> Path:
        return self.root / "truth.jsonl"

    @property
    def summary(self) -> Path:
        return self.root / "summary.json"

    @property
    def report(self) -> Path:
        return self.root / "report"

    def stream(self, filename: str) -> Path:
        return self.streams / filename

    def holds_recording(self) -> bool:
        """Whether the folder holds a talk that cannot be made again: anything but a synthetic
        talk (which its scenario and seed rebuild) with a ``session.json``, stream files or cues.
        """
        if not self.root.is_dir():
            return False
        recorded = (
            self.meta.exists()
            or self.cues.exists()
            or (self.streams.is_dir() and any(self.streams.glob("*.txt")))
        )
        if not recorded:
            return False
        try:
            kind = self.read_meta().get("kind")
        except PrezenceError:
            return True
        return kind != "synthetic"

    def create(self, *, keep_streams: bool = False) -> SessionDir:
        """Make the folder (and ``streams/``) for a new talk.

        A synthetic talk's old files are replaced (its scenario and seed make them again), its
        report removed; a folder that holds anything recorded is refused, never overwritten.

        ``keep_streams``: the folder's stream files are this talk's own input (a rehearsal just
        recorded into it): they are kept, and they do not make the folder refused.

        Raises:
            ConfigError: the folder holds a recorded talk (see :meth:`holds_recording`).
        """
        if not keep_streams and self.holds_recording():
            raise ConfigError(
                "holds a recorded talk; it is never overwritten: use another folder",
                path=self.root,
            )
        if not keep_streams and not self._synthetic():
            # Session 21, a second walkthrough: `run demo --out .` in a project folder replaced
            # the user's own config.toml (and its report/, which the next run then removed
            # whole). Only a synthetic talk's own files (its session.json says so) are replaced.
            theirs = [
                p.name + ("/" if p.is_dir() else "")
                for p in (
                    self.config,
                    self.summary,
                    self.decisions,
                    self.truth,
                    self.gestures,
                    self.report,
                )
                if p.exists()
            ]
            if theirs:
                raise ConfigError(
                    f"holds {', '.join(theirs)} but no talk that Prezence made again (no "
                    "session.json of a synthetic talk): a talk would overwrite them; give an "
                    "empty or new --out",
                    path=self.root,
                )
        try:
            self.streams.mkdir(parents=True, exist_ok=True)
            for p in (self.decisions, self.cues, self.truth, self.summary, self.gestures):
                if p.exists():
                    p.unlink()
            if not keep_streams:
                for p in [*self.streams.glob("*.txt"), *self.streams.glob("*.txt.stamps")]:
                    p.unlink()
                # the earlier synthetic talk's report (rebuilt from its files, now gone): a talk
                # run with --no-report would otherwise sit beside another talk's report. Only
                # in a folder a talk wrote: a report/ of one's own in any other --out is kept
                if self._synthetic() and self.report.is_dir() and not self.report.is_symlink():
                    shutil.rmtree(self.report)
        except OSError as e:
            raise folder_error(self.root, e) from None
        return self

    def _synthetic(self) -> bool:
        """The folder holds a synthetic talk (its ``session.json`` says so)."""
        try:
            return self.meta.is_file() and self.read_meta().get("kind") == "synthetic"
        except PrezenceError:
            return False

    def claim(self) -> FolderLock:
        """Make the folder and hold it for one talk: a second talk into the same folder at
        the same time (another process, a CI job beside this one) is refused instead of
        deleting this one's files under it and mixing both talks in one folder.

        The hold is a lock on the folder itself (no file is added to it); it ends with
        :meth:`FolderLock.release`, or with the process.

        Raises:
            ConfigError: the folder cannot be made (a file in the way, no permission) or
                another talk holds it.
        """
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise folder_error(self.root, e) from None
        return FolderLock.take(self.root)

    def write_meta(self, meta: dict[str, Any]) -> None:
        data = {"format": SESSION_FORMAT, **meta}
        self.meta.write_text(dumps(data, indent=2, sort_keys=True) + "\n")

    def read_meta(self) -> dict[str, Any]:
        """``session.json`` as a dict ({} when there is none).

        Raises:
            ConfigError: it is not a readable JSON object (truncated, a list, too big), or its
                ``format`` is not one this Prezence reads (a newer version wrote it); the
                message names the file.
        """
        if not self.meta.exists():
            return {}
        data = read_json_object(self.meta)
        check_format(data, self.meta)
        return data


def folder_error(root: Path, e: OSError, *, what: str = "session folder") -> ConfigError:
    """A session folder (or ``what``) that cannot be made or written, as one line naming it
    and why."""
    why = {
        errno.ENOTDIR: "a file is in the way (it, or a folder above it, is a file)",
        errno.EEXIST: "a file is in the way (it, or a folder above it, is a file)",
        errno.EACCES: "no permission to write there",
        errno.EPERM: "no permission to write there",
        errno.EROFS: "the disk is read-only",
        errno.ENOSPC: "the disk is full",
    }.get(e.errno or 0, e.strerror or str(e))
    where = f" ({e.filename})" if e.filename and Path(e.filename) != root else ""
    return ConfigError(f"cannot write the {what} here: {why}{where}; give another --out", path=root)


class FolderInUse(ConfigError):
    """Another process holds the folder (:class:`FolderLock`): it is writing into it now."""


class FolderLock:
    """A session (or evaluation) folder held by one process (an exclusive ``flock`` on it).

    It keeps other processes out. In this process a new holder takes the folder over, with no
    moment in which it is free: the talk from the command that claimed its folder
    (:func:`prezence.sessiondir.claim_session_dir`), or a new talk from an earlier one dropped
    unfinished (the Gymnasium environment's ``reset`` mid-episode).
    """

    #: The folders this process holds, by their real path.
    _held: dict[str, FolderLock] = {}

    def __init__(self, root: Path, fd: int | None) -> None:
        self.root = root
        self._fd = fd
        self._key = os.path.realpath(root)
        if fd is not None:
            FolderLock._held[self._key] = self

    @classmethod
    def take(cls, root: Path) -> FolderLock:
        """Hold ``root``, or raise :class:`FolderInUse` when another process holds it."""
        try:
            import fcntl
        except ImportError:  # no flock (Windows): not held
            return cls(root, None)
        earlier = cls._held.get(os.path.realpath(root))
        if earlier is not None and earlier._fd is not None:  # taken over, never let go between
            fd, earlier._fd = earlier._fd, None
            return cls(root, fd)
        try:
            fd = os.open(root, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
        except OSError as e:
            raise folder_error(root, e) from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as e:
            os.close(fd)
            if e.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                raise FolderInUse(
                    "another prezence process is writing into this folder right now (each talk "
                    "or evaluation needs a folder of its own): give another --out",
                    path=root,
                ) from None
            return cls(root, None)  # a file system without locks: not held
        return cls(root, fd)

    def release(self) -> None:
        """Let the folder go (again: nothing)."""
        fd, self._fd = self._fd, None
        if fd is not None:
            if FolderLock._held.get(self._key) is self:
                del FolderLock._held[self._key]
            os.close(fd)  # closing the last descriptor drops the flock

    def __del__(self) -> None:
        self.release()


def release_folder(root: Path) -> None:
    """Let ``root`` go if this process holds it (:class:`FolderLock`)."""
    held = FolderLock._held.get(os.path.realpath(root))
    if held is not None:
        held.release()


def check_format(data: dict[str, Any], path: Path) -> None:
    """Refuse a record whose ``format`` this Prezence does not read, as the config loader does
    (a missing ``format``: read as this version's).

    Example:
        >>> try:
        ...     check_format({"format": 2}, Path("s/session.json"))
        ... except ConfigError as e:
        ...     print(str(e)[:44])
        s/session.json: format: 2 is newer than this
    """
    fmt = data.get("format", SESSION_FORMAT)
    if fmt == SESSION_FORMAT and not isinstance(fmt, bool):
        return
    if isinstance(fmt, int) and not isinstance(fmt, bool) and fmt > SESSION_FORMAT:
        why = (
            f"{fmt} is newer than this Prezence reads (format {SESSION_FORMAT}): a newer "
            "version wrote it; update Prezence to read it"
        )
    else:
        why = f"{fmt!r} is not supported; this Prezence reads format {SESSION_FORMAT}"
    raise ConfigError(why, path=path, key="format")


def strict_json(obj: Any) -> Any:
    """``obj`` with every non-finite float (a time warning's infinite priority, a NaN mean)
    replaced by None, so that what is written is standard JSON that any parser reads."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: strict_json(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [strict_json(v) for v in obj]
    return obj


def dumps(obj: Any, **kwargs: Any) -> str:
    """``json.dumps`` of :func:`strict_json` of ``obj`` (never ``Infinity`` or ``NaN``)."""
    return json.dumps(strict_json(obj), allow_nan=False, **kwargs)


_ONE_LINE = json.JSONEncoder(allow_nan=False, sort_keys=True, separators=(", ", ": ")).encode


def _layout(obj: Any, depth: int) -> str:
    """``obj`` as JSON laid out for reading: an object's keys one per line (sorted, indented by
    two spaces a level), a list of objects or lists one item per line, anything else on one
    line: a record is one line to read or diff, and each line is written by json's C encoder
    (``indent=`` makes json use its Python encoder: 17 ms against 10 for a 6-hour talk's
    summary with 868 cues)."""
    pad = "  " * (depth + 1)
    if isinstance(obj, dict) and obj and all(isinstance(k, str) for k in obj):
        rows = [f"{pad}{_ONE_LINE(k)}: {_layout(obj[k], depth + 1)}" for k in sorted(obj)]
        return "{\n" + ",\n".join(rows) + "\n" + "  " * depth + "}"
    if isinstance(obj, list | tuple) and any(isinstance(v, dict | list | tuple) for v in obj):
        return "[\n" + ",\n".join(pad + _ONE_LINE(v) for v in obj) + "\n" + "  " * depth + "]"
    return _ONE_LINE(obj)


def write_json(path: Path, data: Any) -> None:
    """Write JSON (standard: :func:`strict_json`), laid out for reading (keys one per line, a
    list of records one record per line), atomically enough for a summary: to a temp file,
    then rename."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    try:  # json's encoder refuses a non-finite float: only then is every value walked
        text = _layout(data, 0)
    except ValueError:
        text = _layout(strict_json(data), 0)
    tmp.write_text(text + "\n")
    tmp.replace(path)


_ENCODE = json.JSONEncoder(allow_nan=False, separators=(",", ":")).encode


class JsonlWriter:
    """Append one JSON object per line.

    ``flush=True`` (cues): each line is appended and the file closed at once, so a crash keeps
    every finished line and nothing stays open between lines. ``flush=False`` (the decision
    log, written many times a second): the file is opened at the first line and buffered; a
    crash loses at most the buffer's last lines, never a cue.
    """

    def __init__(self, path: Path, *, flush: bool = True) -> None:
        self.path = path
        self._flush = flush
        self._f: IO[str] | None = None
        self._closed = False
        if flush:
            path.touch()

    def write(self, obj: dict[str, Any]) -> None:
        """One line; keys in the record's own order."""
        try:
            text = _ENCODE(obj)
        except ValueError:  # an infinite priority or a NaN mean: standard JSON says null
            text = json.dumps(strict_json(obj), allow_nan=False, separators=(",", ":"))
        if self._flush:
            # one append per line, the file closed at once, without the text-file layers
            # (a 6-hour replay appends 868 cues)
            data = (text + "\n").encode("utf-8")
            fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
            try:
                while data:
                    data = data[os.write(fd, data) :]
            finally:
                os.close(fd)
            return
        if self._f is None:
            if self._closed:
                raise ValueError(f"{self.path}: written after close()")
            self._f = self.path.open("a", encoding="utf-8")
        self._f.write(text + "\n")

    def close(self) -> None:
        self._closed = True
        if self._f is not None and not self._f.closed:
            self._f.close()


#: Keys each line of ``truth.jsonl`` must have, and their types.
TRUTH_KEYS: dict[str, Any] = {"metric": str, "start": (int, float), "end": (int, float)}
#: Keys each line of ``cues.jsonl`` must have.
CUE_KEYS: dict[str, Any] = {"t": (int, float), "command": str}


def read_jsonl(
    path: Path,
    *,
    require: dict[str, Any] | None = None,
    skipped: list[str] | None = None,
) -> list[dict[str, Any]]:
    """Read a JSONL file of objects; a torn last line (crash mid-write) is ignored.

    Args:
        require: keys each object must have, with their type(s) (numbers must be finite):
            :data:`TRUTH_KEYS` for ``truth.jsonl``, :data:`CUE_KEYS` for ``cues.jsonl``.
        skipped: if given, a bad line anywhere (and a torn last line) is not an error: it is
            logged as a warning, appended here as ``file:line: why`` and skipped (the report
            is built from the rest; the file is left as it is).

    Raises:
        ConfigError: without ``skipped``, a line before the last is not a JSON object
            (``file:line: why``); in any case, the file is not a regular file of bounded size.
    """
    out: list[dict[str, Any]] = []
    if not path.exists():
        return out
    try:
        text = read_regular(path).decode("utf-8", errors="replace")
    except OSError as e:
        raise ConfigError(f"cannot read it ({e.strerror or e})", path=path) from None
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        torn = i == len(lines) - 1 and not text.endswith("\n")
        try:
            obj = _jsonl_object(line, require)
        except ValueError as e:
            if skipped is not None:
                why = f"{e}{'; the last line is incomplete (no newline)' if torn else ''}"
                err = ConfigError(f"{why}; line skipped", path=path, line=i + 1)
                log.warning("%s", err)
                skipped.append(str(err))
                continue
            if torn:
                break  # torn last line
            raise ConfigError(str(e), path=path, line=i + 1) from None
        out.append(obj)
    return out


def _jsonl_object(line: str, require: dict[str, Any] | None) -> dict[str, Any]:
    """One line of a JSONL file as an object with the ``require``d keys.

    Raises:
        ValueError: why it is not (the caller adds the file and line).
    """
    try:
        obj = json.loads(line)
    except (json.JSONDecodeError, RecursionError) as e:
        why = e.msg if isinstance(e, json.JSONDecodeError) else "nested too deeply"
        raise ValueError(f"not a JSON line ({why})") from None
    if not isinstance(obj, dict):
        raise ValueError(f"expected a JSON object {{...}}, found {type(obj).__name__}")
    for key, kind in (require or {}).items():
        v = obj.get(key)
        ok = isinstance(v, kind) and not isinstance(v, bool)
        if ok and isinstance(v, float):
            ok = math.isfinite(v)
        if not ok:
            raise ValueError(f"{key!r} missing or not a {'string' if kind is str else 'number'}")
    return obj


#: No talk is longer than this (seconds): the cap when a folder has no record of its length.
MAX_TALK_S = 6 * 3600.0
#: Samples stamped up to this long after the talk's recorded end are still read (a module's
#: last window is written after the coach stopped).
TALK_MARGIN_S = 30.0


def _tail_lines(path: Path, size: int) -> list[bytes]:
    """The complete lines among the last ``size`` bytes of a regular file ([] for anything
    else): a line cut by the start of the read is left out."""
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            return []
        with open(path, "rb") as f:
            f.seek(max(0, st.st_size - size))
            tail = f.read(size)
    except OSError:
        return []
    lines = tail.splitlines()
    return lines[1:] if st.st_size > size else lines


def _last_decision_t(path: Path) -> float | None:
    """The ``t`` of the last complete line of ``decisions.jsonl`` (reads its last 64 KB)."""
    for line in reversed(_tail_lines(path, 65536)):
        try:
            t = json.loads(line).get("t")
            return float(t) if t is not None and math.isfinite(float(t)) else None
        except (ValueError, AttributeError, TypeError, RecursionError):
            continue
    return None


def _last_stamp(path: Path) -> float | None:
    """The time of the last stamped line of a stream file (reads its last 4 KB), if at most
    :data:`MAX_TALK_S`: a stamp beyond it is a module's clock gone wrong, not the talk's end."""
    from prezence.streams.codec import parse_line

    for line in reversed(_tail_lines(path, 4096)):
        try:
            t, _ = parse_line(line.decode("utf-8"))
        except (UnicodeDecodeError, PrezenceError):
            continue
        return t if t is not None and t <= MAX_TALK_S else None
    return None


def recorded_talk_s(session: SessionDir, meta: dict[str, Any]) -> float | None:
    """How long the talk lasted by the session's own record, not by its samples' stamps.

    ``session.json``'s ``talk_s``; after a coach crash (no ``talk_s``), the last write to the
    folder's files minus the talk's start (``t0_epoch``), or, with no start time either, the
    last decision's time or the last stream sample's, whichever is later (a guessed end never
    cuts off recorded samples); None when the folder keeps no such record (stream files from
    elsewhere). At most :data:`MAX_TALK_S`.
    """
    t = meta.get("talk_s")
    if isinstance(t, int | float) and not isinstance(t, bool) and math.isfinite(t) and t >= 0:
        return min(float(t), MAX_TALK_S)
    found: list[float] = []
    t0 = meta.get("t0_epoch")
    if isinstance(t0, int | float) and not isinstance(t0, bool) and math.isfinite(t0):
        files = [session.cues, session.decisions]
        if session.streams.is_dir():
            files += [p for p in session.streams.glob("*.txt")]
        mtimes = []
        for p in files:
            try:
                st = os.stat(p)
            except OSError:
                continue
            if stat.S_ISREG(st.st_mode):
                mtimes.append(st.st_mtime)
        if mtimes:
            found.append(max(mtimes) - float(t0))
    no_start = not found
    last = _last_decision_t(session.decisions)
    if last is not None:
        found.append(last)
        if no_start and session.streams.is_dir():
            # No start time: the last decision is only a lower bound (decisions.jsonl is
            # written when something changes), so the talk lasted at least to its last sample.
            stamps = (_last_stamp(p) for p in session.streams.glob("*.txt"))
            found += [t for t in stamps if t is not None]
    if not found:
        return None
    return min(max(0.0, max(found)), MAX_TALK_S)


def sample_time_limit(session: SessionDir, meta: dict[str, Any]) -> float:
    """The latest sample time worth reading: the recorded length plus :data:`TALK_MARGIN_S`,
    or :data:`MAX_TALK_S` when the folder keeps no record of its length."""
    rec = recorded_talk_s(session, meta)
    return MAX_TALK_S if rec is None else rec + TALK_MARGIN_S
