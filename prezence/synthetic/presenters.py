"""Synthetic presenters: a scenario played as metric samples, reacting to the robot's cues.

A :class:`SyntheticPresenter` is driven by the runner's clock::

    presenter = SyntheticPresenter(scenario, config, seed=0)
    for now in ...:                       # the runner's ManualClock
        samples = presenter.advance(now)  # every sample with t in (previous now, now]
        for metric, text in presenter.garbage(now):   # lines to write as-is (tailer faults)
        ...
        presenter.on_cue(t, command, metric, params)   # when the robot starts a cue
    presenter.truth()                     # when each metric was really out of range

The value of a metric at time ``t`` is built in three layers:

1. the **script**: the baseline, then every episode in file order (step, ramp, hold, glance);
2. **reactions**: a cue pulls the scripted value a fraction ``size`` of the way to the band's
   *comfortable value* (see :func:`comfortable_values`) from ``start = t + delay`` for ``lasts_s``,
   then the pull fades linearly over ``drift_s``. The pull only acts while the script is on the
   wrong side of the comfortable value, so when the script itself comes back (the notes are put
   away) nothing overshoots. Overlapping pulls in one direction take the strongest;
3. **noise**: seeded Gaussian noise per sample, then clamping to the metric's physical range
   (:data:`PHYSICAL_RANGES`).

The noise-free value of layers 1–2 is :meth:`SyntheticPresenter.true_value`. Ground truth
(:meth:`SyntheticPresenter.truth`) is judged from it by the config's rule on a fixed grid of
:data:`TRUTH_STEP_S`, incrementally up to the presenter's current time, so it reflects the
reactions that really happened in the closed loop. A reaction never rewrites the past: it acts
only after the presenter's current time when it was scheduled.

Randomness: every metric has its own streams derived from ``(seed, crc32(metric name))``, and the
reactions have one more, so adding a metric changes no other metric's samples. Noise, dropouts
and garbage are drawn once at construction, which keeps :meth:`advance` cheap.

Presenter models (:class:`PresenterModel`, chosen with :func:`presenter_model` or the
``model`` argument):

- ``free``: the scenario as written; a cue costs nothing (the model of the first evaluations).
- ``cost``: a presenter who pays for every interruption (:class:`InterruptionCost`): while the
  robot performs a cue they pause and look at it, they may slip on another metric, repeated
  cues about one metric lose effect (habituation) and a correction fades sooner without
  follow-up. ``cost:0.5`` / ``cost:1.5`` scale every assumed number by that factor (the
  sensitivity analysis).
- ``+measured`` (e.g. ``cost+measured``): each metric's noise is the scenario's behavioural
  noise combined (root sum of squares) with the module's measured error
  (:data:`MEASURED_ERROR`).

The cost model draws from its own random stream, so a ``free`` presenter's samples and reactions
are exactly what they were before the cost model existed.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import zlib
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from prezence.config.model import Config, Direction, Rule
from prezence.errors import UnknownName
from prezence.feedback.commands import get_command
from prezence.metrics import METRICS
from prezence.samples import (
    GESTURES,
    HEAD_GAZE,
    SPEECH_ACCURACY,
    SPEECH_SPEED,
    SPEECH_VOLUME,
    Sample,
)
from prezence.synthetic.scenario import Episode, EpisodeKind, MetricScript, Scenario

log = logging.getLogger(__name__)

FloatArray = npt.NDArray[np.float64]

#: Values are clamped to these (low, high) after noise: no negative words per minute.
PHYSICAL_RANGES: Mapping[str, tuple[float, float]] = {
    m.name: m.physical_range for m in METRICS.values() if m.physical_range is not None
}

#: Ground truth is judged on this grid (seconds).
TRUTH_STEP_S = 0.1
_GRID_PER_S = 10  # 1 / TRUTH_STEP_S, as an integer so that grid times are exact multiples

#: For a two-sided band the comfortable value lies this fraction of the band's width inside it.
COMFORT_BAND_FRACTION = 0.25
#: For a one-sided rule it lies this many deviation scales inside the bound (66 dB for >= 60 dB
#: with a 6 dB scale; -5 deg for >= -15 deg with a 10 deg scale).
COMFORT_SCALES = 1.0

# The forms of a garbage line; the runner writes them where a sample would have gone. Each is
# invalid for the stream codec (not a number, not finite, too many fields, a word). A bare
# "<t>" would not do: the codec reads a single field as a bare "<value>" line, as the seed allows.
_GARBAGE_FORMS = ("{t:.3f} ???", "{t:.3f} nan", "{t:.3f} 1 2", "garbage")

_NOISE, _GARBAGE = 0, 1  # the two random streams of each metric
_REACTIONS_KEY = zlib.crc32(b"reactions")
_COST_KEY = zlib.crc32(b"interruption-cost")

#: One standard deviation of each module's measurement error, in the metric's unit, from the
#: figures measured on the shipped modules (README, "Measured"; docs/modules.md).
MEASURED_ERROR: Mapping[str, float] = {
    # per 30 s window within +-10 % of the truth in 96-100 % of windows (bench_speech --part
    # windows): +-10 % ~ 2 sigma, so sigma ~ 5 % of 160 wpm
    SPEECH_SPEED: 8.0,
    # a -6 / -12 dB gain step measured within 0.2 dB (tests/modules): sigma 0.2 dB
    SPEECH_VOLUME: 0.2,
    # clean speech scores 0.71-0.91 over 30 s windows (bench_speech --part clarity): the spread
    # of a constant quality, ~ +-2 sigma, so sigma ~ 0.05
    SPEECH_ACCURACY: 0.05,
    # head pitch after calibration within 2.4 deg over +-20 deg (tests/modules): ~ 2 sigma
    HEAD_GAZE: 1.2,
    # gesture bursts: 10 of 10 found (tests/modules); a missed or extra burst in a minute is
    # +-1 per minute, taken as 2 sigma (assumption: the test has only 10 bursts)
    GESTURES: 0.5,
}


@dataclass(frozen=True)
class InterruptionCost:
    """What a cue costs the synthetic presenter. Every number is a source or an *assumption*.

    Attributes:
        pause_s: the presenter stops talking while attending to the robot: speech speed falls
            for this long after the cue starts. Assumption 2.0 s, about the robot's phrase (its
            planned speech lasts 1.5-2.3 s, the gestures 2.7-3.3 s, in the cue records of a
            replay): dual-task interference, the speaker listens instead of speaking.
        pause_speed_drop: the fraction speech speed falls during the pause (assumption 0.5:
            half the words of those seconds, a pause with a few words over it).
        attend_s: the presenter looks at the robot for this long (assumption 2.5 s, a little
            shorter than a gesture).
        attend_gaze_deg: head pitch while looking at the robot (geometry, assumptions: eyes at
            1.6 m, the NAO's head at 0.5 m on a table or stand 2 m away: atan(1.1 / 2) ≈ 29°
            down, so -29°); a robot at eye level would cost nothing here.
        slip_probability: chance that attending to the robot makes another metric slip
            (assumption 0.3; "robot motion distracts in its own right", issue 14).
        slip_s: how long such a slip lasts (assumption 10 s).
        slip_scales: how far it slips, in deviation scales of that metric's rule, toward its
            nearer bound (assumption 0.5: half a scale, e.g. 3 dB quieter).
        habituation: each earlier cue about the same metric multiplies the chance and size
            of the reaction by this (assumption 0.75; habituation to repeated alerts and the
            guidance hypothesis, Winstein et al. 1994, frequent feedback helps less).
        fade: multiplies how long a correction is held before it drifts back (assumption
            0.6: without follow-up a correction fades sooner than the scenario's own figure).
    """

    pause_s: float = 2.0
    pause_speed_drop: float = 0.5
    attend_s: float = 2.5
    attend_gaze_deg: float = -29.0
    slip_probability: float = 0.3
    slip_s: float = 10.0
    slip_scales: float = 0.5
    habituation: float = 0.75
    fade: float = 0.6

    def scaled(self, k: float, only: str | None = None) -> InterruptionCost:
        """Every assumption (or ``only`` the named one) scaled by ``k``, for the sensitivity
        analysis: durations, sizes and probabilities by ``k`` (a probability capped at 1);
        habituation's *loss* per cue (1 - habituation) and fade's *loss* (1 - fade) by ``k``;
        the gaze pitch's distance below the band's bound (-15) by ``k``.

        Raises:
            ValueError: ``only`` is not a field.
        """
        names = [f.name for f in dataclasses.fields(self)]
        if only is not None and only not in names:
            raise ValueError(f"no cost assumption {only!r} (known: {', '.join(names)})")
        new = {
            "pause_s": self.pause_s * k,
            "pause_speed_drop": min(1.0, self.pause_speed_drop * k),
            "attend_s": self.attend_s * k,
            "attend_gaze_deg": -15.0 + (self.attend_gaze_deg + 15.0) * k,
            "slip_probability": min(1.0, self.slip_probability * k),
            "slip_s": self.slip_s * k,
            "slip_scales": self.slip_scales * k,
            "habituation": max(0.0, 1.0 - (1.0 - self.habituation) * k),
            "fade": max(0.0, 1.0 - (1.0 - self.fade) * k),
        }
        if only is not None:
            return dataclasses.replace(self, **{only: new[only]})
        return InterruptionCost(**new)


#: The largest factor ``cost:K`` / ``cost:NAME=K`` takes. At 4 every probability and every loss
#: per cue has reached its cap (pause speed drop at 2, fade at 2.5, slip chance at 3.3,
#: habituation at 4), so a larger K only lengthens pauses and slips and turns the gaze further
#: down: at 5 the presenter looks 85 deg down at the robot (-15 - 14 x 5) and pauses 10 s per cue;
#: from 5.4 on the gaze would point past straight down (-90 deg), a head no presenter has.
MAX_COST_FACTOR = 5.0


@dataclass(frozen=True)
class PresenterModel:
    """A synthetic presenter's model: what cues cost and how noisy the modules are."""

    name: str = "free"
    cost: InterruptionCost | None = None
    measured_noise: bool = False


def parse_presenter_model(spec: str) -> PresenterModel:
    """``free``, ``cost``, ``cost:K`` (every assumption × K) or ``cost:NAME=K`` (one
    assumption × K), each optionally ``+measured``.

    Raises:
        ValueError: an unknown model or a factor that is not a number from 0 to
            :data:`MAX_COST_FACTOR` (0 turns the assumptions off).

    Example:
        >>> m = parse_presenter_model("cost:1.5+measured")
        >>> (m.cost.pause_s, m.measured_noise)
        (3.0, True)
    """
    base, plus, extra = spec.partition("+")
    if plus and extra != "measured":
        raise ValueError(f"presenter model {spec!r}: only '+measured' may follow")
    kind, colon, factor = base.partition(":")
    if kind == "free" and not colon:
        cost = None
    elif kind == "cost":
        only, eq, raw = factor.rpartition("=")
        try:
            k = float(raw) if colon else 1.0
        except ValueError:
            raise ValueError(f"presenter model {spec!r}: {raw!r} is not a number") from None
        if not (math.isfinite(k) and 0 <= k <= MAX_COST_FACTOR):
            raise ValueError(
                f"presenter model {spec!r}: the factor must be from 0 to {MAX_COST_FACTOR:g}, "
                f"found {raw} (at {MAX_COST_FACTOR:g} the presenter already looks 85 deg down "
                "at the robot and pauses 10 s per cue)"
            )
        cost = InterruptionCost().scaled(k, only if eq else None)
    else:
        raise ValueError(
            f"presenter model {spec!r}: expected free, cost or cost:K, with optional +measured"
        )
    return PresenterModel(spec, cost, bool(plus))


_MODEL = PresenterModel()


@contextlib.contextmanager
def presenter_model(model: PresenterModel | str) -> Iterator[PresenterModel]:
    """Within the block, presenters built without a ``model`` use this one (the evaluation
    sets it around :func:`prezence.synthetic.runner.run_talk`)."""
    global _MODEL
    m = parse_presenter_model(model) if isinstance(model, str) else model
    old, _MODEL = _MODEL, m
    try:
        yield m
    finally:
        _MODEL = old


@dataclass(frozen=True)
class _Slip:
    """A temporary change of one metric caused by attending to the robot."""

    start: float
    end: float
    delta: float = 0.0  # added to the value
    to: float | None = None  # or: the value is at most (gaze) this while it lasts


@dataclass(frozen=True)
class GarbageLine:
    """A line a module wrote that is not a sample (a torn write, a stray print)."""

    metric: str
    t: float
    text: str


def comfortable_values(rule: Rule) -> tuple[float | None, float | None]:
    """Where a presenter who corrects a metric aims, in the metric's raw unit.

    Returns ``(raise_to, lower_to)``: the value aimed at after a "raise" command (the band's
    low side) and after a "lower" command (its high side); None where the rule has no such bound.
    A two-sided band puts them :data:`COMFORT_BAND_FRACTION` of its width inside each bound;
    a one-sided rule :data:`COMFORT_SCALES` deviation scales inside (a scale of 10 % of the bound
    when the rule has none: 0.55 for a clarity bound of 0.5). The rule's ``offset`` is undone,
    as the rule judges ``value + offset``.

    Example:
        >>> from prezence.config.model import Check
        >>> comfortable_values(Rule("speech_speed", Check.IN_RANGE, low=140, high=180))
        (150.0, 170.0)
        >>> comfortable_values(Rule("speech_volume", Check.MIN, low=60, scale=6))
        (66.0, None)
    """
    low, high = rule.low, rule.high
    raise_to: float | None = None
    lower_to: float | None = None
    if low is not None and high is not None:
        inset = COMFORT_BAND_FRACTION * (high - low)
        raise_to, lower_to = low + inset, high - inset
    elif low is not None:
        ref = rule.scale if rule.scale is not None else 0.1 * abs(low)
        raise_to = low + COMFORT_SCALES * ref
    elif high is not None:
        ref = rule.scale if rule.scale is not None else 0.1 * abs(high)
        lower_to = high - COMFORT_SCALES * ref
    return (
        None if raise_to is None else float(raise_to - rule.offset),
        None if lower_to is None else float(lower_to - rule.offset),
    )


@dataclass(frozen=True)
class _Pull:
    """One reaction: pull toward ``target`` by ``size`` from ``start``, fading from ``hold_end``."""

    start: float
    hold_end: float
    end: float
    size: float

    def weight(self, t: FloatArray) -> FloatArray:
        fade = self.end - self.hold_end
        tail = np.clip((self.end - t) / fade, 0.0, 1.0) if fade > 0 else np.zeros_like(t)
        w = np.where(t <= self.hold_end, 1.0, tail)
        # Strictly after the start: a reaction starting "now" leaves the value at now as it was.
        return np.where(t <= self.start, 0.0, w) * self.size


class _Script:
    """The noise-free scripted value of one metric (layer 1), vectorised over time."""

    def __init__(self, script: MetricScript, episodes: tuple[Episode, ...]) -> None:
        self.baseline = script.baseline
        self.episodes = episodes
        # A ramp starts from whatever the earlier layers give at its start.
        self.ramp_from: list[float] = []
        for i, e in enumerate(episodes):
            start = self._eval(np.array([e.at]), i)[0] if e.kind is EpisodeKind.RAMP else 0.0
            self.ramp_from.append(float(start))

    def _eval(self, t: FloatArray, n: int) -> FloatArray:
        v = np.full(t.shape, self.baseline, dtype=np.float64)
        for e, v0 in zip(self.episodes[:n], self.ramp_from, strict=False):
            if e.kind is EpisodeKind.STEP:
                v = np.where(t >= e.at, e.value, v)
                continue
            until = e.until if e.until is not None else math.inf  # the parser sets it
            if e.kind is EpisodeKind.RAMP:
                frac = np.clip((t - e.at) / (until - e.at), 0.0, 1.0)
                v = np.where(t >= e.at, v0 + frac * (e.value - v0), v)
            else:
                v = np.where((t >= e.at) & (t < until), e.value, v)
        return v

    def __call__(self, t: FloatArray) -> FloatArray:
        return self._eval(t, len(self.episodes))


@dataclass
class _Stream:
    """Pre-drawn sample times, noise and faults of one module, and how far it has been read."""

    times: FloatArray
    script: FloatArray
    noise: FloatArray
    writes: npt.NDArray[np.bool_]
    garbage_form: npt.NDArray[np.int64]  # -1: a sample; else an index into _GARBAGE_FORMS
    next_index: int = 0


@dataclass
class _TruthState:
    """Ground truth of one metric so far."""

    rule: Rule
    grid_script: FloatArray
    side: int = 0  # -1 below, 0 in range, +1 above, at the last grid point judged
    start: float = 0.0
    peak: float = 0.0


class SyntheticPresenter:
    """Plays a :class:`~prezence.synthetic.scenario.Scenario` as metric samples and reacts to cues.

    Args:
        scenario: the script, noise, faults and reactions.
        config: the rules (ideal bands) that reactions aim for and ground truth is judged by.
        seed: seeds noise, faults and reactions; the same scenario, config and seed give
            identical samples and truth for the same cues.
        model: the presenter model (see the module doc); None: the one set with
            :func:`presenter_model` (``free`` unless set).

    Raises:
        ValueError: a negative seed.
        TypeError: a seed that is not an integer.
    """

    def __init__(
        self,
        scenario: Scenario,
        config: Config,
        *,
        seed: int,
        model: PresenterModel | str | None = None,
    ) -> None:
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
            raise TypeError(f"seed must be an int, got {seed!r}")
        if seed < 0:
            raise ValueError(f"seed must not be negative, got {seed}")
        self.scenario = scenario
        self.config = config
        self.seed = int(seed)
        if model is None:
            model = _MODEL
        self.model = parse_presenter_model(model) if isinstance(model, str) else model
        self._cost_rng = np.random.default_rng(
            np.random.SeedSequence(self.seed, spawn_key=(_COST_KEY,))
        )
        self._slips: dict[str, list[_Slip]] = {}
        self._cued: dict[str, int] = {}  # cues so far about each metric (habituation)
        self.duration_s = scenario.duration_s
        self._now = -math.inf
        self._rules = {r.metric: r for r in config.rules}
        self._scripts: dict[str, _Script] = {}
        self._streams: dict[str, _Stream] = {}
        self._pulls: dict[tuple[str, int], list[_Pull]] = {}
        self._targets: dict[tuple[str, int], float] = {}
        self._garbage: list[GarbageLine] = []
        self._reaction_rng = np.random.default_rng(
            np.random.SeedSequence(self.seed, spawn_key=(_REACTIONS_KEY,))
        )
        #: One record per cue seen: what the presenter did about it (for logs and reports).
        self.reactions: list[dict[str, Any]] = []

        n_grid = int(math.floor(self.duration_s * _GRID_PER_S + 1e-9)) + 1
        grid = np.arange(n_grid, dtype=np.float64) / _GRID_PER_S
        self._grid_last = n_grid - 1
        self._truth_next = 0  # next grid index to judge
        self._truth: dict[str, _TruthState] = {}
        self._intervals: list[dict[str, Any]] = []

        for ms in scenario.metrics:
            episodes = tuple(e for e in scenario.episodes if e.metric == ms.metric)
            script = _Script(ms, episodes)
            self._scripts[ms.metric] = script
            self._streams[ms.metric] = self._make_stream(ms, script)
            rule = self._rules.get(ms.metric)
            if rule is not None:
                self._truth[ms.metric] = _TruthState(rule, script(grid))
                raise_to, lower_to = comfortable_values(rule)
                if raise_to is not None:
                    self._targets[(ms.metric, +1)] = raise_to
                if lower_to is not None:
                    self._targets[(ms.metric, -1)] = lower_to
            else:
                log.info("metric %s has no rule in the config: no truth, no reactions", ms.metric)

    # -- construction -------------------------------------------------------------------------

    def _make_stream(self, ms: MetricScript, script: _Script) -> _Stream:
        key = zlib.crc32(ms.metric.encode("utf-8"))
        n = int(math.floor((self.duration_s - ms.phase_s) * ms.rate_hz + 1e-9))
        times = ms.phase_s + np.arange(1, max(n, 0) + 1, dtype=np.float64) / ms.rate_hz
        noise_rng = np.random.default_rng(
            np.random.SeedSequence(self.seed, spawn_key=(key, _NOISE))
        )
        sigma = ms.noise
        if self.model.measured_noise:
            sigma = math.hypot(sigma, MEASURED_ERROR.get(ms.metric, 0.0))
        noise = noise_rng.standard_normal(times.shape) * sigma
        writes = np.ones(times.shape, dtype=bool)
        for w in ms.dropout:
            writes &= ~((times >= w.start) & (times < w.end))
        garbage_rng = np.random.default_rng(
            np.random.SeedSequence(self.seed, spawn_key=(key, _GARBAGE))
        )
        is_garbage = garbage_rng.random(times.shape) < ms.garbage
        forms = garbage_rng.integers(0, len(_GARBAGE_FORMS), size=times.shape)
        return _Stream(
            times=times,
            script=script(times),
            noise=noise,
            writes=writes,
            garbage_form=np.where(is_garbage, forms, -1).astype(np.int64),
        )

    # -- time -----------------------------------------------------------------------------------

    @property
    def now(self) -> float:
        """The latest time :meth:`advance` was called with (``-inf`` before the first call)."""
        return self._now

    @property
    def done(self) -> bool:
        """True once the clock has reached the end of the talk."""
        return self._now >= self.duration_s

    def advance(self, now: float) -> list[Sample]:
        """Move to ``now`` and return every sample with ``t`` in (previous now, now], by time.

        A sample that falls in a dropout is not written; one drawn as garbage is not returned
        but queued for :meth:`garbage`. Nothing is written after the end of the talk.

        Raises:
            ValueError: ``now`` is earlier than the previous call's or not finite.
        """
        if not math.isfinite(now):
            raise ValueError(f"now must be finite, got {now!r}")
        if now < self._now:
            raise ValueError(f"time cannot go backwards ({now!r} < {self._now!r})")
        out: list[Sample] = []
        for metric, st in self._streams.items():
            i0 = st.next_index
            i1 = int(np.searchsorted(st.times, now, side="right"))
            if i1 <= i0:
                continue
            st.next_index = i1
            ts = st.times[i0:i1]
            values = self._with_reactions(metric, ts, st.script[i0:i1]) + st.noise[i0:i1]
            lo, hi = PHYSICAL_RANGES.get(metric, (-math.inf, math.inf))
            values = np.clip(values, lo, hi)
            for t, v, ok, form in zip(
                ts.tolist(),
                values.tolist(),
                st.writes[i0:i1].tolist(),
                st.garbage_form[i0:i1].tolist(),
                strict=True,
            ):
                if not ok:
                    continue
                if form >= 0:
                    self._garbage.append(GarbageLine(metric, t, _GARBAGE_FORMS[form].format(t=t)))
                    continue
                out.append(Sample(metric, t, v))
        self._now = now
        out.sort(key=lambda s: s.t)  # stable: within one instant, metrics keep scenario order
        return out

    def garbage(self, now: float) -> list[tuple[str, str]]:
        """Garbage lines due by ``now`` (drawn during :meth:`advance`), once each, in time order.

        Returns:
            ``(metric, text)`` pairs: the runner writes ``text`` as one line of that module's
            file, where a sample would have gone, to exercise the tailer's error handling.
        """
        due = sorted((g for g in self._garbage if g.t <= now), key=lambda g: g.t)
        self._garbage = [g for g in self._garbage if g.t > now]
        return [(g.metric, g.text) for g in due]

    # -- reactions ------------------------------------------------------------------------------

    def on_cue(self, t: float, command: str, metric: str | None, params: Mapping[str, Any]) -> None:
        """The robot started a cue at ``t``: schedule the presenter's reaction (seeded).

        A corrective command pulls its metric toward the band (see the module docs); a neutral
        one (time left, encouragement) changes nothing. The reaction starts at ``t + delay`` but
        never before the presenter's current time, so samples and truth already produced stay
        valid. Four random numbers are drawn per cue whatever happens, so one cue's outcome does
        not shift the next one's.

        Args:
            t: when the cue started.
            command: the command (e.g. ``slowDown``).
            metric: the metric the cue is about; None lets the config's rules tell.
            params: the cue's parameters (not used by the built-in reactions).

        Raises:
            UnknownName: ``command`` is neither in the command table nor in the config's rules.
        """
        u = self._reaction_rng.random(4)
        rule = self._rules.get(metric) if metric is not None else None
        if rule is None and metric is None:
            rule = next((r for r in self.config.rules if command in (r.below, r.above)), None)
        if rule is not None and command == rule.below:
            sign = +1
        elif rule is not None and command == rule.above:
            sign = -1
        else:
            direction = get_command(command).direction
            sign = {Direction.RAISE: +1, Direction.LOWER: -1}.get(direction, 0)
        target_metric = rule.metric if rule is not None else metric
        reaction = self.scenario.reaction(command)
        record: dict[str, Any] = {
            "t": float(t),
            "command": command,
            "metric": target_metric,
            "reacted": False,
        }
        key = (target_metric or "", sign)
        cost = self.model.cost
        keep = 1.0
        fade = 1.0
        if cost is not None:
            self._pay(float(t), target_metric, cost, record)
            if target_metric is not None and sign != 0:
                seen = self._cued.get(target_metric, 0)
                self._cued[target_metric] = seen + 1
                keep = cost.habituation**seen
                record["habituation"] = round(keep, 4)
            fade = cost.fade
        if sign == 0 or target_metric not in self._scripts or key not in self._targets:
            record["why"] = "nothing to change"
        elif u[0] >= reaction.probability * keep:
            record["why"] = "ignored the cue"
        else:
            delay = _lerp(reaction.delay_s, u[1])
            size = _lerp(reaction.size, u[2]) * keep
            lasts = _lerp(reaction.lasts_s, u[3]) * fade
            start = max(float(t) + delay, self._now)
            pull = _Pull(start, start + lasts, start + lasts + reaction.drift_s, size)
            self._pulls.setdefault(key, []).append(pull)
            record.update(
                reacted=True,
                start=start,
                size=size,
                lasts_s=lasts,
                target=self._targets[key],
            )
        log.debug("cue %s at %.1f: %s", command, t, record)
        self.reactions.append(record)

    def _pay(
        self, t: float, cued: str | None, cost: InterruptionCost, record: dict[str, Any]
    ) -> None:
        """The interruption's cost: a pause, a look at the robot, maybe a slip elsewhere.

        Draws three numbers from the cost stream per cue whatever happens.
        """
        u = self._cost_rng.random(3)
        start = max(t, self._now)
        paid: list[str] = []
        speed = self._rules.get(SPEECH_SPEED)
        if speed is not None and SPEECH_SPEED in self._scripts and cost.pause_s > 0:
            ref = speed.low if speed.low is not None else (speed.high or 0.0)
            if speed.low is not None and speed.high is not None:
                ref = 0.5 * (speed.low + speed.high)
            drop = -cost.pause_speed_drop * ref
            self._slips.setdefault(SPEECH_SPEED, []).append(
                _Slip(start, start + cost.pause_s, delta=drop)
            )
            paid.append("pause")
        if HEAD_GAZE in self._scripts and cost.attend_s > 0:
            self._slips.setdefault(HEAD_GAZE, []).append(
                _Slip(start, start + cost.attend_s, to=cost.attend_gaze_deg)
            )
            paid.append("looked at the robot")
        others = [m for m in self._truth if m != cued]
        if others and u[0] < cost.slip_probability and cost.slip_s > 0:
            m = others[int(u[1] * len(others)) % len(others)]
            rule = self._rules[m]
            lo, hi = rule.low, rule.high
            ref_lo = rule.scale if rule.scale is not None else (abs(lo) * 0.1 if lo else 1.0)
            ref_hi = rule.scale if rule.scale is not None else (abs(hi) * 0.1 if hi else 1.0)
            if lo is not None and (hi is None or u[2] < 0.5):
                delta = -cost.slip_scales * ref_lo
            else:
                delta = cost.slip_scales * ref_hi
            self._slips.setdefault(m, []).append(_Slip(start, start + cost.slip_s, delta=delta))
            paid.append(f"slipped on {m}")
        record["cost"] = paid

    def _with_slips(self, metric: str, t: FloatArray, v: FloatArray) -> FloatArray:
        for s in self._slips.get(metric, ()):
            if s.start > t[-1] or s.end < t[0]:
                continue
            on = (t > s.start) & (t <= s.end)
            if s.to is not None:
                v = np.where(on, np.minimum(v, s.to), v)
            else:
                v = np.where(on, v + s.delta, v)
        return v

    def _with_reactions(self, metric: str, t: FloatArray, script: FloatArray) -> FloatArray:
        """Layer 2: the scripted values ``script`` at times ``t`` with every pull (and, for a
        presenter who pays for interruptions, every slip) applied."""
        out = self._with_reactions_only(metric, t, script)
        return self._with_slips(metric, t, out) if self._slips else out

    def _with_reactions_only(self, metric: str, t: FloatArray, script: FloatArray) -> FloatArray:
        out = script
        for sign in (+1, -1):
            pulls = self._pulls.get((metric, sign))
            if not pulls:
                continue
            f = np.zeros_like(t)
            for p in pulls:
                if p.start <= t[-1] and p.end >= t[0]:
                    f = np.maximum(f, p.weight(t))
            gap = self._targets[(metric, sign)] - script
            gap = np.maximum(gap, 0.0) if sign > 0 else np.minimum(gap, 0.0)
            out = out + f * gap
        return out

    # -- truth ----------------------------------------------------------------------------------

    def true_value(self, metric: str, t: float) -> float:
        """The noise-free value of ``metric`` at ``t``, with the reactions scheduled so far.

        Raises:
            UnknownName: the scenario has no such metric.
        """
        if metric not in self._scripts:
            raise UnknownName("metric", metric, self._scripts)
        ts = np.array([float(t)])
        return float(self._with_reactions(metric, ts, self._scripts[metric](ts))[0])

    def _judge_truth(self, now: float) -> None:
        last = min(int(math.floor(now * _GRID_PER_S + 1e-9)), self._grid_last)
        first = self._truth_next
        if last < first:
            return
        self._truth_next = last + 1
        ks = np.arange(first, last + 1)
        ts = ks / _GRID_PER_S
        for metric, st in self._truth.items():
            values = self._with_reactions(metric, ts, st.grid_script[first : last + 1])
            judged = values + st.rule.offset
            below = judged < st.rule.low if st.rule.low is not None else np.zeros(ts.shape, bool)
            above = judged > st.rule.high if st.rule.high is not None else np.zeros(ts.shape, bool)
            sides = np.where(below, -1, np.where(above, 1, 0))
            deviation = np.zeros(ts.shape)
            if st.rule.low is not None:
                ref = st.rule.scale if st.rule.scale is not None else st.rule.low
                deviation = np.where(below, 100.0 * (st.rule.low - judged) / ref, deviation)
            if st.rule.high is not None:
                ref = st.rule.scale if st.rule.scale is not None else st.rule.high
                deviation = np.where(above, 100.0 * (judged - st.rule.high) / ref, deviation)
            changes = np.flatnonzero(np.diff(np.concatenate(([st.side], sides)))).tolist()
            bounds = [0, *changes, len(ts)]
            for a, b in zip(bounds[:-1], bounds[1:], strict=True):
                if a == b:
                    continue
                side = int(sides[a])
                if side != st.side:
                    if st.side != 0:
                        self._close(metric, st, float(ts[a]))
                    st.side, st.start, st.peak = side, float(ts[a]), 0.0
                if side != 0:
                    st.peak = max(st.peak, float(deviation[a:b].max()))

    def _close(self, metric: str, st: _TruthState, end: float) -> None:
        self._intervals.append(_interval(metric, st, end))

    def truth(self) -> list[dict[str, Any]]:
        """When each metric's noise-free value was really out of its rule's range, so far.

        Judged incrementally, from where the last call stopped up to the current time, with
        the reactions as they happened: a reaction only changes values after the moment it was
        scheduled, so judging late gives exactly what judging at every :meth:`advance` would.

        Returns:
            Intervals ``{"metric", "start", "end", "side", "peak_deviation"}`` sorted by start;
            ``side`` is ``"below"`` or ``"above"``; ``end`` is when it came back in range (for one
            still open: the last grid time judged). Judged every :data:`TRUTH_STEP_S` seconds.
        """
        if math.isfinite(self._now):
            self._judge_truth(self._now)
        out = list(self._intervals)
        now = (self._truth_next - 1) / _GRID_PER_S
        for metric, st in self._truth.items():
            if st.side != 0 and self._truth_next > 0:
                out.append(_interval(metric, st, now))
        return sorted(out, key=lambda d: (d["start"], d["metric"]))


def _interval(metric: str, st: _TruthState, end: float) -> dict[str, Any]:
    return {
        "metric": metric,
        "start": st.start,
        "end": end,
        "side": "below" if st.side < 0 else "above",
        "peak_deviation": round(st.peak, 3),
    }


def _lerp(span: tuple[float, float], u: float) -> float:
    return span[0] + (span[1] - span[0]) * float(u)
