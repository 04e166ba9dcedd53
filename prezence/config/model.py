"""The configuration as frozen dataclasses: what both front ends (line format, TOML) produce.

Deviation, the quantity every rule is judged by, is defined here once:

    deviation % = 100 × (distance of the value outside the ideal band) / scale

where ``scale`` is, by default, the bound that was crossed (right for ratio-scale metrics: 225 wpm
is 25 % above 180) and, for interval or log-scale metrics, a unit set per rule (6 dB, 10°). A
bound of zero or below has no meaningful ratio, so such a rule must give ``scale`` explicitly.
Inside the band the deviation is 0.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields, replace
from typing import Any

# re-exported: rules and presenters name it from here
from prezence.feedback.direction import Direction as Direction
from prezence.metrics import METRICS

FORMAT = 1  # version of the TOML config and scenario formats


class Check(enum.Enum):
    """How a metric is judged against its ideal band."""

    MIN = "min"
    MAX = "max"
    IN_RANGE = "inRange"


#: :attr:`Rule.at` of a rule judged at the room's farthest listener (``at=listener``).
LISTENER = "listener"


def signed(x: float) -> str:
    """``x`` with its sign, a real minus for a negative one: ``−25.5``, ``+3``."""
    return f"−{-x:g}" if x < 0 else f"+{x:g}"


def band_words(offset: float, at: str) -> str:
    """Where a band applies, after its bound, for a rule's ``offset`` and ``at`` (as
    ``summary.json`` keeps them): "" with no offset. See :meth:`Rule.band_words`."""
    if not offset:
        return ""
    if at == LISTENER:
        less = "less" if offset < 0 else "more"
        return f" at the farthest listener ({abs(offset):.1f} dB {less} than at your microphone)"
    return f" after the rule's offset of {signed(offset)}"


@dataclass(frozen=True)
class Rule:
    """One production rule: a metric, its ideal band and the commands that correct it.

    Attributes:
        metric: module/metric name; also the default stream file stem.
        check: min, max or inRange.
        low: lower bound (min, inRange), in the metric's unit, after named values are resolved.
        high: upper bound (max, inRange).
        strict: out of range once → warn at the first free moment, ahead of non-strict rules.
        below: command when the value is below the band (None: no cue).
        above: command when the value is above the band (None: no cue).
        scale: deviation scale in the metric's unit; None means "the crossed bound".
        gain: multiplies weight growth for this rule (1.0 = the default rate).
        offset: added to every value before it is judged (e.g. the inverse-square estimate
            at the farthest listener, a negative number of dB). Whatever shows a judged value
            shows it with the offset added and names it (:meth:`shift_words`).
        at: ``"listener"`` when ``offset`` is the room's estimate at the farthest listener
            (``at=listener``), so that it can be said so; "" for a plain offset or none. Not
            part of equality: the offset is what judges.
        stream: stream file name, relative to the session's ``streams/`` folder.
        stale_after_s: the metric is excluded from decisions once its newest sample is older
            than this; None uses the processor setting.
        unit: for display only.
        physical_range: ``(lo, hi)``, the values the metric can physically take, declared by
            the rule (``range=LO..HI``) for a metric without a record in
            :data:`prezence.metrics.METRICS` (a record's range is not the rule's to change);
            None: the record's, if any (see :attr:`value_range`).
        source: ``file:line`` where the rule was defined; not part of equality.
    """

    metric: str
    check: Check
    low: float | None = None
    high: float | None = None
    strict: bool = False
    below: str | None = None
    above: str | None = None
    scale: float | None = None
    gain: float = 1.0
    offset: float = 0.0
    stream: str = ""
    stale_after_s: float | None = None
    unit: str = ""
    physical_range: tuple[float, float] | None = None
    at: str = field(default="", compare=False)
    source: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        if not self.stream:
            object.__setattr__(self, "stream", f"{self.metric}.txt")
        if self.physical_range is not None:
            lo, hi = self.physical_range
            object.__setattr__(self, "physical_range", (float(lo), float(hi)))

    @property
    def value_range(self) -> tuple[float, float] | None:
        """The values the metric's stream may hold: the rule's own ``physical_range``, else its
        record's (:data:`prezence.metrics.METRICS`), else None (any finite value). A sample
        outside it is a module gone wrong: the stream readers skip and report it.

        Example:
            >>> Rule("speech_accuracy", Check.MIN, low=0.5).value_range
            (0.0, 1.0)
            >>> Rule("fidget_rate", Check.MAX, high=3, physical_range=(0, 60)).value_range
            (0.0, 60.0)
            >>> Rule("fidget_rate", Check.MAX, high=3).value_range is None
            True
        """
        if self.physical_range is not None:
            return self.physical_range
        rec = METRICS.get(self.metric)
        return rec.physical_range if rec is not None else None

    def judge(self, value: float) -> tuple[float, str | None]:
        """``(deviation(value), side(value))`` in one pass (the processor's per-sample path)."""
        v = value + self.offset
        if self.low is not None and v < self.low:
            ref = self.scale if self.scale is not None else self.low
            return 100.0 * (self.low - v) / ref, "below"
        if self.high is not None and v > self.high:
            ref = self.scale if self.scale is not None else self.high
            return 100.0 * (v - self.high) / ref, "above"
        return 0.0, None

    def deviation(self, value: float) -> float:
        """Percent deviation of ``value`` from the ideal band (0 inside it).

        Example:
            >>> r = Rule("speech_speed", Check.IN_RANGE, low=140, high=180)
            >>> r.deviation(225.0)
            25.0
            >>> r.deviation(150.0)
            0.0
            >>> Rule("cv_headGaze", Check.MIN, low=0.0, scale=10.0).deviation(-25.0)
            250.0
        """
        return self.judge(value)[0]

    def side(self, value: float) -> str | None:
        """``"below"``, ``"above"`` or None (in range)."""
        return self.judge(value)[1]

    def command_for(self, value: float) -> str | None:
        """The command that corrects ``value``, or None when in range or none is configured."""
        s = self.side(value)
        if s == "below":
            return self.below
        if s == "above":
            return self.above
        return None

    def band_words(self) -> str:
        """Where the band applies, after a bound: "" with no offset.

        Example:
            >>> r = Rule("speech_volume", Check.MIN, low=60, offset=-25.46, unit="dB SPL")
            >>> r.band_words()
            " after the rule's offset of −25.46"
            >>> replace(r, at=LISTENER).band_words()
            ' at the farthest listener (25.5 dB less than at your microphone)'
        """
        return band_words(self.offset, self.at)

    def shift_words(self, measured: float) -> str:
        """How a judged value came from the ``measured`` one, after the judged value in a
        reason: "" with no offset.

        Example:
            >>> r = Rule("speech_volume", Check.MIN, low=60, offset=-25.46, unit="dB SPL")
            >>> r.shift_words(73.21)
            " after the rule's offset of −25.46 (73.21 measured)"
            >>> replace(r, at=LISTENER).shift_words(73.21)
            ' at the farthest listener (73.21 at the microphone − 25.5 dB)'
        """
        if not self.offset:
            return ""
        if self.at == LISTENER:
            sign = "−" if self.offset < 0 else "+"
            return (
                f" at the farthest listener ({measured:.4g} at the microphone {sign} "
                f"{abs(self.offset):.1f} dB)"
            )
        return f" after the rule's offset of {signed(self.offset)} ({measured:.4g} measured)"

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"metric": self.metric, "check": self.check.value}
        for f in fields(self):
            if f.name in ("metric", "check", "source"):
                continue
            if f.name == "offset" and self.at:
                continue  # said by ``at``, which the room resolves to the same number
            v = getattr(self, f.name)
            if f.name == "stream" and v == f"{self.metric}.txt":
                continue
            if f.name == "physical_range" and v is not None:
                d["range"] = list(v)  # the key of both front ends
            elif v is not None and v != f.default:
                d[f.name] = v
        return d


@dataclass(frozen=True)
class RoomProfile:
    """The room: named values for rules (``ANGLE``) and distances for the volume estimate.

    Attributes:
        name: a label.
        values: named values usable in rules, e.g. ``{"ANGLE": -15.0}``.
        scales: deviation scales that go with named values, e.g. ``{"ANGLE": 10.0}``: a rule
            whose bound is that named value and that gives no ``scale`` of its own uses it (so
            the seed's ``cv_headGaze min ANGLE`` works although the bound is negative).
        laptop_distance_m: presenter → laptop microphone distance, where dB are measured.
        farthest_listener_m: presenter → farthest listener; None disables the estimate.
    """

    name: str = "default"
    values: Mapping[str, float] = field(default_factory=lambda: {"ANGLE": -15.0})
    scales: Mapping[str, float] = field(default_factory=lambda: {"ANGLE": 10.0})
    laptop_distance_m: float = 1.0
    farthest_listener_m: float | None = None

    def listener_offset_db(self) -> float:
        """Inverse-square law: level change from the laptop to the farthest listener (<= 0 dB).

        Example:
            >>> round(RoomProfile(laptop_distance_m=1.0, farthest_listener_m=2.0)
            ...       .listener_offset_db(), 2)
            -6.02
        """
        if self.farthest_listener_m is None:
            return 0.0
        return -20.0 * math.log10(self.farthest_listener_m / self.laptop_distance_m)

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "name": self.name,
            "values": dict(self.values),
            "scales": dict(self.scales),
            "laptop_distance_m": self.laptop_distance_m,
        }
        if self.farthest_listener_m is not None:
            d["farthest_listener_m"] = self.farthest_listener_m
        return d


#: Sane bounds of the settings (seconds unless said): a decision period of 1e-4 s would write
#: hundreds of megabytes a minute, one of 1e-300 never end; a day is longer than any talk.
DAY_S = 86400.0
#: Both the config file and a policy spec (``weighted:threshold=800``) hold values to these.
SETTING_BOUNDS: dict[str, tuple[float, float]] = {
    "threshold": (1e-3, 1e9),
    "decay_half_life_s": (0.1, DAY_S),
    "min_gap_s": (0.0, DAY_S),
    "refractory_s": (0.0, DAY_S),
    "stale_after_s": (0.1, DAY_S),
    "decision_period_s": (0.02, 10.0),
    "praise_after_s": (1.0, DAY_S),
    "allocated_s": (1.0, DAY_S),
    "overtime_repeat_s": (1.0, DAY_S),
}
#: Settings that may also be 0, meaning "off".
ZERO_IS_OFF = frozenset({"praise_after_s", "overtime_repeat_s"})


@dataclass(frozen=True)
class ProcessorSettings:
    """How weights grow, decay and fire, and how often cues may go.

    Attributes:
        threshold: a non-strict rule becomes a candidate when its weight reaches this
            (unit: %·s, i.e. deviation percent integrated over seconds).
        decay_half_life_s: while in range a weight halves every this many seconds.
        min_gap_s: quiet time between the end of one cue and the start of the next.
        refractory_s: after a metric is cued it cannot be cued again for this long.
        stale_after_s: default time after a metric's newest sample when it goes stale.
        decision_period_s: how often the coach asks the processor for a decision.
        praise_after_s: say the encouragement command after this long with every metric in
            range and no cue; 0 disables it.
        praise_command: the command used for encouragement.
    """

    threshold: float = 600.0
    decay_half_life_s: float = 8.0
    min_gap_s: float = 6.0
    refractory_s: float = 40.0
    stale_after_s: float = 6.0
    decision_period_s: float = 0.5
    praise_after_s: float = 150.0
    praise_command: str | None = "encourage"

    def to_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


@dataclass(frozen=True)
class TimeSettings:
    """Time used vs allocated.

    Attributes:
        allocated_s: time the presenter has; None disables time warnings.
        warn_at_s_left: give ``warn_command`` when this much time is left (each once).
        warn_command: the time-left command; the cue carries ``minutes_left``.
        overtime_command: given when the allocated time is over, then every ``overtime_repeat_s``.
        overtime_repeat_s: repeat period of the overtime cue (0: only once).
    """

    allocated_s: float | None = 600.0
    warn_at_s_left: tuple[float, ...] = (120.0, 60.0)
    warn_command: str = "timeLeft"
    overtime_command: str = "overtime"
    overtime_repeat_s: float = 60.0

    def to_dict(self) -> dict[str, Any]:
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d["warn_at_s_left"] = list(self.warn_at_s_left)
        return d


@dataclass(frozen=True)
class Config:
    """A whole configuration: rules plus settings. Both front ends build one of these."""

    rules: tuple[Rule, ...]
    processor: ProcessorSettings = ProcessorSettings()
    time: TimeSettings = TimeSettings()
    room: RoomProfile = RoomProfile()
    source: str = field(default="", compare=False)

    def rule(self, metric: str) -> Rule:
        """The rule for ``metric``; raises :class:`prezence.errors.UnknownName`."""
        for r in self.rules:
            if r.metric == metric:
                return r
        from prezence.errors import UnknownName

        raise UnknownName("metric", metric, [r.metric for r in self.rules])

    @property
    def metrics(self) -> tuple[str, ...]:
        return tuple(r.metric for r in self.rules)

    def value_ranges(self) -> dict[str, tuple[float, float]]:
        """Metric → the values its stream may hold (:attr:`Rule.value_range`), where known."""
        return {r.metric: vr for r in self.rules if (vr := r.value_range) is not None}

    def talk_commands(self) -> dict[str, list[str]]:
        """Every command a talk on this config can give, with what gives it: the rules'
        ``below``/``above`` commands (``rules.txt:10 (above= of speech_fillers)``), the praise,
        time warnings and overtime warning the coach gives by these settings, and the
        post-talk summary. A talk is refused when one has no gesture
        (:func:`prezence.feedback.gestures.check_command_gestures`)."""
        out: dict[str, list[str]] = {}

        def add(command: str | None, what: str) -> None:
            if command:
                out.setdefault(command, []).append(what)

        for r in self.rules:
            for side in ("below", "above"):
                where = r.source or self.source or "a rule"
                add(getattr(r, side), f"{where} ({side}= of {r.metric})")
        add(self.processor.praise_command, "the coach's praise")
        add(self.time.warn_command, "the coach's time warnings")
        add(self.time.overtime_command, "the coach's overtime warning")
        add("summary", "the robot's post-talk summary")
        return out

    def with_allocated(self, allocated_s: float | None) -> Config:
        """A copy with another allocated time."""
        return replace(self, time=replace(self.time, allocated_s=allocated_s))

    def to_dict(self) -> dict[str, Any]:
        """The TOML form as a dict (``format``, ``room``, ``processor``, ``time``, ``rules``)."""
        return {
            "format": FORMAT,
            "room": self.room.to_dict(),
            "processor": self.processor.to_dict(),
            "time": self.time.to_dict(),
            "rules": [r.to_dict() for r in self.rules],
        }
