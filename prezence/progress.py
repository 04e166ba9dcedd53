"""Progress across rehearsals: one speaker's sessions side by side, each metric's trend.

A speaker's sessions are the session folders in one folder: ``sessions/NAME/`` when the talks
were recorded with ``--speaker NAME`` (``prezence up --speaker ana`` writes into
``sessions/ana/live-<time>``), else the folder that holds the session (its parent). Replays are
left out: they are the same talk coached again. Each session's ``summary.json`` gives each
metric's time in the ideal range; sessions are ordered by when they were recorded.

``prezence progress DIR`` prints the table; the report of a session shows the same one.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from prezence.errors import ConfigError
from prezence.session import SessionDir, read_json_object

log = logging.getLogger(__name__)

#: A change in time in range smaller than this (fraction) is "steady".
STEADY = 0.05
#: At most this many sessions are compared (the most recent).
MAX_SESSIONS = 12
#: Kinds of session that are not a rehearsal of their own.
SKIPPED_KINDS = ("replay",)


def _when(s: SessionDir, meta: dict[str, Any]) -> float:
    t0 = meta.get("t0_epoch")
    if isinstance(t0, int | float) and not isinstance(t0, bool) and math.isfinite(t0):
        return float(t0)
    try:
        return s.meta.stat().st_mtime
    except OSError:
        return 0.0


def _left_out(path: Path, why: str, left_out: list[dict[str, str]] | None) -> None:
    log.info("%s: %s; left out of the progress table", path, why)
    if left_out is not None:
        left_out.append({"path": str(path), "why": why})


def find_sessions(
    folder: Path, *, left_out: list[dict[str, str]] | None = None
) -> list[tuple[float, SessionDir, dict[str, Any]]]:
    """The sessions of one speaker: ``folder``'s session sub-folders, or, when ``folder`` is a
    session itself, its parent's; oldest first, replays and unreadable ones left out.

    Each sub-folder left out is logged (``-v`` shows it) with the reason, and added to
    ``left_out`` as ``{"path", "why"}`` when that list is given.
    """
    folder = Path(folder)
    if SessionDir(folder).meta.is_file():
        folder = folder.parent
    if not folder.is_dir():
        raise ConfigError("no such folder", path=folder)
    found = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        s = SessionDir(sub)
        if not s.summary.is_file():
            if s.streams.is_dir() and any(f.stat().st_size for f in s.streams.glob("*.txt")):
                # `prezence report` reports on the streams but writes no summary.json
                _left_out(
                    sub,
                    "no summary.json (its talk did not finish?); `prezence report "
                    f"{sub}` still reports on its streams",
                    left_out,
                )
            else:
                _left_out(sub, "not a session folder (no summary.json, no streams)", left_out)
            continue
        if not s.meta.is_file():
            _left_out(sub, "no session.json: when and how it was recorded is unknown", left_out)
            continue
        try:
            meta = s.read_meta()
        except ConfigError as e:
            log.warning("%s; left out of the progress table", e)
            if left_out is not None:
                left_out.append({"path": str(sub), "why": str(e)})
            continue
        if meta.get("kind") in SKIPPED_KINDS:
            _left_out(sub, f"a {meta['kind']}, the same talk coached again", left_out)
            continue
        found.append((_when(s, meta), s, meta))
    found.sort(key=lambda x: x[0])
    for _when_s, s, _meta in found[:-MAX_SESSIONS]:
        _left_out(s.root, f"older than the {MAX_SESSIONS} most recent", left_out)
    return found[-MAX_SESSIONS:]


def time_in_range(path: Path, name: str, entry: Any) -> float | None:
    """A metric's ``time_in_range`` from ``summary.json``: a fraction in [0, 1], or None
    (not measured, or a value that is not one: refused with a warning naming file and key).

    Example:
        >>> time_in_range(Path("s/summary.json"), "speech_volume", {"time_in_range": 0.5})
        0.5
        >>> time_in_range(Path("s/summary.json"), "speech_volume", {"time_in_range": 7.5})
    """
    if not isinstance(entry, dict):
        if entry is not None:
            log.warning("%s: metrics.%s: not an object; left out for this rehearsal", path, name)
        return None
    tir = entry.get("time_in_range")
    if tir is None:
        return None  # not measured
    if isinstance(tir, int | float) and not isinstance(tir, bool) and 0.0 <= tir <= 1.0:
        return float(tir)  # NaN fails the comparison
    log.warning(
        "%s: metrics.%s.time_in_range: %r is not a number in [0, 1]; that metric is left out "
        "for this rehearsal",
        path,
        name,
        tir,
    )
    return None


def _trend(values: Sequence[float | None]) -> str:
    known = [v for v in values if v is not None]
    if len(known) < 2:
        return "–"
    d = known[-1] - known[0]
    if abs(d) < STEADY:
        return "steady"
    return f"{'better' if d > 0 else 'worse'} ({100 * d:+.0f} pts)"


def progress(folder: Path) -> dict[str, Any]:
    """``{"speaker", "sessions": [{"path", "label"}], "rows": [{"metric", "label", "values",
    "trend"}], "left_out": [{"path", "why"}]}``: each metric's time in range (0..1, None: no
    data) per session, and the sub-folders left out with the reason."""
    from prezence.report.build import metric_label

    left_out: list[dict[str, str]] = []
    sessions = find_sessions(folder, left_out=left_out)
    cols: list[dict[str, Any]] = []
    per: list[dict[str, Any]] = []
    for when, s, _meta in sessions:
        try:
            summ = read_json_object(s.summary)
        except ConfigError as e:
            log.warning("%s; left out of the progress table", e)
            left_out.append({"path": str(s.root), "why": str(e)})
            continue
        metrics = summ.get("metrics")
        if not isinstance(metrics, dict):
            log.warning("%s: metrics: not an object; no figures for this rehearsal", s.summary)
            metrics = {}
        per.append({str(k): time_in_range(s.summary, str(k), v) for k, v in metrics.items()})
        label = time.strftime("%d %b %H:%M", time.localtime(when))
        cols.append({"path": str(s.root), "label": label})
    names: list[str] = []
    for m in per:
        names += [k for k in m if k not in names]
    rows = []
    for name in names:
        values = [m.get(name) for m in per]
        rows.append(
            {"metric": name, "label": metric_label(name), "values": values, "trend": _trend(values)}
        )
    root = Path(folder)
    speaker = (root.parent if SessionDir(root).meta.is_file() else root).name
    return {"speaker": speaker, "sessions": cols, "rows": rows, "left_out": left_out}


def progress_for(session_root: Path) -> dict[str, Any] | None:
    """:func:`progress` of the folder holding ``session_root`` (None when it cannot be read)."""
    try:
        return progress(Path(session_root))
    except (ConfigError, OSError) as e:
        log.warning("progress across rehearsals left out: %s", e)
        return None


def format_progress(p: dict[str, Any]) -> str:
    """The progress table as text (``prezence progress DIR``)."""
    cols = p["sessions"]
    # a folder left out is said, with why: a missing rehearsal is not silently dropped
    notes = [f"left out: {Path(x['path']).name}: {x['why']}" for x in p.get("left_out") or []]
    if not cols:
        return "\n".join([f"no sessions with a summary.json in {p['speaker']}", *notes])
    w = max(12, *(len(c["label"]) for c in cols))
    head = f"{'metric':<20}" + "".join(f"{c['label']:>{w + 2}}" for c in cols) + "  trend"
    title = f"{len(cols)} rehearsals of {p['speaker']}, oldest first: time in the ideal range"
    lines = [title, head]
    for r in p["rows"]:
        cells = "".join(
            f"{('-' if v is None else f'{100 * v:.0f}%'):>{w + 2}}" for v in r["values"]
        )
        lines.append(f"{r['label']:<20}{cells}  {r['trend']}")
    lines += notes
    return "\n".join(lines)
