"""Synthetic presenters: determinism, rates, episodes, faults, reactions and ground truth."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from prezence.config.model import Check, Config, Rule
from prezence.errors import UnknownName
from prezence.samples import Sample
from prezence.streams.codec import StreamLineError, parse_line
from prezence.synthetic.presenters import (
    MEASURED_ERROR,
    TRUTH_STEP_S,
    InterruptionCost,
    PresenterModel,
    SyntheticPresenter,
    comfortable_values,
    parse_presenter_model,
    presenter_model,
)
from prezence.synthetic.scenario import Scenario

# The default rule set's bands, written out so these tests do not depend on the shipped file.
CONFIG = Config(
    rules=(
        Rule("speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp", above="slowDown"),
        Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder"),
        Rule("speech_accuracy", Check.MIN, low=0.8, below="articulate"),
        Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp"),
        Rule("cv_gestures", Check.IN_RANGE, low=2, high=12, below="gestureMore",
             above="gestureLess"),
    )
)  # fmt: skip

METRICS: dict[str, dict[str, Any]] = {
    "speech_speed": {"baseline": 160.0, "noise": 6.0, "rate_hz": 1.0},
    "speech_volume": {"baseline": 67.0, "noise": 1.5, "rate_hz": 1.0},
    "speech_accuracy": {"baseline": 0.9, "noise": 0.02, "rate_hz": 1.0},
    "cv_headGaze": {"baseline": -3.0, "noise": 3.0, "rate_hz": 5.0},
    "cv_gestures": {"baseline": 6.0, "noise": 1.0, "rate_hz": 0.2},
}

# Reactions that always happen, after exactly 2 s, going 80 % of the way, for 30 s, then 10 s back.
SURE = {"probability": 1.0, "delay_s": 2.0, "size": 0.8, "lasts_s": 30.0, "drift_s": 10.0}


def make(
    episodes: list[dict[str, Any]] | None = None,
    *,
    metrics: dict[str, dict[str, Any]] | None = None,
    reactions: dict[str, Any] | None = None,
    duration: str = "10:00",
    seed: int = 0,
    config: Config = CONFIG,
    model: str | PresenterModel | None = None,
) -> SyntheticPresenter:
    doc: dict[str, Any] = {
        "format": 1,
        "name": "t",
        "description": "test",
        "duration_s": duration,
        "metrics": copy.deepcopy(metrics if metrics is not None else METRICS),
        "episodes": episodes or [],
        "reactions": reactions or {"default": SURE},
    }
    return SyntheticPresenter(Scenario.from_dict(doc), config, seed=seed, model=model)


def run(p: SyntheticPresenter, until: float, step: float = 1.0) -> list[Sample]:
    out: list[Sample] = []
    for i in range(1, int(round(until / step)) + 1):
        out += p.advance(i * step)
    return out


def of(samples: list[Sample], metric: str) -> list[Sample]:
    return [s for s in samples if s.metric == metric]


NOTES = {"metric": "cv_headGaze", "kind": "hold", "at": "5:00", "until": "7:00", "value": -35.0}


# -- determinism ------------------------------------------------------------------------------


def test_same_seed_gives_identical_samples() -> None:
    assert run(make(seed=3), 600) == run(make(seed=3), 600)


def test_another_seed_gives_other_noise() -> None:
    a = of(run(make(seed=1), 60), "speech_speed")
    b = of(run(make(seed=2), 60), "speech_speed")
    assert [s.t for s in a] == [s.t for s in b]
    assert [s.value for s in a] != [s.value for s in b]


def test_adding_a_metric_leaves_the_others_unchanged() -> None:
    fewer = {k: v for k, v in METRICS.items() if k != "speech_volume"}
    with_all = run(make(metrics=METRICS), 120)
    without = run(make(metrics=fewer), 120)
    assert of(with_all, "speech_speed") == of(without, "speech_speed")
    assert of(with_all, "cv_headGaze") == of(without, "cv_headGaze")


def test_same_cues_give_identical_reactions() -> None:
    def closed_loop(seed: int) -> list[Sample]:
        p = make([NOTES], seed=seed, reactions={"default": {"probability": 0.5}})
        out = run(p, 303)
        for k in range(6):
            p.on_cue(303.0 + 10 * k, "lookUp", "cv_headGaze", {})
            out += run_from(p, 303.0 + 10 * k, 313.0 + 10 * k)
        return out

    assert closed_loop(4) == closed_loop(4)


def run_from(p: SyntheticPresenter, start: float, end: float, step: float = 0.5) -> list[Sample]:
    out: list[Sample] = []
    t = start
    while t < end - 1e-9:
        t = min(end, t + step)
        out += p.advance(t)
    return out


def test_chunking_of_advance_does_not_change_samples() -> None:
    fine = run(make(seed=5), 120, step=0.1)
    coarse = make(seed=5).advance(120.0)
    assert sorted(fine, key=lambda s: (s.t, s.metric)) == sorted(
        coarse, key=lambda s: (s.t, s.metric)
    )


# -- time, rates and ranges -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("metric", "rate"), [(m, d["rate_hz"]) for m, d in METRICS.items()], ids=list(METRICS)
)
def test_each_module_writes_at_its_own_rate(metric: str, rate: float) -> None:
    samples = of(run(make(), 60), metric)
    assert len(samples) == round(60 * rate)
    assert np.allclose(np.diff([s.t for s in samples]), 1.0 / rate)


def test_advance_returns_samples_in_the_half_open_interval_in_time_order() -> None:
    p = make()
    p.advance(10.0)
    batch = p.advance(12.0)
    ts = [s.t for s in batch]
    assert ts == sorted(ts)
    assert min(ts) > 10.0
    assert max(ts) == 12.0


def test_nothing_is_written_after_the_end_of_the_talk() -> None:
    p = make(duration="1:00")
    samples = p.advance(60.0)
    assert max(s.t for s in samples) <= 60.0
    assert p.done
    assert p.advance(90.0) == []


def test_time_cannot_go_backwards() -> None:
    p = make()
    p.advance(10.0)
    with pytest.raises(ValueError, match="backwards"):
        p.advance(9.0)


@pytest.mark.parametrize("seed", [-1])
def test_negative_seed_is_rejected(seed: int) -> None:
    with pytest.raises(ValueError, match="seed"):
        make(seed=seed)


def test_non_integer_seed_is_rejected() -> None:
    scenario = make().scenario
    with pytest.raises(TypeError, match="seed"):
        SyntheticPresenter(scenario, CONFIG, seed=1.5)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("metric", "baseline", "noise", "low", "high"),
    [
        ("speech_accuracy", 0.98, 0.3, 0.0, 1.0),
        ("cv_gestures", 0.5, 3.0, 0.0, np.inf),
        ("speech_speed", 5.0, 50.0, 0.0, np.inf),
    ],
    ids=["accuracy", "gestures", "wpm"],
)
def test_values_stay_in_physical_ranges(
    metric: str, baseline: float, noise: float, low: float, high: float
) -> None:
    metrics = {metric: {"baseline": baseline, "noise": noise, "rate_hz": 5.0}}
    values = [s.value for s in make(metrics=metrics).advance(600.0)]
    assert low <= min(values)
    assert max(values) <= high
    # The clamp really acted: the noise alone would have left the range.
    assert min(values) == low or max(values) == high


# -- episodes ---------------------------------------------------------------------------------


def test_step_changes_the_value_from_its_time_on() -> None:
    p = make([{"metric": "speech_speed", "kind": "step", "at": "3:00", "value": 215.0}])
    assert p.true_value("speech_speed", 179.9) == 160.0
    assert p.true_value("speech_speed", 180.0) == 215.0
    assert p.true_value("speech_speed", 599.0) == 215.0


def test_ramp_is_linear_from_the_earlier_value_and_then_stays() -> None:
    p = make(
        [
            {"metric": "speech_speed", "kind": "step", "at": "1:00", "value": 170.0},
            {"metric": "speech_speed", "kind": "ramp", "at": "3:00", "until": "4:00", "value": 230},
        ]
    )
    assert p.true_value("speech_speed", 180.0) == 170.0
    assert p.true_value("speech_speed", 210.0) == pytest.approx(200.0)
    assert p.true_value("speech_speed", 300.0) == 230.0


def test_hold_comes_back_to_the_earlier_value() -> None:
    p = make([NOTES])
    assert [p.true_value("cv_headGaze", t) for t in (299.9, 300.0, 419.9, 420.0)] == [
        -3.0,
        -35.0,
        -35.0,
        -3.0,
    ]


def test_glance_lasts_its_duration() -> None:
    glance = {"metric": "cv_headGaze", "kind": "glance", "at": "1:10", "duration_s": 1.5,
              "value": -35.0}  # fmt: skip
    p = make([glance])
    assert p.true_value("cv_headGaze", 70.0) == -35.0
    assert p.true_value("cv_headGaze", 71.4) == -35.0
    assert p.true_value("cv_headGaze", 71.5) == -3.0


def test_samples_follow_the_script_within_the_noise() -> None:
    samples = of(run(make([NOTES]), 600), "cv_headGaze")
    during = [s.value for s in samples if 300.0 <= s.t < 420.0]
    before = [s.value for s in samples if s.t < 300.0]
    assert abs(np.mean(during) - -35.0) < 1.0
    assert abs(np.mean(before) - -3.0) < 1.0
    assert 2.0 < np.std(before) < 4.0


def test_unknown_metric_has_no_true_value() -> None:
    with pytest.raises(UnknownName, match="did you mean 'cv_headGaze'"):
        make().true_value("cv_headgaze", 1.0)


# -- faults -----------------------------------------------------------------------------------


def test_dropout_writes_nothing_in_its_window() -> None:
    metrics = copy.deepcopy(METRICS)
    metrics["cv_headGaze"]["dropout"] = [{"from": "4:00", "to": "5:00"}]
    gaze = [s.t for s in of(run(make(metrics=metrics), 600), "cv_headGaze")]
    assert not [t for t in gaze if 240.0 <= t < 300.0]
    assert max(t for t in gaze if t < 240.0) == pytest.approx(239.8)
    assert min(t for t in gaze if t >= 240.0) == 300.0


def test_garbage_lines_replace_samples_and_are_handed_out_once() -> None:
    metrics = {"speech_speed": {"baseline": 160.0, "rate_hz": 1.0, "garbage": 1.0}}
    p = make(metrics=metrics)
    assert p.advance(60.0) == []
    lines = p.garbage(60.0)
    assert [m for m, _ in lines] == ["speech_speed"] * 60
    for _, text in lines:
        with pytest.raises(StreamLineError):
            parse_line(text)
    assert p.garbage(10.0) == []


def test_garbage_probability_is_roughly_respected() -> None:
    metrics = {"cv_headGaze": {"baseline": 0.0, "rate_hz": 5.0, "garbage": 0.1}}
    p = make(metrics=metrics)
    good = len(p.advance(600.0))
    bad = len(p.garbage(600.0))
    assert good + bad == 3000
    assert 200 < bad < 400


# -- reactions --------------------------------------------------------------------------------


def test_comfortable_values_lie_inside_the_band() -> None:
    assert comfortable_values(CONFIG.rule("speech_speed")) == (150.0, 170.0)
    assert comfortable_values(CONFIG.rule("cv_headGaze")) == (-5.0, None)
    assert comfortable_values(CONFIG.rule("speech_accuracy")) == (pytest.approx(0.88), None)
    offset = Rule("speech_volume", Check.MIN, low=60, scale=6, offset=-6.0)
    assert comfortable_values(offset) == (72.0, None)  # 72 dB at the laptop is 66 at the back


def test_reaction_moves_the_true_value_toward_the_band_then_drifts_back() -> None:
    p = make([{"metric": "speech_speed", "kind": "step", "at": "3:00", "value": 215.0}])
    run(p, 210)
    p.on_cue(210.0, "slowDown", "speech_speed", {})
    assert p.true_value("speech_speed", 212.0) == 215.0  # not before the 2 s delay
    during = p.true_value("speech_speed", 230.0)
    assert during == pytest.approx(215.0 - 0.8 * (215.0 - 170.0))
    assert CONFIG.rule("speech_speed").side(during) is None
    assert p.true_value("speech_speed", 212.0 + 30.0 + 5.0) == pytest.approx(215.0 - 0.4 * 45.0)
    assert p.true_value("speech_speed", 260.0) == 215.0


def test_reaction_does_not_overshoot_when_the_script_comes_back() -> None:
    p = make([NOTES])
    run(p, 305)
    p.on_cue(305.0, "lookUp", "cv_headGaze", {})
    assert p.true_value("cv_headGaze", 320.0) == pytest.approx(-35.0 + 0.8 * 30.0)
    p2 = make([{**NOTES, "until": "5:20"}])
    run(p2, 305)
    p2.on_cue(305.0, "lookUp", "cv_headGaze", {})
    assert p2.true_value("cv_headGaze", 325.0) == -3.0  # notes away: back to the script


def test_ignored_cue_changes_nothing() -> None:
    p = make([NOTES], reactions={"default": SURE, "lookUp": {"probability": 0.0}})
    run(p, 305)
    p.on_cue(305.0, "lookUp", "cv_headGaze", {})
    assert p.true_value("cv_headGaze", 320.0) == -35.0
    assert p.reactions[-1]["reacted"] is False


@pytest.mark.parametrize("command", ["timeLeft", "encourage", "overtime"])
def test_neutral_cues_change_no_metric(command: str) -> None:
    p = make([NOTES])
    run(p, 305)
    p.on_cue(305.0, command, None, {"minutes": 2})
    assert p.true_value("cv_headGaze", 320.0) == -35.0


def test_cue_without_metric_finds_it_from_the_rules() -> None:
    p = make([NOTES])
    run(p, 305)
    p.on_cue(305.0, "lookUp", None, {})
    assert p.true_value("cv_headGaze", 320.0) > -15.0


def test_unknown_command_is_rejected() -> None:
    p = make()
    with pytest.raises(UnknownName, match="did you mean 'slowDown'"):
        p.on_cue(1.0, "slowDwn", None, {})


def test_a_late_reaction_never_rewrites_what_was_written() -> None:
    p = make([NOTES])
    written = run(p, 330)
    p.on_cue(300.0, "lookUp", "cv_headGaze", {})  # heard late: 300 s + 2 s delay is past
    assert p.true_value("cv_headGaze", 330.0) == -35.0
    assert p.true_value("cv_headGaze", 330.2) > -15.0  # it starts right after "now"
    assert written == run(make([NOTES]), 330)
    run_from(p, 330, 600)
    first = p.truth()[0]
    assert (first["start"], first["end"]) == (300.0, pytest.approx(330.0 + TRUTH_STEP_S))


# -- truth ------------------------------------------------------------------------------------


def test_truth_of_a_hold_is_its_window() -> None:
    p = make([NOTES])
    run(p, 600)
    assert p.truth() == [
        {"metric": "cv_headGaze", "start": 300.0, "end": 420.0, "side": "below",
         "peak_deviation": 200.0}
    ]  # fmt: skip


def test_truth_of_a_glance_is_a_second_and_a_half() -> None:
    glance = {"metric": "cv_headGaze", "kind": "glance", "at": "1:10", "duration_s": 1.5,
              "value": -35.0}  # fmt: skip
    p = make([glance])
    run(p, 600)
    (interval,) = p.truth()
    assert (interval["start"], interval["end"]) == (70.0, 71.5)


def test_truth_sides_above_and_below() -> None:
    p = make(
        [
            {"metric": "speech_speed", "kind": "hold", "at": "1:00", "until": "2:00", "value": 200},
            {"metric": "speech_speed", "kind": "hold", "at": "3:00", "until": "4:00", "value": 120},
        ]
    )
    run(p, 600)
    assert [(i["start"], i["end"], i["side"]) for i in p.truth()] == [
        (60.0, 120.0, "above"),
        (180.0, 240.0, "below"),
    ]


def test_open_interval_ends_at_the_current_time() -> None:
    p = make([NOTES])
    run(p, 330)
    (interval,) = p.truth()
    assert (interval["start"], interval["end"]) == (300.0, 330.0)


def test_truth_reflects_the_reaction_that_happened() -> None:
    p = make([NOTES])
    run(p, 310)
    p.on_cue(310.0, "lookUp", "cv_headGaze", {})
    run_from(p, 310, 600)
    intervals = [(i["start"], i["end"]) for i in p.truth()]
    # Looked up from 312 s for 30 s; the pull fades over 10 s and crosses -15° on the way.
    fade_crossing = 312.0 + 30.0 + 10.0 * (1 - (20.0 / 30.0) / 0.8)
    assert intervals[0] == (300.0, pytest.approx(312.0 + TRUTH_STEP_S))
    assert intervals[1][0] == pytest.approx(fade_crossing, abs=TRUTH_STEP_S)
    assert intervals[1][1] == 420.0


def test_metric_without_a_rule_has_no_truth() -> None:
    config = Config(rules=(CONFIG.rule("speech_speed"),))
    p = make([NOTES], config=config)
    run(p, 600)
    assert p.truth() == []


# -- presenter models: a presenter who pays for interruptions ----------------------------------

FAST = {"metric": "speech_speed", "kind": "step", "at": "3:00", "value": 215.0}


def test_the_free_model_is_the_presenter_as_before() -> None:
    a, b = make([FAST]), make([FAST], model="free")
    for p in (a, b):
        run(p, 210)
        p.on_cue(210.0, "slowDown", "speech_speed", {})
    assert a.advance(400.0) == b.advance(400.0)
    assert a.truth() == b.truth()


def test_a_cue_costs_a_pause_and_a_look_at_the_robot() -> None:
    cost = InterruptionCost(slip_probability=0.0)
    p = make(model=PresenterModel("no slips", cost))
    run(p, 100)
    p.on_cue(100.0, "timeLeft", None, {"minutes": 2})  # even a neutral cue costs
    assert p.true_value("speech_speed", 101.0) == pytest.approx(160.0 * (1 - 0.5))
    assert p.true_value("speech_speed", 100.0 + cost.pause_s + 0.5) == 160.0
    assert p.true_value("cv_headGaze", 101.0) == cost.attend_gaze_deg
    assert p.true_value("cv_headGaze", 100.0 + cost.attend_s + 0.5) == -3.0
    assert "pause" in p.reactions[-1]["cost"]
    p.advance(120.0)
    out = [x for x in p.truth() if x["metric"] in ("speech_speed", "cv_headGaze")]
    assert {x["metric"] for x in out} == {"speech_speed", "cv_headGaze"}


def test_repeated_cues_about_one_metric_lose_effect() -> None:
    p = make([FAST], model="cost")
    for k in range(3):
        t = 200.0 + 100.0 * k
        p.advance(t)
        p.on_cue(t, "slowDown", "speech_speed", {})
    hab = [r["habituation"] for r in p.reactions]
    assert hab == pytest.approx([1.0, 0.75, 0.75**2])


def test_a_correction_fades_sooner_under_the_cost_model() -> None:
    free, cost = make([FAST]), make([FAST], model="cost")
    for p in (free, cost):
        run(p, 210)
        p.on_cue(210.0, "slowDown", "speech_speed", {})
    assert cost.reactions[-1]["lasts_s"] == pytest.approx(0.6 * free.reactions[-1]["lasts_s"])


def test_slips_happen_at_about_their_probability() -> None:
    p = make(model="cost")
    n = 200
    for k in range(n):
        t = 1.0 + 2.9 * k
        p.advance(t)
        p.on_cue(t, "encourage", None, {})
    slips = sum(any(c.startswith("slipped") for c in r["cost"]) for r in p.reactions)
    assert 0.2 * n < slips < 0.4 * n  # probability 0.3


def test_measured_noise_adds_the_module_error() -> None:
    quiet = dict(METRICS, speech_speed={"baseline": 160.0, "noise": 0.0, "rate_hz": 1.0})
    p = make(metrics=quiet, model="free+measured")
    xs = np.array([s.value for s in of(run(p, 600), "speech_speed")])
    assert xs.std() == pytest.approx(MEASURED_ERROR["speech_speed"], rel=0.15)


def test_presenter_model_specs() -> None:
    assert parse_presenter_model("free").cost is None
    half = parse_presenter_model("cost:0.5").cost
    assert half is not None and half.pause_s == pytest.approx(1.0)
    assert half.habituation == pytest.approx(0.875)
    one = parse_presenter_model("cost:habituation=1.5+measured")
    assert one.cost is not None and one.measured_noise
    assert one.cost.habituation == pytest.approx(0.625)
    assert one.cost.pause_s == InterruptionCost().pause_s  # the others as they are
    with pytest.raises(ValueError, match="no cost assumption"):
        parse_presenter_model("cost:pausing=2")
    with pytest.raises(ValueError, match="expected free"):
        parse_presenter_model("costly")
    with pytest.raises(ValueError, match="measured"):
        parse_presenter_model("cost+noisy")
    with presenter_model("cost"):
        assert make().model.cost is not None
    assert make().model.cost is None
