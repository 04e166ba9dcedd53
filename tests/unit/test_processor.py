"""The seed's rules, one behaviour per test, driven tick by tick with explicit time."""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable

import pytest

from prezence.config.model import (
    Check,
    Config,
    ProcessorSettings,
    Rule,
    TimeSettings,
)
from prezence.processor import Kind, Processor, make_policy
from prezence.processor.types import Decision
from prezence.samples import Sample

SPEED = Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown")
GAZE = Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp")
CLARITY = Rule("speech_accuracy", Check.MIN, low=0.8, below="articulate")
STRICT_CLARITY = Rule("speech_accuracy", Check.MIN, low=0.8, strict=True, below="articulate")

NO_TIME = TimeSettings(allocated_s=None)


def make(
    *rules: Rule,
    policy: str = "weighted",
    time: TimeSettings = NO_TIME,
    **settings: float | str | None,
) -> Processor:
    base = {"praise_after_s": 0.0, "min_gap_s": 0.0, "refractory_s": 30.0}
    base.update(settings)
    cfg = Config(rules=rules, processor=ProcessorSettings(**base), time=time)  # type: ignore[arg-type]
    return Processor(cfg, policy=make_policy(policy))


Signal = Callable[[float], float]


def talk(
    p: Processor,
    signals: dict[str, Signal],
    *,
    until: float,
    dt: float = 0.5,
    rate_hz: dict[str, float] | None = None,
    busy: Callable[[float], bool] = lambda t: False,
) -> list[Decision]:
    """Feed each metric at its rate and decide every ``dt``; returns the decisions with cues."""
    rate_hz = rate_hz or {}
    next_t = {m: 0.0 for m in signals}
    out = []
    t = 0.0
    while t < until - 1e-9:
        t = round(t + dt, 9)
        batch: list[Sample] = []
        for m, f in signals.items():
            period = 1.0 / rate_hz.get(m, 2.0)
            while next_t[m] <= t + 1e-9:
                batch.append(Sample(m, next_t[m], f(next_t[m])))
                next_t[m] = round(next_t[m] + period, 9)
        d = p.step(t, batch, free_since=None if busy(t) else 0.0)
        if d.cue:
            out.append(d)
    return out


def cues(ds: Iterable[Decision]) -> list[tuple[float, str]]:
    return [(d.t, d.cue.command) for d in ds if d.cue]


def test_in_range_gives_no_cue() -> None:
    p = make(SPEED, GAZE)
    assert (
        cues(talk(p, {"speech_speed": lambda t: 160, "cv_headGaze": lambda t: 0}, until=300)) == []
    )


def test_non_strict_weight_grows_with_deviation_times_time() -> None:
    # 25 % above 180 wpm: without persistence the weight grows 25 %·s per second and fires at
    # threshold 600 → 24 s after the onset.
    p = make(SPEED, threshold=600, policy="weighted:persistence_s=0")
    ds = talk(p, {"speech_speed": lambda t: 225.0 if t >= 10 else 160.0}, until=60)
    assert cues(ds)[0][1] == "slowDown"
    assert cues(ds)[0][0] == pytest.approx(34.0, abs=0.6)


def test_persistence_delays_a_held_deviation_by_at_most_its_time_constant() -> None:
    # With persistence P(t) = 1 - exp(-t/tau) the weight is 25 (t - tau (1 - exp(-t/tau))):
    # it reaches 600 at t = 29.0 s for tau = 5 s (24 s plus almost one tau).
    p = make(SPEED, threshold=600, policy="weighted:persistence_s=5")
    ds = talk(p, {"speech_speed": lambda t: 225.0 if t >= 10 else 160.0}, until=60)
    tau, t = 5.0, 24.0
    for _ in range(50):
        t = 24.0 + tau * (1 - math.exp(-t / tau))
    assert cues(ds)[0][0] == pytest.approx(10.0 + t, abs=0.6)


def test_bigger_deviation_fires_sooner() -> None:
    first = {}
    for v in (198.0, 225.0, 270.0):
        p = make(SPEED)
        first[v] = cues(talk(p, {"speech_speed": lambda t, v=v: v}, until=200))[0][0]
    assert first[270.0] < first[225.0] < first[198.0]


def test_brief_glance_is_forgotten_but_reading_notes_wins() -> None:
    glance = make(GAZE)
    ds = talk(glance, {"cv_headGaze": lambda t: -40.0 if 70 <= t < 71.5 else 0.0}, until=200)
    assert cues(ds) == []
    reading = make(GAZE)
    ds = talk(reading, {"cv_headGaze": lambda t: -40.0 if 70 <= t < 190 else 0.0}, until=200)
    assert cues(ds)[0][1] == "lookUp"
    assert 70 < cues(ds)[0][0] < 80


def test_repeated_glances_decay_between_them() -> None:
    # A glance every 20 s: the weight halves every 8 s in between, so it never accumulates.
    p = make(GAZE)
    ds = talk(p, {"cv_headGaze": lambda t: -40.0 if (t % 20.0) < 1.5 else 0.0}, until=600)
    assert cues(ds) == []


def test_module_rate_does_not_change_when_it_fires() -> None:
    times = []
    for hz in (1.0, 2.0, 10.0):
        p = make(SPEED)
        ds = talk(
            p,
            {"speech_speed": lambda t: 225.0 if t >= 10 else 160.0},
            until=80,
            rate_hz={"speech_speed": hz},
        )
        times.append(cues(ds)[0][0])
    assert max(times) - min(times) <= 1.0


def test_strict_fires_at_first_free_moment_ahead_of_heavier_weight() -> None:
    p = make(SPEED, STRICT_CLARITY)
    sig = {
        "speech_speed": lambda t: 240.0,  # weight far above threshold by t=40
        "speech_accuracy": lambda t: 0.7 if 39.0 <= t < 39.5 else 0.9,  # out of range once
    }
    ds = talk(p, sig, until=60, busy=lambda t: t < 40.0)
    assert cues(ds)[0] == (40.0, "articulate")
    assert ds[0].cue.kind == Kind.STRICT
    assert cues(ds)[1][1] == "slowDown"


def test_report_conflict_long_reading_beats_slightly_low_clarity() -> None:
    # The seed's example: clarity slightly below 0.8 (most recent data), notes read for 2 min.
    p = make(CLARITY, GAZE)
    sig = {"speech_accuracy": lambda t: 0.77, "cv_headGaze": lambda t: -35.0 if t < 120 else 0.0}
    ds = talk(p, sig, until=10, busy=lambda t: t < 9.0)
    assert cues(ds)[0][1] == "lookUp"
    assert "beat articulate" in ds[0].cue.reason or ds[0].candidates[0].command == "lookUp"


def test_highest_weight_wins_and_ties_go_to_most_recent_data() -> None:
    p = make(SPEED, GAZE)
    sig = {"speech_speed": lambda t: 200.0, "cv_headGaze": lambda t: -30.0}
    ds = talk(p, sig, until=30, busy=lambda t: t < 29)
    assert cues(ds)[0][1] == "lookUp"  # 150 % deviation outweighs 11 %
    # equal weights: the metric with the newer sample wins
    rule_a = Rule("a", Check.MAX, high=10, above="slowDown")
    rule_b = Rule("b", Check.MAX, high=10, above="softer")
    p = make(rule_a, rule_b, stale_after_s=1000.0)
    p.ingest([Sample("a", 0.0, 20.0), Sample("b", 0.0, 20.0)])
    p.ingest([Sample("a", 99.0, 20.0), Sample("b", 99.5, 20.0)])
    d = p.step(100.0, free_since=0.0)
    assert d.cue is not None and d.cue.command == "softer"


def test_weight_resets_after_firing() -> None:
    p = make(SPEED, refractory_s=0.0)
    ds = talk(p, {"speech_speed": lambda t: 225.0}, until=60)
    assert [c for _, c in cues(ds)] == ["slowDown", "slowDown"]
    assert cues(ds)[1][0] - cues(ds)[0][0] == pytest.approx(24.0, abs=0.6)


def test_refractory_time_per_metric() -> None:
    p = make(SPEED, refractory_s=60.0)
    ds = talk(p, {"speech_speed": lambda t: 225.0}, until=100)
    t0, t1 = cues(ds)[0][0], cues(ds)[1][0]
    assert t1 - t0 >= 60.0


def test_min_gap_counts_from_when_the_robot_became_free() -> None:
    p = make(SPEED, GAZE, min_gap_s=10.0, stale_after_s=1000.0)
    p.ingest([Sample("speech_speed", 0.0, 300.0), Sample("cv_headGaze", 0.0, -40.0)])
    first = p.step(60.0, free_since=0.0)
    assert first.cue is not None
    assert p.step(62.0, free_since=None).reason == "robot busy"
    assert p.step(66.0, free_since=65.0).cue is None  # free for 1 s only
    assert p.step(75.5, free_since=65.0).cue is not None


def test_no_backlog_problem_that_ended_while_busy_is_not_cued() -> None:
    p = make(SPEED)
    # too fast while the robot is busy, back in range before it is free
    ds = talk(
        p, {"speech_speed": lambda t: 240.0 if t < 40 else 160.0}, until=60, busy=lambda t: t < 45
    )
    assert cues(ds) == []


def test_decision_uses_latest_data_when_robot_frees() -> None:
    p = make(SPEED, GAZE)
    sig = {
        "speech_speed": lambda t: 260.0 if t < 40 else 160.0,  # was the worst, now fixed
        "cv_headGaze": lambda t: -30.0 if t >= 30 else 0.0,  # current problem
    }
    ds = talk(p, sig, until=50, busy=lambda t: t < 45)
    assert cues(ds)[0] == (45.0, "lookUp")


def test_stale_metric_is_excluded_and_flagged() -> None:
    p = make(GAZE, stale_after_s=3.0)
    p.ingest([Sample("cv_headGaze", 0.0, -40.0)])
    d = p.step(30.0, free_since=0.0)  # no sample for 30 s: stale
    assert d.cue is None
    assert d.metrics[0].stale is True
    # weight accrued only while fresh (3 s × 250 %), then decayed
    assert p.weight("cv_headGaze", 30.0) < 750.0


def test_time_warnings_at_marks_then_overtime_repeats() -> None:
    ts = TimeSettings(allocated_s=300.0, warn_at_s_left=(120.0, 60.0), overtime_repeat_s=60.0)
    p = make(SPEED, time=ts)
    ds = talk(p, {"speech_speed": lambda t: 160.0}, until=430)
    got = [(t, c.cue.command, c.cue.params) for t, c in ((d.t, d) for d in ds)]
    assert got[0] == (180.0, "timeLeft", {"minutes": 2})
    assert got[1] == (240.0, "timeLeft", {"minutes": 1})
    assert [g[1] for g in got[2:]] == ["overtime", "overtime", "overtime"]
    assert got[2][0] == 300.5 and got[3][0] == 360.5


def test_superseded_time_mark_is_skipped_while_busy() -> None:
    ts = TimeSettings(allocated_s=300.0, warn_at_s_left=(120.0, 60.0))
    p = make(SPEED, time=ts)
    ds = talk(p, {"speech_speed": lambda t: 160.0}, until=290, busy=lambda t: 170 < t < 250)
    assert [(d.cue.command, d.cue.params.get("minutes")) for d in ds] == [("timeLeft", 1)]


def test_praise_after_a_long_good_stretch() -> None:
    p = make(SPEED, praise_after_s=60.0)
    ds = talk(p, {"speech_speed": lambda t: 160.0}, until=130)
    assert cues(ds) == [(60.0, "encourage"), (120.0, "encourage")]


def test_zero_bound_uses_scale_and_negative_bound_does_not_flip() -> None:
    zero = Rule("g", Check.MIN, low=0.0, scale=10.0, below="lookUp")
    neg = Rule("g", Check.MIN, low=-15.0, scale=10.0, below="lookUp")
    assert zero.deviation(-5.0) == pytest.approx(50.0)
    assert neg.deviation(-25.0) == pytest.approx(100.0)
    assert neg.deviation(-10.0) == 0.0
    assert math.isfinite(zero.deviation(-1e6))


def test_same_inputs_give_identical_decision_log() -> None:
    def run() -> str:
        p = make(SPEED, GAZE, CLARITY, praise_after_s=50.0)
        lines = []
        sig = {
            "speech_speed": lambda t: 150 + (t % 37) * 3,
            "cv_headGaze": lambda t: -30.0 if 100 < t < 160 else 0.0,
            "speech_accuracy": lambda t: 0.75 if t > 200 else 0.9,
        }
        nxt = 0.0
        t = 0.0
        while t < 300:
            t += 0.5
            batch = []
            while nxt <= t:
                batch += [Sample(m, nxt, f(nxt)) for m, f in sig.items()]
                nxt += 0.5
            lines.append(json.dumps(p.step(t, batch, free_since=0.0).to_dict(), sort_keys=True))
        return "\n".join(lines)

    assert run() == run()


def test_unknown_metric_samples_are_counted_not_fatal() -> None:
    p = make(SPEED)
    p.ingest([Sample("nonsense", 1.0, 3.0)])
    assert p.unknown_samples == 1


def test_weights_never_negative_and_decay_when_back_in_range() -> None:
    p = make(SPEED)
    talk(p, {"speech_speed": lambda t: 200.0 if t < 20 else 160.0}, until=100)
    w = p.weight("speech_speed", 100.0)
    assert 0.0 <= w < 10.0


def test_marks_beyond_a_short_allocation_are_never_given() -> None:
    # A 90 s slot has no "2 min left"; "1 min left" comes when a minute is left.
    ts = TimeSettings(allocated_s=90.0, warn_at_s_left=(120.0, 60.0), overtime_repeat_s=0.0)
    p = make(SPEED, time=ts)
    ds = talk(p, {"speech_speed": lambda t: 160.0}, until=100)
    assert [(d.t, d.cue.command, d.cue.params) for d in ds] == [
        (30.0, "timeLeft", {"minutes": 1}),
        (90.5, "overtime", {"minutes_over": 0}),
    ]


def test_one_sample_stamped_far_ahead_is_dropped_and_does_not_silence_the_metric() -> None:
    def fed(bogus: bool) -> tuple[list[tuple[float, str]], Processor]:
        p = make(SPEED)
        extra = [Sample("speech_speed", 5000.0, 230.0)] if bogus else []
        p.step(0.5, [Sample("speech_speed", 0.0, 230.0), *extra], free_since=None)
        ds = talk(p, {"speech_speed": lambda t: 230.0}, until=60)
        return cues(ds), p

    clean, _ = fed(False)
    with_bogus, p = fed(True)
    assert clean and with_bogus == clean  # the slowDown comes exactly when it would have
    assert with_bogus[0][1] == "slowDown"
    assert p.counts()["speech_speed"]["ahead"] == 1


def test_an_old_sample_neither_overwrites_the_value_nor_rearms_a_strict_rule() -> None:
    p = make(STRICT_CLARITY)
    p.step(1.0, [Sample("speech_accuracy", 0.5, 0.5)], free_since=0.0)  # fires articulate
    assert p.cues and p.cues[-1].command == "articulate"
    p.step(40.0, [Sample("speech_accuracy", 39.0, 0.95)], free_since=0.0)
    # A module restarted from the start of its file writes its old samples again.
    d = p.step(41.0, [Sample("speech_accuracy", 0.5, 0.5)], free_since=0.0)
    assert d.cue is None
    assert p.state("speech_accuracy").value == 0.95
    assert p.counts()["speech_accuracy"]["late"] == 1


# -- the weight between events -------------------------------------------------------------


def _noisy_talk(seed: int) -> list[Sample]:
    """Four metrics sampled at their own irregular times, wandering in and out of range."""
    import random

    rng = random.Random(seed)
    out: list[Sample] = []
    for rule, (lo, hi), rate in (
        (SPEED, (100.0, 230.0), 1.0),
        (GAZE, (-40.0, 5.0), 5.0),
        (STRICT_CLARITY, (0.4, 1.0), 0.5),
        (Rule("volume", Check.MIN, low=60.0, below="louder"), (45.0, 75.0), 2.0),
    ):
        t = 0.0
        while t < 600.0:
            t += rng.expovariate(rate) if rng.random() > 0.02 else 8.0  # a gap now and then
            out.append(Sample(rule.metric, round(t, 3), rng.uniform(lo, hi)))
    return sorted(out, key=lambda s: s.t)


def _run(
    samples: list[Sample], *, dt: float, look: bool, persistence_s: float
) -> tuple[list[tuple[float, str]], list[tuple[str, float]]]:
    rules = (SPEED, GAZE, STRICT_CLARITY, Rule("volume", Check.MIN, low=60.0, below="louder"))
    policy = f"weighted:persistence_s={persistence_s:g}"
    p = make(*rules, policy=policy, min_gap_s=2.0)
    busy_until = 0.0
    cues_given: list[tuple[float, str]] = []
    seen: list[tuple[str, float]] = []
    i, n = 0, len(samples)
    for k in range(1, int(600.0 / dt) + 1):
        now = round(k * dt, 9)
        j = i
        while j < n and samples[j].t <= now:
            j += 1
        free = None if now < busy_until else busy_until
        d = p.step(now, samples[i:j], free_since=free, with_views=look)
        i = j
        if look:
            p.status(now)
            seen += [(v.metric, v.weight) for v in p.views(now)]
        if d.cue is not None:
            cues_given.append((now, d.cue.command))
            seen.append((d.cue.command, d.cue.weight))
            busy_until = now + 4.0
    return cues_given, [x for x in seen if x[0] in {"speedUp", "lookUp", "louder", "slowDown"}]


@pytest.mark.parametrize("persistence_s", [0.0, 4.0])
def test_looking_at_the_weights_every_tick_changes_nothing(persistence_s: float) -> None:
    # The weights are worked out from the last sample or cue when asked: a live view or a
    # decision log that asks for every metric's view at every tick must see the same cues,
    # with the same weights bit for bit, as a headless run that never asks.
    samples = _noisy_talk(7)
    quiet = _run(samples, dt=0.5, look=False, persistence_s=persistence_s)
    looked = _run(samples, dt=0.5, look=True, persistence_s=persistence_s)
    assert len(quiet[0]) >= 5 and len(quiet[1]) >= 3  # weighted cues among them
    assert looked[0] == quiet[0]
    assert looked[1] == quiet[1]


def test_weight_at_a_time_does_not_depend_on_the_decision_points_before_it() -> None:
    # Same samples, decided on every 0.5 s or every 0.1 s with the robot always busy (so no
    # cue resets anything): the weight at each whole second is the same, bit for bit.
    rules = (SPEED, GAZE, STRICT_CLARITY)
    samples = [s for s in _noisy_talk(3) if s.metric != "volume"]

    def weights(dt: float) -> dict[float, tuple[float, ...]]:
        p = make(*rules, policy="weighted:persistence_s=4")
        out: dict[float, tuple[float, ...]] = {}
        i = 0
        for k in range(1, int(300.0 / dt) + 1):
            now = round(k * dt, 9)
            j = i
            while j < len(samples) and samples[j].t <= now:
                j += 1
            p.step(now, samples[i:j], free_since=None, with_views=False)
            i = j
            if now == int(now):
                out[now] = tuple(p.weight(r.metric, now) for r in rules)
        return out

    coarse, fine = weights(0.5), weights(0.1)
    assert coarse == fine
    assert max(max(w) for w in coarse.values()) > 600.0  # the weights did grow


def test_a_problem_after_a_gap_without_samples_starts_at_the_first_sample_after_it() -> None:
    # Session 20, a tester: a speaker too fast before a 40 s pause (no speed written in it) was
    # cued "since 22 s" on resuming, as if the pause had been too fast too; a report's delay
    # was counted across 28 s without a sample. Nothing is known of a gap longer than the
    # staleness limit, so the out-of-range stretch starts again after it.
    p = make(SPEED, threshold=600, policy="weighted:persistence_s=0", stale_after_s=6.0)
    ds = []
    t = 0.0
    while t < 120.0:
        t = round(t + 0.5, 9)
        fed = t < 10.0 or t >= 40.0  # silent, no samples, from 10 to 40 s
        batch = [Sample("speech_speed", t, 225.0)] if fed else []
        d = p.step(t, batch, free_since=0.0)
        if d.cue:
            ds.append(d)
    assert ds, "the held problem is cued after the gap"
    first = ds[0].cue
    assert first.command == "slowDown" and first.t > 40.0
    assert first.onset == pytest.approx(40.0)
    assert "since 40.0 s" in ds[0].reason


def test_a_strict_warning_pending_over_a_gap_without_samples_dates_from_after_it() -> None:
    # Session 20, review: a strict warning pending (the robot busy) kept its onset from before
    # a gap longer than the staleness limit, so the cue said "since 2 s" of a problem seen
    # again from 30 s.
    p = make(STRICT_CLARITY, stale_after_s=6.0)
    ds = []
    t = 0.0
    while t < 60.0:
        t = round(t + 0.5, 9)
        fed = t < 5.0 or t >= 30.0
        batch = [Sample("speech_accuracy", t, 0.5)] if fed else []
        d = p.step(t, batch, free_since=None if t < 35.0 else 35.0)
        if d.cue:
            ds.append(d)
    assert ds and ds[0].cue.command == "articulate"
    assert ds[0].cue.onset == pytest.approx(30.0), ds[0].reason


def test_a_samples_own_reach_time_is_the_one_the_rule_gives() -> None:
    # session 24 wrote MetricState._reach out inside ingest for speed; the copy must stay the
    # same as the method, or a cue would come at another time after a sample than after a cue
    import random

    from prezence.processor.state import MetricState

    rule = Rule("speech_speed", Check.IN_RANGE, low=140.0, high=180.0)
    rng = random.Random(7)
    for threshold in (600.0, 50.0):
        st = MetricState(rule=rule, stale_after_s=6.0, half_life_s=30.0, threshold=threshold)
        t = 0.0
        for _ in range(300):
            t += rng.choice((0.5, 1.0, 2.0, 9.0))
            st.ingest(t, rng.uniform(100.0, 220.0))
            got = st.reach_t
            st._reach()
            assert got == st.reach_t


def test_a_samples_own_integration_and_judgement_are_the_methods_ones() -> None:
    # session 26 wrote MetricState._integrate and Rule.judge out inside ingest for speed (once
    # per sample); the copies must give the same weight, persistence, deviation and side, to
    # the last bit, or a replay's cues would move
    import copy
    import random

    from prezence.processor.state import MetricState

    rules = (
        Rule("speech_speed", Check.IN_RANGE, low=140.0, high=180.0, gain=1.5),
        Rule("cv_headGaze", Check.MIN, low=-15.0, scale=10.0, offset=-2.5),
        Rule("speech_accuracy", Check.MIN, low=0.8, strict=True),
    )
    rng = random.Random(11)
    for rule in rules:
        lo, hi = {"speech_speed": (100.0, 220.0), "cv_headGaze": (-40.0, 5.0)}.get(
            rule.metric, (0.5, 1.0)
        )
        for tau in (0.0, 5.0):
            st = MetricState(rule=rule, stale_after_s=6.0, half_life_s=8.0, persistence_s=tau)
            t = 0.0
            for _ in range(400):
                t += rng.choice((0.0, 0.5, 1.0, 2.0, 9.0))
                value = rng.uniform(lo, hi)
                ref = copy.copy(st)
                w, p = ref._integrate(t)
                assert st.ingest(t, value)
                assert (st.base_weight, st.base_persistence) == (w, p)
                assert (st.dev, st.side) == rule.judge(value)


def test_the_logs_view_dicts_are_the_views_own() -> None:
    # session 26: the decision log's metric records are made without MetricView objects; they
    # must be what the views' to_dict() gives, key order included (the log is compared byte
    # for byte), with offsets, stale metrics, refractory times and strict warnings
    import json

    rules = (
        Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown"),
        Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder", offset=-4.5),
        Rule("speech_accuracy", Check.MIN, low=0.8, strict=True, below="articulate"),
        Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp"),
    )
    p = make(*rules, threshold=50.0, refractory_s=10.0)
    seen = 0
    for k in range(1, 200):
        t = k * 0.5
        batch = [
            Sample("speech_speed", t, 120.0 + (k % 40) * 2),
            Sample("speech_accuracy", t, 0.6 if k % 30 < 5 else 0.9),
        ]
        if k < 60 or k > 120:  # the volume and the gaze go stale in between
            batch += [Sample("speech_volume", t, 58.0 + k % 9), Sample("cv_headGaze", t, -30.0)]
        p.step(t, batch, free_since=0.0 if k % 20 else None, with_views=False)
        for only in (None, [0, 2], [3]):
            got = p.view_dicts(t, only)
            want = [v.to_dict() for v in p.views(t, only)]
            assert json.dumps(got) == json.dumps(want)
            seen += 1
    assert seen


def test_praise_waits_for_a_metric_out_of_range_before_it_went_silent() -> None:
    # a rehearsal read 125 wpm, then paused for a minute and a half: only the volume came back
    # first, and the robot said "Good, keep it up!" (every metric in range for a while) though
    # the pace had been out 93 s before and was not measured since
    volume = Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder")
    p = make(SPEED, volume, praise_after_s=60.0)
    got = []
    t = 0.0
    while t < 150:
        t = round(t + 0.5, 9)
        batch = [Sample("speech_volume", t, 66.0)]
        if t <= 20:
            batch.append(Sample("speech_speed", t, 125.0))
        d = p.step(t, batch, free_since=0.0)
        got += [(d.t, d.cue.command)] if d.cue else []
    # not at 60 s, while its last reading (20 s) was out 40 s before
    assert got == [(80.0, "encourage"), (140.0, "encourage")]
