"""Scenario files: a synthetic presenter's script, its reactions to cues, and the cues expected.

A scenario is a TOML file in ``scenarios/`` (``format = 1``), read with :mod:`tomllib` into the
frozen dataclasses below. ``scenarios/README.md`` documents the format and every persona; in
short::

    format = 1
    name = "fast_talker"
    description = "Starts at a calm pace, then races from 3:00."
    duration_s = "10:00"          # talk length; times are seconds or "m:ss" / "h:mm:ss"
    allocated_s = "10:00"         # optional: overrides the config's allocated time
    seed = 0                      # the default seed

    [metrics.speech_speed]        # one table per module that writes
    baseline = 160.0              # the presenter's normal value
    noise = 5.0                   # std of seeded Gaussian noise per sample
    rate_hz = 1.0                 # how often the module writes
    dropout = [{ from = "4:00", to = "5:00" }]   # optional: the module writes nothing then
    garbage = 0.01                # optional: probability that a line is garbage

    [[episodes]]                  # applied in file order; a later one overrides an earlier one
    metric = "speech_speed"
    kind = "ramp"                 # step | ramp | hold | glance
    at = "3:00"
    until = "3:20"
    value = 215.0

    [reactions.default]           # how the presenter reacts to any cue...
    probability = 0.9
    delay_s = [1.0, 3.0]          # a number, or [low, high] drawn uniformly (seeded)
    size = 0.8                    # fraction of the way back to the band's comfortable value
    lasts_s = 60.0
    drift_s = 20.0                # then drifts back to the script over this long
    [reactions.lookUp]            # ...and to one command (unset keys come from default)
    probability = 0.0

    [expect]
    forbid = ["lookUp"]           # never allowed
    only = ["encourage"]          # optional: any other cue not expected below fails
    max_cues = 12
    [[expect.cues]]               # at least one such cue in the window
    command = "slowDown"
    metric = "speech_speed"       # optional
    after = "3:00"
    within_s = 45                 # or: before = "3:45"
    [[expect.none]]               # none of these in a window
    command = "lookUp"
    after = "4:07"
    before = "5:00"
    [[expect.order]]              # if `then` comes at all, `first` came before it
    first = "lookUp"
    then = "articulate"

Semantic errors name the file, the line (found by a scan of the text, as for configs) and the
key path, e.g. ``fast_talker.toml:31: episodes[1].at: expected a time such as "3:00" or 180,
got '3:7x'``. A baseline or an episode's value outside the metric's physical range
(:data:`prezence.metrics.METRICS`: 0–400 wpm…) is an error too: the presenter would be
clamped to the range without a word, and the talk would not be the one written.
"""

from __future__ import annotations

import enum
import logging
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from prezence.config.model import FORMAT
from prezence.errors import ConfigError, UnknownName, did_you_mean
from prezence.feedback.commands import load_commands
from prezence.metrics import METRICS, SYNTHETIC_METRICS
from prezence.session import MAX_TALK_S
from prezence.tomlio import loads_toml, locate, parse_keypath

log = logging.getLogger(__name__)

#: The scenario the demo runs when none is named.
DEFAULT_SCENARIO = "demo"

_TIME_RE = re.compile(r"^(?:(\d+):)?(\d+):(\d+(?:\.\d*)?)$")


# --------------------------------------------------------------------------------------------
# times


def parse_time(value: object) -> float:
    """Seconds from a number or a clock string (``"3:00"``, ``"1:10.5"``, ``"1:02:03"``, ``"90"``).

    Example:
        >>> parse_time("3:00")
        180.0
        >>> parse_time("1:10.5")
        70.5
        >>> parse_time(90)
        90.0
        >>> parse_time("1:00:00")
        3600.0

    Raises:
        ValueError: not a time, negative, not finite, or minutes/seconds of 60 or more.
    """
    if isinstance(value, bool) or not isinstance(value, int | float | str):
        raise ValueError(f'expected a time such as "3:00" or 180 (seconds), got {value!r}')
    if isinstance(value, str):
        text = value.strip()
        m = _TIME_RE.match(text)
        if m:
            hours, minutes, seconds = m.groups()
            if float(seconds) >= 60 or (hours is not None and int(minutes) >= 60):
                raise ValueError(f"minutes and seconds must be below 60 in {value!r}")
            v = int(hours or 0) * 3600.0 + int(minutes) * 60.0 + float(seconds)
        else:
            try:
                v = float(text)
            except ValueError:
                raise ValueError(
                    f'expected a time such as "3:00" or 180 (seconds), got {value!r}'
                ) from None
    else:
        v = float(value)
    if not math.isfinite(v) or v < 0:
        raise ValueError(f"a time must be finite and not negative, got {value!r}")
    return v


def format_time(seconds: float) -> str:
    """``m:ss`` (with tenths when not whole) for messages.

    Example:
        >>> format_time(180)
        '3:00'
        >>> format_time(70.5)
        '1:10.5'
        >>> format_time(float("inf"))
        'the end'
    """
    if math.isinf(seconds):
        return "the end"
    tenths = round(seconds * 10)
    minutes, rest = divmod(tenths, 600)
    secs, frac = divmod(rest, 10)
    return f"{minutes}:{secs:02d}" + (f".{frac}" if frac else "")


# --------------------------------------------------------------------------------------------
# the dataclasses


class EpisodeKind(enum.Enum):
    """How an episode changes a metric's scripted value.

    ``step``: ``value`` from ``at`` on. ``ramp``: linear from the value at ``at`` to ``value`` at
    ``until``, then stays. ``hold``: ``value`` from ``at`` to ``until``, then back to what it was.
    ``glance``: a hold given by its length, ``duration_s``.
    """

    STEP = "step"
    RAMP = "ramp"
    HOLD = "hold"
    GLANCE = "glance"


@dataclass(frozen=True)
class Window:
    """A time interval ``[start, end)`` in seconds since the talk began."""

    start: float
    end: float

    def to_dict(self) -> dict[str, Any]:
        return {"from": self.start, "to": self.end}


@dataclass(frozen=True)
class MetricScript:
    """How one module writes: the presenter's normal value, noise, rate and faults.

    Attributes:
        metric: the metric (module) name.
        baseline: the value when no episode applies.
        noise: standard deviation of the Gaussian noise added to each sample.
        rate_hz: samples per second the module writes.
        phase_s: time of the first sample minus one period (modules need not write in step).
        dropout: windows in which the module writes nothing (it looks stale).
        garbage: probability that a line is garbage instead of a sample.
    """

    metric: str
    baseline: float
    noise: float = 0.0
    rate_hz: float = 1.0
    phase_s: float = 0.0
    dropout: tuple[Window, ...] = ()
    garbage: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "baseline": self.baseline,
            "noise": self.noise,
            "rate_hz": self.rate_hz,
        }
        if self.phase_s:
            d["phase_s"] = self.phase_s
        if self.dropout:
            d["dropout"] = [w.to_dict() for w in self.dropout]
        if self.garbage:
            d["garbage"] = self.garbage
        return d


@dataclass(frozen=True)
class Episode:
    """One scripted change of a metric (see :class:`EpisodeKind`).

    Attributes:
        metric: the metric it changes.
        kind: step, ramp, hold or glance.
        at: when it starts (seconds).
        value: the value it goes to.
        until: when a ramp arrives or a hold/glance ends (None for a step).
    """

    metric: str
    kind: EpisodeKind
    at: float
    value: float
    until: float | None = None

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"metric": self.metric, "kind": self.kind.value, "at": self.at}
        if self.kind is EpisodeKind.GLANCE and self.until is not None:
            d["duration_s"] = self.until - self.at
        elif self.until is not None:
            d["until"] = self.until
        d["value"] = self.value
        return d


@dataclass(frozen=True)
class Reaction:
    """How the presenter reacts to a cue. Ranges ``(low, high)`` are drawn uniformly (seeded).

    Attributes:
        probability: chance that the presenter reacts at all.
        delay_s: time from the cue's start to the change.
        size: fraction of the way from the scripted value to the band's comfortable value.
        lasts_s: how long the change is held.
        drift_s: then the value drifts back to the script over this long.
    """

    probability: float = 0.9
    delay_s: tuple[float, float] = (1.0, 3.0)
    size: tuple[float, float] = (0.7, 0.9)
    lasts_s: tuple[float, float] = (45.0, 90.0)
    drift_s: float = 20.0

    def to_dict(self) -> dict[str, Any]:
        return {
            "probability": self.probability,
            "delay_s": list(self.delay_s),
            "size": list(self.size),
            "lasts_s": list(self.lasts_s),
            "drift_s": self.drift_s,
        }


@dataclass(frozen=True)
class ExpectedCue:
    """At least ``min_count`` (and at most ``max_count``) cues of ``command`` start in the window.

    Attributes:
        command: the command.
        metric: when set, the cue must name this metric.
        after: window start (seconds, inclusive).
        before: window end (seconds, inclusive; ``inf`` for the end of the talk).
        min_count: at least this many.
        max_count: at most this many (None: no limit).
    """

    command: str
    metric: str | None = None
    after: float = 0.0
    before: float = math.inf
    min_count: int = 1
    max_count: int | None = None

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"command": self.command}
        if self.metric is not None:
            d["metric"] = self.metric
        d["after"] = self.after
        if not math.isinf(self.before):
            d["before"] = self.before
        if self.min_count != 1:
            d["min_count"] = self.min_count
        if self.max_count is not None:
            d["max_count"] = self.max_count
        return d

    def describe(self) -> str:
        what = self.command + (f" ({self.metric})" if self.metric else "")
        return f"{what} between {format_time(self.after)} and {format_time(self.before)}"


@dataclass(frozen=True)
class Forbidden:
    """No cue of ``command`` may start in ``[after, before]``."""

    command: str
    after: float = 0.0
    before: float = math.inf

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {"command": self.command, "after": self.after}
        if not math.isinf(self.before):
            d["before"] = self.before
        return d


@dataclass(frozen=True)
class Order:
    """If any ``then`` cue comes, a ``first`` cue came before the first of them."""

    first: str
    then: str

    def to_dict(self) -> dict[str, Any]:
        return {"first": self.first, "then": self.then}


@dataclass(frozen=True)
class Expectations:
    """What a headless run of the scenario must show (checked by :func:`check_expectations`).

    Attributes:
        cues: cues that must come, each in its window.
        forbidden: cues that must not come (whole talk or a window).
        order: ordering constraints.
        only: when set, every cue must be one of these commands or an expected cue's command.
        max_cues: at most this many cues in all.
    """

    cues: tuple[ExpectedCue, ...] = ()
    forbidden: tuple[Forbidden, ...] = ()
    order: tuple[Order, ...] = ()
    only: tuple[str, ...] | None = None
    max_cues: int | None = None

    def to_dict(self) -> dict[str, Any]:
        whole = [f.command for f in self.forbidden if f.after == 0 and math.isinf(f.before)]
        windows = [f for f in self.forbidden if not (f.after == 0 and math.isinf(f.before))]
        d: dict[str, Any] = {}
        if whole:
            d["forbid"] = whole
        if self.only is not None:
            d["only"] = list(self.only)
        if self.max_cues is not None:
            d["max_cues"] = self.max_cues
        if self.cues:
            d["cues"] = [c.to_dict() for c in self.cues]
        if windows:
            d["none"] = [f.to_dict() for f in windows]
        if self.order:
            d["order"] = [o.to_dict() for o in self.order]
        return d


@dataclass(frozen=True)
class Scenario:
    """A synthetic presenter: a script per metric, reactions to cues, and expectations.

    Attributes:
        name: the persona (the file stem by default).
        description: what happens, for people.
        duration_s: how long the talk lasts.
        allocated_s: the time the presenter has; None keeps the config's.
        seed: the default seed.
        metrics: one script per module that writes.
        episodes: scripted changes, applied in order (a later one overrides an earlier one).
        reactions: per command, plus ``"default"`` for every other command.
        expect: what a run must show.
        source: the file it came from; not part of equality.
    """

    name: str
    description: str
    duration_s: float
    metrics: tuple[MetricScript, ...]
    allocated_s: float | None = None
    seed: int = 0
    episodes: tuple[Episode, ...] = ()
    reactions: Mapping[str, Reaction] = field(default_factory=lambda: {"default": Reaction()})
    expect: Expectations = Expectations()
    source: str = field(default="", compare=False)

    def metric(self, name: str) -> MetricScript:
        """The script of metric ``name``; raises :class:`UnknownName`."""
        for m in self.metrics:
            if m.metric == name:
                return m
        raise UnknownName("metric", name, [m.metric for m in self.metrics])

    def reaction(self, command: str) -> Reaction:
        """How the presenter reacts to ``command`` (its own entry, else the default)."""
        return self.reactions.get(command) or self.reactions.get("default") or Reaction()

    def to_dict(self) -> dict[str, Any]:
        """The TOML form as a dict; :meth:`from_dict` of it gives an equal scenario."""
        d: dict[str, Any] = {
            "format": FORMAT,
            "name": self.name,
            "description": self.description,
            "duration_s": self.duration_s,
        }
        if self.allocated_s is not None:
            d["allocated_s"] = self.allocated_s
        d["seed"] = self.seed
        d["metrics"] = {m.metric: m.to_dict() for m in self.metrics}
        if self.episodes:
            d["episodes"] = [e.to_dict() for e in self.episodes]
        d["reactions"] = {k: r.to_dict() for k, r in self.reactions.items()}
        expect = self.expect.to_dict()
        if expect:
            d["expect"] = expect
        return d

    @classmethod
    def from_dict(
        cls, doc: Mapping[str, Any], *, path: str | Path = "<dict>", text: str = ""
    ) -> Scenario:
        """Build and validate a scenario from its TOML form.

        Args:
            doc: the parsed TOML.
            path: the file, named in errors.
            text: the file's text, where errors find their line (none when empty).

        Raises:
            ConfigError: naming ``path``, the line and the key path of the first problem.
        """
        return _Parser(str(path), text).scenario(doc)


# --------------------------------------------------------------------------------------------
# parsing


_TOP_KEYS = (
    "format",
    "name",
    "description",
    "duration_s",
    "allocated_s",
    "seed",
    "metrics",
    "episodes",
    "reactions",
    "expect",
)
_METRIC_KEYS = ("baseline", "noise", "rate_hz", "phase_s", "dropout", "garbage")
_EPISODE_KEYS = ("metric", "kind", "at", "until", "duration_s", "value")
_REACTION_KEYS = ("probability", "delay_s", "size", "lasts_s", "drift_s")
_EXPECT_KEYS = ("cues", "forbid", "none", "order", "only", "max_cues")
_CUE_KEYS = ("command", "metric", "after", "before", "within_s", "min_count", "max_count")
_NONE_KEYS = ("command", "after", "before", "within_s")
_MAX_RATE_HZ = 100.0


class _Parser:
    """Reads one scenario document; every error names the file and the key path."""

    def __init__(self, path: str, text: str = "") -> None:
        self.path = path
        self.text = text
        self.metric_names: tuple[str, ...] = ()

    # -- helpers --------------------------------------------------------------------------

    def error(self, key: str, message: str) -> ConfigError:
        line = locate(self.text, parse_keypath(key)) if self.text and key else None
        return ConfigError(message, path=self.path, line=line, key=key or None)

    def physical(self, value: float, metric: str, key: str) -> float:
        """``value`` if ``metric`` can take it; else an error naming the range."""
        rec = METRICS[metric]
        assert rec.physical_range is not None  # SYNTHETIC_METRICS have one
        lo, hi = rec.physical_range
        if not lo <= value <= hi:
            unit = f" {rec.shown_unit}" if rec.shown_unit else ""
            raise self.error(
                key,
                f"{metric} is {lo:g}..{hi:g}{unit} (physical range); {value:g} is outside it "
                "(the presenter would be held at the edge)",
            )
        return value

    def table(self, value: object, key: str, allowed: Sequence[str]) -> Mapping[str, Any]:
        if not isinstance(value, Mapping):
            raise self.error(key, f"expected a table, got {type(value).__name__}")
        for k in value:
            if k not in allowed:
                raise self.error(
                    f"{key}.{k}" if key else k,
                    f"unknown key '{k}'{did_you_mean(k, allowed)}; known: {', '.join(allowed)}",
                )
        return value

    def array(self, value: object, key: str) -> Sequence[Any]:
        if isinstance(value, str) or not isinstance(value, Sequence):
            raise self.error(key, f"expected an array, got {type(value).__name__}")
        return value

    def number(
        self,
        value: object,
        key: str,
        *,
        low: float = -math.inf,
        high: float = math.inf,
        low_open: bool = False,
    ) -> float:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(key, f"expected a number, got {value!r}")
        v = float(value)
        bad_low = v <= low if low_open else v < low
        if not math.isfinite(v) or bad_low or v > high:
            lo = "above" if low_open else "at least"
            if math.isinf(high):
                want = f"{lo} {low:g}" if math.isfinite(low) else "finite"
            else:
                want = f"{lo} {low:g} and at most {high:g}"
            raise self.error(key, f"must be {want}, got {value!r}")
        return v

    def integer(self, value: object, key: str, *, low: int = 0) -> int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(key, f"expected an integer, got {value!r}")
        if value < low:
            raise self.error(key, f"must be at least {low}, got {value}")
        return value

    def string(self, value: object, key: str) -> str:
        if not isinstance(value, str):
            raise self.error(key, f"expected a string, got {value!r}")
        return value

    def time(self, value: object, key: str) -> float:
        try:
            return parse_time(value)
        except ValueError as e:
            raise self.error(key, str(e)) from None

    def span(
        self, value: object, key: str, *, low: float = 0.0, high: float = math.inf
    ) -> tuple[float, float]:
        """A number or ``[low, high]``."""
        if isinstance(value, list | tuple):
            if len(value) != 2:
                raise self.error(key, f"expected a number or [low, high], got {value!r}")
            a = self.number(value[0], f"{key}[0]", low=low, high=high)
            b = self.number(value[1], f"{key}[1]", low=low, high=high)
            if a > b:
                raise self.error(key, f"low must not exceed high in {value!r}")
            return (a, b)
        v = self.number(value, key, low=low, high=high)
        return (v, v)

    def command(self, value: object, key: str) -> str:
        name = self.string(value, key)
        known = load_commands()
        if name not in known:
            raise self.error(key, str(UnknownName("command", name, known)))
        return name

    def metric(self, value: object, key: str) -> str:
        name = self.string(value, key)
        if name not in self.metric_names:
            known = self.metric_names
            raise self.error(
                key,
                f"unknown metric '{name}'{did_you_mean(name, known)}; "
                f"the scenario's [metrics] define: {', '.join(known) or 'none'}",
            )
        return name

    def window(self, d: Mapping[str, Any], key: str, duration: float) -> tuple[float, float]:
        after = self.time(d.get("after", 0.0), f"{key}.after")
        if "before" in d and "within_s" in d:
            raise self.error(key, "give either 'before' or 'within_s', not both")
        if "within_s" in d:
            before = after + self.number(d["within_s"], f"{key}.within_s", low=0.0)
        elif "before" in d:
            before = self.time(d["before"], f"{key}.before")
            if before < after:
                raise self.error(f"{key}.before", "the window ends before it starts")
        else:
            before = math.inf
        if after > duration:
            raise self.error(
                f"{key}.after", f"is after the end of the talk ({format_time(duration)})"
            )
        return after, before

    # -- sections -------------------------------------------------------------------------

    def scenario(self, doc: Mapping[str, Any]) -> Scenario:
        doc = self.table(doc, "", _TOP_KEYS)
        if doc.get("format") != FORMAT:
            raise self.error("format", f"expected format = {FORMAT}, found {doc.get('format')!r}")
        default_name = Path(self.path).stem if self.path.endswith(".toml") else ""
        name = self.string(doc.get("name", default_name), "name")
        if not name:
            raise self.error("name", "a scenario needs a name")
        if "description" not in doc:
            raise self.error("description", "missing: say what the presenter does")
        description = self.string(doc["description"], "description").strip()
        if "duration_s" not in doc:
            raise self.error("duration_s", "missing: how long the talk lasts")
        duration = self.time(doc["duration_s"], "duration_s")
        if duration <= 0:
            raise self.error("duration_s", "must be above 0")
        if duration > MAX_TALK_S:  # a typo's 1e12 s would be terabytes of samples
            raise self.error("duration_s", f"at most {MAX_TALK_S:g} s (6 hours)")
        allocated = None
        if "allocated_s" in doc:
            allocated = self.time(doc["allocated_s"], "allocated_s")
            if allocated <= 0:
                raise self.error("allocated_s", "must be above 0")
        seed = self.integer(doc.get("seed", 0), "seed")
        if "metrics" not in doc:
            raise self.error("metrics", "missing: at least one [metrics.<name>] table")
        metrics = self.metrics(doc["metrics"], duration)
        episodes = tuple(
            self.episode(e, f"episodes[{i}]", duration)
            for i, e in enumerate(self.array(doc.get("episodes", []), "episodes"))
        )
        reactions = self.reactions(doc.get("reactions", {}))
        expect = self.expect(doc.get("expect", {}), duration)
        return Scenario(
            name=name,
            description=description,
            duration_s=duration,
            allocated_s=allocated,
            seed=seed,
            metrics=metrics,
            episodes=episodes,
            reactions=reactions,
            expect=expect,
            source=self.path,
        )

    def metrics(self, value: object, duration: float) -> tuple[MetricScript, ...]:
        if not isinstance(value, Mapping):
            raise self.error("metrics", f"expected a table, got {type(value).__name__}")
        table = value
        if not table:
            raise self.error("metrics", "define at least one metric")
        out = []
        for name, entry in table.items():
            key = f"metrics.{name}"
            if name not in SYNTHETIC_METRICS:
                raise self.error(
                    key,
                    f"unknown metric '{name}'{did_you_mean(name, SYNTHETIC_METRICS)}; "
                    f"known: {', '.join(SYNTHETIC_METRICS)}",
                )
            d = self.table(entry, key, _METRIC_KEYS)
            if "baseline" not in d:
                raise self.error(f"{key}.baseline", "missing: the presenter's normal value")
            dropout = []
            for i, w in enumerate(self.array(d.get("dropout", []), f"{key}.dropout")):
                wkey = f"{key}.dropout[{i}]"
                w = self.table(w, wkey, ("from", "to"))
                if "from" not in w or "to" not in w:
                    raise self.error(wkey, "a dropout needs 'from' and 'to'")
                start = self.time(w["from"], f"{wkey}.from")
                end = self.time(w["to"], f"{wkey}.to")
                if end <= start:
                    raise self.error(f"{wkey}.to", "must be after 'from'")
                dropout.append(Window(start, end))
            out.append(
                MetricScript(
                    metric=name,
                    baseline=self.physical(
                        self.number(d["baseline"], f"{key}.baseline"), name, f"{key}.baseline"
                    ),
                    noise=self.number(d.get("noise", 0.0), f"{key}.noise", low=0.0),
                    rate_hz=self.number(
                        d.get("rate_hz", 1.0),
                        f"{key}.rate_hz",
                        low=0.0,
                        high=_MAX_RATE_HZ,
                        low_open=True,
                    ),
                    phase_s=self.number(d.get("phase_s", 0.0), f"{key}.phase_s", low=0.0),
                    dropout=tuple(dropout),
                    garbage=self.number(d.get("garbage", 0.0), f"{key}.garbage", low=0.0, high=1.0),
                )
            )
        self.metric_names = tuple(m.metric for m in out)
        return tuple(out)

    def episode(self, value: object, key: str, duration: float) -> Episode:
        d = self.table(value, key, _EPISODE_KEYS)
        for required in ("metric", "kind", "at", "value"):
            if required not in d:
                raise self.error(f"{key}.{required}", "missing")
        metric = self.metric(d["metric"], f"{key}.metric")
        kinds = [k.value for k in EpisodeKind]
        kind_name = self.string(d["kind"], f"{key}.kind")
        if kind_name not in kinds:
            raise self.error(f"{key}.kind", str(UnknownName("episode kind", kind_name, kinds)))
        kind = EpisodeKind(kind_name)
        at = self.time(d["at"], f"{key}.at")
        if at >= duration:
            raise self.error(
                f"{key}.at", f"is not before the end of the talk ({format_time(duration)})"
            )
        value_ = self.physical(self.number(d["value"], f"{key}.value"), metric, f"{key}.value")
        until: float | None = None
        if kind is EpisodeKind.STEP:
            for k in ("until", "duration_s"):
                if k in d:
                    raise self.error(f"{key}.{k}", 'a step has no end; use kind = "hold"')
        elif kind is EpisodeKind.GLANCE:
            if "until" in d:
                raise self.error(f"{key}.until", "a glance takes duration_s")
            if "duration_s" not in d:
                raise self.error(f"{key}.duration_s", "missing: how long the glance lasts")
            until = at + self.number(d["duration_s"], f"{key}.duration_s", low=0.0, low_open=True)
        else:
            if "duration_s" in d:
                raise self.error(f"{key}.duration_s", f"a {kind.value} takes 'until'")
            if "until" not in d:
                raise self.error(f"{key}.until", f"missing: when the {kind.value} ends")
            until = self.time(d["until"], f"{key}.until")
            if until <= at:
                raise self.error(f"{key}.until", "must be after 'at'")
        return Episode(metric=metric, kind=kind, at=at, value=value_, until=until)

    def reaction(self, value: object, key: str, base: Reaction) -> Reaction:
        d = self.table(value, key, _REACTION_KEYS)
        return Reaction(
            probability=(
                self.number(d["probability"], f"{key}.probability", low=0.0, high=1.0)
                if "probability" in d
                else base.probability
            ),
            delay_s=self.span(d["delay_s"], f"{key}.delay_s") if "delay_s" in d else base.delay_s,
            size=self.span(d["size"], f"{key}.size", high=1.0) if "size" in d else base.size,
            lasts_s=self.span(d["lasts_s"], f"{key}.lasts_s") if "lasts_s" in d else base.lasts_s,
            drift_s=(
                self.number(d["drift_s"], f"{key}.drift_s", low=0.0)
                if "drift_s" in d
                else base.drift_s
            ),
        )

    def reactions(self, value: object) -> dict[str, Reaction]:
        known = ["default", *load_commands()]
        table = self.table(value, "reactions", known)
        default = self.reaction(table.get("default", {}), "reactions.default", Reaction())
        out = {"default": default}
        for name, entry in table.items():
            if name != "default":
                out[name] = self.reaction(entry, f"reactions.{name}", default)
        return out

    def expect(self, value: object, duration: float) -> Expectations:
        d = self.table(value, "expect", _EXPECT_KEYS)
        cues = []
        for i, c in enumerate(self.array(d.get("cues", []), "expect.cues")):
            key = f"expect.cues[{i}]"
            c = self.table(c, key, _CUE_KEYS)
            if "command" not in c:
                raise self.error(f"{key}.command", "missing")
            after, before = self.window(c, key, duration)
            min_count = self.integer(c.get("min_count", 1), f"{key}.min_count")
            max_count = None
            if "max_count" in c:
                max_count = self.integer(c["max_count"], f"{key}.max_count")
                if max_count < min_count:
                    raise self.error(f"{key}.max_count", "must not be below min_count")
            cues.append(
                ExpectedCue(
                    command=self.command(c["command"], f"{key}.command"),
                    metric=self.metric(c["metric"], f"{key}.metric") if "metric" in c else None,
                    after=after,
                    before=before,
                    min_count=min_count,
                    max_count=max_count,
                )
            )
        forbidden = [
            Forbidden(self.command(c, f"expect.forbid[{i}]"))
            for i, c in enumerate(self.array(d.get("forbid", []), "expect.forbid"))
        ]
        for i, n in enumerate(self.array(d.get("none", []), "expect.none")):
            key = f"expect.none[{i}]"
            n = self.table(n, key, _NONE_KEYS)
            if "command" not in n:
                raise self.error(f"{key}.command", "missing")
            after, before = self.window(n, key, duration)
            forbidden.append(Forbidden(self.command(n["command"], f"{key}.command"), after, before))
        order = []
        for i, o in enumerate(self.array(d.get("order", []), "expect.order")):
            key = f"expect.order[{i}]"
            o = self.table(o, key, ("first", "then"))
            for required in ("first", "then"):
                if required not in o:
                    raise self.error(f"{key}.{required}", "missing")
            order.append(
                Order(
                    self.command(o["first"], f"{key}.first"), self.command(o["then"], f"{key}.then")
                )
            )
        only = None
        if "only" in d:
            only = tuple(
                self.command(c, f"expect.only[{i}]")
                for i, c in enumerate(self.array(d["only"], "expect.only"))
            )
        max_cues = self.integer(d["max_cues"], "expect.max_cues") if "max_cues" in d else None
        expectations = Expectations(tuple(cues), tuple(forbidden), tuple(order), only, max_cues)
        for i, c in enumerate(expectations.cues):
            for f in expectations.forbidden:
                if f.command == c.command and f.after <= c.after and c.before <= f.before:
                    raise self.error(
                        f"expect.cues[{i}]", f"{c.command} is both expected and forbidden there"
                    )
        return expectations


# --------------------------------------------------------------------------------------------
# files


def scenarios_dir() -> Path:
    """The folder of the built-in scenarios (see :func:`prezence.resources.scenarios_dir`)."""
    from prezence.resources import scenarios_dir as _resources_scenarios_dir

    return Path(_resources_scenarios_dir())


def list_scenarios() -> list[str]:
    """Names of the built-in scenarios, sorted."""
    folder = scenarios_dir()
    return sorted(p.stem for p in folder.glob("*.toml")) if folder.is_dir() else []


def read_scenario(path: str | Path) -> Scenario:
    """Load a scenario file.

    Raises:
        ConfigError: missing file, TOML syntax (with line and column) or bad content (key path).
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError("no such scenario file", path=path) from None
    doc = loads_toml(text, path=path)
    return Scenario.from_dict(doc, path=path, text=text)


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Load a built-in scenario by name (``"fast_talker"``) or any scenario file by path.

    Raises:
        UnknownName: no built-in scenario has that name (with a did-you-mean).
        ConfigError: the file is invalid.
    """
    text = str(name_or_path)
    if isinstance(name_or_path, Path) or text.endswith(".toml") or "/" in text or "\\" in text:
        return read_scenario(name_or_path)
    path = scenarios_dir() / f"{text}.toml"
    if not path.is_file():
        raise UnknownName("scenario", text, list_scenarios())
    return read_scenario(path)


# --------------------------------------------------------------------------------------------
# expectations


def _when(cues: Iterable[Mapping[str, Any]]) -> str:
    times = [format_time(float(c["t"])) for c in cues]
    return ", ".join(times) if times else "none"


def check_expectations(scenario: Scenario, cues: Sequence[Mapping[str, Any]]) -> list[str]:
    """Compare the cues of a run with the scenario's expectations.

    Args:
        scenario: the scenario that ran.
        cues: the cues the robot performed, each with at least ``t`` (start time), ``command``
            and ``metric`` (None for cues about no metric).

    Returns:
        One readable sentence per failed expectation; empty when the run is as expected.

    Example:
        >>> wanted = ExpectedCue("slowDown", after=180, before=225)
        >>> s = Scenario("x", "", 600.0, (MetricScript("speech_speed", 160.0),),
        ...              expect=Expectations(cues=(wanted,)))
        >>> check_expectations(s, [{"t": 200.0, "command": "slowDown", "metric": "speech_speed"}])
        []
        >>> check_expectations(s, [])
        ['expected slowDown between 3:00 and 3:45, got none (slowDown at: none)']
    """
    exp = scenario.expect
    cues = sorted(cues, key=lambda c: float(c["t"]))
    failures: list[str] = []

    def of(command: str) -> list[Mapping[str, Any]]:
        return [c for c in cues if c["command"] == command]

    for e in exp.cues:
        same = [c for c in of(e.command) if e.metric is None or c.get("metric") == e.metric]
        inside = [c for c in same if e.after <= float(c["t"]) <= e.before]
        if len(inside) < e.min_count:
            got = f"got {len(inside)}" if inside else "got none"
            need = "" if e.min_count == 1 else f"at least {e.min_count}× "
            failures.append(f"expected {need}{e.describe()}, {got} ({e.command} at: {_when(same)})")
        if e.max_count is not None and len(inside) > e.max_count:
            failures.append(
                f"expected at most {e.max_count}× {e.describe()}, got {len(inside)} "
                f"(at {_when(inside)})"
            )
    for f in exp.forbidden:
        bad = [c for c in of(f.command) if f.after <= float(c["t"]) <= f.before]
        if bad:
            where = (
                "at any time"
                if f.after == 0 and math.isinf(f.before)
                else f"between {format_time(f.after)} and {format_time(f.before)}"
            )
            failures.append(f"{f.command} is forbidden {where}, but came at {_when(bad)}")
    for o in exp.order:
        then = of(o.then)
        if not then:
            continue
        first = of(o.first)
        if not first or float(first[0]["t"]) >= float(then[0]["t"]):
            failures.append(
                f"expected {o.first} before {o.then}, but {o.then} came first at "
                f"{format_time(float(then[0]['t']))} ({o.first} at: {_when(first)})"
            )
    if exp.only is not None:
        allowed = set(exp.only) | {e.command for e in exp.cues}
        extra = [c for c in cues if c["command"] not in allowed]
        if extra:
            listed = ", ".join(f"{c['command']} at {format_time(float(c['t']))}" for c in extra)
            failures.append(f"unexpected cues: {listed} (allowed: {', '.join(sorted(allowed))})")
    if exp.max_cues is not None and len(cues) > exp.max_cues:
        failures.append(
            f"expected at most {exp.max_cues} cues, got {len(cues)}: "
            + ", ".join(f"{c['command']} at {format_time(float(c['t']))}" for c in cues)
        )
    return failures
