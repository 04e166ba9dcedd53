"""Figures for one talk, computed from what the session folder records.

Everything here takes the recorded samples and cue records, never the processor's memory, so a
summary (and the report built on it) can be rebuilt after a crash from the files alone.
"""

from __future__ import annotations

import bisect
import math
import re
from collections.abc import Collection, Mapping, Sequence
from operator import attrgetter
from typing import TYPE_CHECKING, Any

import numpy as np

from prezence.config.model import Config, Rule
from prezence.metrics import (
    METRICS,
    UNTIMED_METRIC,
    UNTIMED_WORDS,
    WORD_WINDOW_REASONS,
    Untimed,
)
from prezence.samples import Sample
from prezence.session import CUE_KEYS, SessionDir, read_jsonl, write_json

if TYPE_CHECKING:
    from prezence.processor import Processor
    from prezence.streams.tail import MultiTailer, StreamProblem, TailStats


#: A sample's time and value (C-level getters: a 6-hour replay's summary reads 108k of each)
_T = attrgetter("t")
_VALUE = attrgetter("value")


def hold_ends(ts: Sequence[float] | np.ndarray, cuts: Sequence[float] | np.ndarray) -> np.ndarray:
    """For each sample time, the first of ``cuts`` at or after it (inf when none).

    A cut is when the module writing the metric died (crashed, or went silent before it was
    killed as hung): its last value does not hold past it.

    Example:
        >>> hold_ends([1.0, 4.0, 9.0], [5.0]).tolist()
        [5.0, 5.0, inf]
    """
    c = np.append(np.sort(np.asarray(cuts, dtype=float)), np.inf)
    return c[np.searchsorted(c, np.asarray(ts, dtype=float), side="left")]


#: The percentiles a metric's summary gives (p10, p50, p90), as fractions.
_DECILES = np.true_divide([10, 50, 90], 100)


def _percentiles(a: np.ndarray, q: np.ndarray) -> np.ndarray:
    """``np.percentile(a, 100 * q)`` (its default, linear method), equal to it but for the
    sign of a zero: a zero is always written 0.0.

    numpy's own looks its bounds up with ``np.unique``, whose first call imports ``numpy.ma``
    (about 10 ms of a replay's start); this takes the same steps on a sorted copy: virtual
    index ``(n - 1)·q``, its floor and the next, and numpy's two-sided interpolation. A sort
    and numpy's partition order 0.0 and -0.0 differently, so either may come out of numpy
    where the values hold both (session 24's review); "-0.0" in a summary only puzzles.
    """
    n = len(a)
    s = np.sort(a)
    virtual = (n - 1) * q
    lo = np.floor(virtual)
    hi = lo + 1.0
    above = virtual >= n - 1
    lo[above] = -1
    hi[above] = -1
    below = virtual < 0
    lo[below] = 0
    hi[below] = 0
    prev = s[lo.astype(np.intp)]
    nxt = s[hi.astype(np.intp)]
    gamma = virtual - lo
    diff = nxt - prev
    out = np.add(prev, diff * gamma)
    np.subtract(nxt, diff * (1 - gamma), out=out, where=gamma >= 0.5)
    if np.isnan(s[-1]):  # numpy's answer for values with a NaN (sorted last)
        out[:] = s[-1]
    return out + 0.0  # -0.0 + 0.0 is 0.0


def _in_range_time(
    rule: Rule,
    ts: np.ndarray,
    vs: np.ndarray,
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
) -> dict[str, float]:
    """Sample-and-hold the values over the talk: seconds in range, out of range (and of
    that, below and above the band), no data.

    ``ts`` (sorted) and ``vs`` are the samples' times and values. Each value holds from its
    time until the next sample, the stale time, the talk's end or the next of ``cuts`` (its
    module died), whichever comes first; a stretch out of range is broken by a value in range
    or by a gap (a stale module). For a metric whose record states a measurement error
    (:meth:`prezence.metrics.Metric.margin`), ``within_error_s`` is the time out of range by
    no more than it.
    """
    k = int(np.searchsorted(ts, talk_s, side="left"))  # samples before the talk's end
    t = ts[:k]
    nxt = np.append(ts[1:], talk_s)[:k]
    end = np.minimum(np.minimum(nxt, t + stale_s), talk_s)
    if len(cuts):
        end = np.minimum(end, hold_ends(t, cuts))
    dt = np.maximum(end - t, 0.0)
    v = vs[:k] + rule.offset
    below = v < rule.low if rule.low is not None else np.zeros(k, dtype=bool)
    above = v > rule.high if rule.high is not None else np.zeros(k, dtype=bool)
    out = below | above
    in_s = float(dt[~out].sum())
    out_s = float(dt[out].sum())
    rec = METRICS.get(rule.metric)
    near: dict[str, float] = {}
    if rec is not None and (rec.error_pct is not None or rec.error_abs is not None):
        # out, but by no more than the measurement's error: cannot be told from in range
        close = np.zeros(k, dtype=bool)
        if rule.low is not None:
            close |= below & (v >= rule.low - rec.margin(rule.low))
        if rule.high is not None:
            close |= above & (v <= rule.high + rec.margin(rule.high))
        near["within_error_s"] = round(float(dt[close].sum()), 3)
    longest_out = 0.0
    if out.any():
        gap = end < nxt
        # a stretch starts at an out-of-range sample after one in range or after a gap
        starts = out & np.concatenate(([True], ~out[:-1] | gap[:-1]))
        stretch = np.cumsum(starts) - 1
        longest_out = float(np.bincount(stretch[out], weights=dt[out]).max())
    covered = in_s + out_s
    return {
        "in_range_s": round(in_s, 3),
        "out_of_range_s": round(out_s, 3),
        # each side on its own: a pace both too slow and too fast is two things to say
        "below_s": round(float(dt[below].sum()), 3),
        "above_s": round(float(dt[above].sum()), 3),
        "no_data_s": round(max(0.0, talk_s - covered), 3),
        "time_in_range": round(in_s / covered, 4) if covered > 0 else None,  # type: ignore[dict-item]
        "longest_out_of_range_s": round(longest_out, 3),
        **near,
    }


def _truth_intervals(truth: Sequence[Mapping[str, Any]], metric: str) -> list[tuple[float, float]]:
    return sorted((float(x["start"]), float(x["end"])) for x in truth if x.get("metric") == metric)


#: A metric measured for less than this many seconds (the time its samples held) is not
#: judged: the report gives no advice on it and no praise for it, and says it was measured
#: too briefly (a 2 s recording; 3 s of pace before a Ctrl-C). The same figure as a pace
#: window: a shorter stretch is one or two samples.
MIN_JUDGED_S = 10.0

#: The vision module's record of what it could not measure and how it measured the rest
#: (``SESSION/vision.json``: ``{"off": {metric: why}, "gesture_source": "body"|"motion"}``).
VISION_STATUS = "vision.json"
#: The speech module's record of which of its metrics are estimates (``speech.json``).
SPEECH_STATUS = "speech.json"

#: ``cv_gestures_source``'s value for a rate from the frame difference (the fallback).
GESTURES_FROM_MOTION = 2.0
#: ``cv_gestures_source``'s value for a rate from the body whose window had an arm hidden (or the
#: body out of view) in 10 % or more of its frames: it counts what was seen, and may be low.
GESTURES_PARTLY_COUNTED = 3.0


def _failure_text(msg: str) -> str:
    """A module's last error line without its ``error:`` prefix."""
    msg = msg.strip()
    return msg[len("error:") :].strip() if msg.startswith("error:") else msg


def _module_status(folder: Any, name: str) -> dict[str, Any]:
    """A module's status record in the session folder (``vision.json``, ``speech.json``); {}
    when it is absent or torn (a torn record says nothing; the streams still do)."""
    from pathlib import Path

    from prezence.session import read_json_object

    path = Path(folder) / name
    if not path.is_file():
        return {}
    try:
        return read_json_object(path)
    except (OSError, ValueError):
        return {}


def _stream_values(folder: Any, metric: str) -> list[float]:
    """Every value of ``streams/<metric>.txt`` in the session folder; [] without the file."""
    from pathlib import Path

    from prezence.streams.tail import read_stream

    path = Path(folder) / "streams" / f"{metric}.txt"
    if not path.is_file():
        return []
    samples, _ = read_stream(path, metric)
    return [x.value for x in samples]


def untimed_labels(codes: Sequence[float]) -> str:
    """The speech module's reasons for its untimed word windows (``speech_untimed_reason``),
    in words, the most frequent first; "" for none.

    Example:
        >>> untimed_labels([7.0, 7.0, 3.0, 5.0])
        'too much background noise, music or noise next to the words'
    """
    counts: dict[str, int] = {}
    for c in codes:
        if c in WORD_WINDOW_REASONS and int(c) in UNTIMED_WORDS:
            counts[UNTIMED_WORDS[int(c)]] = counts.get(UNTIMED_WORDS[int(c)], 0) + 1
    return ", ".join(sorted(counts, key=lambda w: -counts[w]))


#: How the report's notes on a clipped recording begin (the spoken summary looks for it).
CLIPPED_NOTE = "the recording is clipped"

#: The speech module's log line on a clipped recording (prezence/modules/speech.py):
#: "… (the recording is clipped: 6 % of the speech samples at or near full scale; record …".
_CLIPPED_LOG = re.compile(r"the recording is clipped: ([^;()]*?)\s*[;)]")


def clipped_detail(root: Any) -> str | None:
    """How clipped the recording was, as the speech module's log in the session folder says it
    ("6 % of the speech samples at or near full scale"); None when it does not say so.

    The module's record (``speech.json``'s ``clipped``, since session 23) is read first; a
    folder written before it falls back to the log line (a log worded otherwise, or no
    ``speech.log``, gives None, and the report then says only that neither count was trusted).

    Example:
        >>> import tempfile, pathlib
        >>> d = pathlib.Path(tempfile.mkdtemp())
        >>> _ = (d / "speech.log").write_text("speech: WARNING: t=12 s: speech speed cannot be "
        ...     "measured (the recording is clipped: 6 % of the speech samples at or near full "
        ...     "scale; record with less input gain)\\n")
        >>> clipped_detail(d), clipped_detail(d / "nothing")
        ('6 % of the speech samples at or near full scale, speech.log', None)
    """
    from pathlib import Path

    record = _module_status(root, SPEECH_STATUS).get("clipped")
    if isinstance(record, Mapping):  # the module's record (session 23), not its log's words
        share = record.get("max_share")
        if isinstance(share, int | float) and not isinstance(share, bool) and share > 0:
            return (
                f"up to {100 * share:.0f} % of a word window's speech samples at or near full scale"
            )
    path = Path(root) / "speech.log"
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    found = _CLIPPED_LOG.search(text)
    return f"{found.group(1)}, speech.log" if found else None


def estimate_notes(root: Any) -> dict[str, str]:
    """Per metric, why its figures are an estimate, as far as the session folder records it
    (the speech module's ``speech.json``: the volume of an uncalibrated microphone; the gesture
    rate where ``cv_gestures_source`` says an arm was hidden in part of the window). Unlike
    ``less_reliable`` these keep their advice: a level relative to a guessed offset still says
    louder or quieter, but its dB SPL figure is not a measurement."""
    est = _module_status(root, SPEECH_STATUS).get("estimate")
    notes = {str(k): str(v) for k, v in est.items()} if isinstance(est, Mapping) else {}
    source = _stream_values(root, "cv_gestures_source")
    partly = sum(1 for v in source if v == GESTURES_PARTLY_COUNTED)
    if partly:
        written = sum(1 for v in source if v != 0.0)
        notes["cv_gestures"] = (
            f"in {partly} of its {written} samples an arm was hidden from the camera (or the "
            "body out of view) in part of the window, so the rate there counts the gestures "
            "seen and may be low (vision.log says when)"
        )
    return notes


def measurement_notes(
    root: Any, recorded: Mapping[str, Any] | None
) -> tuple[dict[str, str], dict[str, str]]:
    """Why metrics were not measured, and which were measured in a less reliable way, as far
    as the session folder records it.

    Args:
        root: the session folder.
        recorded: ``summary.json`` (or the ``extra`` about to go into it): its
            ``module_failures`` (module → its last error line) name modules that could not run.

    Returns:
        ``(unmeasured, less_reliable)``: per metric, why it was not measured (its module
        failed; head pose was off) and why its figures are less reliable (the gesture rate
        from the frame-difference fallback).
    """
    unmeasured: dict[str, str] = {}
    failures = (recorded or {}).get("module_failures") or {}
    modules = (recorded or {}).get("modules")
    # a module that ran and then crashed or hung (rehearse records a hang in both) is said by
    # its crash record (module_notes), not as one that 'could not run'
    ran = {
        str(name)
        for name, rec in (modules.items() if isinstance(modules, Mapping) else ())
        if isinstance(rec, Mapping) and rec.get("crashes")
    }
    if isinstance(failures, Mapping):
        for name, rec in METRICS.items():
            msg = failures.get(rec.module)
            if isinstance(msg, str) and rec.module not in ran:
                unmeasured[name] = f"the {rec.module} module could not run: {_failure_text(msg)}"
    for status in (VISION_STATUS, SPEECH_STATUS):  # speech: a talk not in English
        off = _module_status(root, status).get("off")
        if isinstance(off, Mapping):
            for metric, why in off.items():
                unmeasured.setdefault(str(metric), str(why))
    if _module_status(root, VISION_STATUS).get("gesture_source") == "motion":
        # a folder written before session 23 (its fallback rate went to cv_gestures, and
        # vision.json did not list it as off): a replay takes none of those samples, and one
        # with no gesture rate left is not measured, not a module that never reported
        unmeasured.setdefault(
            "cv_gestures",
            "counted from the frame difference, the fallback when the pose model cannot run "
            "(a folder written before session 23): too unreliable to advise on",
        )
    activity = _stream_values(root, "speech_activity")
    if activity and not any(activity):  # no voice in any window
        # which, where the module wrote its reasons (issue 11): sound or silence
        codes = set(_stream_values(root, UNTIMED_METRIC))
        heard = (
            "noise, a hum, music or a whisper without a voice"
            if Untimed.NO_VOICE in codes
            else "silence, or sound too faint to be a voice"
            if codes == {Untimed.PAUSE}
            else "silence, or noise, a hum, music or a whisper without a voice: speech.log "
            "says which"
        )
        for name, rec in METRICS.items():
            if rec.module == "speech":
                unmeasured.setdefault(name, f"the speech module heard no voice ({heard})")
    # the speech module's log says the recording is clipped (session 23: only the log said
    # "record with less input gain"; the report praised the clipped recording's volume)
    clipped = clipped_detail(root)
    gain = "record with less input gain or farther from the microphone"
    source = _stream_values(root, "speech_speed_source")
    if source and not any(source) and clipped:
        for metric in ("speech_speed", "speech_articulation"):
            unmeasured.setdefault(metric, f"{CLIPPED_NOTE} ({clipped}): {gain}")
    if source and not any(source):  # 0 in every window: no count trusted
        # which reasons, where the module wrote them (issue 11); else the log says which
        said = untimed_labels(_stream_values(root, UNTIMED_METRIC))
        for metric in ("speech_speed", "speech_articulation"):
            unmeasured.setdefault(
                metric,
                "the speech module trusted neither its recogniser nor its syllable count "
                "in any window ("
                + (said or "noise, music, a clipped recording: speech.log says which")
                + ")",
            )
    less: dict[str, str] = {}
    if clipped:
        less["speech_volume"] = (
            f"{CLIPPED_NOTE} ({clipped}), so its level is the recorder's limit, "
            f"not your voice's: {gain}"
        )
    # a folder written before session 23, whose fallback rate went to cv_gestures (since then
    # it goes to cv_gestures_motion, and vision.json lists cv_gestures as not measured)
    if GESTURES_FROM_MOTION in _stream_values(root, "cv_gestures_source"):
        less["cv_gestures"] = (
            "counted from the frame difference, the fallback when the pose model cannot "
            "run (it misses most gestures and counts other motion)"
        )
    return unmeasured, less


#: A corrective cue within this many seconds after its problem ended is "stale", not a false
#: alarm: the same window as :data:`prezence.evaluate.STALE_WINDOW_S` (a test holds them equal).
STALE_WINDOW_S = 10.0


class Stretches:
    """Out-of-range stretches indexed for :func:`classify_cue`: per (metric, side), sorted by
    start, with the running maximum of their ends, so that a cue is classed in O(log n)
    rather than by a pass over every stretch (a 6-hour replay has thousands per metric).
    """

    def __init__(self, intervals: Sequence[Mapping[str, Any]]) -> None:
        groups: dict[tuple[Any, Any], list[tuple[float, float]]] = {}
        for x in intervals:
            groups.setdefault((x.get("metric"), x.get("side")), []).append(
                (float(x["start"]), float(x["end"]))
            )
        self._index: dict[tuple[Any, Any], tuple[list[float], list[float], list[float]]] = {}
        for key, iv in groups.items():
            iv.sort()
            peak: list[float] = []
            top = -math.inf
            for _, b in iv:
                top = b if b > top else top
                peak.append(top)
            self._index[key] = ([a for a, _ in iv], [b for _, b in iv], peak)

    def classify(
        self, metric: str, side: str, t: float, *, window_s: float = STALE_WINDOW_S
    ) -> tuple[str, float | None]:
        """See :func:`classify_cue`."""
        found = self._index.get((metric, side))
        if found is None:
            return "false_alarm", None
        starts, ends, peak = found
        # the first stretch (in start order) that ends at or after t: it holds t if it has
        # begun by then; if it has not, no later one has either
        i = bisect.bisect_left(peak, t)
        if i < len(starts) and starts[i] <= t:
            return "relevant", starts[i]
        # none holds t: every stretch begun by t ended before it; the latest end is the peak
        k = bisect.bisect_right(starts, t)
        if k and peak[k - 1] >= t - window_s:
            return "stale", peak[k - 1]
        return "false_alarm", None


def classify_cue(
    intervals: Sequence[Mapping[str, Any]] | Stretches,
    metric: str,
    side: str,
    t: float,
    *,
    window_s: float = STALE_WINDOW_S,
) -> tuple[str, float | None]:
    """``"relevant"``, ``"stale"`` or ``"false_alarm"`` for a corrective cue at ``t``, and the
    onset of the stretch it is about (relevant) or when that stretch ended (stale).

    The definitions of the evaluation (docs/evaluation.md, "What the columns mean";
    :func:`prezence.evaluate.classify_cue` with the cue chosen and started at ``t``, as the
    coach starts a cue when it chooses it): *relevant* when ``metric`` was out of range on the
    cued ``side`` at ``t``; *stale* when it was in range but had been out on that side in the
    ``window_s`` before; a *false alarm* otherwise.

    Args:
        intervals: out-of-range stretches ``{"metric", "start", "end", "side"}``: the ground
            truth of a synthetic talk, or :func:`measured_intervals` of the recorded values
            (or them indexed once as :class:`Stretches`, for many cues).

    Example:
        >>> iv = [{"metric": "m", "start": 10.0, "end": 20.0, "side": "above"}]
        >>> [classify_cue(iv, "m", "above", t) for t in (15.0, 25.0, 40.0)]
        [('relevant', 10.0), ('stale', 20.0), ('false_alarm', None)]
        >>> classify_cue(iv, "m", "below", 15.0)
        ('false_alarm', None)
    """
    index = intervals if isinstance(intervals, Stretches) else Stretches(intervals)
    return index.classify(metric, side, t, window_s=window_s)


def measured_intervals(
    rule: Rule,
    samples: Sequence[Sample],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
) -> list[dict[str, Any]]:
    """The stretches the recorded values were out of ``rule``'s range, as :func:`classify_cue`
    takes them: each sample holds as in the time in range (until the next sample, the stale
    time, the talk's end or its module's death); a gap or a change of side ends a stretch.

    What a talk without ground truth (a live one, a rehearsal) judges its cues by.

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("v", Check.MIN, low=60.0)
        >>> ss = [Sample("v", float(t), v) for t, v in [(0, 50), (1, 55), (2, 70), (3, 50)]]
        >>> [(x["start"], x["end"], x["side"]) for x in measured_intervals(r, ss, 10.0, 2.0)]
        [(0.0, 2.0, 'below'), (3.0, 5.0, 'below')]
    """
    ss = sorted(samples, key=_T)
    n = len(ss)
    ts = np.fromiter(map(_T, ss), dtype=float, count=n)
    vs = np.fromiter(map(_VALUE, ss), dtype=float, count=n)
    return _measured_stretches(rule, ts, vs, talk_s, stale_s, cuts)


def _measured_stretches(
    rule: Rule,
    ts: np.ndarray,
    values: np.ndarray,
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float],
) -> list[dict[str, Any]]:
    """:func:`measured_intervals` of the samples' times ``ts`` (in time order) and values."""
    vs = values + rule.offset
    # each sample holds until the next one, the stale time, the talk's end, its module's death
    held = np.minimum(np.minimum(np.append(ts[1:], talk_s), ts + stale_s), talk_s)
    if cuts:
        held = np.minimum(held, hold_ends(ts, cuts))
    lo = -math.inf if rule.low is None else rule.low
    hi = math.inf if rule.high is None else rule.high
    below = vs < lo  # Rule.side, for every sample at once
    off = np.flatnonzero((below | (vs > hi)) & (ts < talk_s))  # in range: no stretch
    out: list[dict[str, Any]] = []
    last: dict[str, Any] | None = None
    for t, end, low in zip(ts[off].tolist(), held[off].tolist(), below[off].tolist(), strict=True):
        side = "below" if low else "above"
        if last is not None and last["side"] == side and last["end"] >= t:
            if end > last["end"]:
                last["end"] = end
        else:
            last = {"metric": rule.metric, "start": t, "end": end, "side": side}
            out.append(last)
    return out


def no_data_spans(
    samples: Sequence[Sample],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
) -> list[tuple[float, float]]:
    """The stretches of the talk no recorded value held (each sample holds as in
    :func:`measured_intervals`: until the next one, the stale time, the talk's end or its
    module's death), as ``(from, to)``: before the first value, and from when a value stopped
    holding until the next one or the talk's end.

    A cue given in one cannot be judged: nothing says whether the metric was still out of
    range (session 22: a cue 3 s after a module crashed was called "STALE: back in range").

    Example:
        >>> ss = [Sample("v", t, 1.0) for t in (2.0, 3.0, 10.0)]
        >>> no_data_spans(ss, 20.0, 2.0, cuts=[4.0])
        [(0.0, 2.0), (4.0, 10.0), (12.0, 20.0)]
    """
    ts = np.fromiter(map(_T, samples), dtype=float, count=len(samples))
    return _no_data(ts, talk_s, stale_s, cuts)


def _no_data(
    times: np.ndarray, talk_s: float, stale_s: float, cuts: Sequence[float]
) -> list[tuple[float, float]]:
    """:func:`no_data_spans` of the samples' times."""
    ts = np.sort(times)
    ts = ts[ts < talk_s]
    if not len(ts):
        return [(0.0, float(talk_s))] if talk_s > 0 else []
    nxt = np.append(ts[1:], talk_s)
    held = np.minimum(np.minimum(nxt, ts + stale_s), talk_s)
    if len(cuts):
        held = np.minimum(held, hold_ends(ts, cuts))
    out = [(0.0, float(ts[0]))] if ts[0] > 0 else []
    # only the samples whose value stopped holding before the next one, as Python floats: a
    # numpy scalar per sample took 24 ms of a 6-hour replay's summary
    gap = held < nxt
    out += list(zip(held[gap].tolist(), nxt[gap].tolist(), strict=True))
    return out


def _in_span(spans: Sequence[tuple[float, float]], t: float) -> tuple[float, float] | None:
    """The span of ``spans`` (sorted, apart) that holds ``t`` (``from <= t < to``), if any."""
    i = bisect.bisect_right([a for a, _ in spans], t) - 1
    return spans[i] if i >= 0 and t < spans[i][1] else None


def _truth_in_range_fraction(
    truth: Sequence[Mapping[str, Any]], metric: str, talk_s: float
) -> float:
    out = sum(
        max(0.0, min(b, talk_s) - a) for a, b in _truth_intervals(truth, metric) if a < talk_s
    )
    return round(1.0 - out / talk_s, 4) if talk_s > 0 else 1.0


def _died_at(crash: Mapping[str, Any]) -> float:
    """When a module stopped measuring: a hung one when it last showed life, else its exit."""
    since = crash.get("silent_since")
    return float(since if isinstance(since, int | float) else crash["t"])


def _crashes(rec: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """A module record's crashes (``summary.json``'s ``modules.NAME.crashes``), each with a
    time; anything else in the list is left out."""
    return [
        c
        for c in rec.get("crashes") or []
        if isinstance(c, Mapping) and isinstance(c.get("t"), int | float)
    ]


def module_outages(
    modules: Mapping[str, Any] | None,
    streams: Mapping[str, Sequence[Sample]],
    talk_s: float,
) -> dict[str, list[dict[str, Any]]]:
    """Per metric, the stretches its module was dead: ``[{"module", "from", "to"}]``.

    Each crash or hang in ``summary.json``'s ``modules`` (the launcher's record, with the
    metrics each module writes) starts a stretch when the module stopped (a hung one: when it
    last showed life); it ends at the metric's first sample after the module was restarted,
    or at the talk's end. Overlapping stretches are merged. A module whose record has no
    metrics is left out (nothing says which metrics it took with it; :func:`module_notes`
    says so).

    Example:
        >>> mods = {"pace": {"metrics": ["speech_speed"], "crashes": [{"t": 5.0, "why": "x"}]}}
        >>> ss = {"speech_speed": [Sample("speech_speed", t, 1.0) for t in (1.0, 4.0, 9.0)]}
        >>> module_outages(mods, ss, 20.0)
        {'speech_speed': [{'module': 'pace', 'from': 5.0, 'to': 9.0}]}
    """
    out: dict[str, list[dict[str, Any]]] = {}
    for name, rec in (modules or {}).items():
        if not isinstance(rec, Mapping):
            continue
        crashes = _crashes(rec)
        for metric in rec.get("metrics") or []:
            ts = sorted(s.t for s in streams.get(str(metric), ()))
            spans: list[dict[str, Any]] = []
            for c in sorted(crashes, key=_died_at):
                i = bisect.bisect_right(ts, float(c["t"]))
                # a sample written after its last seen sign of life still counts
                start = min(max(_died_at(c), ts[i - 1] if i else 0.0), talk_s)
                end = min(ts[i], talk_s) if i < len(ts) else talk_s
                if spans and start <= spans[-1]["to"]:
                    spans[-1]["to"] = max(spans[-1]["to"], end)
                else:
                    spans.append({"module": str(name), "from": start, "to": end})
            if spans:
                out.setdefault(str(metric), []).extend(
                    {**sp, "from": round(sp["from"], 3), "to": round(sp["to"], 3)} for sp in spans
                )
    return out


def with_failures(
    modules: Mapping[str, Any] | None,
    failures: Mapping[str, Any] | None,
    streams: Mapping[str, Sequence[Sample]],
) -> dict[str, Any]:
    """``modules`` (the launcher's record) with each module ``failures`` names (``rehearse``'s
    ``module_failures``: module → its last error line) that wrote values before it failed,
    recorded as ``up`` records a crash, so that the notes, the report and the robot say what
    it left unmeasured (session 22: a crash in ``rehearse`` was in ``module_failures`` and
    nowhere else). Which metrics it writes is its metric records'; when it died is not
    recorded: it is put one step (its metrics' usual time between values) after its last
    value (``last_value_t``), so that value holds as long as the others did. A module that
    wrote no value is left out: its metrics are "not measured: the … module could not run"
    (:func:`measurement_notes`).

    Example:
        >>> ss = {"speech_speed": [Sample("speech_speed", t, 150.0) for t in (17.0, 18.0, 19.0)]}
        >>> with_failures({}, {"speech": "boom"}, ss)["speech"]["crashes"]
        [{'t': 20.0, 'why': 'boom', 'last_value_t': 19.0}]
    """
    out: dict[str, Any] = dict(modules or {})
    for name, why in (failures or {}).items() if isinstance(failures, Mapping) else ():
        rec = out.get(name)
        if isinstance(rec, Mapping) and _crashes(rec):
            continue  # the launcher recorded its crashes itself
        wrote = {
            metric: np.sort(np.fromiter(map(_T, streams[metric]), dtype=float))
            for metric, m in METRICS.items()
            if m.module == name and streams.get(metric)
        }
        if not wrote:
            continue
        last = max(float(ts[-1]) for ts in wrote.values())
        died = max(
            float(ts[-1]) + (float(np.median(np.diff(ts))) if len(ts) > 1 else 0.0)
            for ts in wrote.values()
        )
        crash = {"t": round(died, 3), "why": str(why), "last_value_t": round(last, 3)}
        out[name] = {
            **(rec if isinstance(rec, Mapping) else {}),
            "restarts": 0,
            "crashes": [crash],
            "metrics": sorted(wrote),
        }
    return out


def stale_spans(ts: np.ndarray, talk_s: float, stale_s: float) -> list[dict[str, Any]]:
    """A metric's stale episodes: each stretch with no new value for longer than ``stale_s``
    (its last value holds that long), as ``{"after", "from", "to", "stale_after_s"}``: its
    last value's time (None: no value at all), when that value stopped holding, and the next
    value or the talk's end. One per stale episode: ``stale_episodes`` is their number.

    Example:
        >>> stale_spans(np.array([0.0, 1.0, 10.0]), 12.0, 6.0)
        [{'after': 1.0, 'from': 7.0, 'to': 10.0, 'stale_after_s': 6.0}]
        >>> stale_spans(np.array([]), 12.0, 6.0)
        [{'after': None, 'from': 0.0, 'to': 12.0, 'stale_after_s': 6.0}]
    """
    ends = [(float(ts[i]), float(ts[i + 1])) for i in np.flatnonzero(np.diff(ts) > stale_s)]
    if len(ts) and talk_s - float(ts[-1]) > stale_s:
        ends.append((float(ts[-1]), talk_s))
    spans: list[dict[str, Any]] = [
        {"after": round(a, 3), "from": round(a + stale_s, 3), "to": round(b, 3)} for a, b in ends
    ]
    if not len(ts):  # the module that opened the file never reported: stale all the talk
        spans = [{"after": None, "from": 0.0, "to": round(talk_s, 3)}]
    return [{**sp, "stale_after_s": stale_s} for sp in spans]


def _hung(crash: Mapping[str, Any]) -> bool:
    return "silent_since" in crash or "(hung)" in str(crash.get("why") or "")


def module_notes(
    modules: Mapping[str, Any] | None, metrics: Mapping[str, Mapping[str, Any]]
) -> list[dict[str, Any]]:
    """What went wrong with each module that crashed or hung, for the reader.

    Args:
        modules: ``summary.json``'s ``modules`` (the launcher's record).
        metrics: the per-metric figures, with the ``lost`` stretches of :func:`module_outages`.

    Returns:
        One dict per module that stopped at least once: ``module``, ``crashes`` (exits) and
        ``first_crash_t``, ``hangs``, ``first_hang_t`` (when it went silent) and
        ``first_kill_t``, ``restarts``, ``last_why`` and ``lost`` (``metric``, ``from``,
        ``to``), and ``metrics_unknown`` (True) when the record does not say which metrics it
        writes (so nothing says which it left unmeasured); ``cut_short`` (its message) for a
        module whose input file broke off before its end (``modules.NAME.cut_short``, written
        by ``up`` and ``rehearse``); [] when every module ran throughout on all its input.
    """
    notes: list[dict[str, Any]] = []
    for name, rec in (modules or {}).items():
        if not isinstance(rec, Mapping):
            continue
        crashes = _crashes(rec)
        cut = rec.get("cut_short")
        if not crashes:
            if isinstance(cut, str) and cut:
                notes.append({"module": str(name), "cut_short": cut, "lost": []})
            continue
        hangs = [c for c in crashes if _hung(c)]
        exits = [c for c in crashes if not _hung(c)]
        lost = [
            {"metric": metric, "from": sp["from"], "to": sp["to"]}
            for metric, m in metrics.items()
            for sp in m.get("lost") or ()
            if sp.get("module") == name
        ]
        notes.append(
            {
                "module": str(name),
                "crashes": len(exits),
                "first_crash_t": float(exits[0]["t"]) if exits else None,
                "hangs": len(hangs),
                "first_hang_t": _died_at(hangs[0]) if hangs else None,
                "first_kill_t": float(hangs[0]["t"]) if hangs else None,
                "restarts": int(rec.get("restarts") or 0),
                "last_why": str(crashes[-1].get("why") or ""),
                "lost": lost,
                **({} if isinstance(rec.get("metrics"), list) else {"metrics_unknown": True}),
                # rehearse's failure: it died some time after its last value, then
                **(
                    {"last_value_t": float(crashes[0]["last_value_t"])}
                    if isinstance(crashes[0].get("last_value_t"), int | float)
                    else {}
                ),
                **({"cut_short": cut} if isinstance(cut, str) and cut else {}),
            }
        )
    return notes


def cut_short(cue: Mapping[str, Any]) -> str | None:
    """Why a cue the robot started was not given in full (None: it was, or it was dropped).

    A robot lost mid-cue ends its motions with ``ok=False`` and the error; a cue still going
    when the talk ended is ``unfinished``.

    Example:
        >>> cut_short({"ok": False, "dropped": False, "gesture_error": "robot lost: reset"})
        'robot lost: reset'
        >>> cut_short({"ok": True, "dropped": False}) is None
        True
    """
    if cue.get("dropped") or (cue.get("ok") is not False and not cue.get("unfinished")):
        return None
    if outcome_unknown(cue) is not None:
        return None
    failed = [
        p
        for p in ("gesture", "speech")
        if cue.get(f"{p}_error") and cue.get(f"{p}_outcome") != "unknown"
    ]
    for p in failed:
        said = " (the phrase was said)" if p == "gesture" and cue.get("speech_ok") is True else ""
        return str(cue[f"{p}_error"]) + said
    if cue.get("unfinished"):
        return "the talk ended before it finished"
    return "the robot did not finish it"


def outcome_unknown(cue: Mapping[str, Any]) -> str | None:
    """Why whether the robot gave a cue is not known: the link to it was lost while the cue ran
    (the robot may well have finished it); None when the outcome is known.

    Example:
        >>> outcome_unknown({"ok": False, "dropped": False, "speech_ok": False,
        ...                  "speech_outcome": "unknown", "speech_error": "robot lost: gone"})
        'robot lost during the cue (robot lost: gone)'
    """
    if cue.get("dropped") or cue.get("ok") is not False:
        return None
    parts = [p for p in ("gesture", "speech") if cue.get(f"{p}_ok") is False]
    if not parts or any(cue.get(f"{p}_outcome") != "unknown" for p in parts):
        return None
    return f"robot lost during the cue ({cue.get(f'{parts[0]}_error')})"


def measured_end_s(talk_s: float, recording_s: Any) -> float:
    """Where measuring stops: the talk's end, or the recordings' end when every input was a
    file played to its end (``recording_s``, a positive number; anything else is ignored).

    Example:
        >>> measured_end_s(63.6, 61.4), measured_end_s(63.6, None), measured_end_s(63.6, "x")
        (61.4, 63.6, 63.6)
    """
    number = isinstance(recording_s, (int, float)) and not isinstance(recording_s, bool)
    return min(talk_s, float(recording_s)) if number and recording_s > 0 else talk_s


def build_summary(
    config: Config,
    streams: Mapping[str, Sequence[Sample]],
    cues: Sequence[Mapping[str, Any]],
    *,
    talk_s: float,
    truth: Sequence[Mapping[str, Any]] | None = None,
    stream_stats: Mapping[str, Mapping[str, Any]] | None = None,
    backend_stats: Mapping[str, Any] | None = None,
    extra: Mapping[str, Any] | None = None,
    processor_counts: Mapping[str, Mapping[str, int]] | None = None,
    problems: Sequence[str] = (),
    not_measured: Collection[str] = (),
    modules: Mapping[str, Any] | None = None,
    skipped_records: Sequence[str] = (),
    unmeasured: Mapping[str, str] | None = None,
    less_reliable: Mapping[str, str] | None = None,
    estimates: Mapping[str, str] | None = None,
    module_failures: Mapping[str, Any] | None = None,
    out_of_order: Sequence[str] = (),
) -> dict[str, Any]:
    """The ``summary.json`` of a talk.

    Args:
        config: the talk's configuration.
        streams: samples per metric, in file order.
        cues: records from ``cues.jsonl``.
        talk_s: how long the talk lasted.
        truth: ground-truth out-of-range intervals (synthetic talks only).
        stream_stats: tailer counters per metric (malformed, truncations…).
        backend_stats: the backend's own figures (joint-limit violations…).
        extra: anything else to record at top level (scenario, seed, wall time…).
        processor_counts: per metric, samples the processor dropped (``late``, ``ahead``).
        problems: skipped stream lines as ``file:line: reason`` (kept up to 100).
        not_measured: metrics no module was run for (no stream file at all, e.g. the camera's
            in an audio-only rehearsal): they have no samples and no stale episode.
        modules: the launcher's record of the modules (``summary.json``'s ``modules``): a
            metric whose module died holds its last value only until then, and its
            ``lost`` stretches (:func:`module_outages`) are listed.
        skipped_records: damaged lines of ``cues.jsonl`` left out, as ``file:line: why``
            (``skipped_records`` and ``counts.skipped_records``, only when there is one).
        unmeasured: per metric, why it was not measured (:func:`measurement_notes`): with no
            sample it has ``not_measured_why`` and no stale episode. A metric with no sample
            in a talk shorter than its first value (``Metric.first_after_s``) gets the same:
            the talk was too short.
        less_reliable: per metric, why its figures are less reliable (``less_reliable``).
        estimates: per metric, why its figures are an estimate (``estimate``,
            :func:`estimate_notes`); its advice stands.
        out_of_order: per stream file whose times went back, its first such sample as
            ``file:line: t=… goes back from …`` (``out_of_order_times``).
        module_failures: ``rehearse``'s modules that failed (module → its last error line):
            one that wrote values first is in ``modules`` as a crash (:func:`with_failures`).

    A metric measured for less than :data:`MIN_JUDGED_S` has ``too_brief``: the report neither
    advises on it nor praises it. A metric's stale episodes are counted (``stale_episodes``)
    and listed (``stale_spans``, :func:`stale_spans`, with the module that writes it when
    ``modules`` says).
    """
    metrics: dict[str, Any] = {}
    stale_default = config.processor.stale_after_s
    recorded_modules = modules
    modules = with_failures(modules, module_failures, streams)
    # `up` of recordings played to their end: nothing was measured after the recordings'
    # end, though the coach's clock ran on while the modules stopped (session 22: a 61.4 s
    # file read 'pace 0:55 of 1:01' in up, 0:50 in rehearse)
    end_s = measured_end_s(talk_s, (extra or {}).get("recording_s"))
    lost = module_outages(modules, streams, end_s)
    writers = {  # metric -> the module that writes it, as the launcher records it
        str(metric): str(name)
        for name, rec in (modules or {}).items()
        if isinstance(rec, Mapping) and isinstance(rec.get("metrics"), list)
        for metric in rec["metrics"]
    }
    # each metric's times and values in time order, made once (a 6-hour replay has 108k)
    columns: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for rule in config.rules:
        ss = sorted(streams.get(rule.metric, ()), key=_T)
        ts = np.fromiter(map(_T, ss), dtype=float, count=len(ss))
        vals = np.fromiter(map(_VALUE, ss), dtype=float, count=len(ss))
        columns[rule.metric] = (ts, vals)
        stale_s = rule.stale_after_s if rule.stale_after_s is not None else stale_default
        m: dict[str, Any] = {"samples": len(ss), "unit": rule.unit}
        cuts = [sp["from"] for sp in lost.get(rule.metric, ())]
        m.update(_in_range_time(rule, ts, vals, end_s, stale_s, cuts))
        if rule.metric in lost:
            m["lost"] = lost[rule.metric]
        if len(vals):
            # the figures are of the values as judged, so that they read against the band; a
            # rule's offset is kept with them, and the mean as measured
            judged = vals + rule.offset if rule.offset else vals
            p = _percentiles(judged, _DECILES)
            with np.errstate(over="ignore", invalid="ignore"):  # 1e308s: mean inf, then None
                mean = float(judged.mean())
                raw_mean = float(vals.mean())
            m.update(
                mean=round(mean, 4) if np.isfinite(mean) else None,
                p10=round(float(p[0]), 4),
                p50=round(float(p[1]), 4),
                p90=round(float(p[2]), 4),
            )
            if rule.offset:
                m["measured_mean"] = round(raw_mean, 4) if np.isfinite(raw_mean) else None
        if rule.offset:
            m["offset"] = rule.offset
            if rule.at:
                m["at"] = rule.at
        why = (unmeasured or {}).get(rule.metric)
        rec = METRICS.get(rule.metric)
        if not ss and why is None and rec is not None and talk_s < rec.first_after_s:
            first = f"first values after {rec.first_after_s:.0f} s"
            why = f"the talk was too short to measure it ({first})"
        if not ss and why is None and rule.metric in not_measured and rec is None:
            why = no_writer_why(rule.metric, rule.stream, writers.get(rule.metric))
        if not ss and (rule.metric in not_measured or why is not None):
            m["stale_episodes"] = 0  # nothing was asked to, or could, measure it
            m["measured"] = False
            if why is not None:
                m["not_measured_why"] = why
        else:
            # No sample at all is one stale episode as long as the talk: the module that
            # opened the file never reported. Each is said in the notes (session 21: a
            # module silent again after its restart was counted, never said)
            spans = stale_spans(ts, end_s, stale_s)
            m["stale_episodes"] = len(spans)
            if spans:
                who = writers.get(rule.metric)
                m["stale_spans"] = [{**sp, "module": who} if who else sp for sp in spans]
                # a module that writes less often than its record declares goes stale between
                # its values: said with its stale spans (session 22: every 10 s against 1 s)
                pace = float(np.median(np.diff(ts))) if len(ts) >= 3 else 0.0
                if rec is not None and pace > 2.0 * rec.cadence_s + 0.5:
                    m["slow_cadence"] = {
                        "median_gap_s": round(pace, 3),
                        "declared_s": rec.cadence_s,
                    }
        if ss and m["in_range_s"] + m["out_of_range_s"] < MIN_JUDGED_S:
            m["too_brief"] = True
        if ss and less_reliable and rule.metric in less_reliable:
            m["less_reliable"] = less_reliable[rule.metric]
        if ss and estimates and rule.metric in estimates:
            m["estimate"] = estimates[rule.metric]
        if truth is not None:
            m["truth_time_in_range"] = _truth_in_range_fraction(truth, rule.metric, end_s)
        if stream_stats and rule.metric in stream_stats:
            m["stream"] = dict(stream_stats[rule.metric])
        if processor_counts and rule.metric in processor_counts:
            pc = processor_counts[rule.metric]
            m["dropped"] = {"late": int(pc.get("late", 0)), "ahead": int(pc.get("ahead", 0))}
        metrics[rule.metric] = m

    rules = {r.metric: r for r in config.rules}
    # when each cued metric had no value: a cue then cannot be judged by the recorded values
    gaps: dict[str, list[tuple[float, float]]] = {}
    # what each corrective cue is judged by: the ground truth, else the recorded values
    if truth is not None:
        judged_by = Stretches(truth)
    else:  # only the metrics that were cued
        cued = {c.get("metric") for c in cues}
        gaps = {
            rule.metric: _no_data(
                columns[rule.metric][0],
                end_s,
                rule.stale_after_s if rule.stale_after_s is not None else stale_default,
                [sp["from"] for sp in lost.get(rule.metric, ())],
            )
            # after the recordings' end nothing was measured, though the coach's clock ran on
            # while the modules stopped: a cue then is not judged (session 22's review: one
            # at 1:01.5 of a 1:01 recording was 'STALE: back in range 0 s before')
            + ([(end_s, talk_s)] if end_s < talk_s else [])
            for rule in config.rules
            if rule.metric in cued
        }
        judged_by = Stretches(
            [
                x
                for rule in config.rules
                if rule.metric in cued
                for x in _measured_stretches(
                    rule,
                    *columns[rule.metric],
                    end_s,
                    rule.stale_after_s if rule.stale_after_s is not None else stale_default,
                    [sp["from"] for sp in lost.get(rule.metric, ())],
                )
            ]
        )
    cue_rows: list[dict[str, Any]] = []
    for c in cues:
        row = {k: c.get(k) for k in ("t", "command", "metric", "kind", "reason", "params")}
        for k in (
            "planned_s",
            "measured_s",
            "gesture",
            "gesture_planned_s",
            "gesture_measured_s",
            "phrase",
            "dropped",
            "gesture_peak_velocity_ratio",
            "gesture_violations",
        ):
            if k in c:
                row[k] = c[k]
        if c.get("dropped") and "drop_reason" in c:  # why the robot did not give it
            row["drop_reason"] = c["drop_reason"]
        t = float(c["t"])
        metric = c.get("metric")
        onset = c.get("onset")
        relevant: bool | None = None
        cue_rule = rules.get(metric) if metric is not None else None
        if cue_rule is not None:
            side = "below" if c["command"] == cue_rule.below else "above"
            kind, when = judged_by.classify(cue_rule.metric, side, t)
            no_data = gaps.get(cue_rule.metric, [])
            gap = _in_span(no_data, t) if kind != "relevant" else None
            if gap is not None:
                # no value held at t (its module died, the stream went stale): not "back in
                # range" nor "in range", only not measured (session 22)
                kind, when = "unmeasured", None
                row["not_measured_since"] = round(gap[0], 3)
            elif kind == "stale" and when is not None:
                # measured back in range when the first value after a gap came, not when the
                # last value out of range stopped holding
                when = next((b for a, b in no_data if abs(a - when) < 1e-6 and b <= t), when)
            row["cue_class"] = kind
            relevant = None if kind == "unmeasured" else kind == "relevant"
            if kind == "relevant":
                if truth is not None:  # the real onset; the coach's is its own view
                    onset = when
            else:  # no problem to measure a delay from
                onset = None
                if kind == "stale" and when is not None:
                    row["ended_s_before"] = round(t - when, 3)
        elif metric is not None:  # a metric no rule judges: the coach's own view
            relevant = float(c.get("deviation") or 0.0) > 0.0
        elif c.get("kind") == "time":
            relevant = True
        row["onset"] = onset
        row["latency_s"] = round(t - float(onset), 3) if onset is not None else None
        row["relevant"] = relevant
        cut = cut_short(c)
        if cut is not None:
            row["cut_short"] = cut
        unknown = outcome_unknown(c)
        if unknown is not None:
            row["outcome_unknown"] = unknown
        cue_rows.append(row)

    allocated = config.time.allocated_s
    used_s = talk_s
    recording_s = (extra or {}).get("recording_s")
    if isinstance(recording_s, int | float) and 0.0 < recording_s < talk_s:
        # `up` of files played to their end: the recordings' length, not the coach's clock,
        # which ran on while the modules started up and caught up
        used_s = float(recording_s)
    time_used: dict[str, Any] = {"used_s": round(used_s, 3), "allocated_s": allocated}
    if allocated:
        time_used["over_under_pct"] = round(100.0 * (used_s - allocated) / allocated, 2)
    if (extra or {}).get("stopped_at_time_limit"):
        # the talk went on past the allocated time plus its grace and was stopped there: the
        # time used is at least this
        time_used["stopped_at_limit"] = True
    malformed = sum(int(s.get("malformed", 0)) for s in (stream_stats or {}).values())
    backwards = sum(int(s.get("out_of_order", 0)) for s in (stream_stats or {}).values())
    n_cut = sum(1 for r in cue_rows if "cut_short" in r)
    n_unknown = sum(1 for r in cue_rows if "outcome_unknown" in r)
    n_unmeasured = sum(1 for r in cue_rows if r.get("cue_class") == "unmeasured")
    out: dict[str, Any] = {
        "talk_s": round(talk_s, 3),
        "time": time_used,
        "metrics": metrics,
        "cues": cue_rows,
        "counts": {
            "cues": len(cue_rows),
            "cues_dropped": sum(1 for c in cues if c.get("dropped")),
            "false_alarms": sum(1 for r in cue_rows if r.get("cue_class") == "false_alarm")
            + sum(1 for r in cue_rows if r["relevant"] is False and "cue_class" not in r),
            "stale": sum(1 for r in cue_rows if r.get("cue_class") == "stale"),
            **({"cues_unmeasured": n_unmeasured} if n_unmeasured else {}),
            "malformed_samples": malformed,
            # kept as written, but a module's clock went back: said with the first (session 22)
            **({"out_of_order": backwards} if backwards else {}),
            "dropped_samples": sum(
                int(pc.get("late", 0)) + int(pc.get("ahead", 0))
                for pc in (processor_counts or {}).values()
            ),
            "stale_episodes": sum(m["stale_episodes"] for m in metrics.values()),
            # None: the backend measures none (fake, naoqi): an unmeasured check is no 0
            "joint_limit_violations": (
                None
                if (jlv := (backend_stats or {}).get("joint_limit_violations")) is None
                else int(jlv)
            ),
            **({"cues_cut_short": n_cut} if n_cut else {}),
            **({"cues_outcome_unknown": n_unknown} if n_unknown else {}),
            **({"skipped_records": len(skipped_records)} if skipped_records else {}),
        },
        "backend_stats": dict(backend_stats or {}),
        "stream_problems": list(problems)[:100],
        **({"out_of_order_times": list(out_of_order)} if out_of_order else {}),
        **({"skipped_records": list(skipped_records)[:100]} if skipped_records else {}),
    }
    if extra:
        out.update(extra)
    if modules != dict(recorded_modules or {}):  # a failure of rehearse's, as up records it
        out["modules"] = modules
    return out


def no_writer_why(metric: str, stream: str, module: str | None = None) -> str:
    """Why a judged metric no shipped module writes has no stream file at all: the module
    that should write it wrote none (``module``, when the modules' record names it), or none
    does (a misspelled metric: session 22, a rule on ``speech_filers`` ended in "Well done!").

    Example:
        >>> no_writer_why("speech_sped", "speech_sped.txt")
        "no module wrote streams/speech_sped.txt (no shipped module writes 'speech_sped'; did you mean 'speech_speed'?)"
    """  # noqa: E501 - a doctest output line
    import difflib

    if module:
        return f"module {module} wrote no streams/{stream}"
    close = difflib.get_close_matches(metric, list(METRICS), n=1, cutoff=0.6)
    hint = f"; did you mean '{close[0]}'?" if close else ""
    return f"no module wrote streams/{stream} (no shipped module writes '{metric}'{hint})"


def in_folder(path: Any, root: Any) -> str:
    """``path`` as ``summary.json`` names it: relative to the session folder when it is inside
    it (``streams/x.txt``), so that the record holds wherever the folder is copied and from
    whatever folder the command was run; else as given.

    Example:
        >>> in_folder("/data/s1/streams/x.txt", "/data/s1"), in_folder("/elsewhere/x.txt", "/data/s1")
        ('streams/x.txt', '/elsewhere/x.txt')
    """  # noqa: E501 - a doctest line
    from pathlib import Path

    p, r = Path(path), Path(root)
    for a, b in ((p, r), (p.absolute(), r.absolute())):
        try:
            return a.relative_to(b).as_posix()
        except ValueError:
            pass
    return str(path)


def summarize_session(
    session: SessionDir,
    config: Config,
    *,
    talk_s: float,
    truth: Sequence[Mapping[str, Any]] | None = None,
    backend_stats: Mapping[str, Any] | None = None,
    extra: Mapping[str, Any] | None = None,
    live: MultiTailer | None = None,
    processor: Processor | None = None,
    readings: Mapping[str, tuple[list[Sample], TailStats, list[StreamProblem]]] | None = None,
) -> dict[str, Any]:
    """Read a session folder's module files and cue log, write and return ``summary.json``.

    Args:
        live: the tailer that fed the processor during the talk: its counters (truncations,
            replacements, lines ahead of the clock…) and skipped lines go into the summary, as
            re-reading the final files cannot see them. None (a rebuild): from the files.
        processor: the talk's processor: the samples it dropped (late, ahead) are counted.
        readings: stream files already read (metric → samples, counters, skipped lines; a
            replay's), used instead of reading the session's copies again.

    A damaged line of ``cues.jsonl`` (a torn one, or one in the middle) is skipped, named
    (``file:line: why``) in ``skipped_records`` and counted, as the report does: the end of a
    talk never fails on it, and the summary is built from the other cues.
    """
    from prezence.streams.tail import read_stream

    samples: dict[str, list[Sample]] = {}
    stats: dict[str, dict[str, Any]] = {}
    found: list[StreamProblem] = []
    absent: list[str] = []  # metrics without a stream file: no module was run for them
    for rule in config.rules:
        if readings is not None and rule.metric in readings:
            ss, st, skipped = readings[rule.metric]
            found += skipped
        else:
            ss, st = read_stream(
                session.stream(rule.stream),
                rule.metric,
                problems=found,
                value_range=rule.value_range,
            )
        samples[rule.metric] = ss
        stats[rule.metric] = st.to_dict()
        if not ss and not session.stream(rule.stream).exists():
            absent.append(rule.metric)
    if live is not None:
        for metric, lst in live.stats().items():
            stats[metric] = lst.to_dict()
        found = live.problems()
    # a replay read the recording's files; the session holds byte-identical copies of them
    copies = {
        str(p.path): f"streams/{rule.stream}"
        for rule in config.rules
        if readings is not None and rule.metric in readings
        for p in readings[rule.metric][2]
    }
    problems = [
        f"{copies.get(str(p.path)) or in_folder(p.path, session.root)}:{p.line}: {p.reason}"
        for p in found
    ]
    backwards: list[str] = []  # the first time that went back, per file (read again: rare)
    for rule in config.rules:
        n = int(stats.get(rule.metric, {}).get("out_of_order") or 0)
        if n:
            first: list[StreamProblem] = []
            path = session.stream(rule.stream)
            read_stream(
                path, rule.metric, problems=[], value_range=rule.value_range, out_of_order=first
            )
            where = in_folder(path, session.root)
            if first:
                where = (
                    f"{in_folder(first[0].path, session.root)}:{first[0].line}: {first[0].reason}"
                )
            backwards.append(
                f"{where} (kept as written; {n} sample{'s' if n != 1 else ''} of {rule.metric} "
                "went back in time)"
            )
    bad_cues: list[str] = []
    cues = read_jsonl(session.cues, require=CUE_KEYS, skipped=bad_cues)
    prefix = f"{session.cues}:"
    bad_cues = [
        f"{session.cues.name}:{b[len(prefix) :]}" if b.startswith(prefix) else b for b in bad_cues
    ]
    unmeasured, less_reliable = measurement_notes(session.root, extra)
    summary = build_summary(
        config,
        samples,
        cues,
        talk_s=talk_s,
        truth=truth,
        stream_stats=stats,
        backend_stats=backend_stats,
        extra=extra,
        unmeasured=unmeasured,
        less_reliable=less_reliable,
        estimates=estimate_notes(session.root),
        processor_counts=processor.counts() if processor is not None else None,
        problems=problems,
        not_measured=absent,
        modules=(extra or {}).get("modules"),
        skipped_records=bad_cues,
        module_failures=(extra or {}).get("module_failures"),
        out_of_order=backwards,
    )
    write_json(session.summary, summary)
    return summary
