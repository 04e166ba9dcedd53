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


def find_sessions(folder: Path) -> list[tuple[float, SessionDir, dict[str, Any]]]:
    """The sessions of one speaker: ``folder``'s session sub-folders, or, when ``folder`` is a
    session itself, its parent's; oldest first, replays and unreadable ones left out."""
    folder = Path(folder)
    if SessionDir(folder).meta.is_file():
        folder = folder.parent
    if not folder.is_dir():
        raise ConfigError("no such folder", path=folder)
    found = []
    for sub in sorted(p for p in folder.iterdir() if p.is_dir()):
        s = SessionDir(sub)
        if not (s.meta.is_file() and s.summary.is_file()):
            continue
        try:
            meta = s.read_meta()
        except ConfigError as e:
            log.warning("%s; left out of the progress table", e)
            continue
        if meta.get("kind") in SKIPPED_KINDS:
            continue
        found.append((_when(s, meta), s, meta))
    found.sort(key=lambda x: x[0])
    return found[-MAX_SESSIONS:]


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
    "trend"}]}``: each metric's time in range (0..1, None: no data) per session."""
    from prezence.report.build import metric_label

    sessions = find_sessions(folder)
    cols: list[dict[str, Any]] = []
    per: list[dict[str, Any]] = []
    for when, s, _meta in sessions:
        try:
            summ = read_json_object(s.summary)
        except ConfigError as e:
            log.warning("%s; left out of the progress table", e)
            continue
        metrics = summ.get("metrics")
        per.append(metrics if isinstance(metrics, dict) else {})
        label = time.strftime("%d %b %H:%M", time.localtime(when))
        cols.append({"path": str(s.root), "label": label})
    names: list[str] = []
    for m in per:
        names += [k for k in m if k not in names]
    rows = []
    for name in names:
        values: list[float | None] = []
        for m in per:
            tir = m.get(name, {}).get("time_in_range") if isinstance(m.get(name), dict) else None
            values.append(float(tir) if isinstance(tir, int | float) else None)
        rows.append(
            {"metric": name, "label": metric_label(name), "values": values, "trend": _trend(values)}
        )
    root = Path(folder)
    speaker = (root.parent if SessionDir(root).meta.is_file() else root).name
    return {"speaker": speaker, "sessions": cols, "rows": rows}


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
    if not cols:
        return f"no sessions with a summary.json in {p['speaker']}"
    w = max(12, *(len(c["label"]) for c in cols))
    head = f"{'metric':<20}" + "".join(f"{c['label']:>{w + 2}}" for c in cols) + "  trend"
    title = f"{len(cols)} rehearsals of {p['speaker']}, oldest first: time in the ideal range"
    lines = [title, head]
    for r in p["rows"]:
        cells = "".join(
            f"{('-' if v is None else f'{100 * v:.0f}%'):>{w + 2}}" for v in r["values"]
        )
        lines.append(f"{r['label']:<20}{cells}  {r['trend']}")
    return "\n".join(lines)
