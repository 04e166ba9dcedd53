"""The session folder: everything a talk leaves behind, and the one place that names its files.

::

    SESSION/
      session.json        what ran: scenario, seed, backend, config file, format version
      config.toml         the effective configuration (rebuild and replay use it)
      streams/<metric>.txt   one append-only file per module, "<t> <value>" per line
      streams/<metric>.txt.stamps  only for bare "<value>" lines: the time the coach gave each
      decisions.jsonl     a JSON line per decision point where a cue is chosen or something changes
      cues.jsonl          one JSON line per cue the robot performed, with its outcome
      truth.jsonl         synthetic talks only: when each metric was really out of range
      summary.json        per-metric and per-cue figures for the talk
      report/             the post-speech report (HTML, PNG, JSON)

The module files are the record: the report is rebuilt from ``streams/`` and ``cues.jsonl``,
so a crash loses nothing that was written.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

SESSION_FORMAT = 1


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

    def create(self, *, keep_streams: bool = False) -> SessionDir:
        """Make the folder (and ``streams/``); an existing session's files are replaced
        (its stream files too, unless ``keep_streams``: they are the talk's input)."""
        self.streams.mkdir(parents=True, exist_ok=True)
        for p in (self.decisions, self.cues, self.truth, self.summary):
            if p.exists():
                p.unlink()
        if not keep_streams:
            for p in self.streams.glob("*.txt"):
                p.unlink()
        return self

    def write_meta(self, meta: dict[str, Any]) -> None:
        data = {"format": SESSION_FORMAT, **meta}
        self.meta.write_text(dumps(data, indent=2, sort_keys=True) + "\n")

    def read_meta(self) -> dict[str, Any]:
        if not self.meta.exists():
            return {}
        data: dict[str, Any] = json.loads(self.meta.read_text())
        return data


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


def write_json(path: Path, data: Any) -> None:
    """Write JSON atomically enough for a summary: to a temp file, then rename."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(dumps(data, indent=2, sort_keys=True) + "\n")
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
            with self.path.open("a", encoding="utf-8") as f:
                f.write(text + "\n")
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


def read_jsonl(path: Path) -> list[dict[str, Any]]:
    """Read a JSONL file; a torn last line (crash mid-write) is ignored."""
    out: list[dict[str, Any]] = []
    if not path.exists():
        return out
    lines = path.read_text(encoding="utf-8").splitlines()
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            if i == len(lines) - 1:
                break
            raise
    return out
