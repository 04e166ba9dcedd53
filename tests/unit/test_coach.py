"""The coach loop: cues reach the robot only when it is free, and every cue is recorded."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from prezence.backends.base import Motion
from prezence.backends.fake import FakeBackend
from prezence.coach import Coach
from prezence.config.model import Check, Config, ProcessorSettings, Rule, TimeSettings
from prezence.errors import BackendUnavailable
from prezence.feedback.trajectory import Trajectory
from prezence.processor import Cue, Processor, make_policy
from prezence.samples import Sample
from prezence.session import SessionDir, read_jsonl

SPEED = Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown")


def planner(gesture: str, params: Mapping[str, Any]) -> Trajectory:
    return Trajectory(gesture, ("HeadYaw",), (1.5, 3.0), ((0.3,), (0.0,)), (0.0,))


def make_coach(
    tmp_path: Path, backend: FakeBackend, heard: list[Cue], log_mode: str = "changes"
) -> Coach:
    cfg = Config(
        rules=(SPEED,),
        processor=ProcessorSettings(min_gap_s=2.0, refractory_s=0.0, praise_after_s=0.0),
        time=TimeSettings(allocated_s=None),
    )
    backend.open()
    return Coach(
        Processor(cfg, policy=make_policy("weighted")),
        backend,
        SessionDir(tmp_path).create(),
        planner=planner,
        on_cue=heard.append,
        log_mode=log_mode,
    )


def run(coach: Coach, until: float) -> None:
    t = 0.0
    while t < until:
        t += 0.5
        coach.tick(t, [Sample("speech_speed", t, 240.0)])
    coach.close()


def test_cues_are_spaced_by_performance_and_gap_and_recorded(tmp_path: Path) -> None:
    heard: list[Cue] = []
    coach = make_coach(tmp_path, FakeBackend(), heard)
    run(coach, 60.0)
    assert coach.decisions == 120
    recs = read_jsonl(tmp_path / "decisions.jsonl")
    # the log is compact: a line where a cue is chosen or something changed, not every tick
    assert 2 < len(recs) < 120
    cues = read_jsonl(tmp_path / "cues.jsonl")
    assert [r["t"] for r in recs if r["cue"]] == [c["t"] for c in cues]
    assert [c["command"] for c in cues] == ["slowDown"] * len(cues) and len(cues) >= 2
    assert [c.t for c in heard] == [c["t"] for c in cues]
    for a, b in zip(cues, cues[1:], strict=False):
        # the next cue starts only after the robot finished the last one and the gap passed
        assert b["t"] >= a["t"] + a["measured_s"] + 2.0
    assert cues[0]["phrase"] == "Slow down a little."
    assert cues[0]["gesture_planned_s"] == 3.0
    # while busy, every decision says so and none carries a cue
    busy = [r for r in recs if r["busy"]]
    assert busy and all(r["cue"] is None for r in busy)


class LostRobot(FakeBackend):
    def play(self, traj: Trajectory, *, now: float) -> Motion:
        raise BackendUnavailable("robot went away")


def test_cue_for_a_lost_robot_is_dropped_and_the_talk_goes_on(tmp_path: Path) -> None:
    heard: list[Cue] = []
    coach = make_coach(tmp_path, LostRobot(), heard)
    run(coach, 80.0)
    cues = read_jsonl(tmp_path / "cues.jsonl")
    assert cues and all(c["dropped"] for c in cues)
    assert heard == []  # the presenter saw nothing
    assert coach.decisions == 160
    logged = read_jsonl(tmp_path / "decisions.jsonl")
    assert [r["t"] for r in logged if r["cue"]] == [c["t"] for c in cues]


def test_compact_decision_log_is_the_full_log_where_something_changes(tmp_path: Path) -> None:
    """Every line of the compact log is the full log's line at that time, and the full log's
    lines left out repeat the line before them (same reason, robot state and metric states)."""
    (tmp_path / "every").mkdir()
    (tmp_path / "changes").mkdir()
    run(make_coach(tmp_path / "every", FakeBackend(), [], log_mode="every"), 60.0)
    run(make_coach(tmp_path / "changes", FakeBackend(), [], log_mode="changes"), 60.0)
    every = read_jsonl(tmp_path / "every" / "decisions.jsonl")
    compact = read_jsonl(tmp_path / "changes" / "decisions.jsonl")
    assert len(every) == 120
    by_t = {r["t"]: r for r in every}

    def head(r: dict[str, object]) -> tuple[object, ...]:
        return (r["busy"], r["cue"], r["reason"], r["candidates"])

    for r in compact:
        assert head(r) == head(by_t[r["t"]])
        shown = {m["metric"]: m for m in r["metrics"]}
        full = {m["metric"]: m for m in by_t[r["t"]]["metrics"]}
        for metric, view in shown.items():  # what is shown is the full log's view
            assert view == full[metric]
    kept = {r["t"] for r in compact}
    last = None
    for r in every:
        if r["t"] in kept:
            last = r
        else:
            assert last is not None and r["cue"] is None
            assert (r["busy"], r["reason"]) == (last["busy"], last["reason"])


def test_decision_log_lines_read_back_as_typed_records(tmp_path: Path) -> None:
    from prezence.processor import Decision

    run(make_coach(tmp_path, FakeBackend(), []), 60.0)
    lines = read_jsonl(tmp_path / "decisions.jsonl")
    decisions = [Decision.from_dict(r) for r in lines]
    assert [d.to_dict() for d in decisions] == lines  # a round trip changes nothing
    cued = [d for d in decisions if d.cue is not None]
    assert cued and all(d.cue.command == "slowDown" for d in cued if d.cue)
    # the first line and every cue's line show every metric; the others those that changed
    assert all(d.metrics and d.metrics[0].metric == "speech_speed" for d in [decisions[0], *cued])
