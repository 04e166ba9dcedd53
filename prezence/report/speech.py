"""The report in words: the robot's short spoken summary and the terminal summary."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

from prezence.metrics import UNTIMED_WORDS, Untimed

#: The heading of the metrics whose median read within the measurement's error of their band
#: (``at_edge``) after things to work on or a little off.
EDGE_HEAD = "May have been in range (out by no more than the measuring error)"
#: The spoken summary stays under this many words (the robot speaks at ~150 wpm: ~16 s).
MAX_SPOKEN_WORDS = 40


def mmss(t: float | None) -> str:
    if t is None:
        return "-"
    # halves up: round() takes them to even, so 325.5 s read "5:26" but 522.5 s "8:42"
    total = int(max(0.0, float(t)) + 0.5)
    if total >= 3600:  # a talk of hours: "6:00:00", not "360:00"
        return f"{total // 3600}:{total % 3600 // 60:02d}:{total % 60:02d}"
    return f"{total // 60}:{total % 60:02d}"


def _spoken_minutes(s: float) -> str:
    """Seconds as a speakable length: ``"9 and a half minutes"``, ``"40 seconds"``; halves
    round up, as a listener rounds (Python's ``round`` goes to the even one).

    Example:
        >>> [_spoken_minutes(x) for x in (40.2, 59.6, 75.0, 105.0)]
        ['40 seconds', '1 minute', '1 and a half minutes', '2 minutes']
        >>> [_spoken_minutes(x) for x in (3600.0, 5460.0, 21600.0)]
        ['1 hour', '1 hour 31 minutes', '6 hours']
    """
    value = _spoken_value(s)
    if value < 60:
        n = int(value)
        return f"{n} second{'' if n == 1 else 's'}"
    if value >= 3600:  # a talk of hours: "6 hours", "1 hour 31 minutes", not "360 minutes"
        h, m = divmod(int(value) // 60, 60)
        hours = f"{h} hour{'' if h == 1 else 's'}"
        return f"{hours} {m} minute{'' if m == 1 else 's'}" if m else hours
    half = value / 60.0
    whole = int(half)
    unit = "minute" if half == 1 else "minutes"
    return f"{whole} and a half {unit}" if half != whole else f"{whole} {unit}"


def _spoken_value(s: float) -> float:
    """The seconds :func:`_spoken_minutes` says: 130 s is said "2 minutes", 120 s; 59.6 s
    "1 minute", not "60 seconds"."""
    n = math.floor(s + 0.5)
    if n < 60:
        return float(n)
    half = 30.0 * math.floor(s / 30.0 + 0.5)
    return half if half < 3600 else 60.0 * math.floor(s / 60.0 + 0.5)  # hours: whole minutes


def _hours_minutes(minutes: int) -> list[str]:
    """Whole minutes as spoken parts: ``["1 hour", "6 minutes"]``, ``["9 minutes"]``, []."""
    h, m = divmod(minutes, 60)
    parts = [f"{h} hour{'' if h == 1 else 's'}"] if h else []
    return parts + ([f"{m} minute{'' if m == 1 else 's'}"] if m else [])


def _spoken_exact(s: float) -> str:
    """Seconds to the second: ``"9 minutes 48 seconds"``, ``"10 minutes"``, ``"1 minute"``;
    past an hour ``"1 hour 6 minutes 39 seconds"`` (halves up, as :func:`mmss`)."""
    m, sec = divmod(math.floor(max(0.0, s) + 0.5), 60)
    parts = _hours_minutes(m)
    if sec or not m:
        parts.append(f"{sec} second{'' if sec == 1 else 's'}")
    return " ".join(parts)


def _spoken_tenths(s: float) -> str:
    """Seconds to the tenth: ``"17.6 seconds"``, ``"1 minute 5.4 seconds"``, ``"1 hour 0.5
    seconds"``."""
    tenths = math.floor(max(0.0, s) * 10 + 0.5)
    m, rest = divmod(tenths, 600)
    parts = _hours_minutes(m)
    if rest or not m:
        sec = rest / 10
        parts.append(f"{sec:g} second{'' if sec == 1 else 's'}")
    return " ".join(parts)


def _said_pct_agrees(used: float, alloc: float, pct: float) -> bool:
    """Whether ``used`` and ``alloc`` as said give the percentage said (``pct``, to the whole
    per cent; "right on time" under 1 %)."""
    if alloc <= 0:
        return False
    said_pct = 100.0 * (used - alloc) / alloc
    if abs(pct) < 1.0 or abs(said_pct) < 1.0:
        return abs(pct) < 1.0 and abs(said_pct) < 1.0
    return f"{said_pct:+.0f}" == f"{pct:+.0f}"


def measured_s(m: Mapping[str, Any]) -> float:
    """The seconds a metric's values held over the talk (in range or out): what it covered."""
    return float(m.get("in_range_s") or 0.0) + float(m.get("out_of_range_s") or 0.0)


def time_sentence(report: Mapping[str, Any], *, first_words: bool = True) -> str:
    """One sentence on time used vs allocated.

    Lengths are said to the half minute; when that would make the two sound equal while the
    talk was over or under, or give another percentage than the one said (40 s "of 2 minutes"
    is 67 % under, not the 69 % of 40 s of 2:10), both are said to the second, and where even
    that gives another percentage (17.6 s "18 seconds" of 20 is 10 %, not 12 %), to the tenth,
    so the words never contradict the percentage. With ``first_words``, a voice first heard
    late into the talk (``time.first_voice_s``: :data:`prezence.report.build.LATE_START_S` or
    more) is said too.

    Example:
        >>> time_sentence({"time": {"used_s": 630.0, "allocated_s": 600.0, "over_under_pct": 5.0}})
        'You used 10 and a half minutes of 10 minutes, 5% over.'
        >>> time_sentence({"time": {"used_s": 588.0, "allocated_s": 600.0, "over_under_pct": -2.0}})
        'You used 9 minutes 48 seconds of 10 minutes, 2% under.'
        >>> time_sentence({"time": {"used_s": 40.0, "allocated_s": 130.0, "over_under_pct": -69.2}})
        'You used 40 seconds of 2 minutes 10 seconds, 69% under.'
        >>> time_sentence({"time": {"used_s": 17.6, "allocated_s": 20.0, "over_under_pct": -12.0}})
        'You used 17.6 seconds of 20 seconds, 12% under.'
        >>> time_sentence({"time": {"used_s": 300.0, "allocated_s": None}})
        'You spoke for 5 minutes.'
        >>> cut = {"used_s": 330.0, "allocated_s": 300.0, "over_under_pct": 10.0,
        ...        "stopped_at_limit": True}
        >>> print(time_sentence({"time": cut}))  # doctest: +NORMALIZE_WHITESPACE
        You were still going when the coach stopped at 5 and a half minutes, after the
        5 minutes allocated: at least 10% over.
    """
    t = report["time"]
    used = float(t["used_s"])
    alloc = t.get("allocated_s")
    if not alloc:
        return f"You spoke for {_spoken_minutes(used)}.{_late_start(t) if first_words else ''}"
    alloc = float(alloc)
    pct = float(t.get("over_under_pct", 0.0))
    said_used, said_alloc = _spoken_minutes(used), _spoken_minutes(alloc)
    on_time = abs(pct) < 1.0
    if (said_used == said_alloc and not on_time) or not _agrees(used, alloc, pct):
        said_used, said_alloc = _spoken_exact(used), _spoken_exact(alloc)
        if not _said_pct_agrees(float(round(used)), float(round(alloc)), pct):
            said_used, said_alloc = _spoken_tenths(used), _spoken_tenths(alloc)
    if t.get("stopped_at_limit"):  # cut at the allocated time plus the grace: a lower bound
        return (
            f"You were still going when the coach stopped at {said_used}, after "
            f"the {said_alloc} allocated: at least {pct:.0f}% over."
        )
    side = "over" if pct > 0 else "under"
    how = "right on time" if on_time else f"{abs(pct):.0f}% {side}"
    return f"You used {said_used} of {said_alloc}, {how}.{_late_start(t) if first_words else ''}"


def _agrees(used: float, alloc: float, pct: float) -> bool:
    """Whether the lengths as :func:`_spoken_minutes` says them give the percentage said
    (``pct``, to the whole per cent; "right on time" under 1 %)."""
    return _said_pct_agrees(_spoken_value(used), _spoken_value(alloc), pct)


def _late_start(t: Mapping[str, Any]) -> str:
    """ " Your first words came 1 minute in: …" when the voice began late (else "")."""
    first = t.get("first_voice_s")
    if not isinstance(first, int | float):
        return ""
    return (
        f" Your first words came {_spoken_minutes(float(first))} in, and the time counts from "
        "the start."
    )


def was(label: str) -> str:
    """The verb for a metric's label: "pace was", "gestures were"."""
    return "were" if label.endswith("s") else "was"


def _judged(m: Mapping[str, Any]) -> bool:
    from prezence.report.build import judged

    return judged(m)


def measured_share(report: Mapping[str, Any]) -> str:
    """Which of the report's metrics were judged: ``"all"``, ``"some"`` or ``"none"``.

    Praise needs something measured: a talk whose microphone gave nothing is not a talk
    whose delivery stayed in range. A metric counts when it was measured long enough
    (:data:`prezence.summary.MIN_JUDGED_S`) and not by a less reliable fallback: one volume
    sample of a 2 s recording, or gestures from the frame difference alone, earn no praise. A
    metric whose module died mid-talk (``lost``) was measured only in part: ``"some"`` at most.
    """
    metrics = [m for m in (report.get("metrics") or {}).values() if isinstance(m, Mapping)]
    n = sum(1 for m in metrics if _judged(m))
    if n == 0:
        return "none"
    return "all" if n == len(metrics) and not any(m.get("lost") for m in metrics) else "some"


def _and(words: Sequence[str]) -> str:
    return words[0] if len(words) == 1 else f"{', '.join(words[:-1])} and {words[-1]}"


def unjudged_labels(report: Mapping[str, Any]) -> list[str]:
    """The metrics something was known about but that were not judged: measured too briefly,
    by a fallback, or not measured at all (:func:`unmeasured_labels`)."""
    none = set(unmeasured_labels(report))
    out = []
    for k, m in (report.get("metrics") or {}).items():
        label = str(m.get("label") or k) if isinstance(m, Mapping) else ""
        if label and not _judged(m) and (m.get("samples") or label in none):
            out.append(label)
    return out


def unmeasured_labels(report: Mapping[str, Any]) -> list[str]:
    """The judged metrics that got no value at all, where one was looked for: not measured for
    a recorded reason (a module that could not run), a file a module opened and left empty (a
    module that ran but wrote nothing), or a metric no shipped module writes (a misspelled
    one). A metric of ours whose module was not run at all (the camera's, in a rehearsal of a
    sound file) is left out: nothing was asked to measure it (session 22: a rule on
    ``speech_filers`` and a module that wrote nothing both ended in "Everything I could measure
    stayed in the ideal range").

    Example:
        >>> unmeasured_labels({"metrics": {
        ...     "speech_speed": {"label": "pace", "samples": 40},
        ...     "cv_gestures": {"label": "gestures", "samples": 0, "measured": False},
        ...     "speech_filers": {"samples": 0, "measured": False},
        ...     "my_rate": {"label": "my rate", "samples": 0, "measured": True}}})
        ['speech_filers', 'my rate']
    """
    from prezence.metrics import METRICS

    return [
        str(m.get("label") or k)
        for k, m in (report.get("metrics") or {}).items()
        if isinstance(m, Mapping)
        and not m.get("samples")
        and (m.get("not_measured_why") or m.get("measured") is not False or k not in METRICS)
    ]


def unmeasured_line(labels: Sequence[str]) -> str:
    """The report's headline for judged metrics that got no value at all.

    Example:
        >>> unmeasured_line(["filler words"])
        'Not measured at all, so not judged: filler words (see the notes).'
    """
    return f"Not measured at all, so not judged: {_and(labels)} (see the notes)."


def metric_notes(report: Mapping[str, Any]) -> list[str]:
    """One line per metric not measured for a known reason, measured too briefly to judge,
    measured in a less reliable way, or an estimate (an uncalibrated volume), for the text and
    the HTML report alike.

    Example:
        >>> metric_notes({"metrics": {"speech_speed": {"label": "pace", "samples": 3,
        ...     "in_range_s": 0.0, "out_of_range_s": 2.9, "too_brief": True}}})
        ['pace: measured for only 3 s, under the 10 s needed to judge it: no advice on it']
    """

    out = []
    # said beside the advice where the metric is listed (:func:`listed_coverage`)
    listed = {
        r.get("metric")
        for key in ("priorities", "slightly_off", "at_edge")
        for r in report.get(key) or ()
        if isinstance(r, Mapping)
    }
    for k, m in (report.get("metrics") or {}).items():
        if not isinstance(m, Mapping):
            continue
        label = str(m.get("label") or k)
        if not m.get("samples") and m.get("not_measured_why"):
            out.append(f"{label}: not measured: {m['not_measured_why']}")
        elif m.get("samples") and m.get("less_reliable"):
            out.append(f"{label}: {m['less_reliable']}; less reliable, so no advice on it")
        elif m.get("samples") and m.get("estimate"):
            out.append(f"{label}: {m['estimate']}")
        if m.get("samples") and isinstance(m.get("offset"), int | float) and m["offset"]:
            out.append(offset_note(label, m))
        if m.get("samples") and m.get("too_brief") and not m.get("less_reliable"):
            out.append(f"{label}: {too_brief_words(measured_s(m))}: no advice on it")
        elif m.get("samples") and k not in listed and syllable_words(m):  # from syllables
            out.append(f"{label}: {syllable_words(m)}")
    return out


def too_brief_words(s: float) -> str:
    """``"measured for only 3 s, under the 10 s needed to judge it"``; 9.6 s is not "10 s,
    under the 10 s needed": near the limit, a tenth, rounded down.

    Example:
        >>> too_brief_words(9.96)
        'measured for only 9.9 s, under the 10 s needed to judge it'
    """
    from prezence.summary import MIN_JUDGED_S

    shown = f"{s:.0f}" if s < MIN_JUDGED_S - 0.5 else f"{math.floor(s * 10) / 10:.1f}"
    return f"measured for only {shown} s, under the {MIN_JUDGED_S:.0f} s needed to judge it"


def offset_note(label: str, m: Mapping[str, Any]) -> str:
    """What a rule's offset did to a metric's figures (``summary.json``'s ``offset``, ``at``,
    ``measured_mean``): they are as judged, not as measured.

    Example:
        >>> offset_note("volume", {"offset": -25.46, "at": "listener", "measured_mean": 73.36,
        ...     "unit": "dB SPL"})
        'volume: judged at the farthest listener (25.5 dB less than at your microphone): its figures are there (mean 73.4 dB SPL at your microphone)'
    """  # noqa: E501 - a doctest output line
    from prezence.config.model import band_words

    at = str(m.get("at") or "")
    unit = f" {m['unit']}" if m.get("unit") else ""
    raw = m.get("measured_mean")
    where = "at your microphone" if at else "as measured"
    mean = f" (mean {float(raw):.3g}{unit} {where})" if isinstance(raw, int | float) else ""
    there = "there" if at else "after it"
    return f"{label}: judged{band_words(float(m['offset']), at)}: its figures are {there}{mean}"


def _inputs_used(report: Mapping[str, Any]) -> str:
    """What to check when nothing could be judged: the recording, or the live inputs used."""
    if report.get("recording"):
        return "the recording"
    from prezence.metrics import METRICS

    used = {
        METRICS[k].module
        for k, m in (report.get("metrics") or {}).items()
        if k in METRICS and isinstance(m, Mapping) and m.get("measured")
    }
    devices = [
        d for mod, d in (("speech", "the microphone"), ("vision", "the camera")) if mod in used
    ]
    # a module of one's own (`up --module`): its input is none of ours to name (session 21, a
    # second walkthrough: "check the microphone and the camera" when neither was used)
    metrics = {k: m for k, m in (report.get("metrics") or {}).items() if isinstance(m, Mapping)}
    ours = [k for k in metrics if k in METRICS and METRICS[k].module in ("speech", "vision")]
    own = sorted(str(k) for k in metrics if k not in ours)
    if not devices and (ours or not own):  # nothing said which of ours ran: both
        devices = ["the microphone", "the camera"]
    if own:
        devices.append(f"the module that writes {_and(own)}")
    return _and(devices)


def nothing_judged_sentence(report: Mapping[str, Any]) -> str:
    """What the robot says when no metric was judged: why, as far as the record says."""
    from prezence.summary import MIN_JUDGED_S

    metrics = [m for m in (report.get("metrics") or {}).values() if isinstance(m, Mapping)]
    whys = " ".join(str(m.get("not_measured_why") or "") for m in metrics)
    if 0.0 < _talk_s(report) < MIN_JUDGED_S:
        return "The talk was too short for me to judge your delivery."
    if "no audio track" in whys:
        return "I could not judge your delivery: the recording has no audio track."
    if "heard no voice" in whys:
        return (
            "I heard no voice, only silence, noise or a whisper, so I could not judge your "
            f"delivery: speak aloud, or check {_inputs_used(report)}."
        )
    if "the talk is in '" in whys:  # --language: pace and clarity not measured, and why
        return (
            "I measure pace and clarity in English talks only, and could not judge the rest "
            "of your delivery."
        )
    if any(m.get("too_brief") for m in metrics):
        return "I measured too little of your delivery to judge it."
    return f"I could not measure enough of your delivery to judge it: check {_inputs_used(report)}."


def of_time(row: Mapping[str, Any], measured: str = "it was measured") -> str:
    """``"time"``, or ``"6 s it was measured"`` for a metric whose module died mid-talk."""
    s = row.get("measured_s")
    return "time" if s is None else f"{float(s):.0f} s {measured}"


def _sides(row: Mapping[str, Any]) -> list[Mapping[str, Any]]:
    """A work-on or a-little-off row's sides (:func:`prezence.report.build.off_sides`); a
    report written before sides were kept has its one ``side``."""
    sides: list[Mapping[str, Any]] = [x for x in row.get("sides") or () if isinstance(x, Mapping)]
    return sides or [{"side": row.get("side"), "bound": row.get("bound")}]


def _unit(row: Mapping[str, Any]) -> str:
    """The unit after a bound, and where the band applies when a rule's offset moves it."""
    where = f" {row['where']}" if row.get("where") else ""
    return (f" {row['unit']}" if row.get("unit") else "") + where


def priority_sides(row: Mapping[str, Any], m: Mapping[str, Any]) -> str:
    """What a thing to work on was, side by side, each with its own seconds out of range.

    Example:
        >>> row = {"label": "pace", "unit": "wpm", "sides": [
        ...     {"side": "below", "bound": 140.0, "out_s": 173.0},
        ...     {"side": "above", "bound": 180.0, "out_s": 71.0}]}
        >>> priority_sides(row, {})
        'your pace was below the lowest good value, 140 wpm, for 173 s and above the highest good value, 180 wpm, for 71 s'
    """  # noqa: E501 - a doctest output line
    parts = []
    for x in _sides(row):
        limit = "lowest" if x.get("side") == "below" else "highest"
        secs = x.get("out_s")
        if not isinstance(secs, int | float):  # one side only: all the time out was on it
            secs = float(m.get("out_of_range_s") or 0.0)
        took = f"{float(secs):.0f} s" if float(secs) >= 0.5 else "under 1 s"  # never "0 s"
        parts.append(
            f"{x.get('side')} the {limit} good value, {_num(x.get('bound'))}{_unit(row)}, "
            f"for {took}{_side_within(x)}"
        )
    return f"your {row['label']} {was(str(row['label']))} {' and '.join(parts)}"


def off_sides_text(row: Mapping[str, Any]) -> str:
    """A metric a little off, side by side, each with its own share of the measured time.

    Example:
        >>> row = {"label": "pace", "unit": "wpm", "share_out": 0.4, "sides": [
        ...     {"side": "below", "bound": 140.0, "share_out": 0.3},
        ...     {"side": "above", "bound": 180.0, "share_out": 0.1}]}
        >>> off_sides_text(row)
        'your pace was below 140 wpm 30% and above 180 wpm 10% of the time'
    """
    parts = []
    for x in _sides(row):
        share = x.get("share_out")
        if not isinstance(share, int | float):
            share = float(row.get("share_out") or 0.0)
        parts.append(
            f"{x.get('side')} {_num(x.get('bound'))}{_unit(row)} {_share_words(float(share))}"
            f"{_side_within(x)}"
        )
    # the time within the error, where no side says it is all of one side's
    said = any(x.get("within_error") for x in _sides(row))
    return (
        f"your {row['label']} {was(str(row['label']))} {' and '.join(parts)} of the {of_time(row)}"
        f"{'' if said else _within_error(row)}"
    )


def _side_within(side: Mapping[str, Any]) -> str:
    """ " (all by less than the measurement's error, 8%)" for a side of a row to work on or a
    little off none of whose readings were out by more than the error, while the other side's
    were (:func:`prezence.report.build.off_sides`); "" otherwise."""
    if not side.get("within_error"):
        return ""
    return f" (all by less than the measurement's error, {side.get('error')})"


#: A judged metric measured over less of the talk than this share is named when the report
#: says everything stayed in range: the praise covers only the time it was measured.
COVERED_SHARE = 0.9
#: Seconds a metric may miss beyond its first window before a short talk is told it was
#: measured only in part: the speech module's word-based values come a second or two after its
#: 10 s window fills (pace at about 0:12), which is 13 % of a 25 s talk's 15 s after the window.
COVERED_SLACK_S = 5.0


def coverage_gaps(report: Mapping[str, Any]) -> list[tuple[str, float]]:
    """:func:`_gap_rows`' label and seconds measured."""
    return [(label, secs) for _, label, secs in _gap_rows(report)]


def _gap_rows(report: Mapping[str, Any]) -> list[tuple[Mapping[str, Any], str, float]]:
    """The judged metrics measured over less than :data:`COVERED_SHARE` of the talk after
    their first window (``Metric.first_after_s``: a module's first value of a windowed metric
    comes only when its window has filled), with the seconds they were measured (a video whose
    picture stops at 0:20 of a 0:54 talk).

    The wait for the first window is no gap (session 23: every clean talk was told "I
    measured your pace and clarity for only part of the talk", 96 s of 108 s measured, the
    first 10-12 s missing by design)."""
    from prezence.metrics import METRICS

    talk = _talk_s(report)
    out = []
    for k, m in (report.get("metrics") or {}).items():
        if not isinstance(m, Mapping) or not _judged(m) or talk <= 0 or "in_range_s" not in m:
            continue  # not judged, or its coverage not recorded
        secs = measured_s(m)
        rec = METRICS.get(str(k))
        first = min(rec.first_after_s, talk) if rec is not None else 0.0
        missed = (talk - first) - secs
        if missed > max((1.0 - COVERED_SHARE) * (talk - first), COVERED_SLACK_S):
            out.append((m, str(m.get("label") or k), secs))
    return out


#: The robot's sentence for a reason, when it is the largest (:func:`untimed_sentence`).
UNTIMED_SPOKEN: Mapping[int, str] = {
    Untimed.PAUSE: "There were long silences.",
    Untimed.NO_VOICE: "At times I heard no voice.",
    Untimed.TOO_LITTLE_TALK: "At times there were too few words yet to time.",
    Untimed.AFTER_PAUSE: "There were long silences.",
    Untimed.NOISE_NEAR: "Music or noise was near your words.",
    Untimed.CLIPPED: "Your recording is clipped.",
    Untimed.NOISY: "There was too much background noise.",
    Untimed.OTHER_VOICES: "Other people were talking near you.",
}
#: A reason is named when it held at least this long: a lone window of one is no reason to
#: give a presenter (the level window of music can hold under 1 s of voice activity: a "pause").
MIN_UNTIMED_S = 2.0


def untimed_words(m: Mapping[str, Any]) -> str:
    """Why a metric was not measured where it was not, from its ``untimed`` rows (the speech
    module's reason codes and their seconds; "" in a folder without them), largest first.

    Example:
        >>> untimed_words({"untimed": [{"code": 5, "s": 31.0}, {"code": 2, "s": 16.0},
        ...                            {"code": 1, "s": 1.0}, {"code": 99, "s": 3.0}]})
        'music or noise next to the words for 0:31, no voice for 0:16, reason 99 for 0:03'
    """
    per: dict[str, float] = {}
    for row in m.get("untimed") or ():
        if not isinstance(row, Mapping) or not isinstance(row.get("s"), int | float):
            continue
        code = row.get("code")
        label = UNTIMED_WORDS.get(code, f"reason {code}") if isinstance(code, int) else None
        if label is not None:
            per[label] = per.get(label, 0.0) + float(row["s"])
    said = sorted(((s, w) for w, s in per.items() if s >= MIN_UNTIMED_S), key=lambda x: -x[0])
    return ", ".join(f"{w} for {mmss(s)}" for s, w in said)


def untimed_sentence(report: Mapping[str, Any], metric: str | None = None) -> str:
    """The robot's one sentence on why pace or clarity (or only ``metric``) was measured over
    only part of the talk: the reason that held longest in any of them ("" when none is known,
    or the only ones are said otherwise). Too little speech to time is named only alone: it
    follows from the others (after music, the module waits for 10 s of words).

    Example:
        >>> m = {"label": "pace", "in_range_s": 69.0, "out_of_range_s": 0.0, "check": "min",
        ...      "samples": 69, "untimed": [{"code": 5, "s": 31.0}, {"code": 2, "s": 16.0}]}
        >>> untimed_sentence({"talk_s": 123.0, "metrics": {"speech_speed": m}})
        'Music or noise was near your words.'
    """
    longest: dict[str, float] = {}
    only = (report.get("metrics") or {}).get(metric) if metric is not None else None
    for m, _, _ in _gap_rows(report):
        if metric is not None and m is not only:
            continue
        per: dict[str, float] = {}
        for row in m.get("untimed") or ():
            code = row.get("code") if isinstance(row, Mapping) else None
            if isinstance(code, int) and isinstance(row.get("s"), int | float):
                said = UNTIMED_SPOKEN.get(code)
                if said is not None:
                    per[said] = per.get(said, 0.0) + float(row["s"])
        for said, secs in per.items():
            longest[said] = max(longest.get(said, 0.0), secs)
    if clipped(report):
        longest.pop(UNTIMED_SPOKEN[Untimed.CLIPPED], None)  # said already, with what to do
    known = {w: s for w, s in longest.items() if s >= MIN_UNTIMED_S}
    if len(known) > 1:
        known.pop(UNTIMED_SPOKEN[Untimed.TOO_LITTLE_TALK], None)
    return max(known, key=lambda w: known[w]) if known else ""


def coverage_words(report: Mapping[str, Any]) -> str:
    """``"gestures measured over 0:15 of 0:54, head pitch measured over 0:26 of 0:54"`` (""
    when every judged metric covered the talk), each with why where the module said
    (``"pace measured over 1:09 of 2:03 (music or noise next to the words for 0:31, …)"``)."""
    return ", ".join(
        _coverage_phrase(report, m, label, secs) for m, label, secs in _gap_rows(report)
    )


def _coverage_phrase(
    report: Mapping[str, Any], m: Mapping[str, Any], label: str, secs: float
) -> str:
    """``"pace measured over 1:09 of 2:03 (music or noise next to the words for 0:31)"``."""
    why = untimed_words(m)
    return f"{label} measured over {mmss(secs)} of {mmss(_talk_s(report))}" + (
        f" ({why})" if why else ""
    )


def listed_coverage(report: Mapping[str, Any], metric: str) -> str:
    """For a metric the report lists to work on (or a little off, or at its edge): over how
    much of the talk it was measured and why, where the speech module said why it measured
    only part (issue 11: the praise said it, a list of advice did not), and how much of it came
    from the syllable count (:func:`syllable_words`); "" otherwise, as before the module's
    reasons were written.

    Example:
        >>> m = {"label": "pace", "in_range_s": 0.0, "out_of_range_s": 49.0, "check": "min",
        ...      "samples": 49, "untimed": [{"code": 1, "s": 40.0}, {"code": 3, "s": 13.0}]}
        >>> listed_coverage({"talk_s": 123.0, "metrics": {"speech_speed": m}}, "speech_speed")
        'pace measured over 0:49 of 2:03 (silence for 0:40, too little speech yet to time for 0:13)'
    """  # noqa: E501 - a doctest output line
    m = (report.get("metrics") or {}).get(metric)
    if not isinstance(m, Mapping):
        return ""
    said = [
        _coverage_phrase(report, g, label, secs)
        for g, label, secs in _gap_rows(report)
        if g is m and untimed_words(g)
    ]
    syllables = syllable_words(m)
    if syllables:
        said.append(syllables if said else f"{m.get('label') or metric}: {syllables}")
    return "; ".join(said)


#: The share of a metric's measured time from the syllable count (``syllables``: the speech
#: module's ``speech_speed_source``) at which the report says so: a fifth. Its pace is
#: calibrated on the speaker's own recognised windows, but where the recogniser was not
#: trusted at all it is the corpus's average (8 % error against the recogniser's 5 %).
SYLLABLE_SHARE = 0.2


def syllable_words(m: Mapping[str, Any]) -> str:
    """ "40% of it from the syllable count, not the recogniser's words (telephone-quality audio
    for 0:41): less sure" for a metric a notable share (:data:`SYLLABLE_SHARE`) of whose
    measured time came from the speech module's syllable count ("" otherwise).

    Example:
        >>> syllable_words({"in_range_s": 60.0, "out_of_range_s": 40.0, "syllables":
        ...     {"s": 41.0, "untimed": [{"code": 8, "s": 41.0}]}})
        "41% of it from the syllable count, not the recogniser's words (telephone-quality audio for 0:41): less sure"
    """  # noqa: E501 - a doctest output line
    held = m.get("syllables")
    secs = measured_s(m)
    if not isinstance(held, Mapping) or not isinstance(held.get("s"), int | float) or secs <= 0:
        return ""
    share = min(1.0, float(held["s"]) / secs)
    if share < SYLLABLE_SHARE or float(held["s"]) < MIN_UNTIMED_S:
        return ""
    why = untimed_words(held)
    return (
        f"{_share_words(share)} of it from the syllable count, not the recogniser's words"
        + (f" ({why})" if why else "")
        + ": less sure"
    )


def _out_for(secs: float) -> str:
    return "under 1 s" if secs < 0.5 else f"{secs:.0f} s" if secs < 59.5 else mmss(secs)


def _share_words(share: float) -> str:
    """``"30%"``, ``"less than 1%"`` (never "0%" of a time that was out)."""
    return "less than 1%" if 100.0 * share < 0.5 else f"{100.0 * share:.0f}%"


def near_words(report: Mapping[str, Any]) -> str:
    """The metrics out of their band for too little of the time to be listed
    (``near_range``: :func:`prezence.report.build.near_range`), with their figures (""
    when none was).

    Example:
        >>> near_words({"near_range": [{"label": "pace", "unit": "wpm", "sides": [
        ...     {"side": "below", "bound": 140.0, "out_s": 8.0, "share_out": 0.19}]}]})
        'pace was under 140 wpm for 8 s (19% of the time it was measured)'
    """
    said: list[str] = []
    for row in report.get("near_range") or ():
        if not isinstance(row, Mapping):
            continue
        parts = [
            f"{'under' if x.get('side') == 'below' else 'over'} {_num(x.get('bound'))}"
            f"{_unit(row)} for {_out_for(float(x.get('out_s') or 0.0))} "
            f"({_share_words(float(x.get('share_out') or 0.0))}"
            + (" of the time it was measured)" if not said and i == 0 else ")")
            for i, x in enumerate(_sides(row))
        ]
        label = str(row.get("label") or row.get("metric"))
        said.append(f"{label} {was(label)} {' and '.join(parts)}{_within_error(row)}")
    return "; ".join(said)


def _error_share(row: Mapping[str, Any]) -> tuple[float, bool]:
    """A ``near_range`` row's seconds out by less than the measurement's error, and whether
    that is all of its time out."""
    near = row.get("within_error_s")
    if not isinstance(near, int | float) or near <= 0.0:
        return 0.0, False
    out = sum(float(x.get("out_s") or 0.0) for x in _sides(row))
    return float(near), near >= out - 0.05


def _within_error(row: Mapping[str, Any]) -> str:
    """ ", all of it by less than the measurement's error (8%)" for a ``near_range`` row whose
    time out was partly or wholly within it ("" otherwise)."""
    near, whole = _error_share(row)
    if not near:
        return ""
    much = "all of it" if whole else f"{_out_for(near)} of it"
    return f", {much} by less than the measurement's error ({row.get('error')})"


def _edge_value(row: Mapping[str, Any]) -> str:
    """An ``at_edge`` row's median reading, to as many places as keep it apart from its bound
    (139.6 against 140 is "139.6", not "140"), and to the tenth where how far out it read is
    said to the tenth (128.8 wpm "8.0% under" 140, not "129 wpm, 8.0% under"; a head pitch
    of -19.8 "4.8 degrees under" -15, not "-20 degrees, 4.8 degrees under")."""
    med, bound = float(row.get("median") or 0.0), float(row.get("bound") or 0.0)
    said = _num(med)
    tenths = "." in _edge_off(row) and "." not in said and med != round(med)
    return f"{med:.1f}" if said == _num(bound) or tenths else said


def _edge_off(row: Mapping[str, Any]) -> str:
    """How far out an ``at_edge`` row's median read: "1%", "less than 1%", "7.9%" (not "8%"
    beside an error of 8%), "2 degrees" (the unit alone: where an offset moves the band is
    said after the bound).

    Example:
        >>> _edge_off({"off_pct": 7.9, "error": "8%"}), _edge_off({"off_pct": 0.3})
        ('7.9%', 'less than 1%')
        >>> _edge_off({"off": 3.0, "unit": "degrees", "where": "after the rule's offset of +3"})
        '3 degrees'
    """
    pct = row.get("off_pct")
    if isinstance(pct, int | float):
        said = _share_words(float(pct) / 100.0)
        # rounded to the error's own figure, it would read as out by the error, not within it
        return f"{float(pct):.1f}%" if said in str(row.get("error")).split(" or ") else said
    unit = f" {row['unit']}" if row.get("unit") else ""
    return f"{_num(float(row.get('off') or 0.0))}{unit}"


def edge_text(row: Mapping[str, Any]) -> str:
    """A metric whose median reading lay out of its band by less than the measurement's
    error (``at_edge``: :func:`prezence.report.build.at_edge`), for the written report.

    Example:
        >>> edge_text({"label": "pace", "unit": "wpm", "side": "below", "bound": 140.0,
        ...     "median": 138.5, "off": 1.5, "off_pct": 1.1, "error": "8%", "felt": "slow",
        ...     "advice": "pick up the pace", "sides": [{"side": "below", "bound": 140.0,
        ...     "out_s": 53.0, "share_out": 0.53}]})
        "your pace read 138 wpm at its median, 1% under the lowest good value, 140 wpm: within the measurement's error (8%), so it may well have been in range (it read under 140 wpm for 53% of the time it was measured); if it felt slow, pick up the pace a little"
    """  # noqa: E501 - a doctest output line
    below = row.get("side") == "below"
    limit = "lowest" if below else "highest"
    felt = row.get("felt") or ("low" if below else "high")
    unit = f" {row['unit']}" if row.get("unit") else ""
    times = [
        f"{'under' if x.get('side') == 'below' else 'over'} {_num(x.get('bound'))}{unit} for "
        f"{_share_words(float(x.get('share_out') or 0.0))}"
        for x in _sides(row)
        if isinstance(x.get("share_out"), int | float)
    ]
    when = f" (it read {' and '.join(times)} of the time it was measured)" if times else ""
    return (
        f"your {row['label']} read {_edge_value(row)}{unit} at its median, {_edge_off(row)} "
        f"{'under' if below else 'over'} the {limit} good value, {_num(row.get('bound'))}"
        f"{_unit(row)}: within the measurement's error ({row.get('error')}), so it may "
        f"well have been in range{when}; if it felt {felt}, "
        f"{row.get('advice')} a little"
    )


def edge_spoken(row: Mapping[str, Any], *, short: bool = False) -> str:
    """The robot's words for an ``at_edge`` row: what it could not tell and the advice if the
    speaker felt so; ``short``: only that it was within the error (after other advice).

    Example:
        >>> row = {"label": "pace", "side": "below", "felt": "slow", "advice": "pick up the pace"}
        >>> edge_spoken(row)
        'Your pace read just under its ideal range, within my measuring error: it may have been fine. If it felt slow, pick up the pace a little.'
    """  # noqa: E501 - a doctest output line
    below = row.get("side") == "below"
    label = str(row.get("label") or row.get("metric"))
    where = f"Your {label} read just {'under' if below else 'over'} its ideal range"
    if short:
        return f"{where}, within my measuring error."
    felt = row.get("felt") or ("low" if below else "high")
    return (
        f"{where}, within my measuring error: it may have been fine. "
        f"If it felt {felt}, {row.get('advice')} a little."
    )


def praise_line(report: Mapping[str, Any], share: str) -> str:
    """The report's written praise when nothing was off: ``share`` is :func:`measured_share`
    (``"all"`` or ``"some"``); qualified by what was measured over only part of the talk, and
    "in or near" its range, naming the figures, when a metric was out of it at all
    (:func:`near_words`)."""
    every = "Every metric" if share == "all" else "Every judged metric"
    gaps = coverage_words(report)
    near = near_words(report)
    where = "in or near its ideal range" if near else "in its ideal range"
    said = "; ".join(w for w in (gaps, near) if w)
    if gaps:
        return f"{every} stayed {where} while it was measured: {said}."
    if near:
        return f"{every} stayed {where}: {said}."
    return f"{every} stayed {where}."


def _talk_s(report: Mapping[str, Any]) -> float:
    """The talk's length as the report says it: the time used where that is shorter (an `up`
    of files: the recordings' length, not the coach's clock that ran on through the modules'
    start-up), so that "measured over 0:03 of 0:18" agrees with "You used 18 seconds"."""
    used = (report.get("time") or {}).get("used_s")
    talk = report.get("talk_s")
    if talk and used:
        return float(min(float(talk), float(used)))
    return float(talk or used or 0.0)


def _times(n: int) -> str:
    return "once" if n == 1 else f"{n} times"


def module_sentences(
    notes: Sequence[Mapping[str, Any]],
    talk_s: float,
    label: Callable[[str], str] = str,
) -> list[str]:
    """One sentence per module that crashed or hung: when, whether it was restarted, and from
    when to when its metrics were not measured; and one per module whose input was cut short.

    Args:
        notes: :func:`prezence.summary.module_notes`'s rows.
        talk_s: the talk's length (a stretch lost until then is lost "to the end").
        label: a reader's name for a metric.

    Example:
        >>> n = {"module": "fidget", "crashes": 6, "first_crash_t": 5.7, "hangs": 0,
        ...      "restarts": 6, "lost": [{"metric": "fidget_rate", "from": 5.7, "to": 45.3}]}
        >>> module_sentences([n], 45.3)
        ['module fidget crashed 6 times (first at 0:06) and was restarted; fidget_rate was not measured from 0:06 to the end (0:45)']
    """  # noqa: E501 - a doctest output line
    out: list[str] = []
    for n in notes:
        if n.get("cut_short"):
            out.append(
                f"module {n['module']}'s input was cut short ({n['cut_short']}): "
                "the talk was judged on what was read"
            )
            if not (n.get("crashes") or n.get("hangs")):
                continue
        what: list[str] = []
        crashes, hangs = int(n.get("crashes") or 0), int(n.get("hangs") or 0)
        if n.get("last_value_t") is not None:  # rehearse's: when it died is not known
            what.append(f"failed after its last value at {mmss(n.get('last_value_t'))}")
        elif crashes:
            what.append(f"crashed {_times(crashes)} (first at {mmss(n.get('first_crash_t'))})")
        if hangs == 1 and n.get("first_kill_t") == n.get("first_hang_t"):
            # rehearse: the recording's clock stood where it fell silent (killed in wall time)
            what.append(f"hung at {mmss(n.get('first_hang_t'))}")
        elif hangs == 1:
            what.append(
                f"hung at {mmss(n.get('first_hang_t'))} (killed at {mmss(n.get('first_kill_t'))})"
            )
        elif hangs:
            what.append(
                f"hung {hangs} times (first at {mmss(n.get('first_hang_t'))}, killed at "
                f"{mmss(n.get('first_kill_t'))})"
            )
        restarts = int(n.get("restarts") or 0)
        if restarts >= crashes + hangs:
            again = "was restarted"
        elif restarts:
            again = f"was restarted {_times(restarts)}"
        else:
            again = f"was not restarted ({n.get('last_why')})"
        text = f"module {n['module']} {' and '.join(what)} and {again}"
        by_metric: dict[str, list[Mapping[str, Any]]] = {}
        for sp in n.get("lost") or ():
            by_metric.setdefault(str(sp["metric"]), []).append(sp)
        for metric, spans in by_metric.items():
            parts = []
            for sp in spans:
                to = float(sp["to"])
                end = f"the end ({mmss(to)})" if to >= talk_s - 0.5 else mmss(to)
                parts.append(f"from {mmss(sp['from'])} to {end}")
            name = label(metric)
            text += f"; {name} {was(name)} not measured {' and '.join(parts)}"
        if n.get("metrics_unknown"):
            text += (
                "; which metrics it measures is not known, so none is marked as lost (name "
                f"them: --module {n['module']}:METRIC,...=COMMAND)"
            )
        out.append(text)
    return out


def stale_sentences(
    metrics: Mapping[str, Any],
    notes: Sequence[Mapping[str, Any]],
    talk_s: float,
    label: Callable[[str], str] = str,
) -> list[str]:
    """One sentence per metric that went stale (no new value for longer than a value holds:
    its ``stale_spans``, one per stale episode counted) at a time a module's crash or hang
    (``notes``, :func:`module_sentences`) does not already say: from when to when it was not
    measured. Session 21, a second walkthrough: a module silent again after its restart was
    counted as a stale episode but said nowhere.

    Example:
        >>> sp = {"after": 35.0, "from": 41.0, "to": 44.0, "stale_after_s": 6.0, "module": "f"}
        >>> stale_sentences({"fidget_rate": {"stale_spans": [sp]}}, [], 45.0)
        ['fidget_rate went stale (module f wrote no new value for over 6 s) after 0:35: not measured from 0:41 to 0:44']
    """  # noqa: E501 - a doctest output line
    said: dict[str, list[tuple[float, float]]] = {}
    for n in notes:
        for sp in n.get("lost") or ():
            said.setdefault(str(sp["metric"]), []).append((float(sp["from"]), float(sp["to"])))
    out: list[str] = []
    for metric, m in metrics.items():
        if not isinstance(m, Mapping):
            continue
        spans = [
            sp
            for sp in m.get("stale_spans") or ()
            if isinstance(sp, Mapping)
            and not any(
                a < float(sp["to"]) and float(sp["from"]) < b for a, b in said.get(metric, ())
            )
        ]
        if not spans:
            continue
        module = spans[0].get("module")
        name = label(metric)
        parts = []
        for sp in spans:
            to = float(sp["to"])
            # the speech module's reasons for the stretch (issue 11), in the end's brackets
            why = untimed_words(sp)
            end = (
                f"the end ({mmss(to)}{'; ' + why if why else ''})"
                if to >= talk_s - 0.5
                else mmss(to) + (f" ({why})" if why else "")
            )
            parts.append(f"from {mmss(float(sp['from']))} to {end}")
        after = [mmss(float(sp["after"])) for sp in spans if sp.get("after") is not None]
        if not after:  # no value at all: the table's "no data", said with its span
            who = f"module {module} wrote no value" if module else "no value came"
            out.append(f"{name} had no data {parts[0]}: {who}")
            continue
        who = f"module {module} wrote no new value" if module else "no new value came"
        hold = float(spans[0].get("stale_after_s") or 0.0)
        slow = m.get("slow_cadence")
        why = ""
        if isinstance(slow, Mapping) and slow.get("median_gap_s") and slow.get("declared_s"):
            why = (
                f" ({'its module' if module else 'it'} wrote a value every "
                f"{float(slow['median_gap_s']):g} s (median), where its record declares one every "
                f"{float(slow['declared_s']):g} s)"
            )
        out.append(
            f"{name} went stale ({who} for over {hold:g} s) after {_and(after)}: not measured "
            + " and ".join(parts)
            + why
        )
    return out


def unreadable_sentences(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """One sentence per stream file with lines skipped as unreadable.

    Example:
        >>> unreadable_sentences([{"file": "x.txt", "lines": 2, "example": "line 4: t < 0"}])
        ['2 unreadable lines in x.txt were skipped (e.g. line 4: t < 0)']
    """
    out = []
    for r in rows:
        n = int(r.get("lines") or 0)
        first = f" (e.g. {r['example']})" if r.get("example") else ""
        out.append(
            f"{n} unreadable line{'s' if n != 1 else ''} in {r['file']} "
            f"{'were' if n != 1 else 'was'} skipped{first}"
        )
    return out


def backwards_sentences(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """One sentence per stream file whose times went back (kept as written, counted).

    Example:
        >>> backwards_sentences([{"file": "streams/x.txt", "samples": 13,
        ...                       "example": "line 4: t=8 goes back from 12"}])
        ["13 samples in streams/x.txt went back in time and were kept as written (e.g. line 4: t=8 goes back from 12): a module's clock went wrong"]
    """  # noqa: E501 - a doctest output line
    out = []
    for r in rows:
        n = int(r.get("samples") or 0)
        first = f" (e.g. {r['example']})" if r.get("example") else ""
        out.append(
            f"{n} sample{'s' if n != 1 else ''} in {r['file']} went back in time and "
            f"{'were' if n != 1 else 'was'} kept as written{first}: a module's clock went wrong"
        )
    return out


def _spoken_after(t: float, start: str) -> str:
    """``"after 6 seconds"``, ``"after 2 and a half minutes"``; ``start`` under half a second."""
    return start if t < 0.5 else f"after {_spoken_minutes(max(t, 1.0))}"


def lost_sentences(report: Mapping[str, Any]) -> list[str]:
    """What the robot says of each module that died mid-talk: what it could not follow.

    A person told "everything stayed in range" after the camera died half way must hear that
    half of it was not watched.

    Example:
        >>> n = {"module": "vision", "lost": [{"metric": "cv_gestures", "from": 65.0, "to": 300.0},
        ...      {"metric": "cv_headGaze", "from": 65.0, "to": 300.0}]}
        >>> lost_sentences({"talk_s": 300.0, "modules": [n]})
        ['I could not follow your gestures and head pitch after 1 minute.']
        >>> n = {"module": "pace", "lost": [{"metric": "speech_speed", "from": 6.0, "to": 46.0}]}
        >>> lost_sentences({"talk_s": 300.0, "modules": [n]})
        ['I could not follow your pace for 40 seconds.']
        >>> lost_sentences({"modules": [{"module": "fidget", "metrics_unknown": True,
        ...                              "first_crash_t": 5.7}]})
        ['Your fidget module stopped after 6 seconds, so I may have missed something.']
    """  # noqa: E501 - a doctest input line
    from prezence.report.build import metric_label

    talk_s = _talk_s(report)
    out = []
    for n in report.get("modules") or ():
        spans = [sp for sp in n.get("lost") or () if isinstance(sp, Mapping)]
        if spans:
            labels = " and ".join(dict.fromkeys(metric_label(str(sp["metric"])) for sp in spans))
            per_metric: dict[str, float] = {}
            for sp in spans:
                key = str(sp["metric"])
                per_metric[key] = per_metric.get(key, 0.0) + float(sp["to"]) - float(sp["from"])
            once = len(spans) == len(per_metric)  # one stretch per metric
            if once and all(float(sp["to"]) >= talk_s - 0.5 for sp in spans):
                when = _spoken_after(min(float(sp["from"]) for sp in spans), "from the start")
                out.append(f"I could not follow your {labels} {when}.")
            elif (lost_s := max(per_metric.values())) >= 1.0:  # a blink is not worth a word
                out.append(f"I could not follow your {labels} for {_spoken_minutes(lost_s)}.")
        elif n.get("metrics_unknown"):
            died = [
                float(t)
                for t in (n.get("first_crash_t"), n.get("first_hang_t"))
                if isinstance(t, int | float)
            ]
            when = f" {_spoken_after(min(died), 'at the start')}" if died else ""
            out.append(f"Your {n['module']} module stopped{when}, so I may have missed something.")
    if any(n.get("cut_short") for n in report.get("modules") or ()):
        # "You used 15 seconds" of a talk whose recording broke off there is not the whole
        # story: the speaker must hear that the rest was never heard
        out.append(
            f"Your recording breaks off after {_spoken_minutes(talk_s)}, so I judged only that."
        )
    return out


def cut_sentences(report: Mapping[str, Any]) -> list[str]:
    """Cues the robot did not give (dropped) or did not give in full, and a post-talk summary
    it did not say."""
    out = []
    dropped = [c for c in report.get("cues") or () if c.get("dropped")]
    if dropped:
        which = "; ".join(
            f"{mmss(c['t'])} {c['command']}: {c.get('drop_reason') or 'dropped'}" for c in dropped
        )
        n = len(dropped)
        out.append(
            f"the robot did not give {n} cue{'s' if n != 1 else ''} the coach chose ({which}): "
            f"{'they are' if n != 1 else 'it is'} listed, but the speaker never heard "
            f"{'them' if n != 1 else 'it'}"
        )
    cut = [c for c in report.get("cues") or () if c.get("cut_short")]
    if cut:
        which = "; ".join(f"{mmss(c['t'])} {c['command']}: {c['cut_short']}" for c in cut)
        out.append(f"{len(cut)} cue{'s' if len(cut) != 1 else ''} cut short ({which})")
    unknown = [c for c in report.get("cues") or () if c.get("outcome_unknown")]
    if unknown:
        which = "; ".join(f"{mmss(c['t'])} {c['command']}: {c['outcome_unknown']}" for c in unknown)
        n = len(unknown)
        out.append(
            f"{n} cue{'s' if n != 1 else ''} of unknown outcome: the robot may have given "
            f"{'them' if n != 1 else 'it'} in full ({which})"
        )
    post = report.get("post_talk") or {}
    if post.get("ok") is False and post.get("speech_ok") is True:
        out.append(
            "the robot said its summary after the talk, but its gesture was cut short "
            f"({post.get('gesture_error') or 'cut short'})"
        )
    elif post.get("ok") is False and post.get("speech_outcome") == "unknown":
        out.append(
            "the robot was lost while saying its summary after the talk: whether it said it "
            f"is unknown ({post.get('speech_error') or 'robot lost'})"
        )
    elif post.get("ok") is False:
        out.append(
            "the robot did not say its summary after the talk "
            f"({post.get('drop_reason') or 'cut short'})"
        )
    return out


def skipped_sentences(problems: Sequence[str]) -> list[str]:
    """The record lines the report skipped (``cues.jsonl:4: not a JSON line …``).

    Example:
        >>> skipped_sentences(["cues.jsonl:4: not a JSON line (Expecting value); line skipped"])
        ['a damaged record line was left out, so a cue may be missing: cues.jsonl:4: not a JSON line (Expecting value); line skipped']
    """  # noqa: E501 - a doctest output line
    return [f"a damaged record line was left out, so a cue may be missing: {p}" for p in problems]


def truth_skipped_sentences(problems: Sequence[str]) -> list[str]:
    """The ground-truth lines left out (``truth.jsonl:7: …``): the truth column misses them.

    Example:
        >>> truth_skipped_sentences(["truth.jsonl:7: not a JSON line (Unterminated string)"])
        ['a damaged ground-truth line was left out, so the truth figures may be wrong: truth.jsonl:7: not a JSON line (Unterminated string)']
    """  # noqa: E501 - a doctest output line
    return [
        f"a damaged ground-truth line was left out, so the truth figures may be wrong: {p}"
        for p in problems
    ]


def beyond_sentence(beyond: Mapping[str, int]) -> str | None:
    """The samples left out as stamped after the talk's end (a module's clock gone wrong)."""
    if not beyond:
        return None
    n = sum(beyond.values())
    return (
        f"{n} sample{'s' if n != 1 else ''} stamped after the end of the talk "
        f"({', '.join(sorted(beyond))}) were left out: a module's clock went wrong"
    )


def trouble_sentences(report: Mapping[str, Any]) -> list[str]:
    """What went wrong on the way, for the text and the HTML report alike: a damaged
    ``config.toml`` (and the rules judged by instead), cues cut short and an unsaid summary,
    modules that crashed or hung, metrics that went stale, unreadable stream lines, samples
    stamped after the talk, damaged record and ground-truth lines ([] for a talk where nothing
    did)."""
    from prezence.report.build import metric_label

    beyond = beyond_sentence(report.get("beyond_talk") or {})
    stopped = report.get("analysis_stopped_s")
    analysis = (
        [
            f"the analysis of the recording was stopped at {mmss(float(stopped))} of its "
            f"{mmss(_talk_s(report))}: the figures cover that part"
        ]
        if isinstance(stopped, int | float)
        else []
    )
    damaged = report.get("config_damaged")
    return (
        ([str(damaged)] if damaged else [])
        + analysis
        + cut_sentences(report)
        + module_sentences(report.get("modules") or (), _talk_s(report), metric_label)
        + stale_sentences(
            report.get("metrics") or {}, report.get("modules") or (), _talk_s(report), metric_label
        )
        + unreadable_sentences(report.get("unreadable") or ())
        + backwards_sentences(report.get("out_of_order") or ())
        + ([beyond] if beyond else [])
        + skipped_sentences(report.get("skipped_records") or ())
        + truth_skipped_sentences(report.get("truth_skipped") or ())
    )


def summary_phrase(report: Mapping[str, Any]) -> str:
    """What the robot says after the talk (at most :data:`MAX_SPOKEN_WORDS` words).

    Time used vs allocated, what it could not follow (a module that died mid-talk), then the
    two things to work on first (or praise when nothing was out of range). To keep under the
    limit with what it could not follow, the second thing to work on, then what it stopped
    reminding of, is left out, and a metric a little off is said without "Nothing was far off".

    Example:
        >>> r = {"time": {"used_s": 600.0, "allocated_s": 600.0, "over_under_pct": 0.0},
        ...      "priorities": [{"advice": "slow down"}, {"advice": "look up at your audience"}]}
        >>> summary_phrase(r)
        'You used 10 minutes of 10 minutes, right on time. Work first on this: slow down. Then: look up at your audience.'
    """  # noqa: E501 - a doctest output line
    parts = [time_sentence(report, first_words=False)]
    if clipped(report):  # what to do differently next time, before what could not be judged
        parts.append("Your recording is clipped: record it with less input gain.")
    lost = lost_sentences(report)
    parts += lost
    droppable: list[str] = []  # least important last
    late = _late_start(report["time"]).strip()  # after the advice; the first left out
    stopped = [n for n in report.get("stopped_repeating") or [] if isinstance(n, Mapping)]
    if stopped:  # the coach stopped repeating these during the talk: said once, here
        from prezence.report.build import metric_label

        names = " and ".join(dict.fromkeys(metric_label(str(n.get("metric"))) for n in stopped))
        if heard_none(report, [str(n.get("metric")) for n in stopped]):
            # a recorded rehearsal: nobody was reminded of anything (session 22)
            parts.append(f"Your {names} needed reminders again and again: work on it next time.")
        else:
            parts.append(f"I stopped reminding you about your {names}: work on it next time.")
        droppable.append(parts[-1])
    pri = list(report.get("priorities") or [])
    off = [o for o in report.get("slightly_off") or [] if isinstance(o, Mapping)]
    edge = [o for o in report.get("at_edge") or [] if isinstance(o, Mapping)]
    none = unmeasured_labels(report)
    if none and (pri or off or edge):  # the praise names them itself; here, before the advice
        parts.append(f"I could not measure your {_and(none)}.")
    if not pri and off:  # too little to work on first, too much to call in range
        o = off[0]
        # over how little of the talk, and how surely, it was measured (as for a thing to
        # work on: session 25 said it only there); room is made for it as for what was lost
        caveat = advice_caveat(report, o)
        lead = "Your" if lost or caveat else "Nothing was far off, but your"
        said = []
        if _error_share(o)[0]:  # part of it within the error: the part beyond it, said so
            side = "under" if o.get("side") == "below" else "over"
            beyond = float(o.get("share_out") or 0.0)
            said = [f"{side} the ideal range by more than my measuring error for {beyond:.0%}"]
        for i, x in enumerate(_sides(o) if not said else ()):
            share = x.get("share_out")
            share = float(o["share_out"]) if not isinstance(share, int | float) else share
            where = ("under" if x.get("side") == "below" else "over") + (
                " the ideal range" if i == 0 else " it"
            )
            said.append(f"{where} {_share_words(float(share))}")
        parts.append(
            f"{lead} {o['label']} {was(o['label'])} a little {' and '.join(said)} "
            f"of the {of_time(o, 'I could measure it')}: {o['advice']}."
        )
        parts += caveat
        droppable += caveat
    elif not pri and edge:  # nothing known to be out: what it could not tell, and why
        if not lost:
            parts.append("Nothing was clearly off.")
            droppable.append(parts[-1])
        parts.append(edge_spoken(edge[0]))
    elif not pri:
        share = measured_share(report)
        if share == "none":
            parts.append(nothing_judged_sentence(report))
        elif share == "some" or coverage_gaps(report):
            parts.append(_some_praise(report))
            # the praise says "only part of the talk" when it names no metric it could not judge
            why = "" if unjudged_labels(report) else untimed_sentence(report)
            if why:  # why it measured only part (issue 11); kept before the near sentence
                parts.append(why)
                droppable.append(why)
        else:
            parts.append(f"Your delivery stayed {_in(report)}. Well done!")
        if share != "none" and _near_spoken(report):  # which one was near, not in: if room
            parts.append(_near_spoken(report))
            droppable.append(parts[-1])
    else:
        parts.append(f"Work first on this: {pri[0]['advice']}.")
        # over how little of the talk the advice was measured, and why (issue 11): dropped
        # after the second advice, which goes with its own
        parts += advice_caveat(report, pri[0])
        droppable += advice_caveat(report, pri[0])
        if len(pri) > 1:
            parts.append(f"Then: {pri[1]['advice']}.")
            droppable.append(parts[-1])
            parts += advice_caveat(report, pri[1])
            droppable += advice_caveat(report, pri[1])
    if edge and (pri or off):  # after what is known to be out; the first left out for length
        parts.append(edge_spoken(edge[0], short=True))
        droppable.append(parts[-1])
    if late:
        parts.append(late)
        droppable.append(late)  # last in: the first dropped
    # whole sentences go first, least important first, so that nothing is cut mid-sentence
    # (session 20: "…but I measured only part of.")
    while droppable and len(" ".join(parts).split()) > MAX_SPOKEN_WORDS:
        parts.remove(droppable.pop())
    text = " ".join(parts)
    words = text.split()
    if len(words) > MAX_SPOKEN_WORDS:  # custom advice texts could be long: never ramble
        kept = words[:MAX_SPOKEN_WORDS]
        # at the last whole sentence that fits, else at the word limit
        ends = [i for i, w in enumerate(kept) if w.endswith((".", "!", "?"))]
        kept = kept[: ends[-1] + 1] if ends else kept
        text = " ".join(kept).rstrip(",.;:") + ("" if kept[-1].endswith(("!", "?")) else ".")
    return text


#: A thing to work on measured over less of the talk than this share is said so by the robot
#: with the reason the speech module gave (issue 11: advice on pace from 40 % of the talk);
#: likewise one taken from the syllable count for this share of its measured time or more.
SPOKEN_SHARE = 0.5


def advice_caveat(report: Mapping[str, Any], row: Mapping[str, Any]) -> list[str]:
    """The robot's sentences after a thing to work on (``row``, a priority; or the metric a
    little off, said when nothing is to be worked on) measured over
    under :data:`SPOKEN_SHARE` of the talk where the speech module said why, or taken from
    its syllable count for that share of its time or more ([] otherwise; and in a folder
    without the module's reasons, as before them).

    Example:
        >>> m = {"label": "pace", "in_range_s": 0.0, "out_of_range_s": 49.0, "check": "min",
        ...      "samples": 49, "untimed": [{"code": 1, "s": 60.0}, {"code": 3, "s": 13.0}]}
        >>> report = {"talk_s": 123.0, "metrics": {"speech_speed": m}}
        >>> advice_caveat(report, {"metric": "speech_speed"})
        ['I measured your pace over only 40% of the talk.', 'There were long silences.']
    """
    metric = str(row.get("metric"))
    m = (report.get("metrics") or {}).get(metric)
    talk = _talk_s(report)
    if not isinstance(m, Mapping) or talk <= 0:
        return []
    label = str(m.get("label") or metric)
    out = []
    secs = measured_s(m)
    gap = any(g is m for g, _, _ in _gap_rows(report))
    if gap and untimed_words(m) and secs < SPOKEN_SHARE * talk:
        part = _share_words(secs / talk)
        # not "over only less than 1%", nor "over only 50%" of under half (session 26's tester)
        if part == "50%":
            part = "just under half"
        elif not part.startswith("less"):
            part = f"only {part}"
        out.append(f"I measured your {label} over {part} of the talk.")
        why = untimed_sentence(report, metric)
        if why:
            out.append(why)
    held = m.get("syllables")
    if isinstance(held, Mapping) and isinstance(held.get("s"), int | float) and secs > 0:
        share = min(1.0, float(held["s"]) / secs)
        if share >= SPOKEN_SHARE:
            out.append(
                f"I timed {_share_words(share)} of your {label} from syllables, not words, "
                "so I am less sure of it."
            )
    return out


def clipped(report: Mapping[str, Any]) -> bool:
    """Whether a metric's note says the recording is clipped (the speech module's log said so:
    :func:`prezence.summary.clipped_detail`)."""
    from prezence.summary import CLIPPED_NOTE

    return any(
        str(m.get(key) or "").startswith(CLIPPED_NOTE)
        for m in (report.get("metrics") or {}).values()
        if isinstance(m, Mapping)
        for key in ("not_measured_why", "less_reliable")
    )


def heard_none(report: Mapping[str, Any], metrics: Sequence[str]) -> bool:
    """Whether the speaker heard none of the cues about ``metrics`` (a recorded rehearsal, an
    `up` of recordings: the report's cues say ``heard`` false), so that nothing may be said to
    have reminded them.

    Example:
        >>> cues = [{"metric": "speech_speed", "heard": False}]
        >>> heard_none({"cues": cues}, ["speech_speed"]), heard_none({"cues": []}, ["x"])
        (True, False)
    """
    about = [c for c in report.get("cues") or () if c.get("metric") in metrics]
    return bool(about) and all(c.get("heard") is False for c in about)


def _why_pointer(report: Mapping[str, Any]) -> str:
    """Where the reader learns why nothing was judged: the notes below, the modules' logs when
    they say something, else nothing."""
    if metric_notes(report):
        return " (see the notes under the table)"
    if report.get("logs"):
        return f" (see {_and(list(report['logs']))} in the session folder)"
    return ""


def _some_praise(report: Mapping[str, Any]) -> str:
    """Praise for the metrics judged, naming them when others were measured but not judged."""
    rest = unjudged_labels(report)
    part = [label for label, _ in coverage_gaps(report)]
    if not rest and part:  # praise for the time it was measured only, and said so
        judged_n = sum(
            1
            for m in (report.get("metrics") or {}).values()
            if isinstance(m, Mapping) and _judged(m)
        )
        what = (
            "only part of your talk"
            if len(part) == judged_n
            else f"your {_and(part)} for only part of the talk"
        )
        return f"Everything I could measure stayed {_in(report)}, but I measured {what}."
    if not rest:
        return f"Everything I could measure stayed {_in(report)}. Well done!"
    good = [
        str(m.get("label") or k)
        for k, m in (report.get("metrics") or {}).items()
        if isinstance(m, Mapping) and _judged(m)
    ]
    whys = [
        str(m.get("not_measured_why") or "")
        for m in (report.get("metrics") or {}).values()
        if isinstance(m, Mapping)
    ]
    if any(w.startswith("the talk is in '") for w in whys):
        # the speech module was told the talk's language (--language): the reason is said too
        return (
            f"Your {_and(good)} stayed {_in(report)}; I did not judge your {_and(rest)}: "
            "I measure them in English talks only."
        )
    return f"Your {_and(good)} stayed {_in(report)}; I could not judge your {_and(rest)}."


def _in(report: Mapping[str, Any]) -> str:
    """ "in the ideal range", or "in or near the ideal range" when a metric was out of it at all
    (``near_range``)."""
    return "in or near the ideal range" if report.get("near_range") else "in the ideal range"


def _near_spoken(report: Mapping[str, Any]) -> str:
    """The metric most out of its band among those near it, short: "Your pace was under its
    ideal range for 8 seconds." ("" when none was; "it" would point at whatever the sentence
    before named, a metric not judged, say)."""
    rows = [r for r in report.get("near_range") or () if isinstance(r, Mapping)]
    if not rows:
        return ""
    row = rows[0]
    label = str(row.get("label") or row.get("metric"))
    said = [
        f"{'under' if x.get('side') == 'below' else 'over'} {'it' if i else 'its ideal range'} for "
        + (
            _spoken_minutes(float(x.get("out_s") or 0.0))
            if float(x.get("out_s") or 0.0) >= 0.5
            else "under a second"
        )
        for i, x in enumerate(_sides(row))
    ]
    if _error_share(row)[1]:  # after every side: it is said of them all
        said[-1] += ", by less than my measuring error"
    return f"Your {label} {was(label)} {' and '.join(said)}."


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100.0 * x:.0f}%"


def _num(x: float | None) -> str:
    if x is None:
        return "-"
    return f"{x:.3g}" if abs(x) < 10 else f"{x:.0f}"


def format_text(report: Mapping[str, Any]) -> str:
    """The terminal summary of a report: time, work-on list, a table per metric, the cues."""
    lines: list[str] = []
    head = f"Post-speech report: {report.get('scenario') or report.get('session')}"
    about = [f"seed {report['seed']}"] if report.get("seed") is not None else []
    if report.get("policy"):  # a replay has no seed of its own, but its policy is the point
        about.append(f"policy {report['policy']}")
    if report.get("replay_of"):
        about.append(f"a replay of {report['replay_of']}")
    if about:
        head += f" ({', '.join(about)})"
    lines.append(head)
    if not report.get("complete", True):
        lines.append(
            f"  note: the record stops at {mmss(report['talk_s'])} of a planned "
            f"{mmss(report.get('planned_s'))}; figures cover what was recorded"
        )
    lines += [f"  note: {sentence}" for sentence in trouble_sentences(report)]
    lines.append("  " + time_sentence(report))
    none = unmeasured_labels(report)
    if none:  # not in the praise nor the advice: said before them
        lines.append("  " + unmeasured_line(none))
    pri = report.get("priorities") or []
    if pri:
        lines.append("  Work on, first:")
        for i, p in enumerate(pri, 1):
            m = report["metrics"].get(p["metric"], {})
            lines.append(f"    {i}. {p['advice']} ({priority_sides(p, m)} in all)")
            if p.get("noise"):
                lines.append(f"       {p['noise']}")
            if cov := listed_coverage(report, str(p["metric"])):
                lines.append(f"       {cov}")
    elif not report.get("slightly_off") and not report.get("at_edge"):
        lines.append(
            {
                "none": (
                    "  Nothing was judged: no metric was measured long enough"
                    if any(m.get("samples") for m in report["metrics"].values())
                    else "  Nothing was measured: no metric has a sample"
                )
                + _why_pointer(report)
                + ".",
                "some": "  " + praise_line(report, "some"),
                "all": "  " + praise_line(report, "all"),
            }[measured_share(report)]
        )
    off = report.get("slightly_off") or []
    if off:
        lines.append(
            "  A little off, not enough to work on:" if pri else "  Nothing was far off, but:"
        )
        for o in off:
            lines.append(f"    - {off_sides_text(o)} ({o['advice']})")
            if o.get("noise"):
                lines.append(f"      {o['noise']}")
            if cov := listed_coverage(report, str(o.get("metric"))):
                lines.append(f"      {cov}")
    edge = report.get("at_edge") or []
    if edge:
        lines.append(f"  {EDGE_HEAD}:" if pri or off else "  Nothing was clearly off, but:")
        for o in edge:
            lines.append(f"    - {edge_text(o)}")
            if cov := listed_coverage(report, str(o.get("metric"))):
                lines.append(f"      {cov}")
    lines.append("")
    lines.append(
        f"  {'metric':<12} {'measured':>13} {'in range':>12} {'mean':>7} {'p10':>7} {'p90':>7} "
        f"{'longest out':>12}"
    )
    talk = mmss(_talk_s(report))
    for name, m in report["metrics"].items():
        tir = (
            ("-*" if m.get("too_brief") else _pct(m.get("time_in_range")))  # * : not judged
            if m.get("samples")
            else m.get("data") or "no data"
        )
        # over how much of the talk its figures hold: "0:15 of 0:54" is not the whole talk
        covered = f"{mmss(measured_s(m))} of {talk}" if m.get("samples") else "-"
        lines.append(
            f"  {m.get('label', name):<12} {covered:>13} {tir:>12} "
            f"{_num(m.get('mean')):>7} {_num(m.get('p10')):>7} {_num(m.get('p90')):>7} "
            + (  # nothing measured: no stretch out of range to speak of
                f"{m.get('longest_out_of_range_s', 0.0):>10.0f} s"
                if m.get("samples")
                else f"{'-':>12}"
            )
        )
    lines += [f"  note: {n}" for n in metric_notes(report)]
    lines.append("")
    cues = report.get("cues") or []
    lines.append(
        f"  {len(cues)} cue{'' if len(cues) == 1 else 's'}"
        + "".join(f"; {p}" for p in cue_count_parts(report))
    )
    for c in cues:
        mark = cue_mark(c)
        if c.get("cut_short"):
            mark = f"CUT SHORT: {c['cut_short']}" + (f"; {mark}" if mark else "")
        elif c.get("outcome_unknown"):
            mark = f"OUTCOME UNKNOWN: {c['outcome_unknown']}" + (f"; {mark}" if mark else "")
        # a time warning has no problem whose onset it follows (its "latency" is 0 by design)
        lat = c.get("latency_s") if c.get("metric") else None
        lat_s = f" {int(lat + 0.5)} s after onset" if lat is not None else ""  # halves up
        lines.append(f"    {mmss(c['t']):>5}  {c['command']:<12}{lat_s:<20} {mark}")
    return "\n".join(lines) + "\n"


def cue_count_parts(report: Mapping[str, Any]) -> list[str]:
    """What the cues were and what followed them, for the text and the HTML report alike.

    What followed a correction is what the metric did in the window after it (back in range,
    closer to it, no closer), never "you got better": the metric may have come back by itself.
    A synthetic talk's ground truth says whether the presenter reacted. False alarms and stale
    cues are counted apart, as the evaluation counts them (docs/evaluation.md).

    Example:
        >>> c = {"cues_judged": 2, "cues_improved": 1, "cues_back_in_range": 1,
        ...      "cues_reacted": 0, "cues_reaction_known": 2, "false_alarms": 1, "stale": 3}
        >>> cue_count_parts({"counts": c, "effect_window_s": 30.0})
        ['in the 30 s after each of 2 corrections: 1 back in range, 1 no closer', 'the presenter reacted to 0 of them (ground truth)', '1 false alarm (cued while in range, not out on that side in the 10 s before)', '3 stale (cued within 10 s after the problem had ended)']
    """  # noqa: E501 - a doctest output line
    counts = report.get("counts") or {}
    w = float(report.get("effect_window_s") or 30.0)
    parts: list[str] = []
    judged = int(counts.get("cues_judged") or 0)
    if judged:
        back = int(counts.get("cues_back_in_range") or 0)
        closer = int(counts.get("cues_improved") or 0) - back
        followed = [
            f"{n} {what}"
            for n, what in (
                (back, "back in range"),
                (closer, "closer to range"),
                (judged - back - closer, "no closer"),
            )
            if n
        ]
        each = "each of " if judged > 1 else ""
        s = "s" if judged > 1 else ""
        parts.append(f"in the {w:g} s after {each}{judged} correction{s}: {', '.join(followed)}")
        if counts.get("cues_reaction_known"):
            reacted = int(counts.get("cues_reacted") or 0)
            if int(counts["cues_reaction_known"]) == judged == 1:
                did = "reacted" if reacted else "did not react"
                parts.append(f"the presenter {did} to it (ground truth)")
            elif int(counts["cues_reaction_known"]) == judged:
                parts.append(f"the presenter reacted to {reacted} of them (ground truth)")
            else:
                parts.append(
                    f"the presenter reacted to {reacted} of {counts['cues_reaction_known']} "
                    "(ground truth)"
                )
    unheard = int(counts.get("cues_not_heard") or 0)
    if unheard:
        why = report.get("effects_not_judged") or "the speaker did not hear them"
        s = "s" if unheard != 1 else ""
        parts.append(f"what followed {unheard} correction{s} is not judged: {why}")
    dropped = int(counts.get("cues_dropped") or 0)
    if dropped:
        parts.append(f"{dropped} not given: the robot dropped {'them' if dropped != 1 else 'it'}")
    fa = int(counts.get("false_alarms") or 0)
    if fa:
        parts.append(
            f"{fa} false alarm{'s' if fa != 1 else ''} (cued while in range, not out on that "
            "side in the 10 s before)"
        )
    stale = int(counts.get("stale") or 0)
    if stale:
        parts.append(f"{stale} stale (cued within 10 s after the problem had ended)")
    unmeasured = int(counts.get("cues_unmeasured") or 0)
    if unmeasured:
        parts.append(
            f"{unmeasured} not judged (cued while {'its' if unmeasured == 1 else 'their'} "
            "metric was not measured: its module had stopped, or it went stale)"
        )
    return parts


def cue_mark(c: Mapping[str, Any]) -> str:
    """One cue's outcome: a false alarm, a stale cue, one given while its metric was not
    measured (its module had died: not judged), or what followed it (and, where the talk
    records it, whether the presenter reacted).

    Example:
        >>> cue_mark({"effect": "back in range after 16 s", "reacted": False,
        ...           "reaction": "ignored the cue"})
        'back in range after 16 s; the presenter ignored it'
        >>> cue_mark({"stale": True, "ended_s_before": 4.2})
        'STALE: back in range 4 s before'
        >>> cue_mark({"unmeasured": True, "not_measured_since": 21.06})
        'NOT JUDGED: not measured after 0:21'
    """
    if c.get("dropped"):
        return f"DROPPED, not given: {c.get('drop_reason') or 'the robot did not give it'}"
    if c.get("false_alarm"):
        return "FALSE ALARM: it was in range"
    if c.get("stale"):
        return f"STALE: back in range {float(c.get('ended_s_before') or 0.0):.0f} s before"
    if c.get("unmeasured"):
        since = float(c.get("not_measured_since") or 0.0)
        return f"NOT JUDGED: not measured {f'after {mmss(since)}' if since > 0 else 'yet'}"
    if c.get("heard") is False:
        return "not heard by the speaker"
    mark = str(c.get("effect") or "")
    if "reacted" in c and mark:
        mark += f"; {_REACTIONS.get(str(c.get('reaction')), 'the presenter did not react')}"
        if c["reacted"]:
            mark = mark.rsplit("; ", 1)[0] + "; the presenter reacted"
    return mark


#: The synthetic presenter's reasons for not reacting (its ``reactions`` record), in words.
_REACTIONS = {
    "ignored the cue": "the presenter ignored it",
    "nothing to change": "the presenter had nothing to change",
}
