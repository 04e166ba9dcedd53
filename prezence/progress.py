"""Progress across rehearsals: one speaker's sessions side by side, each metric's trend.

The sessions compared are session folders in one folder (``sessions/NAME/`` with ``--speaker
NAME``: ``prezence up --speaker ana`` writes into ``sessions/ana/live-<time>``), grouped by who
was rehearsing: the speaker ``session.json`` records (``--speaker`` on ``up`` and
``rehearse``); for a synthetic talk, its scenario (a persona is one speaker; two personas are
not); else, as before speakers were recorded, the folder (joined to the speaker of that
folder's name). Replays are left out: they are the same talk coached again. Each session's
``summary.json`` gives each metric's time in the ideal range (one that cannot be read, torn
mid-write, has its figures rebuilt from the streams as ``prezence report`` rebuilds them, and
said so); sessions are ordered by when they were recorded.

A metric the report did not judge (measured for less than 10 s: ``too_brief``) has no figure
("–*", a note says why) and is left out of the trend. The trend is the newest rehearsal against
the one before; a metric out of its band for a good part of a talk says on which side ("0%
high").

A time in range holds only for the band it was judged by (``config.toml``): a metric judged by
another band than in the newest rehearsal is marked and left out of its trend, with a note.

``prezence progress DIR`` prints one table per speaker; the report of a session shows its own.
"""

from __future__ import annotations

import contextvars
import logging
import math
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from prezence.config.model import Rule
from prezence.errors import ConfigError, PrezenceError
from prezence.session import SessionDir, read_json_object

log = logging.getLogger(__name__)

#: A change in time in range smaller than this (fraction) is "steady".
STEADY = 0.05
#: At most this many sessions are compared (the most recent).
MAX_SESSIONS = 12
#: Kinds of session that are not a rehearsal of their own.
SKIPPED_KINDS = ("replay",)


def _when(s: SessionDir, meta: dict[str, Any]) -> float:
    """When the talk was run: ``session.json``'s ``t0_epoch`` (live) or ``started_at`` (every
    talk since session 15), else, for an older folder, ``session.json``'s modification time
    (which a copy without its times resets)."""
    for key in ("t0_epoch", "started_at"):
        t0 = meta.get(key)
        if isinstance(t0, int | float) and not isinstance(t0, bool) and math.isfinite(t0):
            return float(t0)
    try:
        return s.meta.stat().st_mtime
    except OSError:
        return 0.0


def speaker_of(folder: Path, meta: dict[str, Any]) -> tuple[str, str]:
    """Who rehearsed the session in ``folder``: a key that groups sessions, and a name.

    Example:
        >>> speaker_of(Path("s/x"), {"speaker": "ana", "kind": "live"})
        ('speaker:ana', 'ana')
        >>> speaker_of(Path("s/x"), {"kind": "synthetic", "scenario": "fast_talker"})
        ('scenario:fast_talker', 'fast_talker (a synthetic persona)')
        >>> speaker_of(Path("sessions/live-1"), {"kind": "live"})
        ('folder:sessions', 'the talks in sessions with no speaker recorded')
    """
    name = meta.get("speaker")
    if isinstance(name, str) and name:
        return f"speaker:{name}", name
    scenario = meta.get("scenario")
    if meta.get("kind") == "synthetic" and isinstance(scenario, str) and scenario:
        return f"scenario:{scenario}", f"{scenario} (a synthetic persona)"
    parent = Path(folder).parent
    return f"folder:{parent}", f"the talks in {parent} with no speaker recorded"


def _left_out(path: Path, why: str, left_out: list[dict[str, str]] | None) -> None:
    log.info("%s: %s; left out of the progress table", path, why)
    if left_out is not None:
        left_out.append({"path": str(path), "why": why})


def find_sessions(
    folder: Path, *, left_out: list[dict[str, str]] | None = None
) -> list[tuple[float, SessionDir, dict[str, Any]]]:
    """The sessions of one speaker, oldest first: when ``folder`` is a session, its parent's
    sessions by the same speaker as it (:func:`speaker_of`; [] when it is itself left out, a
    replay); else those of the speaker of ``folder``'s newest session. See
    :func:`find_all_sessions`.
    """
    return _group(Path(folder), left_out)[1]


def _group(
    folder: Path, left_out: list[dict[str, str]] | None
) -> tuple[str, list[tuple[float, SessionDir, dict[str, Any]]]]:
    """(the speaker's name, their sessions) for :func:`find_sessions`."""
    if not SessionDir(folder).meta.is_file():
        groups = find_all_sessions(folder, left_out=left_out)
        return (groups[-1][0][1], groups[-1][1]) if groups else (folder.name, [])
    groups = find_all_sessions(folder.parent, left_out=left_out)
    mine = folder.resolve()
    for (_key, name), found in groups:
        if any(s.root.resolve() == mine for _, s, _ in found):
            return name, found
    return folder.name, []


def find_all_sessions(
    folder: Path, *, left_out: list[dict[str, str]] | None = None
) -> list[tuple[tuple[str, str], list[tuple[float, SessionDir, dict[str, Any]]]]]:
    """``folder``'s session sub-folders grouped by speaker (:func:`speaker_of`), each group
    oldest first and the groups by their newest session; replays and unreadable ones left out.
    A sub-folder that is no session but holds sessions (``sessions/NAME``, which ``--speaker
    NAME`` writes into) is looked into: its sessions count as ``folder``'s.

    Each sub-folder left out is logged (``-v`` shows it) with the reason, and added to
    ``left_out`` as ``{"path", "why"}`` when that list is given.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise ConfigError("no such folder", path=folder)
    found = []
    subs = sorted(p for p in folder.iterdir() if p.is_dir())
    for speaker_dir in [p for p in subs if _holds_sessions(p)]:
        # `--speaker NAME` writes sessions/NAME/<talk>: a speaker's folder, looked into
        subs.remove(speaker_dir)
        subs += sorted(p for p in speaker_dir.iterdir() if p.is_dir())
    for sub in subs:
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
                _left_out(
                    sub,
                    "not a session folder (no summary.json, no streams) and no sessions in it",
                    left_out,
                )
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
    groups: dict[tuple[str, str], list[tuple[float, SessionDir, dict[str, Any]]]] = {}
    named = {speaker_of(s.root, m)[0] for _, s, m in found}
    for item in found:
        who = speaker_of(item[1].root, item[2])
        parent = item[1].root.parent
        if who[0] == f"folder:{parent}" and f"speaker:{parent.name}" in named:
            # --speaker NAME wrote into sessions/NAME before session.json recorded the name
            who = (f"speaker:{parent.name}", parent.name)
        groups.setdefault(who, []).append(item)
    out = []
    for who, items in groups.items():
        for _when_s, s, _meta in items[:-MAX_SESSIONS]:
            _left_out(s.root, f"older than the {MAX_SESSIONS} most recent", left_out)
        out.append((who, items[-MAX_SESSIONS:]))
    out.sort(key=lambda g: g[1][-1][0])
    return out


def _holds_sessions(folder: Path) -> bool:
    """Whether ``folder`` is not a session but holds sessions: a speaker's folder
    (``sessions/NAME`` that ``--speaker NAME`` writes into)."""
    s = SessionDir(folder)
    if s.summary.is_file() or s.meta.is_file() or s.streams.is_dir():
        return False
    return any(
        SessionDir(p).summary.is_file() or SessionDir(p).meta.is_file()
        for p in folder.iterdir()
        if p.is_dir()
    )


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


def not_judged_why(entry: Any) -> str | None:
    """Why a metric's figure in ``summary.json`` was not judged (the report neither praised
    nor advised on it), None when it was or when there is no figure: measured for less than
    :data:`prezence.summary.MIN_JUDGED_S` (``too_brief``), or for no time at all.

    Example:
        >>> not_judged_why({"time_in_range": 0.0, "in_range_s": 0.0, "out_of_range_s": 0.0,
        ...                 "too_brief": True})
        'measured for only 0 s, under the 10 s needed to judge it'
        >>> not_judged_why({"time_in_range": 0.8, "in_range_s": 40.0, "out_of_range_s": 10.0})
    """
    from prezence.report.speech import too_brief_words

    if not isinstance(entry, dict) or entry.get("time_in_range") is None:
        return None
    in_s, out_s = _number(entry.get("in_range_s")), _number(entry.get("out_of_range_s"))
    measured = None if in_s is None or out_s is None else in_s + out_s
    if entry.get("too_brief") or (measured is not None and not measured > 0.0):
        return too_brief_words(measured or 0.0)
    return None


def off_side(entry: Any) -> str | None:
    """``"low"`` or ``"high"``: the side of its band a metric was mostly out on, when it was out
    for :data:`prezence.report.build.SLIGHTLY_OFF_SHARE` or more of the time it was measured
    (what the report calls a little off or to work on); None otherwise or when not recorded.

    Example:
        >>> off_side({"time_in_range": 0.0, "below_s": 0.0, "above_s": 60.0})
        'high'
        >>> off_side({"time_in_range": 0.9, "below_s": 6.0, "above_s": 0.0})
    """
    from prezence.report.build import SLIGHTLY_OFF_SHARE

    if not isinstance(entry, dict):
        return None
    tir, below, above = (_number(entry.get(k)) for k in ("time_in_range", "below_s", "above_s"))
    if tir is None or below is None or above is None:
        return None
    if 1.0 - tir < SLIGHTLY_OFF_SHARE or not below + above > 0.0:
        return None
    return "low" if below >= above else "high"


def _number(x: Any) -> float | None:
    return float(x) if isinstance(x, int | float) and not isinstance(x, bool) else None


def _trend(values: Sequence[float | None], sides: Sequence[str | None] | None = None) -> str:
    """The newest rehearsal against the one before it (both judged, by the same band).

    Not the first against the newest: 0 % too fast, 100 %, 0 % too slow is no "steady". When
    the two were out of their band on different sides, that is said too.

    Example:
        >>> _trend([0.0, 1.0, 0.0], ["high", None, "low"])
        'worse (-100 pts)'
        >>> _trend([0.0, None, 0.0], ["high", None, "low"])
        'steady, but from high to low'
        >>> _trend([0.5, 0.9])
        'better (+40 pts)'
    """
    sides = sides if sides is not None else [None] * len(values)
    known = [(v, side) for v, side in zip(values, sides, strict=True) if v is not None]
    if len(known) < 2:
        return "–"
    (before, was_side), (now, now_side) = known[-2], known[-1]
    d = now - before
    text = "steady" if abs(d) < STEADY else f"{'better' if d > 0 else 'worse'} ({100 * d:+.0f} pts)"
    if was_side and now_side and was_side != now_side:
        text += f", but from {was_side} to {now_side}"
    return text


def median_move(rule: Rule, medians: Sequence[float | None], sides: Sequence[str | None]) -> str:
    """What a "steady" trend leaves out: the newest rehearsal's median reading (``p50``, as
    judged: a rule's offset is in it) against the one before's (the two the trend compares:
    ``medians`` holds theirs alone), when both were out of the band on the same side and the median
    moved nearer to it or further from it by more than the module's stated measurement error
    (:func:`prezence.report.build.error_margins`); "" otherwise (no error stated, no median
    recorded, in range, or a move within the error).

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180, unit="wpm")
        >>> median_move(r, [232.0, 190.0], ["high", "high"])
        ', but its median read nearer the range (232 then 190 wpm)'
        >>> median_move(r, [232.0, 228.0], ["high", "high"])
        ''
    """
    from prezence.report.build import error_margins

    margins = error_margins(rule)
    known = [(m, side) for m, side in zip(medians, sides, strict=True) if m is not None]
    if margins is None or len(known) < 2:
        return ""
    (before, was_side), (now, now_side) = known[-2], known[-1]
    if was_side is None or was_side != now_side:
        return ""
    side = "below" if now_side == "low" else "above"
    bound = rule.low if side == "below" else rule.high
    if bound is None:
        return ""
    margin = margins[0] if side == "below" else margins[1]

    def out(v: float) -> float:  # how far out of the band (``p50`` is as judged: offset in)
        return max(0.0, bound - v) if side == "below" else max(0.0, v - bound)

    moved = out(now) - out(before)
    if abs(moved) <= margin:
        return ""
    unit = f" {rule.unit}" if rule.unit else ""
    where = "nearer the range" if moved < 0 else "further from the range"
    return f", but its median read {where} ({before:.4g} then {now:.4g}{unit})"


def _rules(s: SessionDir) -> dict[str, Rule] | None:
    """Each metric's rule as ``config.toml`` judged the talk, None when the file is missing
    or cannot be read (the bands are then unknown)."""
    if not s.config.is_file():
        return None
    from prezence.config.load import load_config

    try:
        cfg = load_config(s.config)
    except PrezenceError as e:
        log.warning("%s; its bands are unknown", e)
        return None
    return {r.metric: r for r in cfg.rules}


def at_edge(rule: Rule | None, entry: Any) -> bool:
    """Whether a metric's ``summary.json`` figures put its median reading (``p50``) out of its
    band by less than its module's measurement error (the report's "at the edge": it may have
    been in range; :func:`prezence.report.build.edge_reading`); False without the rule.

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
        >>> at_edge(r, {"p50": 138.5}), at_edge(r, {"p50": 120.0}), at_edge(None, {"p50": 1})
        (True, False, False)
    """
    from prezence.report.build import edge_reading

    return rule is not None and isinstance(entry, dict) and edge_reading(rule, entry) is not None


def _edges(s: SessionDir, metrics: Mapping[str, Any], rules: Mapping[str, Rule] | None) -> set[str]:
    """The metrics a rehearsal's report says may have been in range (its ``at_edge``): of
    those whose median reading :func:`at_edge` puts within the error of the band, the ones
    the report did not list to work on or as a little off (cued, strict, or out by more than
    the error for long enough: session 25's review found one marked "0% low~" beside "Work
    first on this: pick up the pace"). The report's own code decides (rebuilt from the
    streams, as ``prezence report`` does), for such a rehearsal only, and for one whose
    ``summary.json`` was written before it recorded the median (``p50``), of a metric marked
    low or high whose module states an error; none when it fails. Also those marked low or
    high with the median in range whose report puts them in or near range, every reading out
    within the error (session 26)."""
    from prezence.report.build import _median_in_band, build_report, error_margins

    near = {str(k) for k, v in metrics.items() if at_edge((rules or {}).get(str(k)), v)}
    near |= {  # an old summary.json: the report rebuilds the median from the streams
        str(k)
        for k, v in metrics.items()
        if isinstance(v, dict)
        and "p50" not in v
        and off_side(v)
        and (rule := (rules or {}).get(str(k))) is not None
        and error_margins(rule) is not None
    }
    # marked low / high with its median in range: the report calls it in or near range when
    # every reading out was within the error (session 26's review: 136 and 184 wpm by turns
    # read "0% low" beside "stayed in or near the ideal range … by less than my measuring
    # error")
    inside = {
        str(k)
        for k, v in metrics.items()
        if isinstance(v, dict)
        and off_side(v)
        and (rule := (rules or {}).get(str(k))) is not None
        and error_margins(rule) is not None
        and _median_in_band(rule, v)
    }
    if not near and not inside:
        return set()

    token = _QUIET.set(True)  # what the rebuild finds is the report's to say, not the table's
    try:
        report = build_report(s.root)
    except (PrezenceError, OSError) as e:
        log.warning("%s: its report could not be rebuilt (%s); no metric marked ~", s.root, e)
        return set()
    finally:
        _QUIET.reset(token)
    said = report.get("at_edge") or []
    within = {  # in or near range, every reading out within the error
        str(r.get("metric"))
        for r in report.get("near_range") or []
        if isinstance(r, Mapping)
        and r.get("within_error_s") is not None
        and float(r["within_error_s"])
        >= sum(float(x.get("out_s") or 0.0) for x in r.get("sides") or []) - 0.05
    }
    return (near & {str(r.get("metric")) for r in said if isinstance(r, Mapping)}) | (
        inside & within
    )


def _band_text(rule: Rule) -> str:
    """``"140–180 wpm"``, ``"≥ 60 dB"``; an offset is part of the band (``+3``)."""
    unit = f" {rule.unit}" if rule.unit else ""
    if rule.low is not None and rule.high is not None:
        text = f"{rule.low:g}–{rule.high:g}{unit}"
    elif rule.low is not None:
        text = f"≥ {rule.low:g}{unit}"
    else:
        text = f"≤ {rule.high:g}{unit}"
    return text + (f" (offset {rule.offset:+g})" if rule.offset else "")


def progress(folder: Path) -> dict[str, Any]:
    """One speaker's table: of the session ``folder`` and its parent's sessions by the same
    speaker, or of the speaker of the newest session in the folder ``folder``.

    Returns:
        ``{"speaker", "sessions": [{"path", "name", "label"}], "rows": [{"metric", "label",
        "values", "trend", "other_band"}], "notes", "left_out": [{"path", "why"}]}``: each
        metric's time in range (0..1, None: no data) per session; ``other_band`` marks the
        sessions whose band for that metric differs from the newest one's (left out of the
        trend; ``notes`` says which band); the sub-folders left out with the reason.
    """
    left_out: list[dict[str, str]] = []
    speaker, sessions = _group(Path(folder), left_out)
    return {**_table(speaker, sessions, left_out), "left_out": left_out}


def progress_all(folder: Path) -> list[dict[str, Any]]:
    """:func:`progress`'s table for every speaker with sessions in ``folder`` (the folders left
    out are in the last table's ``left_out``)."""
    left_out: list[dict[str, str]] = []
    groups = find_all_sessions(Path(folder), left_out=left_out)
    tables = [{**_table(who[1], sessions, []), "left_out": []} for who, sessions in groups]
    if tables:
        tables[-1]["left_out"] = left_out
    else:
        tables = [
            {
                "speaker": str(folder),
                "sessions": [],
                "rows": [],
                "notes": [],
                "left_out": left_out,
            }
        ]
    return tables


def _table(
    speaker: str,
    sessions: Sequence[tuple[float, SessionDir, dict[str, Any]]],
    left_out: list[dict[str, str]],
) -> dict[str, Any]:
    from prezence.report.build import metric_label

    cols: list[dict[str, Any]] = []
    per: list[dict[str, float | None]] = []
    unjudged: list[dict[str, str]] = []  # per rehearsal, metric -> why it was not judged
    sides: list[dict[str, str]] = []  # per rehearsal, metric -> the side it was mostly out on
    bands: list[dict[str, str] | None] = []
    edges: list[set[str]] = []  # per rehearsal, the metrics whose median read at the edge
    medians: list[dict[str, float]] = []  # per rehearsal, metric -> its median reading (p50)
    recordings: set[str] = set()
    notes: list[str] = []  # the rehearsals rebuilt from their streams first
    newest_rules: dict[str, Rule] | None = None  # the newest rehearsal's (the trend's band)
    for when, s, meta in sessions:
        rebuilt: str | None = None  # why its figures come from its streams
        try:
            summ: dict[str, Any] | None = read_json_object(s.summary)
        except ConfigError as e:
            summ, rebuilt = _rebuilt(s, e, left_out), str(e)
        if summ is None:
            continue
        metrics = summ.get("metrics")
        if not isinstance(metrics, dict):
            log.warning("%s: metrics: not an object; no figures for this rehearsal", s.summary)
            metrics = {}
        per.append({str(k): time_in_range(s.summary, str(k), v) for k, v in metrics.items()})
        unjudged.append({str(k): w for k, v in metrics.items() if (w := not_judged_why(v))})
        sides.append({str(k): side for k, v in metrics.items() if (side := off_side(v))})
        rules = _rules(s)
        newest_rules = rules
        bands.append(None if rules is None else {k: _band_text(r) for k, r in rules.items()})
        # marked low / high, but its median read within the measurement's error of the band
        # and its report says it may have been in range
        edges.append(_edges(s, metrics, rules))
        medians.append(
            {
                str(k): med
                for k, v in metrics.items()
                if isinstance(v, dict) and (med := _number(v.get("p50"))) is not None
            }
        )
        # to the second, with the folder: talks a minute apart are told apart
        label = time.strftime("%d %b %Y %H:%M:%S", time.localtime(when))
        rec = meta.get("recording")
        if isinstance(rec, str) and rec:  # a rehearsal: which recording it coached
            label += f", {Path(rec).name}"
            recordings.add(rec)
        if rebuilt is not None:
            label += ", rebuilt from its streams (its summary.json is damaged)"
            notes.append(
                f"rehearsal {len(cols) + 1} ({s.root.name}): figures rebuilt from its streams, "
                f"as `prezence report` does: {rebuilt}"
            )
        cols.append(
            {
                "path": str(s.root),
                "name": s.root.name,
                "label": label,
                **({"rebuilt": rebuilt} if rebuilt is not None else {}),
            }
        )
    names: list[str] = []
    for m in per:
        names += [k for k in m if k not in names]
    rows = []
    for name in names:
        # a figure the report did not judge (0 s of pace is "0 %") is no figure: "–", a note
        why = [u.get(name) for u in unjudged]
        values = [None if w else m.get(name) for m, w in zip(per, why, strict=True)]
        out_on = [None if w else x.get(name) for x, w in zip(sides, why, strict=True)]
        edge = [bool(o) and name in e for o, e in zip(out_on, edges, strict=True)]
        # a time in range holds only under its band: compare with the newest rehearsal's
        newest = bands[-1].get(name) if bands and bands[-1] is not None else None
        judged = [None if b is None else b.get(name) for b in bands]
        other = [j != newest and v is not None for j, v in zip(judged, values, strict=True)]
        label = metric_label(name)
        if any(other):
            which = sorted(
                {
                    str(j) if j is not None else "not recorded"
                    for j, o in zip(judged, other, strict=True)
                    if o
                }
            )
            notes.append(
                f"† {label}: judged by another band in {sum(other)} rehearsal"
                f"{'s' if sum(other) != 1 else ''} ({', '.join(which)}; the newest: "
                f"{newest if newest is not None else 'not recorded'}), so not comparable: "
                "left out of the trend"
            )
        if any(why):
            whys = sorted({w for w in why if w})
            which = [str(i) for i, w in enumerate(why, 1) if w]
            notes.append(
                f"* {label}: not judged in rehearsal{'s' if len(which) != 1 else ''} "
                f"{', '.join(which)} ({'; '.join(whys)}): no figure, left out of the trend"
            )
        kept = [None if o else v for v, o in zip(values, other, strict=True)]
        trend = _trend(kept, out_on)
        rule = (newest_rules or {}).get(name)
        compared = [i for i, v in enumerate(kept) if v is not None][-2:]  # as _trend does
        if trend.startswith("steady") and rule is not None and len(compared) == 2:
            # 0 % in range twice says nothing of 232 wpm then 190 (session 25's tester); the
            # medians of the two rehearsals the trend compares, or none (a summary.json
            # written before it kept p50: session 26's tester)
            meds = [medians[i].get(name) for i in compared]
            if all(x is not None for x in meds):
                trend += median_move(rule, meds, [out_on[i] for i in compared])
        rows.append(
            {
                "metric": name,
                "label": label,
                "values": values,
                "trend": trend,
                "other_band": other,
                "not_judged": [bool(w) for w in why],
                "sides": out_on,
                "at_edge": edge,
            }
        )
    if any(any(row["sides"]) for row in rows):
        notes.append(
            "low / high: out of its ideal range, mostly below / above it, for "
            f"{100 * _slightly_off():.0f}% or more of the time it was measured"
        )
    edged = [row for row in rows if any(row["at_edge"])]
    if edged:
        from prezence.metrics import METRICS
        from prezence.report.build import error_words

        errors = ", ".join(
            f"{row['label']} {error_words(METRICS[str(row['metric'])])}"
            for row in edged
            if row["metric"] in METRICS
        )
        notes.append(
            "~: its median reading was out of its ideal range by less than the measurement's "
            f"error ({errors}), or, its median in range, every reading out was: it may have "
            "been in range (the report says so)"
        )
    named = any(isinstance(m.get("speaker"), str) and m.get("speaker") for _, _, m in sessions)
    if len(recordings) > 1 and not named:
        # grouped by folder only: nothing says these are one speaker's rehearsals of one talk
        notes.append(
            f"these {len(cols)} rehearsals name no speaker and coach {len(recordings)} "
            "different recordings: the trend is across them, not one speaker's progress "
            "(give --speaker NAME to prezence rehearse and up to compare a speaker's own)"
        )
    return {"speaker": speaker, "sessions": cols, "rows": rows, "notes": notes}


def _rebuilt(
    s: SessionDir, damaged: ConfigError, left_out: list[dict[str, str]]
) -> dict[str, Any] | None:
    """The figures of a rehearsal whose ``summary.json`` cannot be read (torn mid-write,
    damaged), rebuilt from its streams by the report's own code (:func:`prezence.report.build.
    build_report`, what ``prezence report`` prints), as ``{"metrics": …}``; None (and the
    rehearsal added to ``left_out``) when even that fails. Session 21, a second walkthrough:
    such a rehearsal was left out of the table though its report could be rebuilt."""
    from prezence.report.build import build_report

    log.warning("%s; its figures are rebuilt from its streams, as `prezence report` does", damaged)
    token = _QUIET.set(True)  # what the rebuild finds is the report's to say, not the table's
    try:
        return {"metrics": build_report(s.root)["metrics"]}
    except (PrezenceError, OSError) as e:
        error: Exception = e
    finally:
        _QUIET.reset(token)
    log.warning("%s: not rebuilt either (%s); left out of the progress table", s.root, error)
    why = f"{damaged}; not rebuilt from its streams either: {error}"
    left_out.append({"path": str(s.root), "why": why})
    return None


def progress_for(session_root: Path) -> dict[str, Any] | None:
    """:func:`progress` of the session ``session_root`` (None when it cannot be read).

    A talk's report reads the rehearsals beside it; what is wrong with those is for
    ``prezence progress`` to say, not for every talk's log (session 21, a second walkthrough:
    each ``run`` printed the warnings of damaged folders next to it): they are not repeated here.
    """
    token = _QUIET.set(True)  # this thread's (and context's) only: evaluate's talks are apart
    try:
        return progress(Path(session_root))
    except (ConfigError, OSError) as e:
        error: Exception = e
    finally:
        _QUIET.reset(token)
    log.warning("progress across rehearsals left out: %s", error)
    return None


#: Set while a talk's report reads its neighbours (:func:`progress_for`).
_QUIET: contextvars.ContextVar[bool] = contextvars.ContextVar("quiet_neighbours", default=False)


class _QuietNeighbours(logging.Filter):
    """Drops what reading the rehearsals beside a talk logs (their damaged files, their
    configs' notes) while :data:`_QUIET` is set; ``prezence progress`` says it all."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not _QUIET.get()


for _name in (
    __name__,
    "prezence.config.load",
    "prezence.config.lines",
    "prezence.report.build",
    "prezence.session",
    "prezence.streams.tail",
):
    logging.getLogger(_name).addFilter(_QuietNeighbours())


def _slightly_off() -> float:
    from prezence.report.build import SLIGHTLY_OFF_SHARE

    return SLIGHTLY_OFF_SHARE


def cell(row: dict[str, Any], i: int) -> str:
    """Rehearsal ``i``'s cell of a progress row: ``"81%"``, ``"0% high"``, ``"–*"`` (not
    judged: a note says why), ``"-"`` (no data), ``"100%†"`` (judged by another band)."""
    v = row["values"][i]
    if (row.get("not_judged") or [False] * len(row["values"]))[i]:
        text = "–*"
    elif v is None:
        text = "-"
    else:
        side = (row.get("sides") or [None] * len(row["values"]))[i]
        text = f"{100 * v:.0f}%" + (f" {side}" if side else "")
        if side and (row.get("at_edge") or [False] * len(row["values"]))[i]:
            text += "~"
    return text + ("†" if (row.get("other_band") or [False] * len(row["values"]))[i] else "")


def format_progress(p: dict[str, Any]) -> str:
    """One speaker's progress table as text (``prezence progress DIR``): columns numbered,
    each named below by its folder and when it was recorded."""
    cols = p["sessions"]
    # a folder left out is said, with why: a missing rehearsal is not silently dropped
    notes = [f"left out: {Path(x['path']).name}: {x['why']}" for x in p.get("left_out") or []]
    if not cols:
        return "\n".join([f"no sessions with a summary.json in {p['speaker']}", *notes])
    w = 10  # "100% high†"
    head = f"{'metric':<20}" + "".join(f"{i:>{w}}" for i in range(1, len(cols) + 1)) + "  trend"
    n = len(cols)
    title = (
        f"{n} rehearsal{'s' if n != 1 else ''} of {p['speaker']}, oldest first: time in the "
        "ideal range; the trend is the newest against the one before"
    )
    lines = [title, head]
    for r in p["rows"]:
        cells = "".join(f"{cell(r, i):>{w}}" for i in range(len(r["values"])))
        lines.append(f"{r['label']:<20}{cells}  {r['trend']}")
    lines += [f"{i}: {c['name']}, {c['label']}" for i, c in enumerate(cols, 1)]
    lines += list(p.get("notes") or ())
    lines += notes
    return "\n".join(lines)
