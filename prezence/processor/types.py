"""Values the processor hands out: candidates, cues, decisions (frozen, JSON-ready)."""

from __future__ import annotations

import enum
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, NamedTuple


class Kind(enum.IntEnum):
    """Candidate classes. Lower wins first under the seed's policy: time, strict, weighted."""

    TIME = 0  # time-left warnings and overtime
    STRICT = 1  # a strict rule went out of range
    WEIGHTED = 2  # a non-strict rule's weight passed the threshold
    PRAISE = 3  # everything has gone well for a while


@dataclass(frozen=True, slots=True)
class Candidate:
    """A piece of feedback that could be given now.

    Attributes:
        kind: which class of candidate.
        command: the command to give.
        metric: the metric it corrects (None for time and praise).
        eligible: whether the seed's firing condition holds (strict pending, weight over the
            threshold, a time mark crossed). Simpler policies may ignore it.
        weight: the non-strict weight (%·s); for strict rules the peak deviation.
        deviation: current deviation in percent (0 for time and praise).
        value: the newest value of the metric, as judged (with the rule's ``offset`` added).
        offset: the rule's offset (0: none), so that the measured value is ``value - offset``.
        side: "below" or "above".
        onset: when the current problem began (sample time).
        recency: time of the newest sample behind this candidate (tie-break).
        params: command parameters (e.g. ``{"minutes": 2}``).
    """

    kind: Kind
    command: str
    metric: str | None
    eligible: bool
    weight: float = 0.0
    deviation: float = 0.0
    value: float | None = None
    side: str | None = None
    onset: float | None = None
    recency: float = 0.0
    params: dict[str, Any] = field(default_factory=dict)
    offset: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        d = {
            "kind": self.kind.name.lower(),
            "command": self.command,
            "metric": self.metric,
            "eligible": self.eligible,
            "weight": _logged(self.weight),
            "deviation": _logged(self.deviation),
            "value": self.value,
            "side": self.side,
            "onset": self.onset,
            "params": self.params,
        }
        if self.offset:  # only then: a talk without offsets logs as it always did
            d["offset"] = self.offset
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Candidate:
        """The candidate of a decision-log line (weights as logged: rounded; a time warning's
        infinite weight is logged as null and read back as infinity)."""
        return cls(
            kind=Kind[str(d["kind"]).upper()],
            command=str(d["command"]),
            metric=d.get("metric"),
            eligible=bool(d["eligible"]),
            weight=_num(d.get("weight")),
            deviation=_num(d.get("deviation")),
            value=d.get("value"),
            side=d.get("side"),
            onset=d.get("onset"),
            params=dict(d.get("params") or {}),
            offset=float(d.get("offset") or 0.0),
        )


def _num(x: Any) -> float:
    return math.inf if x is None else float(x)


def _logged(x: float) -> float | None:
    """A weight or deviation as logged: rounded; an infinite one (a time warning) as null,
    which standard JSON has and :func:`_num` reads back as infinity."""
    return round(x, 3) if x - x == 0.0 else None


@dataclass(frozen=True, slots=True)
class Cue:
    """The one piece of feedback chosen at time ``t``."""

    t: float
    command: str
    metric: str | None
    kind: Kind
    reason: str
    params: dict[str, Any] = field(default_factory=dict)
    onset: float | None = None
    deviation: float = 0.0
    weight: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "t": self.t,
            "command": self.command,
            "metric": self.metric,
            "kind": self.kind.name.lower(),
            "reason": self.reason,
            "params": self.params,
            "onset": self.onset,
            "deviation": _logged(self.deviation),
            "weight": _logged(self.weight),
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Cue:
        """A cue of ``cues.jsonl`` or of the decision log (extra keys, such as the phrase
        and the robot's timings, are ignored)."""
        return cls(
            t=float(d["t"]),
            command=str(d["command"]),
            metric=d.get("metric"),
            kind=Kind[str(d["kind"]).upper()],
            reason=str(d.get("reason", "")),
            params=dict(d.get("params") or {}),
            onset=d.get("onset"),
            deviation=_num(d.get("deviation", 0.0)),
            weight=_num(d.get("weight", 0.0)),
        )


@dataclass(frozen=True, slots=True)
class MetricView:
    """A metric's state at a decision point (for the decision log).

    ``value`` is as judged: with the rule's ``offset`` added (the measured value is ``value -
    offset``), so that it reads against the band.
    """

    metric: str
    value: float | None
    deviation: float
    weight: float
    stale: bool
    refractory: bool
    strict_pending: bool
    offset: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        d = {
            "metric": self.metric,
            "value": self.value,
            "deviation": _logged(self.deviation),
            "weight": _logged(self.weight),
            "stale": self.stale,
            "refractory": self.refractory,
            "strict_pending": self.strict_pending,
        }
        if self.offset:  # only then: a talk without offsets logs as it always did
            d["offset"] = self.offset
        return d

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> MetricView:
        return cls(
            metric=str(d["metric"]),
            value=d.get("value"),
            deviation=float(d["deviation"]),
            weight=float(d["weight"]),
            stale=bool(d["stale"]),
            refractory=bool(d["refractory"]),
            strict_pending=bool(d["strict_pending"]),
            offset=float(d.get("offset") or 0.0),
        )


class Decision(NamedTuple):
    """The outcome of one decision point: a cue or none, with the reason and the evidence.

    A named tuple, not a frozen dataclass like the other values here: one is made at every
    decision point (43,200 in a 6-hour replay), and a frozen dataclass's ``__init__`` took
    0.77 µs against 0.28 µs (timeit). Change a field with ``d._replace(...)``.
    """

    t: float
    cue: Cue | None
    reason: str
    busy: bool
    candidates: tuple[Candidate, ...] = ()
    metrics: tuple[MetricView, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        return {
            "t": round(self.t, 6),
            "busy": self.busy,
            "cue": self.cue.to_dict() if self.cue else None,
            "winner": self.cue.command if self.cue else None,
            "reason": self.reason,
            "candidates": [c.to_dict() for c in self.candidates],
            "metrics": [m.to_dict() for m in self.metrics],
        }

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> Decision:
        """A line of ``decisions.jsonl`` (an agent's cue line has no candidates or views)."""
        cue = d.get("cue")
        return cls(
            t=float(d["t"]),
            cue=Cue.from_dict(cue) if cue else None,
            reason=str(d.get("reason", "")),
            busy=bool(d.get("busy", False)),
            candidates=tuple(Candidate.from_dict(c) for c in d.get("candidates", ())),
            metrics=tuple(MetricView.from_dict(m) for m in d.get("metrics", ())),
        )
