"""Rebuild a talk's post-speech report from its session folder alone.

The report reads only what the talk wrote as it went: the module files (``streams/*.txt``, or
at the folder's root: replay's discovery, :func:`prezence.streams.locate.locate_streams`), the cue
records (``cues.jsonl``), the effective configuration (``config.toml``) and ``session.json``;
``truth.jsonl`` is used when a synthetic talk finished and left one. It never needs the
processor's memory, so it works after a crash: a torn last line is ignored, a stream that stops
early ends the record there, and missing files give empty sections rather than errors.

Figures per metric come from :func:`prezence.summary.build_summary`; this module adds what only
the report needs: the effect of each cue, the deviation integral that ranks the things to work
on, and the talk's length when the record ends early.
"""

from __future__ import annotations

import logging
import math
from bisect import bisect_right
from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

from prezence.config.model import Config, Rule, signed
from prezence.errors import ConfigError, PrezenceError
from prezence.metrics import (
    METRICS,
    NOISY_METRIC,
    NOISY_SNR_DB,
    SNR_METRIC,
    SOURCE_SYLLABLES,
    SPEECH_ARTICULATION,
    SPEECH_SPEED_SOURCE,
    UNTIMED_METRIC,
)
from prezence.report.speech import measured_s, mmss, was
from prezence.samples import SPEECH_SPEED, Sample
from prezence.session import (
    CUE_KEYS,
    TRUTH_KEYS,
    SessionDir,
    read_json_object,
    read_jsonl,
    sample_time_limit,
)
from prezence.summary import (
    build_summary,
    estimate_notes,
    hold_ends,
    measured_end_s,
    measurement_notes,
    module_notes,
    no_data_spans,
    with_failures,
)

log = logging.getLogger(__name__)

REPORT_FORMAT = 1

#: Seconds before and after a cue over which its effect is judged.
EFFECT_WINDOW_S = 30.0
#: A cue "helped" when the mean deviation after it is at most this fraction of the one before.
IMPROVED_RATIO = 0.8

#: Head-turn streams the vision module writes, shown whether or not a rule uses them.
HEAD_YAW = "cv_headYaw"
FACING = "cv_facingAudience"
#: |yaw| above this (degrees) counts as the head turned to one side.
TURNED_DEG = 20.0


def metric_label(metric: str) -> str:
    """A reader's name for ``metric`` (the metric name itself when none is known).

    Example:
        >>> metric_label("cv_headGaze"), metric_label("my_module")
        ('head pitch', 'my_module')
    """
    rec = METRICS.get(metric)
    return rec.label if rec is not None else metric


def advice(rule: Rule, side: str) -> str:
    """What to do about ``rule``'s metric being on ``side`` ("below"/"above") of its band.

    Example:
        >>> from prezence.config.model import Check
        >>> advice(Rule("speech_speed", Check.IN_RANGE, low=140, high=180), "above")
        'slow down'
        >>> advice(Rule("x", Check.MIN, low=1.0), "below")
        'raise x'
    """
    rec = METRICS.get(rule.metric)
    known = rec.advice.get(side) if rec is not None else None
    if known is not None:
        return known
    return f"{'raise' if side == 'below' else 'lower'} {metric_label(rule.metric)}"


# -- pure figures ------------------------------------------------------------------------------


def deviation_seconds(
    rule: Rule,
    samples: Sequence[Sample],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
    *,
    margins: tuple[float, float] | None = None,
) -> dict[str, float]:
    """Deviation integrated over time (%·s) on each side of the band, sample-and-hold.

    Each sample's deviation holds until the next sample, the end of the talk, ``stale_s``
    after it, or the next of ``cuts`` (its module died), whichever comes first (the same
    holding as the summary's time in range), so a module that writes twice as often does not
    count twice as much, and a dead module's last value is not counted as measured.

    Returns:
        ``{"below": %·s, "above": %·s}``; with ``margins`` (how far under the low bound and
        over the high one a reading may lie within the measurement's error:
        :meth:`prezence.metrics.Metric.margin`) also ``below_beyond`` and ``above_beyond``,
        the part of each from readings out by more than that (:func:`at_edge`).

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
        >>> ss = [Sample("speech_speed", 0.0, 198.0), Sample("speech_speed", 10.0, 160.0)]
        >>> deviation_seconds(r, ss, talk_s=20.0, stale_s=60.0)
        {'below': 0.0, 'above': 100.0}
        >>> deviation_seconds(r, ss, talk_s=20.0, stale_s=60.0, margins=(11.2, 14.4))
        {'below': 0.0, 'above': 100.0, 'below_beyond': 0.0, 'above_beyond': 100.0}
    """
    out = {"below": 0.0, "above": 0.0}
    if margins is not None:
        out.update(below_beyond=0.0, above_beyond=0.0)
    for s, dt in held(samples, talk_s, stale_s, cuts):
        dev, side = rule.judge(s.value)
        if side is not None and dt > 0:
            out[side] += dev * dt
            if margins is not None and _beyond(rule, s.value, side, margins):
                out[f"{side}_beyond"] += dev * dt
    return {k: round(v, 3) for k, v in out.items()}


def held(
    samples: Sequence[Sample], talk_s: float, stale_s: float, cuts: Sequence[float] = ()
) -> Iterator[tuple[Sample, float]]:
    """Each sample of the talk (``t < talk_s``) with the seconds its value held, sample and
    hold: to the next sample, at most ``stale_s``, at most to the talk's end, and not past a
    ``cuts`` time (its module died there: :func:`prezence.summary.hold_ends`).

    Example:
        >>> ss = [Sample("m", 0.0, 1.0), Sample("m", 10.0, 2.0), Sample("m", 30.0, 3.0)]
        >>> [(s.value, dt) for s, dt in held(ss, talk_s=35.0, stale_s=6.0)]
        [(1.0, 6.0), (2.0, 6.0), (3.0, 5.0)]
    """
    ends = hold_ends([s.t for s in samples], cuts) if cuts else None
    for i, s in enumerate(samples):
        if s.t >= talk_s:
            break
        nxt = samples[i + 1].t if i + 1 < len(samples) else talk_s
        if ends is not None:
            nxt = min(nxt, float(ends[i]))
        yield s, max(0.0, min(nxt, s.t + stale_s, talk_s) - s.t)


def _beyond(rule: Rule, value: float, side: str, margins: tuple[float, float]) -> bool:
    """Whether ``value``, out of ``rule``'s band on ``side``, is out by more than the
    measurement's error (``margins``: under the low bound, over the high one)."""
    v = value + rule.offset
    if side == "below":
        return rule.low is not None and v < rule.low - margins[0]
    return rule.high is not None and v > rule.high + margins[1]


def error_margins(rule: Rule) -> tuple[float, float] | None:
    """How far under its low bound and over its high one ``rule``'s metric may read within
    its module's stated measurement error; None when its record states none."""
    rec = METRICS.get(rule.metric)
    if rec is None or (rec.error_pct is None and rec.error_abs is None):
        return None
    lo = rec.margin(rule.low) if rule.low is not None else 0.0
    hi = rec.margin(rule.high) if rule.high is not None else 0.0
    return lo, hi


def mean_deviation(rule: Rule, samples: Sequence[Sample], start: float, end: float) -> float | None:
    """Mean deviation (%) of the samples with ``start <= t < end``; None when there are none.

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_volume", Check.MIN, low=60.0, scale=6.0)
        >>> ss = [Sample("speech_volume", t, v) for t, v in [(1, 54.0), (2, 57.0), (5, 66.0)]]
        >>> mean_deviation(r, ss, 0.0, 3.0), mean_deviation(r, ss, 3.0, 9.0)
        (75.0, 0.0)
        >>> mean_deviation(r, ss, 10.0, 20.0) is None
        True
    """
    devs = [rule.deviation(s.value) for s in samples if start <= s.t < end]
    return sum(devs) / len(devs) if devs else None


def back_in_range_s(
    rule: Rule, samples: Sequence[Sample], t: float, *, window_s: float = EFFECT_WINDOW_S
) -> float | None:
    """Seconds from ``t`` until the metric was back in range to stay, within ``window_s``.

    The samples in ``[t, t + window_s)`` must end in range: the answer is the time of the
    first of the in-range samples after the last one out of range; None when the window ends
    out of range or holds no sample.

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
        >>> ss = [Sample("speech_speed", t, 200.0 if t < 42 else 170.0) for t in range(60)]
        >>> back_in_range_s(r, ss, 30.0), back_in_range_s(r, ss[:40], 30.0)
        (12.0, None)
    """
    after = [s for s in samples if t <= s.t < t + window_s]
    if not after or rule.side(after[-1].value) is not None:
        return None
    out = [i for i, s in enumerate(after) if rule.side(s.value) is not None]
    first = out[-1] + 1 if out else 0
    return round(after[first].t - t, 3)


def cue_effect(
    rule: Rule, samples: Sequence[Sample], t: float, *, window_s: float = EFFECT_WINDOW_S
) -> dict[str, Any]:
    """What the metric did after a cue at ``t``: mean deviation before vs after, and whether
    it was back in range within the window.

    Compares the mean deviation of the samples in ``[t - window_s, t)`` with those in
    ``[t, t + window_s)``. ``improved`` is True when the deviation after is at most
    :data:`IMPROVED_RATIO` of the one before, False when it is not, None when either window has
    no samples or there was nothing to improve (deviation 0 before); ``back_in_range_s`` is
    :func:`back_in_range_s` (None when not judged). This is what was measured, not why: a
    presenter who ignored the cue may be back in range all the same (the report says so where
    the talk records whether the presenter reacted).

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
        >>> ss = [Sample("speech_speed", t, 200.0 if t < 30 else 170.0) for t in range(60)]
        >>> cue_effect(r, ss, 30.0)
        {'deviation_before': 11.111, 'deviation_after': 0.0, 'improved': True, 'back_in_range_s': 0.0}
    """  # noqa: E501 - a doctest output line
    before = mean_deviation(rule, samples, t - window_s, t)
    after = mean_deviation(rule, samples, t, t + window_s)
    improved: bool | None = None
    if before is not None and after is not None and before > 0.0:
        improved = after <= IMPROVED_RATIO * before
    back = back_in_range_s(rule, samples, t, window_s=window_s) if improved is not None else None
    return {
        "deviation_before": None if before is None else round(before, 3),
        "deviation_after": None if after is None else round(after, 3),
        "improved": improved,
        "back_in_range_s": back,
    }


def effect_words(row: Mapping[str, Any]) -> str | None:
    """What followed a cue, in words that say what was measured, not that the cue caused it.

    Example:
        >>> effect_words({"improved": True, "back_in_range_s": 16.0})
        'back in range after 16 s'
        >>> effect_words({"improved": True}), effect_words({"improved": False})
        ('closer to range after', 'no closer after')
    """
    improved = row.get("improved")
    if improved is None:
        return None
    back = row.get("back_in_range_s")
    if isinstance(back, int | float):
        return f"back in range after {back:.0f} s"
    return "closer to range after" if improved else "no closer after"


#: Kinds of session whose speaker heard the robot's cues as they were given (``session.json``).
HEARD_KINDS = ("live", "synthetic")
#: Two cues are the same cue when their times differ by less than this (seconds): a replay's
#: decision points fall at the recording's times.
SAME_CUE_S = 1e-3


def heard_cues(
    session: SessionDir,
    meta: Mapping[str, Any],
    cues: Sequence[Mapping[str, Any]],
    own: Mapping[str, Any],
) -> tuple[list[Mapping[str, Any] | None], str | None]:
    """Which cues the speaker heard, and the folder whose record says how they reacted.

    A cue's effect can be judged only if the speaker heard it. In a live or synthetic talk
    (and a folder whose kind is not recorded) they heard every cue. In a rehearsal the coach
    chose its cues after the recording was made: nobody heard them. In a replay the speaker
    heard the *recording's* cues: a replayed cue is judged only when the recording (a live or
    synthetic talk whose folder is still there) gave the same command at the same time, and
    then on the recorded talk it followed; the others are not judged.

    Args:
        own: the folder's own ``summary.json`` ({} when there is none).

    Returns:
        Per cue, the ``summary.json`` (a dict, {} when there is none) of the talk in which it
        was heard, or None when it was not heard; and a sentence saying why some were not
        (None when all were).
    """
    kind = meta.get("kind")
    if kind == "rehearsal":
        return [None] * len(cues), (
            "a recorded rehearsal is coached after it was recorded, so the speaker heard none "
            "of these cues"
        )
    if kind == "live" and meta.get("recorded_inputs"):
        # `up` with files played as if live: the person in them could not hear the robot
        return [None] * len(cues), (
            "the talk's inputs were recordings played as if live, so the speaker heard none "
            "of these cues"
        )
    if kind != "replay":
        return [own] * len(cues), None
    why = "this is a replay, whose speaker heard the recording's cues, not these"
    src = _replay_source(session, meta)
    if src is None:
        return [None] * len(cues), f"{why} (the recording's folder is not found)"
    try:
        src_meta = src.read_meta()
    except PrezenceError:
        src_meta = {}
    src_kind = src_meta.get("kind")
    if src_kind not in HEARD_KINDS:
        return [None] * len(cues), why
    if src_meta.get("recorded_inputs"):  # an `up` from files: nobody heard its cues either
        return [None] * len(cues), why
    given = read_jsonl(src.cues, require=CUE_KEYS, skipped=[]) if src.cues.is_file() else []
    src_summary = _read_summary(src)
    heard: list[Mapping[str, Any] | None] = []
    for c in cues:
        same = any(
            g["command"] == c["command"] and abs(float(g["t"]) - float(c["t"])) < SAME_CUE_S
            for g in given
        )
        heard.append(src_summary if same else None)
    if all(h is not None for h in heard):
        return heard, None
    return heard, why


def _replay_source(session: SessionDir, meta: Mapping[str, Any]) -> SessionDir | None:
    """The recording a replay coached (``session.json``'s ``source``), if it is still there:
    the path as recorded, or a folder of that name next to the replay's (both copied)."""
    source = meta.get("source")
    if not isinstance(source, str) or not source:
        return None
    path = Path(source)
    tries = [path, session.root.parent / path.name]
    for p in tries:
        s = SessionDir(p)
        if s.meta.is_file() or (p.name == "streams" and SessionDir(p.parent).meta.is_file()):
            return s if s.meta.is_file() else SessionDir(p.parent)
    return None


def _reaction(summary: Mapping[str, Any], cue: Mapping[str, Any]) -> Mapping[str, Any] | None:
    """The synthetic presenter's recorded reaction to ``cue`` (``summary.json``'s
    ``reactions``: its ground truth), None when the talk records none."""
    for r in summary.get("reactions") or ():
        if (
            isinstance(r, Mapping)
            and r.get("command") == cue.get("command")
            and isinstance(r.get("t"), int | float)
            and abs(float(r["t"]) - float(cue["t"])) < SAME_CUE_S
        ):
            return r
    return None


#: A metric out of its band for at least this share of the time it was measured needs work,
#: however little it was off each time: half the talk under 140 wpm is not "a little off"
#: (:func:`rank_priorities`).
FAR_OFF_SHARE = 0.5
#: A metric out of its band for at least this share of its measured time is not "in the ideal
#: range", even when it was too little off to work on (:func:`slightly_off`).
SLIGHTLY_OFF_SHARE = 0.2


#: A voice first heard this many seconds or more into the talk is said with the time used
#: (session 20: a recording that began with 60 s of silence was told "1:51 used of 2:00", the
#: robot said "1 min left" before a word was spoken, and nothing said where speech began).
LATE_START_S = 20.0


#: A talk the time limit stopped was still going on when a voice was heard this close to the
#: stop (the speech module's activity window is 10 s).
STILL_GOING_S = 15.0


def voice_times(session: SessionDir, limit: float | None = None) -> list[float] | None:
    """When the speech module heard a voice (``speech_activity`` above 0), seconds into the
    talk, in order; None without that stream."""
    from prezence.streams.tail import read_stream

    path = session.stream("speech_activity.txt")
    if not path.is_file():
        return None
    samples, _ = read_stream(path, "speech_activity", max_t=limit, problems=[])
    return sorted(s.t for s in samples if s.value > 0.0)


def _module_stream(session: SessionDir, metric: str, limit: float | None) -> list[Sample] | None:
    """A module's stream of the session folder, in time order; None without the file."""
    from prezence.streams.tail import read_stream

    path = session.stream(f"{metric}.txt")
    if not path.is_file():
        return None
    samples, _ = read_stream(path, metric, max_t=limit, problems=[])
    return sorted(samples, key=lambda s: s.t)


def room_snr(session: SessionDir, limit: float | None = None) -> list[Sample] | None:
    """The speech module's estimated SNR per word window (``speech_snr``), in time order;
    None without that stream (a recording made before session 21, a synthetic talk)."""
    return _module_stream(session, SNR_METRIC, limit)


#: The metrics whose value at a time came from the count ``speech_speed_source`` names then
#: (the speech module's pace and articulation rate).
SOURCED = frozenset({SPEECH_SPEED, SPEECH_ARTICULATION})


def untimed_reasons(session: SessionDir, limit: float | None = None) -> list[Sample] | None:
    """The speech module's reason codes (``speech_untimed_reason``), in time order; None
    without that stream (a folder written before issue 11, a synthetic talk)."""
    return _module_stream(session, UNTIMED_METRIC, limit)


def untimed_seconds(
    reasons: Sequence[Sample],
    samples: Sequence[Sample],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
    *,
    first_after_s: float = 0.0,
) -> list[dict[str, Any]]:
    """Why a speech metric was not measured where it was not: per reason code, the seconds
    its lines held (each until the next line, the stale time or the talk's end, as a value
    holds) inside the stretches the metric's own values did not hold, largest first.

    The module's first line (at ``first_after_s``, its window's end) describes that window,
    so it holds from the talk's start (music from 0:00 to 0:16: "no voice for 0:16", not 0:06).
    A stretch the reasons do not cover (a module that died) is left out: said elsewhere.

    Example:
        >>> r = [Sample("r", float(t), 2.0 if t < 16 else 5.0) for t in range(10, 30)]
        >>> ss = [Sample("v", float(t), 150.0) for t in range(30, 60)]
        >>> untimed_seconds(r, ss, 60.0, 6.0, first_after_s=10.0)
        [{'code': 2, 's': 16.0}, {'code': 5, 's': 14.0}]

        The module died at 20 s: its last reason (at 19 s) does not hold into the 40 s after.

        >>> untimed_seconds(r[:10], [], 60.0, 60.0, [20.0], first_after_s=10.0)
        [{'code': 2, 's': 16.0}, {'code': 5, 's': 4.0}]
    """
    gaps = no_data_spans(samples, talk_s, stale_s, cuts)
    return untimed_in(reasons, gaps, talk_s, stale_s, cuts, first_after_s=first_after_s)


def _stale_why(
    span: Mapping[str, Any],
    reasons: Sequence[Sample],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float],
    first_after_s: float,
) -> Mapping[str, Any]:
    """A stale span (``stale_spans``' row) with the speech module's reasons for its stretch
    (``untimed``, as :func:`untimed_in` gives them) where it wrote any."""
    rows = untimed_in(
        reasons,
        [(float(span["from"]), float(span["to"]))],
        talk_s,
        stale_s,
        cuts,
        first_after_s=first_after_s,
    )
    return {**span, "untimed": rows} if rows else span


def stale_reasons(root: Path, summary: Mapping[str, Any]) -> dict[str, list[dict[str, Any]]]:
    """Per speech metric of ``summary`` (a ``summary.json``) that went stale, its
    ``stale_spans`` with the speech module's reasons for each stretch (``untimed``), as the
    report gives them; {} when the folder at ``root`` holds no reasons (a folder written before
    issue 11, a synthetic talk). For the notes printed after a talk (session 25's "Not done":
    ``up`` printed "not measured from 0:50 to the end (2:03)" where its report said why)."""
    reasons = untimed_reasons(SessionDir(root))
    if not reasons:
        return {}
    talk_s = float(summary.get("talk_s") or 0.0)
    rec_s = summary.get("recording_s")
    end_s = measured_end_s(talk_s, float(rec_s) if isinstance(rec_s, int | float) else None)
    out: dict[str, list[dict[str, Any]]] = {}
    for metric, m in (summary.get("metrics") or {}).items():
        record = METRICS.get(str(metric))
        spans = m.get("stale_spans") if isinstance(m, Mapping) else None
        if record is None or record.module != "speech" or not spans:
            continue
        cuts = [float(sp["from"]) for sp in m.get("lost") or ()]
        out[str(metric)] = [
            dict(
                _stale_why(
                    sp,
                    reasons,
                    end_s,
                    float(sp.get("stale_after_s") or 0.0),
                    cuts,
                    record.first_after_s,
                )
            )
            for sp in spans
        ]
    return out


def untimed_in(
    reasons: Sequence[Sample],
    gaps: Sequence[tuple[float, float]],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
    *,
    first_after_s: float = 0.0,
) -> list[dict[str, Any]]:
    """:func:`untimed_seconds` inside the stretches ``gaps`` (``(from, to)``, in time order):
    per reason code, the seconds its lines held there, largest first. A stale span's own
    stretch gives its reasons (issue 11: "not measured from 1:09 to 2:02" said no why).

    Example:
        >>> r = [Sample("r", float(t), 1.0 if t < 40 else 3.0) for t in range(30, 60)]
        >>> untimed_in(r, [(36.0, 50.0)], 60.0, 6.0)
        [{'code': 3, 's': 10.0}, {'code': 1, 's': 4.0}]
    """
    if not gaps or not reasons:
        return []
    ts = [s.t for s in reasons]
    # a reason holds no further than a value would: not past its module's death
    ends = hold_ends(ts, cuts) if cuts else None
    per: dict[int, float] = {}
    g = 0
    for i, s in enumerate(reasons):
        start = 0.0 if i == 0 and s.t <= first_after_s + 1e-6 else s.t
        nxt = ts[i + 1] if i + 1 < len(ts) else talk_s
        if ends is not None:
            nxt = min(nxt, float(ends[i]))
        end = min(nxt, s.t + stale_s, talk_s)
        while g < len(gaps) and gaps[g][1] <= start:
            g += 1
        j = g
        while j < len(gaps) and gaps[j][0] < end:
            held = min(end, gaps[j][1]) - max(start, gaps[j][0])
            if held > 0:
                per[int(s.value)] = per.get(int(s.value), 0.0) + held
            j += 1
    rows = [{"code": c, "s": round(v, 1)} for c, v in per.items() if v > 0]
    return sorted(rows, key=lambda r: (-r["s"], r["code"]))


def syllable_seconds(
    samples: Sequence[Sample],
    sources: Sequence[Sample],
    reasons: Sequence[Sample],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
    *,
    syllables: float,
) -> dict[str, Any] | None:
    """Of the time a speech metric's values held (each as in :func:`deviation_seconds`), the
    seconds of those the speech module took from its syllable count (``speech_speed_source``
    ``syllables`` at the value's time), with the reasons it wrote at those times
    (``speech_untimed_reason``: a narrowband recording, a recogniser it was unsure of) and
    their seconds, largest first; None when no value came from it.

    Example:
        >>> v = [Sample("v", float(t), 150.0) for t in range(10, 20)]
        >>> src = [Sample("s", float(t), 2.0 if t >= 16 else 1.0) for t in range(10, 20)]
        >>> why = [Sample("r", float(t), 8.0) for t in range(16, 20)]
        >>> syllable_seconds(v, src, why, 20.0, 6.0, syllables=2.0)
        {'s': 4.0, 'untimed': [{'code': 8, 's': 4.0}]}
    """
    source = {round(s.t, 3): s.value for s in sources}
    code = {round(s.t, 3): int(s.value) for s in reasons}
    total = 0.0
    per: dict[int, float] = {}
    for s, dt in held(samples, talk_s, stale_s, cuts):
        if source.get(round(s.t, 3)) != syllables:
            continue
        total += dt
        c = code.get(round(s.t, 3))
        if c is not None:
            per[c] = per.get(c, 0.0) + dt
    if not total > 0.0:
        return None
    rows = [{"code": c, "s": round(v, 1)} for c, v in per.items() if v > 0]
    return {"s": round(total, 1), "untimed": sorted(rows, key=lambda r: (-r["s"], r["code"]))}


def noisy_low_seconds(
    rule: Rule,
    samples: Sequence[Sample],
    snr: Sequence[Sample],
    talk_s: float,
    stale_s: float,
    cuts: Sequence[float] = (),
) -> float:
    """Of the time ``rule``'s metric read below its band (each value held as in
    :func:`deviation_seconds`, so the whole is the summary's ``below_s``), the seconds whose
    newest SNR, at most ``stale_s`` old, was under :data:`prezence.metrics.NOISY_SNR_DB`.

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_accuracy", Check.MIN, low=0.5)
        >>> acc = [Sample("speech_accuracy", t, v) for t, v in ((10, 0.2), (20, 0.3), (30, 0.9))]
        >>> snr = [Sample("speech_snr", t, v) for t, v in ((10, 9.0), (20, 30.0), (30, 9.0))]
        >>> noisy_low_seconds(r, acc, snr, talk_s=40.0, stale_s=60.0)
        10.0
    """
    ts = [s.t for s in snr]
    out = 0.0
    for s, dt in held(samples, talk_s, stale_s, cuts):
        if rule.side(s.value) != "below":
            continue
        j = bisect_right(ts, s.t)
        if j == 0 or s.t - ts[j - 1] > stale_s or not snr[j - 1].value < NOISY_SNR_DB:
            continue
        out += dt
    return round(out, 3)


def noise_in_row(row: dict[str, Any], m: Mapping[str, Any], noisy_s: float) -> None:
    """Say in ``row`` (a priority's or a "little off" one, clarity's) that ``noisy_s`` of the
    time clarity read low the room was noisy: ``noise`` is the sentence, and where the noise
    covers half that time or more the advice is the room's, not the articulation's."""
    low_s = float(m.get("below_s") or m.get("out_of_range_s") or 0.0)
    if not noisy_s > 0.0 or not low_s > 0.0:
        return
    noisy_s = min(noisy_s, low_s)
    row["noisy_s"] = round(noisy_s, 1)
    row["noise"] = (
        f"{row.get('label', 'clarity')} read low for {mmss(low_s)}; for "
        f"{'all' if noisy_s >= low_s - 0.05 else mmss(noisy_s)} of it the room was noisy "
        f"or echoing (estimated SNR under {NOISY_SNR_DB:g} dB): the room, not your "
        "articulation, may be the cause"
    )
    if noisy_s >= 0.5 * low_s:
        row["advice"] = "speak up, and rehearse somewhere quieter or nearer the microphone"
    else:
        row["noise"] += "; rehearse somewhere quieter or nearer the microphone"


def still_going(heard: Sequence[float] | None, talk_s: float) -> bool:
    """Whether a talk the time limit stopped was still going on: a voice heard (``heard``:
    :func:`voice_times`) within :data:`STILL_GOING_S` of the stop, or no speech module to say
    (an input still ran). A microphone keeps its module running after the speaker has finished
    (session 20 review)."""
    return heard is None or (bool(heard) and heard[-1] >= talk_s - STILL_GOING_S)


def _share_out(m: Mapping[str, Any], *, beyond_error: bool = False) -> float | None:
    """The share of the measured time out of range; with ``beyond_error``, out by more than
    the measurement's error (``within_error_s``, for a metric whose record states one)."""
    tir = m.get("time_in_range")
    if not isinstance(tir, int | float):
        return None
    share = 1.0 - float(tir)
    near = m.get("within_error_s") if beyond_error else None
    total = measured_s(m)
    if isinstance(near, int | float) and near > 0.0 and total > 0.0:
        share = max(0.0, share - float(near) / total)
    return share


def off_sides(
    rule: Rule,
    d: Mapping[str, float],
    m: Mapping[str, Any] | None = None,
    *,
    hedge: bool = False,
    said: Collection[str] = (),
) -> list[dict[str, Any]]:
    """Each side of its band a metric was out on, the side with the larger deviation first:
    ``side``, ``bound``, its own seconds out (``out_s``) and share of the measured time
    (``share_out``) when the figures say, and ``advice`` for the first side and for any other
    side out for at least :data:`prezence.summary.MIN_JUDGED_S` (a 3 s burst of speed in a
    slow talk is said, not advised on).

    With ``hedge`` (a metric neither cued nor strict) and ``d``'s deviation beyond the
    measurement's error (``below_beyond``, ``above_beyond``), the side with more of that comes
    first, and a side none of whose readings were out by more than the error is listed with
    no advice (``within_error``): a pace read 132 for most of a talk and 200 for a fifth of it
    is "slow down", not "pick up the pace, but at times slow down". A side the coach cued
    (``said``) is always advised on (session 26: a talk cued "slow down" on 200 wpm for a
    fifth of it, 132 the rest, read "pick up the pace, but at times slow down"); the order
    stays the deviation's beyond the error (the side cued once early in a talk mostly out on
    the other is not first).

    Args:
        d: the metric's :func:`deviation_seconds`.
        m: the metric's figures (``below_s``, ``above_s``: :func:`prezence.summary.build_summary`).
        hedge: the measurement's error decides as above.
        said: the sides ("below", "above") the coach cued during the talk.

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
        >>> m = {"in_range_s": 100.0, "out_of_range_s": 100.0, "below_s": 70.0, "above_s": 30.0}
        >>> [(x["side"], x["out_s"], x["advice"]) for x in off_sides(r, {"below": 900.0,
        ...     "above": 400.0}, m)]
        [('below', 70.0, 'pick up the pace'), ('above', 30.0, 'slow down')]
    """
    from prezence.summary import MIN_JUDGED_S

    m = m or {}
    total = measured_s(m)
    below, above = float(d.get("below", 0.0)), float(d.get("above", 0.0))
    order = ["above", "below"] if above > below else ["below", "above"]
    beyond = hedge and "below_beyond" in d and "above_beyond" in d
    if beyond and d["below_beyond"] != d["above_beyond"]:
        order = ["above", "below"] if d["above_beyond"] > d["below_beyond"] else ["below", "above"]
    rows: list[dict[str, Any]] = []
    for side in order:
        got = m.get(f"{side}_s")
        known = isinstance(got, int | float)
        secs = float(got) if isinstance(got, int | float) else 0.0
        # a side is out when its seconds say so; without them (a bare deviation), its deviation
        if not (secs > 0.0 if known else float(d.get(side, 0.0)) > 0.0):
            continue
        row: dict[str, Any] = {
            "side": side,
            "bound": rule.high if side == "above" else rule.low,
        }
        if known:
            row["out_s"] = round(secs, 1)
            if total > 0:
                row["share_out"] = round(secs / total, 3)
        within = (
            beyond
            and rows
            and side not in said
            and float(d.get(f"{side}_beyond", 0.0)) <= 0.0
            and (float(d.get(f"{rows[0]['side']}_beyond", 0.0)) > 0.0 or rows[0]["side"] in said)
        )
        if within:  # the other side was out beyond the error, this one only within it
            row.update(within_error=True, error=error_words(METRICS[rule.metric]))
        elif not rows or not known or secs >= MIN_JUDGED_S:
            row["advice"] = advice(rule, side)
        rows.append(row)
    return rows


def sides_advice(sides: Sequence[Mapping[str, Any]]) -> str:
    """The advice of each side advised on: ``"pick up the pace, but at times slow down"``."""
    said = [str(s["advice"]) for s in sides if s.get("advice")]
    return said[0] + "".join(f", but at times {a}" for a in said[1:])


def needs_work(
    rule: Rule,
    d: Mapping[str, float],
    m: Mapping[str, Any] | None,
    *,
    threshold: float,
    cued: Collection[str] = (),
) -> bool:
    """Whether a judged metric is a thing to work on: see :func:`rank_priorities`."""
    score = float(d.get("below", 0.0)) + float(d.get("above", 0.0))
    if score <= 0.0:
        return False  # never left its band
    if rule.metric in cued or rule.strict:
        return True
    share = _share_out(m or {})
    if edge_reading(rule, m or {}) is not None and "below_beyond" in d:
        # its median reading is out by less than the measurement's error: only the readings
        # out by more than it are known to be out (issue 11: a true 143 wpm read 138.5, 53 %
        # of the time under 140, and was told "Work first on this: pick up the pace")
        score = float(d.get("below_beyond", 0.0)) + float(d.get("above_beyond", 0.0))
        share = _share_out(m or {}, beyond_error=True)
    elif _median_in_band(rule, m or {}):
        # out half the time with its median reading in the band: out on both sides, and half
        # the time out says nothing of either; only the readings beyond the error count
        # towards it (session 25's review: 130 and 185 wpm, a third of the talk each, each
        # within the pace's 8 %, were "pick up the pace, but at times slow down"). Nor
        # towards a cue's worth: a reading within the error of its bound is not known to be
        # out (session 25's tester: 136 and 184 wpm by turns for 10 minutes, median 160, was
        # "Work first on this: pick up the pace, but at times slow down" on readings each
        # within the pace's 8 %)
        share = _share_out(m or {}, beyond_error=True)
        if "below_beyond" in d:
            score = float(d.get("below_beyond", 0.0)) + float(d.get("above_beyond", 0.0))
    return score >= threshold or (share is not None and share >= FAR_OFF_SHARE)


def _median_in_band(rule: Rule, m: Mapping[str, Any]) -> bool:
    """Whether a metric's median reading (``p50``, as judged) lies in its band; False when
    it is not recorded."""
    med = m.get("p50")
    if not isinstance(med, int | float) or isinstance(med, bool) or not math.isfinite(med):
        return False
    return rule.side(float(med) - rule.offset) is None


def edge_reading(rule: Rule, m: Mapping[str, Any]) -> dict[str, Any] | None:
    """Where a metric's median reading (``p50``, as judged: the rule's offset added) lies out
    of its band by no more than its module's stated measurement error
    (:meth:`prezence.metrics.Metric.margin`): the module cannot tell whether the talk was
    typically in range or out. ``side``, ``bound``, ``median``, ``off`` (how far out, in the
    metric's unit) and ``off_pct`` (that in percent of the bound, for an error stated in
    percent); None when the median is in range or out by more, when no error is stated or
    the median is not recorded (a figure made before it was), and for a strict rule (out
    once is out).

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
        >>> edge_reading(r, {"p50": 138.5})
        {'side': 'below', 'bound': 140.0, 'median': 138.5, 'off': 1.5, 'off_pct': 1.1}
        >>> edge_reading(r, {"p50": 128.0}), edge_reading(r, {"p50": 150.0})  # 8.6 % under
        (None, None)
    """
    rec = METRICS.get(rule.metric)
    med = m.get("p50")
    if rule.strict or rec is None or not isinstance(med, int | float) or isinstance(med, bool):
        return None
    if (rec.error_pct is None and rec.error_abs is None) or not math.isfinite(med):
        return None
    for side, bound in (("below", rule.low), ("above", rule.high)):
        if bound is None:
            continue
        off = float(bound) - float(med) if side == "below" else float(med) - float(bound)
        # compared as the summary's within_error_s and _beyond compare a reading, not by
        # ``off``: 194.4 - 180 is 14.400000000000006, over the 14.4 that 194.4 is within
        edge = float(bound) + rec.margin(float(bound)) * (-1.0 if side == "below" else 1.0)
        if off > 0.0 and (float(med) >= edge if side == "below" else float(med) <= edge):
            row: dict[str, Any] = {
                "side": side,
                "bound": float(bound),
                "median": float(med),
                "off": round(off, 3),
            }
            if rec.error_pct is not None and bound:
                row["off_pct"] = round(100.0 * off / abs(float(bound)), 1)
            return row
    return None


def rank_priorities(
    config: Config,
    dev_s: Mapping[str, Mapping[str, float]],
    *,
    talk_s: float,
    top: int | None = 2,
    cued: Collection[str] = (),
    metrics: Mapping[str, Mapping[str, Any]] | None = None,
    cued_sides: Mapping[str, Collection[str]] | None = None,
) -> list[dict[str, Any]]:
    """The things to work on, in order: metrics ranked by deviation × time out of range.

    The rule that sorts each judged metric into one of three classes (the report's text, page
    and spoken summary word these lists and nothing else, so their words match the numbers):

    - **work on** (this list): it left its band and at least one of: its deviation integrated
      over the talk (%·s) adds up to one cue's worth (the processor's ``threshold``, 600 %·s
      by default: 20 % off for 30 s); the coach cued it; it was out of its band for at least
      :data:`FAR_OFF_SHARE` of the time it was measured (a pace 5 % under the band for half
      the talk is not "a little off", however small each miss); its rule is strict. For a
      metric at the edge (below), the first and third count its readings out by more than
      its measurement's error only; for one whose median reading is in its band (out on both
      sides), the first and third do too.
    - **a little off** (:func:`slightly_off`): none of these, but out of its band, by more
      than its measurement's error, for at least :data:`SLIGHTLY_OFF_SHARE` of its measured
      time: not praised as in range either.
    - **at the edge** (:func:`at_edge`): its median reading out of its band by no more than
      its measurement's error (:func:`edge_reading`: a true 143 wpm read 138.5 against 140
      by a module accurate to 8 %), not cued, not strict, and neither of the first two
      classes on its readings out by *more* than the error alone (their deviation, their
      share of the time: the time within the error is not known to be out). The module
      cannot tell whether it was in range: said so, with advice only "if it felt slow".
      Listed after every metric to work on and every one a little off, never first: a metric
      known to be out comes before one that may not have been.
    - **in or near range**: the rest (a glance down for a second is not worth advice). Those
      out of their band at all (:func:`near_range`) are named with their seconds out when the
      report praises: "stayed in or near its ideal range", never "stayed in its ideal range".

    The score is the deviation integrated over the talk (%·s), the time out of range times
    the mean deviation while out; the list is ordered by it. Each row names every side the
    metric was out on with its own seconds (``sides``, :func:`off_sides`: a pace both too slow
    and too fast is both), the side with the larger deviation first (``side``, ``bound``), and
    ``advice`` for each side advised on.

    Args:
        config: the rules.
        dev_s: per metric, :func:`deviation_seconds`'s result (only the judged metrics).
        talk_s: the talk's length (to express the score per minute of talk).
        top: how many to return (None: all that need work).
        cued: the metrics the coach cued during the talk.
        metrics: the report's per-metric figures (``time_in_range``, ``below_s``,
            ``above_s``); without them only the score and the cues decide.
        cued_sides: per metric cued, the sides its cues were on (:func:`cued_sides`): a
            cued metric's sides are then weighed as an uncued one's, the cued sides first
            and advised on (:func:`off_sides`); without them, every side as cued.
    """
    rows: list[dict[str, Any]] = []
    for rule in config.rules:
        d = dev_s.get(rule.metric)
        if not d:
            continue
        m = (metrics or {}).get(rule.metric) or {}
        threshold = config.processor.threshold
        if not needs_work(rule, d, m, threshold=threshold, cued=cued):
            continue
        score = float(d.get("below", 0.0)) + float(d.get("above", 0.0))
        if rule.metric in cued and cued_sides is not None and not rule.strict:
            sides = off_sides(rule, d, m, hedge=True, said=cued_sides.get(rule.metric, ()))
        else:
            sides = off_sides(rule, d, m, hedge=rule.metric not in cued and not rule.strict)
        if not sides:
            continue
        rows.append(
            {
                **_off_side(rule, str(sides[0]["side"])),
                "score": round(score, 1),
                "score_per_min": round(60.0 * score / talk_s, 1) if talk_s > 0 else None,
                "advice": sides_advice(sides),
                "sides": sides,
            }
        )
    rows.sort(key=lambda r: (-r["score"], r["metric"]))
    return rows if top is None else rows[:top]


def cued_sides(config: Config, cues: Sequence[Mapping[str, Any]]) -> dict[str, set[str]]:
    """Per metric cued, the sides of its band ("below", "above") its cues' commands name
    (a command that is neither side's, such as one of a rule changed since, names none).

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp",
        ...          above="slowDown")
        >>> cued_sides(Config(rules=(r,)), [{"metric": "speech_speed", "command": "slowDown"}])
        {'speech_speed': {'above'}}
    """
    rules = {r.metric: r for r in config.rules}
    out: dict[str, set[str]] = {}
    for c in cues:
        rule = rules.get(str(c.get("metric")))
        if rule is None:
            continue
        sides = out.setdefault(rule.metric, set())
        command = c.get("command")
        if command is not None and command == rule.below:
            sides.add("below")
        elif command is not None and command == rule.above:
            sides.add("above")
    return out


def _off_side(rule: Rule, side: str) -> dict[str, Any]:
    """Which metric is off on ``side`` and the bound it crossed, for a reader: the start of
    a priority's row and of a "slightly off" one (each adds its figures, then the advice)."""
    return {
        "metric": rule.metric,
        "label": metric_label(rule.metric),
        "side": side,
        "bound": rule.high if side == "above" else rule.low,
        "unit": rule.unit,
        **({"where": rule.band_words().strip()} if rule.offset else {}),
    }


def slightly_off(
    config: Config,
    dev_s: Mapping[str, Mapping[str, float]],
    metrics: Mapping[str, Mapping[str, Any]],
    *,
    listed: Collection[str] = (),
) -> list[dict[str, Any]]:
    """Metrics a little off for a good part of the talk, not listed to work on.

    The middle class of :func:`rank_priorities`'s rule: a metric that does not need work (too
    little off to add up to a cue's worth, never cued, out for less than
    :data:`FAR_OFF_SHARE` of its measured time) may still have been out of its band for a
    good part of it. It must not then be praised as "in the ideal range": it is listed here
    when out of its band, by more than its measurement's error where its record states one
    (:meth:`prezence.metrics.Metric.margin`), for at least :data:`SLIGHTLY_OFF_SHARE` of the
    time it was measured, and when that time may be judged at all (:func:`judged`: 3 s of
    pace before a Ctrl-C is not). Each side it was out on is named with its own share (``sides``).

    Args:
        config: the rules.
        dev_s: per metric, :func:`deviation_seconds`'s result.
        metrics: the report's per-metric figures (``time_in_range``, ``out_of_range_s``).
        listed: the metrics already listed to work on.
    """
    rows: list[dict[str, Any]] = []
    for rule in config.rules:
        m = metrics.get(rule.metric) or {}
        # out for under half the time, its median reading is in range: a reading out by less
        # than the measurement's error is then not told from one in range, and no reason to
        # advise (session 24: a reader at 158 wpm was told "a little under the ideal range 41%
        # of the time: pick up the pace" after a pause, on readings of 135-137 against 140 by
        # a module accurate to 8 %). Out for half the time or more (:func:`needs_work`), the
        # best estimate itself is out: told, however close
        share = _share_out(m, beyond_error=True)
        d = dev_s.get(rule.metric) or {}
        if rule.metric in listed or share is None or not judged(m):
            continue
        if share < SLIGHTLY_OFF_SHARE:
            continue
        sides = off_sides(rule, d, m, hedge=True)
        if not sides:
            continue
        out_s = sum(float(m.get(f"{x['side']}_s") or 0.0) for x in sides)
        rows.append(
            {
                **_off_side(rule, str(sides[0]["side"])),
                "share_out": round(share, 3),
                "advice": sides_advice(sides),
                "sides": sides,
                # its module died mid-talk: the share is of the time it was measured
                **({"measured_s": round(measured_s(m), 1)} if m.get("lost") else {}),
                # the part of its time out the module could not tell from in range (its
                # share_out leaves it out; its sides' shares do not)
                **_within_error_part(rule, m, out_s),
            }
        )
    rows.sort(key=lambda r: (-r["share_out"], r["metric"]))
    return rows


#: Out of its band for less than this (seconds, in all) is in it: the figures are kept to the
#: tenth of a second, so less is rounding, not a sample out of range.
NEAR_RANGE_MIN_S = 0.05


def error_words(rec: Any) -> str:
    """A metric record's measurement error for a reader: ``"8%"``, ``"5 degrees"``.

    Example:
        >>> error_words(METRICS["speech_speed"]), error_words(METRICS["cv_headGaze"])
        ('8%', '5 degrees')
    """
    said = []
    if rec.error_pct is not None:
        said.append(f"{rec.error_pct:g}%")
    if rec.error_abs is not None:
        said.append(f"{rec.error_abs:g} {rec.unit}")
    return " or ".join(said)


def _time_out(rule: Rule, m: Mapping[str, Any], *, first: str = "below") -> list[dict[str, Any]]:
    """Each side of its band a judged metric was out on for :data:`NEAR_RANGE_MIN_S` or more,
    ``first`` first: ``side``, ``bound``, its seconds out (``out_s``) and share of the
    measured time (``share_out``), from the report's figures (``below_s``, ``above_s``).

    Example:
        >>> from prezence.config.model import Check
        >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
        >>> m = {"in_range_s": 80.0, "out_of_range_s": 20.0, "below_s": 15.0, "above_s": 5.0}
        >>> [(x["side"], x["out_s"], x["share_out"]) for x in _time_out(r, m, first="above")]
        [('above', 5.0, 0.05), ('below', 15.0, 0.15)]
    """
    total = measured_s(m)
    rows: list[dict[str, Any]] = []
    for side in (first, "above" if first == "below" else "below"):
        secs = m.get(f"{side}_s")
        if isinstance(secs, int | float) and secs >= NEAR_RANGE_MIN_S and total > 0:
            rows.append(
                {
                    "side": side,
                    "bound": rule.high if side == "above" else rule.low,
                    "out_s": round(float(secs), 1),
                    "share_out": round(float(secs) / total, 3),
                }
            )
    return rows


def _within_error_part(rule: Rule, m: Mapping[str, Any], out_s: float) -> dict[str, Any]:
    """How much of a metric's ``out_s`` seconds out of its band the module could not tell from
    in range (``within_error_s``, :func:`_share_out`) and its error (``error``), for a
    ``near_range`` or ``slightly_off`` row; {} when none was or no error is stated."""
    near = m.get("within_error_s")
    rec = METRICS.get(rule.metric)
    if not isinstance(near, int | float) or near <= 0.0 or rec is None:
        return {}
    return {"within_error_s": round(min(float(near), out_s), 1), "error": error_words(rec)}


def near_range(
    config: Config, metrics: Mapping[str, Mapping[str, Any]], *, listed: Collection[str] = ()
) -> list[dict[str, Any]]:
    """The judged metrics out of their band for some of the talk but in no other list: too little
    to work on or to be "a little off" (:func:`rank_priorities`), yet not "in the ideal range"
    either (session 21: "Every judged metric stayed in its ideal range" over a pace under 140
    wpm for 8 s, 19 % of the time). Each names every side it was out on with its seconds and
    share of its measured time (``sides``); the most out first.

    Args:
        config: the rules.
        metrics: the report's per-metric figures.
        listed: the metrics already listed to work on or as a little off.
    """
    rows: list[dict[str, Any]] = []
    for rule in config.rules:
        m = metrics.get(rule.metric) or {}
        if rule.metric in listed or not judged(m):
            continue
        sides = _time_out(rule, m)
        if not sides:
            continue
        sides.sort(key=lambda x: -float(x["out_s"]))
        out_s = sum(float(m.get(f"{x['side']}_s") or 0.0) for x in sides)
        share = out_s / measured_s(m)
        row = {**_off_side(rule, str(sides[0]["side"])), "share_out": round(share, 3)}
        row["sides"] = sides
        row.update(_within_error_part(rule, m, out_s))
        rows.append(row)
    rows.sort(key=lambda r: (-r["share_out"], r["metric"]))
    return rows


def at_edge(
    config: Config, metrics: Mapping[str, Mapping[str, Any]], *, listed: Collection[str] = ()
) -> list[dict[str, Any]]:
    """The judged metrics whose median reading lay out of their band by less than the
    measurement's error (:func:`edge_reading`) and in no list before: the module cannot tell
    whether they were in range, so the report says so and advises only if the speaker thinks
    so too ("if it felt slow, pick up the pace a little"), after every metric that needs work
    and every one a little off (:func:`rank_priorities` states the order). Each row has the
    median and how far out it read (``median``, ``off``, ``off_pct``), the error
    (``error``), the time out on each side (``sides``, as :func:`near_range`'s) and the
    ``advice``; the most out first.

    Args:
        config: the rules.
        metrics: the report's per-metric figures (``p50``, ``below_s``, ``above_s``).
        listed: the metrics already listed to work on or as a little off.
    """
    rows: list[dict[str, Any]] = []
    for rule in config.rules:
        m = metrics.get(rule.metric) or {}
        rec = METRICS.get(rule.metric)
        edge = edge_reading(rule, m)
        if rule.metric in listed or not judged(m) or edge is None or rec is None:
            continue
        total = measured_s(m)
        sides = _time_out(rule, m, first=str(edge["side"]))
        out = sum(float(m.get(f"{x['side']}_s") or 0.0) for x in sides)
        rows.append(
            {
                **_off_side(rule, str(edge["side"])),
                **{k: v for k, v in edge.items() if k not in ("side", "bound")},
                "error": error_words(rec),
                "share_out": round(out / total, 3) if total > 0 else 0.0,
                "sides": sides,
                "advice": advice(rule, str(edge["side"])),
                "felt": rec.felt.get(str(edge["side"]))
                or ("low" if edge["side"] == "below" else "high"),
            }
        )
    rows.sort(key=lambda r: (-r["share_out"], r["metric"]))
    return rows


# -- reading the folder ------------------------------------------------------------------------


def _read_meta(session: SessionDir) -> dict[str, Any]:
    try:
        return session.read_meta()
    except ConfigError as e:  # torn while being written: the rest still tells a lot
        log.warning("%s; going on without it", e)
        return {}


def _judging_config(
    session: SessionDir, config: Config | None, recorded: Mapping[str, Any]
) -> tuple[Config, str | None]:
    """The rules to judge the talk by, and what the report says when its ``config.toml`` is
    damaged (None when it is not).

    ``config`` (rules given: ``--config``) judges the talk with the allocated time its own
    ``config.toml`` records (replay does the same); None takes that file, or the built-in
    configuration when the talk died before writing it. A ``config.toml`` that cannot be read
    (torn mid-write: session 21, a second walkthrough) does not stop the report: it is named
    (``file:line:col``) and the talk judged by the rules given, else by the built-in
    configuration, with the allocated time its ``summary.json`` records when it records one.
    """
    from prezence.config.load import keep_recorded_time, load_config

    if not session.config.exists():
        if config is not None:
            return config, None
        log.warning("%s missing: using the built-in configuration", session.config)
        return load_config(None), None
    try:
        own = load_config(session.config)
    except ConfigError as e:
        damaged = e
    else:
        if config is None:
            return own, None
        # rules given to judge the talk again keep its allocated time (replay does the same)
        return keep_recorded_time(config, own, session.config), None
    cfg = config if config is not None else load_config(None)
    used = "the rules given (--config)" if config is not None else "the built-in configuration"
    time_used = _recorded(recorded, "time")
    allocated = time_used.get("allocated_s")
    if "allocated_s" in time_used and (
        allocated is None or isinstance(allocated, int | float) and not isinstance(allocated, bool)
    ):
        cfg = cfg.with_allocated(None if allocated is None else float(allocated))
        said = "no time" if allocated is None else f"{float(allocated):g} s"
        used += f", with the allocated time its summary.json records ({said})"
    else:
        used += " (no summary.json records its allocated time)"
    log.warning("%s; the report judges the talk by %s", damaged, used)
    note = f"the talk's config.toml is damaged, so it was judged by {used}: "
    return cfg, note + _shown_record(str(damaged), session.root)


def _talk_length(
    meta: Mapping[str, Any],
    streams: Mapping[str, Sequence[Sample]],
    cues: Sequence[Mapping[str, Any]],
    stale_s: float,
    ended: bool = False,
) -> tuple[float, bool]:
    """The talk's length and whether the record covers it.

    ``session.json`` states the planned length. A talk the coach ran to its end (``ended``)
    lasted that long even when the metrics stop well before it (the presenter fell silent,
    a module stopped writing). Otherwise, when the records stop more than a stale period
    before it (the process died mid-talk), the talk is taken to have ended at the last
    record.
    """
    last = max(
        [s[-1].t for s in streams.values() if s] + [float(c["t"]) for c in cues if "t" in c],
        default=0.0,
    )
    planned = meta.get("talk_s")
    if planned is None:
        return last, True
    planned = float(planned)
    if not ended and last + stale_s < planned:
        return last, False
    return planned, True


def _why(rule: Rule, row: Mapping[str, Any]) -> str:
    """A reader's reason for a metric cue: which metric, which way, how far."""
    side = str(row.get("side"))
    bound = rule.low if side == "below" else rule.high
    unit = f" {rule.unit}" if rule.unit else ""
    strict = "must-keep limit: " if row.get("kind") == "strict" else ""
    limit = "lowest" if side == "below" else "highest"
    value = row.get("value")
    then = judged_value(rule, value)
    label = metric_label(rule.metric)
    where = rule.band_words()
    return (
        f"{strict}{label} {was(label)} {side} the {limit} good value, {bound:g}{unit}{where}{then}"
    )


def judged_value(rule: Rule, value: Any) -> str:
    """A cue's value as judged (``row["value"]``, the rule's offset added) after the band, in
    brackets; with an offset, after a semicolon (the band's words end in brackets) and with
    the measured one: "; 47.7 dB SPL there, 73.2 at your microphone"."""
    if not isinstance(value, int | float):
        return ""
    unit = f" {rule.unit}" if rule.unit else ""
    if not rule.offset:
        return f" ({float(value):.3g}{unit})"
    measured = float(value) - rule.offset
    if rule.at:
        return f"; {float(value):.3g}{unit} there, {measured:.3g} at your microphone"
    return f"; {float(value):.3g}{unit} after the offset, {measured:.3g} measured"


def _why_other(row: Mapping[str, Any]) -> str:
    kind = row.get("kind")
    if kind == "time":
        p = row.get("params") or {}
        if "minutes" in p:
            return f"{p['minutes']} min of the allocated time left"
        return "over the allocated time"
    if kind == "praise":
        return "everything in range for a while"
    return str(row.get("reason") or "")


def _cue_dicts(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    return [dict(c) for c in summary.get("cues", [])]


def build_report(
    session_dir: str | Path,
    *,
    config: Config | None = None,
    ended: bool | None = None,
    modules: Mapping[str, Any] | None = None,
    stopped_at_limit: bool | None = None,
    recording_s: float | None = None,
    module_failures: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """Rebuild the report of one talk from its session folder.

    Args:
        session_dir: the session folder (see :mod:`prezence.session`).
        config: the rules to judge by; None reads the folder's ``config.toml`` (or the
            built-in configuration if the talk died before writing it, or it is damaged:
            :func:`_judging_config`).
        ended: the coach ran the talk to its end (None: it did if its ``summary.json`` says
            when the talk ended, as a finished talk's does).
        modules: the launcher's record of the modules' crashes (None: ``summary.json``'s,
            which a talk still running has not written yet).
        stopped_at_limit: the time limit stopped the talk while an input still ran (None:
            ``summary.json``'s ``stopped_at_time_limit``); said as a lower bound of the time
            used only when the talk was still going on (:func:`still_going`).
        recording_s: how long the recordings an ``up`` of files played to their end lasted
            (None: ``summary.json``'s ``recording_s``): the time used.
        module_failures: ``rehearse``'s modules that failed, module → its last error line
            (None: ``summary.json``'s, which a rehearsal not yet ended has not written): one
            that wrote values first is reported as a crash at its last value.

    Returns:
        The report as a JSON-ready dict: ``time`` (used vs allocated), ``metrics`` (the
        summary's figures plus band, label and deviation-seconds), ``cues`` (each with its
        latency and effect), ``priorities`` (the two things to work on first), ``counts``,
        ``complete`` (False when the record stops before the planned end) and ``streams``.

    Raises:
        ConfigError: the folder does not exist, or it is not a session folder (no
            ``session.json`` nor ``cues.jsonl``) and holds no stream file. A ``config.toml``
            that cannot be read is named in ``config_damaged`` (the rules used instead said).
    """
    return _rebuild(
        session_dir, config, ended, modules, stopped_at_limit, recording_s, module_failures
    )[0]


def _read_summary(session: SessionDir) -> dict[str, Any]:
    """The folder's ``summary.json`` as written by the coach, read once ({} when there is none
    or it cannot be read: its own problems are reported where it is read for itself)."""
    if not session.summary.is_file():
        return {}
    try:
        return read_json_object(session.summary)
    except PrezenceError:
        return {}


def _recorded(summary: Mapping[str, Any], key: str) -> dict[str, Any]:
    """``summary.json``'s ``key`` object (the modules' record, the post-talk summary), {} if
    there is none."""
    value = summary.get(key)
    return value if isinstance(value, dict) else {}


def _recorded_modules(summary: Mapping[str, Any]) -> dict[str, Any]:
    """``summary.json``'s record of the modules (crashes, restarts), {} if there is none."""
    mods = _recorded(summary, "modules")
    return {str(k): v for k, v in mods.items() if isinstance(v, dict)}


def _recorded_drops(summary: Mapping[str, Any]) -> dict[str, dict[str, int]]:
    """Per metric, the samples the coach's processor left out (``summary.json``'s
    ``metrics.<metric>.dropped``: ``late``, ``ahead``): only the coach knew them, so a rebuild
    takes them from its record ({} when there is none)."""
    out: dict[str, dict[str, int]] = {}
    for metric, m in _recorded(summary, "metrics").items():
        d = m.get("dropped") if isinstance(m, dict) else None
        if isinstance(d, dict) and all(
            isinstance(d.get(k, 0), int) and not isinstance(d.get(k, 0), bool) and d.get(k, 0) >= 0
            for k in ("late", "ahead")
        ):
            out[str(metric)] = {"late": int(d.get("late", 0)), "ahead": int(d.get("ahead", 0))}
    return out


def _rebuild(
    session_dir: str | Path,
    config: Config | None,
    ended: bool | None = None,
    modules: Mapping[str, Any] | None = None,
    stopped_at_limit: bool | None = None,
    recording_s: float | None = None,
    module_failures: Mapping[str, Any] | None = None,
) -> tuple[dict[str, Any], dict[str, list[Sample]]]:
    session = SessionDir(Path(session_dir))
    if not session.root.is_dir():
        raise ConfigError("no such session folder", path=session.root)
    meta = _read_meta(session)
    recorded = _read_summary(session)  # the coach's summary.json, if it wrote one
    cfg, config_damaged = _judging_config(session, config, recorded)
    from prezence.streams.locate import locate_streams, no_streams_error
    from prezence.streams.tail import read_stream

    paths = locate_streams(session.root, cfg)
    if not paths and not (session.meta.exists() or session.cues.exists()):
        # not a session folder, and no stream file either: nothing to report on
        raise no_streams_error(session.root, cfg)
    streams: dict[str, list[Sample]] = {}
    stats: dict[str, dict[str, Any]] = {}
    unreadable: list[dict[str, Any]] = []
    backwards: list[dict[str, Any]] = []
    limit = sample_time_limit(session, meta)  # a stamp of 1e9 s is not a 30-year talk
    for rule in cfg.rules:
        path = paths.get(rule.metric, session.stream(rule.stream))
        skipped: list[Any] = []
        back: list[Any] = []
        samples, st = read_stream(
            path,
            rule.metric,
            max_t=limit,
            problems=skipped,
            value_range=rule.value_range,
            out_of_order=back,
        )
        if st.out_of_order:  # kept as written, but a module's clock went back: said
            backwards.append(
                {
                    "file": _shown_path(Path(path), session.root),
                    "samples": st.out_of_order,
                    "example": f"line {back[0].line}: {back[0].reason}" if back else None,
                }
            )
        streams[rule.metric] = sorted(samples, key=lambda s: s.t)
        stats[rule.metric] = st.to_dict()
        if st.malformed:
            first = skipped[0] if skipped else None
            unreadable.append(
                {
                    "file": _shown_path(Path(path), session.root),
                    "lines": st.malformed,
                    "example": None if first is None else f"line {first.line}: {first.reason}",
                }
            )
    if modules is None:
        modules = _recorded_modules(recorded)
    if module_failures is None:
        module_failures = _recorded(recorded, "module_failures")
    # rehearse's failed modules, as up records a crash (summary.json's own, else from here)
    modules = with_failures(modules, module_failures, streams)
    # a bad cue line (a torn last line, a damaged one) is skipped and said, not fatal: the
    # rest of the record still makes a report
    bad_cues: list[str] = []
    cues = read_jsonl(session.cues, require=CUE_KEYS, skipped=bad_cues)
    # the same for the ground truth: its other lines still make a truth column, said to lack one
    bad_truth: list[str] = []
    truth = (
        read_jsonl(session.truth, require=TRUTH_KEYS, skipped=bad_truth)
        if session.truth.exists()
        else None
    )
    if bad_truth and not truth:  # every line damaged: no truth, not a talk always in range
        truth = None
    stale_default = cfg.processor.stale_after_s
    if ended is None:  # a coach that ran to the end wrote when it ended
        ended = recorded.get("ended_at_s") is not None
        # a rehearsal stopped while its modules analysed it: the recording still lasted its
        # length (session.json's talk_s); its figures cover the part analysed, as said
        ended = ended or (meta.get("kind") == "rehearsal" and bool(meta.get("interrupted")))
    talk_s, complete = _talk_length(meta, streams, cues, stale_default, ended)
    talk_s = min(talk_s, limit)
    if not complete:
        log.warning(
            "%s: the record stops at %.1f s of a planned %.1f s; reporting what was recorded",
            session.root,
            talk_s,
            float(meta["talk_s"]),
        )
    # only a backend that measures joint limits (the sim) has a figure: its cues carry
    # gesture_violations, its summary.json a backend_stats one; others have none, not 0
    measured = any("gesture_violations" in c for c in cues) or (
        "joint_limit_violations" in _recorded(recorded, "backend_stats")
    )
    backend_stats = (
        {"joint_limit_violations": sum(int(c.get("gesture_violations") or 0) for c in cues)}
        if measured
        else {}
    )
    unmeasured, less_reliable = measurement_notes(
        session.root, {**recorded, "module_failures": module_failures}
    )
    rec_s = recording_s if recording_s is not None else recorded.get("recording_s")
    summary = build_summary(
        cfg,
        streams,
        cues,
        talk_s=talk_s,
        truth=truth,
        stream_stats=stats,
        backend_stats=backend_stats,
        modules=modules,
        # no stream file at all: nothing was asked to measure it (as summary.json says)
        not_measured=[r.metric for r in cfg.rules if r.metric not in paths],
        unmeasured=unmeasured,
        less_reliable=less_reliable,
        estimates=estimate_notes(session.root),
        processor_counts=_recorded_drops(recorded),
        # `up` of files played to their end: the time used is the recordings' length
        extra={"recording_s": rec_s} if rec_s is not None else None,
    )

    # nothing was measured after the recordings' end (as build_summary judges)
    end_s = measured_end_s(talk_s, rec_s)
    dev_s: dict[str, dict[str, float]] = {}
    metrics: dict[str, Any] = {}
    reasons: list[Sample] | None = None  # the speech module's, read when first needed
    sources: list[Sample] | None = None  # its speech_speed_source, likewise
    for rule in cfg.rules:
        stale_s = rule.stale_after_s if rule.stale_after_s is not None else stale_default
        m = dict(summary["metrics"][rule.metric])
        cuts = [float(sp["from"]) for sp in m.get("lost") or ()]
        dev_s[rule.metric] = deviation_seconds(
            rule, streams[rule.metric], end_s, stale_s, cuts, margins=error_margins(rule)
        )
        # "not measured": no module wrote this metric's file at all; "no data": the file is
        # there but holds no sample of the talk
        measured = rule.metric in paths
        m.update(
            measured=measured,
            data="ok"
            if m.get("samples")
            else "no data"
            if measured and "not_measured_why" not in m
            else "not measured",
            label=metric_label(rule.metric),
            check=rule.check.value,
            low=rule.low,
            high=rule.high,
            strict=rule.strict,
            deviation_s=dev_s[rule.metric],
            # what the plots break their line at: longer without a sample is no data
            stale_after_s=stale_s,
        )
        if rule.offset:  # the band applies to the values shifted (at the farthest listener)
            m["where"] = rule.band_words().strip()
        if m.get("samples"):  # over how much of the talk it was measured
            m["measured_s"] = round(measured_s(m), 3)
            record = METRICS.get(rule.metric)
            if record is not None and record.module == "speech":
                if reasons is None:
                    reasons = untimed_reasons(session, limit) or []
                why = untimed_seconds(
                    reasons,
                    streams[rule.metric],
                    end_s,
                    stale_s,
                    cuts,
                    first_after_s=record.first_after_s,
                )
                if why:  # where and why the speech module could not measure it (issue 11)
                    m["untimed"] = why
                if reasons and m.get("stale_spans"):  # and why it went stale, span by span
                    m["stale_spans"] = [
                        _stale_why(sp, reasons, end_s, stale_s, cuts, record.first_after_s)
                        for sp in m["stale_spans"]
                    ]
                if rule.metric in SOURCED:  # a value from the syllable count is less sure
                    if sources is None:
                        sources = _module_stream(session, SPEECH_SPEED_SOURCE, limit) or []
                    held = syllable_seconds(
                        streams[rule.metric],
                        sources,
                        reasons,
                        end_s,
                        stale_s,
                        cuts,
                        syllables=SOURCE_SYLLABLES,
                    )
                    if held is not None:
                        m["syllables"] = held
        metrics[rule.metric] = m

    rules = {r.metric: r for r in cfg.rules}
    cue_rows = _cue_dicts(summary)
    heard, not_heard = heard_cues(session, meta, cues, recorded)
    for row, rec, heard_in in zip(cue_rows, cues, heard, strict=True):
        row["phrase"] = rec.get("phrase")
        cue_rule = rules.get(row.get("metric") or "")
        if cue_rule is not None:
            row["deviation"] = rec.get("deviation")
            row["side"] = "below" if row["command"] == cue_rule.below else "above"
            row["value"] = _value_at(streams[cue_rule.metric], float(row["t"]))
            if cue_rule.offset and row["value"] is not None:  # as judged, as the band is
                row["value"] += cue_rule.offset
            row["why"] = _why(cue_rule, row)
            row.update(cue_effect(cue_rule, streams[cue_rule.metric], float(row["t"])))
            if rec.get("dropped"):  # the robot never gave it: nothing followed from it
                row.update(improved=None, back_in_range_s=None)
            elif heard_in is None:  # the speaker never heard it: nothing followed from it
                row.update(heard=False, improved=None, back_in_range_s=None)
            else:
                reaction = _reaction(heard_in, rec)
                if reaction is not None:  # the synthetic presenter's ground truth
                    row["reacted"] = bool(reaction.get("reacted"))
                    if reaction.get("why"):
                        row["reaction"] = str(reaction["why"])
        else:
            row["why"] = _why_other(row)
        # a cue about a metric that was in range (a false alarm, or stale: its problem had
        # just ended) corrected nothing: what followed it is no improvement it brought
        kind = row.get("cue_class")
        row["false_alarm"] = kind == "false_alarm" or (
            kind is None and row.get("relevant") is False and row.get("metric") is not None
        )
        row["stale"] = kind == "stale"
        row["unmeasured"] = kind == "unmeasured"
        if row["false_alarm"] or row["stale"] or row["unmeasured"]:
            row["improved"] = None
            row["back_in_range_s"] = None
            if cue_rule is not None:
                now = judged_value(cue_rule, row.get("value"))
                label = metric_label(cue_rule.metric)
                if row["unmeasured"]:
                    since = float(row.get("not_measured_since") or 0.0)
                    row["why"] = (
                        f"cued as {row.get('side')} its ideal range; your {label} "
                        f"{was(label)} not measured {_after(since)}, so whether it still "
                        "was is not known"
                    )
                elif row["stale"]:
                    ago = float(row.get("ended_s_before") or 0.0)
                    row["why"] = (
                        f"cued as {row.get('side')} its ideal range, but your {label} had come "
                        f"back in range {ago:.0f} s before{now}"
                    )
                else:
                    row["why"] = (
                        f"cued as {row.get('side')} its ideal range, but your {label} "
                        f"{was(label)} in range{now}"
                    )
    for row in cue_rows:
        row["effect"] = effect_words(row)
    helped = [r for r in cue_rows if r.get("improved") is not None]

    time_used = dict(summary["time"])
    if stopped_at_limit is None:  # as summary.json says (a talk that ended wrote it)
        stopped_at_limit = bool(recorded.get("stopped_at_time_limit"))
    voiced = voice_times(session, limit)  # read once: the stop's wording, the first words
    if stopped_at_limit and still_going(voiced, talk_s):  # cut at allocated time + grace
        time_used["stopped_at_limit"] = True
    if voiced and voiced[0] >= LATE_START_S:
        time_used["first_voice_s"] = round(voiced[0], 1)
    # a metric the robot cued is listed (it said so), but only for a cue it gave (a dropped
    # cue was never heard) on a side the talk was out on by these rules (a replay under
    # another band, a command of a rule changed since, names none: session 26's tester)
    said = cued_sides(cfg, [c for c in cues if not c.get("dropped")])
    said = {
        k: {x for x in v if float((metrics.get(k) or {}).get(f"{x}_s") or 0.0) > 0.0}
        for k, v in said.items()
    }
    cued = {k for k, v in said.items() if v}
    # advice only on what was measured long enough, and not by a fallback (MIN_JUDGED_S)
    judged_dev = {k: v for k, v in dev_s.items() if judged(metrics.get(k) or {})}
    # every metric that needs work is listed, in order: one left out would be read as fine
    priorities = rank_priorities(
        cfg,
        judged_dev,
        talk_s=talk_s,
        cued=cued,
        metrics=metrics,
        top=None,
        cued_sides=said,
    )
    a_little_off = slightly_off(cfg, judged_dev, metrics, listed=[p["metric"] for p in priorities])
    edge = at_edge(cfg, metrics, listed=[r["metric"] for r in [*priorities, *a_little_off]])
    listed = [r["metric"] for r in [*priorities, *a_little_off, *edge]]
    near = near_range(cfg, metrics, listed=listed)
    snr = room_snr(session, limit) or []
    for row in [*priorities, *a_little_off] if snr else ():
        if row["metric"] != NOISY_METRIC:
            continue  # a cue on another metric is not about the noise
        rule = cfg.rule(NOISY_METRIC)
        m = metrics[NOISY_METRIC]
        stale_s = rule.stale_after_s if rule.stale_after_s is not None else stale_default
        cuts = [float(sp["from"]) for sp in m.get("lost") or ()]
        noisy = noisy_low_seconds(rule, streams[NOISY_METRIC], snr, end_s, stale_s, cuts)
        noise_in_row(row, m, noisy)
    counts = dict(summary["counts"])
    counts["cues_improved"] = sum(1 for r in helped if r["improved"])
    counts["cues_judged"] = len(helped)
    counts["cues_back_in_range"] = sum(1 for r in helped if r.get("back_in_range_s") is not None)
    unheard = sum(
        1
        for r in cue_rows
        if r.get("heard") is False and not (r["false_alarm"] or r["stale"] or r["unmeasured"])
    )
    if unheard:
        counts["cues_not_heard"] = unheard
    reacted = [r["reacted"] for r in helped if "reacted" in r]
    if reacted:  # ground truth: did the presenter react to the corrections judged?
        counts["cues_reacted"] = sum(reacted)
        counts["cues_reaction_known"] = len(reacted)
    report: dict[str, Any] = {
        "format": REPORT_FORMAT,
        "session": str(session.root),
        "scenario": meta.get("scenario"),
        "seed": meta.get("seed"),
        "policy": meta.get("policy"),
        "backend": meta.get("backend"),
        "complete": complete,
        # a rehearsal stopped while its modules analysed it: how far they got
        **(
            {"analysis_stopped_s": float(meta["analysed_s"])}
            if meta.get("interrupted") and isinstance(meta.get("analysed_s"), int | float)
            else {}
        ),
        "planned_s": meta.get("talk_s"),
        "talk_s": round(talk_s, 3),
        "time": time_used,
        "metrics": metrics,
        "cues": cue_rows,
        "priorities": priorities,
        "slightly_off": a_little_off,
        "at_edge": edge,
        "near_range": near,
        "counts": counts,
        "has_truth": truth is not None,
        "effect_window_s": EFFECT_WINDOW_S,
        **({"effects_not_judged": not_heard} if not_heard else {}),
        **({"replay_of": meta["source"]} if meta.get("kind") == "replay" else {}),
        **({"recording": str(meta["recording"])} if meta.get("recording") else {}),
        **({"logs": logs} if (logs := _module_logs(session)) else {}),
        "head": (head := head_turns(session, talk_s=talk_s, limit=limit))
        | (
            {"not_measured_why": unmeasured[HEAD_YAW]}
            if HEAD_YAW in unmeasured
            else {}
            if head["measured"]
            else {"not_measured_why": no_camera_why(session, meta)}
        ),
        "stopped_repeating": _stopped_repeating(recorded),
        "beyond_talk": {k: v["beyond_talk"] for k, v in stats.items() if v.get("beyond_talk")},
    }
    # what went wrong on the way, only when something did (a clean talk's report is as before)
    troubles = {
        "config_damaged": config_damaged,
        "unreadable": unreadable,
        "out_of_order": backwards,
        "skipped_records": [_shown_record(p, session.root) for p in bad_cues],
        # this folder's truth.jsonl, and a replay's recording's (its summary.json names them)
        "truth_skipped": list(
            dict.fromkeys(
                [_shown_record(p, session.root) for p in bad_truth]
                + [str(p) for p in recorded.get("truth_skipped") or ()]
            )
        ),
        "modules": module_notes(modules, metrics),
    }
    report.update({k: v for k, v in troubles.items() if v})
    post = _recorded(recorded, "post_talk")
    if post.get("ok") is False:  # the robot was lost: its summary was never heard
        report["post_talk"] = post
    return report, streams


def _after(t: float) -> str:
    """``"after 0:21"``; ``"yet"`` when no value had come by then."""
    return f"after {mmss(t)}" if t > 0 else "yet"


def judged(m: Mapping[str, Any]) -> bool:
    """Whether a metric's figures may earn advice or praise: it has samples, held for at least
    :data:`prezence.summary.MIN_JUDGED_S`, and not from a less reliable fallback."""
    return bool(m.get("samples")) and not m.get("too_brief") and not m.get("less_reliable")


def _module_logs(session: SessionDir) -> list[str]:
    """The input modules' log files in the session folder that say something."""
    return sorted(
        p.name for p in session.root.glob("*.log") if p.is_file() and p.stat().st_size > 0
    )


def _shown_path(path: Path, root: Path) -> str:
    """``path`` relative to the session folder when it is inside it (``streams/x.txt``)."""
    try:
        return str(path.relative_to(root))
    except ValueError:
        return str(path)


def _shown_record(problem: str, root: Path) -> str:
    """``file:line: why`` with the file relative to the session folder (``cues.jsonl:4: …``)."""
    prefix = f"{root}{'/' if not str(root).endswith('/') else ''}"
    return problem[len(prefix) :] if problem.startswith(prefix) else problem


def _stopped_repeating(summary: Mapping[str, Any]) -> list[dict[str, Any]]:
    """What the coach stopped repeating during the talk (``summary.json``), [] if unknown."""
    notes = summary.get("stopped_repeating")
    return [n for n in notes if isinstance(n, dict)] if isinstance(notes, list) else []


def _value_at(samples: Sequence[Sample], t: float) -> float | None:
    """The newest sample's value at ``t`` (None before the first)."""
    v = None
    for s in samples:
        if s.t > t:
            break
        v = s.value
    return v


def no_camera_why(session: SessionDir, meta: Mapping[str, Any], *, depth: int = 0) -> str:
    """Why no head turns were measured when no camera module recorded them, with advice that
    fits the command that made the talk (``session.json``'s ``kind``): ``rehearse`` takes one
    recording, ``up`` takes ``--video``, a replay has what its recording has (session 21: an
    audio-only rehearsal was told to "give --video cam", an option ``rehearse`` has not).

    Example:
        >>> no_camera_why(SessionDir(Path("s")), {"kind": "rehearsal", "recording": "/x/t.flac"})
        't.flac is a sound recording: rehearse a video file (with sound) to measure head turns and gestures'
    """  # noqa: E501 - a doctest output line
    from prezence.rehearse import VIDEO_EXT

    kind = meta.get("kind")
    if kind == "rehearsal":
        rec = Path(str(meta.get("recording") or "the recording"))
        if rec.suffix.lower() in VIDEO_EXT:
            return (
                f"no camera module measured {rec.name} (head pose needs the vision env: python "
                "-m prezence.modules.vision_env install)"
            )
        return (
            f"{rec.name} is a sound recording: rehearse a video file (with sound) to measure "
            "head turns and gestures"
        )
    if kind == "replay" and depth == 0:
        src = _replay_source(session, meta)
        if src is None:
            return "the recording this replays is not found, and this replay has no head turns"
        if src.stream(f"{HEAD_YAW}.txt").is_file() or src.stream(f"{FACING}.txt").is_file():
            return (
                f"the recording measured them but this replay did not copy them: see the "
                f"report of {src.root}"
            )
        try:
            src_meta = src.read_meta()
        except PrezenceError:
            src_meta = {}
        return f"the recording replayed has none: {no_camera_why(src, src_meta, depth=1)}"
    if kind == "synthetic":
        return "a synthetic talk's persona has no head turns"
    return (
        "no camera module ran (give --video cam or a video file to prezence up; head pose "
        "needs the vision env)"
    )


def head_turns(session: SessionDir, *, talk_s: float, limit: float) -> dict[str, Any]:
    """Head turns from the vision module's ``cv_headYaw`` and ``cv_facingAudience`` streams.

    Returns ``{"measured": False}`` when neither file is there; otherwise the share of samples
    facing the audience, the share turned left / right by more than :data:`TURNED_DEG`, the
    median |yaw| and how many times the head turned away (yaw crossing the threshold).
    """
    from prezence.streams.tail import read_stream

    out: dict[str, Any] = {"measured": False}
    yaw_path, facing_path = session.stream(f"{HEAD_YAW}.txt"), session.stream(f"{FACING}.txt")
    if yaw_path.is_file():
        yaw, _ = read_stream(yaw_path, HEAD_YAW, max_t=limit)
        yaw = [s for s in yaw if s.t <= talk_s]
        out["measured"] = True
        if yaw:
            vals = sorted(abs(s.value) for s in yaw)
            out["yaw_samples"] = len(yaw)
            out["median_abs_yaw_deg"] = round(vals[len(vals) // 2], 1)
            out["left_share"] = round(sum(s.value > TURNED_DEG for s in yaw) / len(yaw), 3)
            out["right_share"] = round(sum(s.value < -TURNED_DEG for s in yaw) / len(yaw), 3)
            turned = [abs(s.value) > TURNED_DEG for s in yaw]
            pairs = zip(turned, turned[1:], strict=False)
            out["turns_away"] = sum(1 for a, b in pairs if b and not a)
    if facing_path.is_file():
        facing, _ = read_stream(facing_path, FACING, max_t=limit)
        facing = [s for s in facing if s.t <= talk_s]
        out["measured"] = True
        if facing:
            # each sample is the share of the last few seconds spent facing the audience
            out["facing_share"] = round(sum(s.value for s in facing) / len(facing), 3)
    out["turned_deg"] = TURNED_DEG
    return out


def finite(x: Any) -> Any:
    """``x`` with infinities and NaNs replaced by None, recursively (strict JSON has neither)."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: finite(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [finite(v) for v in x]
    return x


def write_report(
    session_dir: str | Path,
    *,
    config: Config | None = None,
    progress: Callable[[float, float], None] | None = None,
    plots: bool = True,
    ended: bool | None = None,
) -> Path:
    """Build the report and write it into ``SESSION/report/``.

    Writes ``report.html`` (self-contained), ``report.json``, ``summary.txt`` (the terminal
    summary), ``spoken.txt`` (what the robot says) and, with matplotlib installed, the plots as
    ``summary.png`` and ``timeline_<metric>.png`` (for each metric with data; the page says "no
    data" for the others). Without matplotlib, or with ``plots=False`` (a synthetic talk's
    default: drawing costs about 1 s of CPU, more than the talk), the page has tables only and
    says how to get the plots. ``ended``: as for :func:`build_report`.

    Returns:
        The path of ``report.html``.

    Raises:
        ConfigError: see :func:`build_report`.
    """
    from prezence.report.html import render_html
    from prezence.report.speech import format_text, summary_phrase
    from prezence.session import write_json

    session = SessionDir(Path(session_dir))
    report, streams = _rebuild(session.root, config, ended)
    from prezence.progress import progress_for

    report["progress"] = progress_for(session.root)
    report["phrase"] = summary_phrase(report)
    report["text"] = format_text(report)
    folder = session.report
    folder.mkdir(parents=True, exist_ok=True)
    images: dict[str, bytes] = {}
    from prezence.report import plots as draw

    for old in folder.glob("*.png"):  # plots of an earlier build would not match this one
        old.unlink()
    if not plots:
        report["plots"] = []
        report["plots_missing"] = "not drawn for this run"
    elif draw.available():
        images["summary"] = draw.summary_png(report)
        allocated = report["time"].get("allocated_s")
        n_plots = 1 + len(report["metrics"])
        for i, (metric, m) in enumerate(report["metrics"].items()):
            if progress is not None:  # one step per plot: the slow part of a long talk
                progress(i + 1, n_plots)
            if not streams[metric]:
                continue  # no data: the page says so instead of an empty plot
            about = [c for c in report["cues"] if c.get("metric") == metric]
            drawn, shown = streams[metric], m
            offset = float(m.get("offset") or 0.0)
            if offset:  # drawn as judged, against the band they were judged by, and said so
                drawn = [Sample(s.metric, s.t, s.value + offset) for s in drawn]
                where = f"at the farthest listener ({offset:+.1f} dB)" if m.get("at") else ""
                where = where or f"after the offset of {signed(offset)}"
                shown = {**m, "label": f"{m.get('label', metric)} {where}"}  # short: a title
            images[f"timeline_{metric}"] = draw.timeline_png(
                shown, drawn, about, talk_s=float(report["talk_s"]), allocated_s=allocated
            )
        if progress is not None:
            progress(n_plots, n_plots)
        for name, png in images.items():
            (folder / f"{name}.png").write_bytes(png)
        report["plots"] = sorted(f"{name}.png" for name in images)
    else:
        log.warning(
            'matplotlib is not installed: report without plots (pip install "prezence[report]")'
        )
        report["plots"] = []
        report["plots_missing"] = "matplotlib is not installed"
    write_json(folder / "report.json", finite(report))
    (folder / "summary.txt").write_text(report["text"], encoding="utf-8")
    (folder / "spoken.txt").write_text(report["phrase"] + "\n", encoding="utf-8")
    page = folder / "report.html"
    page.write_text(render_html(report, images), encoding="utf-8")
    return page


def report_main(session_dir: str | Path, *, config: str | Path | None = None) -> int:
    """``prezence report SESSION_DIR``: write the report, print the summary; returns 0.

    Args:
        session_dir: the session folder.
        config: a configuration file to judge by instead of the folder's ``config.toml``.

    Raises:
        ConfigError: the folder does not exist or the configuration given is invalid (the CLI
            prints it); the folder's own ``config.toml`` damaged is said in the report instead.
    """
    from prezence.bars import progress_bar
    from prezence.config.load import load_config

    cfg = load_config(config) if config is not None else None
    with progress_bar("report plots") as bar:
        page = write_report(session_dir, config=cfg, progress=bar)
    print((page.parent / "summary.txt").read_text(encoding="utf-8"), end="")
    print(f"report: {page}")
    return 0
