"""Decision points that cannot change anything are counted, not stepped (session 26).

A replay steps the coach every ``decision_period_s``; a point with no new sample at which
time alone changes nothing (no weight reaches the threshold, no refractory time or minimum
gap ends, no time warning, no praise, no metric goes stale, the robot moves nothing) is only
counted. The decision log, the cues and the count must be those of stepping every point.
"""

from __future__ import annotations

import math
import random
from pathlib import Path

import pytest

from prezence import coach as coach_mod
from prezence.backends.fake import FakeBackend
from prezence.config.model import Check, Config, ProcessorSettings, Rule, TimeSettings
from prezence.processor import Decision
from prezence.samples import Sample
from prezence.talk import RecordedSource, RunOptions, TalkRun, run_talk

RULES = (
    Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown"),
    Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder"),
    Rule("speech_accuracy", Check.MIN, low=0.8, strict=True, below="articulate"),
    Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp"),
)


def recording(seed: int, talk_s: float) -> list[Sample]:
    """Streams that drift in and out of range, at their own rates, with silent stretches
    longer than the stale time (a module that stops writing for a while)."""
    rng = random.Random(seed)
    out: list[Sample] = []
    bands = {
        "speech_speed": (110.0, 210.0),
        "speech_volume": (50.0, 70.0),
        "speech_accuracy": (0.7, 0.98),
        "cv_headGaze": (-35.0, 0.0),
    }
    for metric, (lo, hi) in bands.items():
        period = rng.choice((1.0, 2.0, 3.0, 5.0))
        t = rng.uniform(0.0, 2.0)
        level = rng.uniform(lo, hi)
        while t < talk_s:
            if rng.random() < 0.01:
                t += rng.uniform(8.0, 40.0)  # silent for a while
                continue
            if rng.random() < 0.05:
                level = rng.uniform(lo, hi)
            out.append(Sample(metric, round(t, 3), level + rng.gauss(0.0, (hi - lo) / 50)))
            t += period
    out.sort(key=lambda s: s.t)
    return out


def replay(
    tmp_path: Path, name: str, samples: list[Sample], config: Config, policy: str, *, every: bool
) -> TalkRun:
    source = RecordedSource(samples, talk_s=samples[-1].t + 30.0)

    def on_decision(d: Decision) -> None:  # watching every point: each one is stepped
        return None

    return run_talk(
        source,
        config=config,
        session=tmp_path / name,
        backend=FakeBackend(),
        options=RunOptions.default(policy=policy),
        on_decision=on_decision if every else None,
    )


@pytest.mark.parametrize(
    ("seed", "policy", "allocated_s", "praise_after_s"),
    [
        (1, "weighted", 300.0, 30.0),
        (2, "weighted", 120.0, 0.0),
        (3, "recent", 400.0, 60.0),
        (4, "weighted", None, 20.0),
        (5, "most_conditions", 90.0, 30.0),
        (6, "random", 200.0, 30.0),
        (7, "pz16", 200.0, 30.0),
    ],
    ids=["weighted", "short-talk-no-praise", "recent", "no-time", "overtime", "random", "pz16"],
)
def test_counted_points_leave_the_same_decisions_as_stepped_ones(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    seed: int,
    policy: str,
    allocated_s: float | None,
    praise_after_s: float,
) -> None:
    config = Config(
        rules=RULES,
        processor=ProcessorSettings(
            threshold=300.0, refractory_s=20.0, min_gap_s=4.0, praise_after_s=praise_after_s
        ),
        time=TimeSettings(allocated_s=allocated_s, overtime_repeat_s=30.0),
    )
    samples = recording(seed, 600.0)
    ticks = 0
    tick = coach_mod.Coach.tick

    def counted(self: coach_mod.Coach, *a: object, **k: object) -> Decision:
        nonlocal ticks
        ticks += 1
        return tick(self, *a, **k)  # type: ignore[arg-type]

    monkeypatch.setattr(coach_mod.Coach, "tick", counted)
    quick = replay(tmp_path, "quick", samples, config, policy, every=False)
    quick_ticks, ticks = ticks, 0
    full = replay(tmp_path, "full", samples, config, policy, every=True)
    assert ticks == full.decisions  # watched: every point stepped
    assert quick.decisions == full.decisions
    if policy == "weighted":
        assert quick_ticks < quick.decisions * 0.8  # points were counted without a step
    assert quick.cues == full.cues
    for name in ("decisions.jsonl", "cues.jsonl"):
        assert (tmp_path / "quick" / name).read_bytes() == (tmp_path / "full" / name).read_bytes()
    assert quick.summary["decisions"] == full.summary["decisions"]


def test_a_fake_backend_that_moves_its_motions_its_own_way_promises_no_quiet_time() -> None:
    # session 26's review: a subclass ending its motions early (as test_robot_exit's
    # LosingBackend does) inherited FakeBackend's "nothing changes until the planned end",
    # so a replay could skip the decision point where its motion ended
    class Early(FakeBackend):
        def _advance(self, now: float) -> None:
            super()._advance(now)

    assert FakeBackend().idle_until() == math.inf
    assert Early().idle_until() is None
