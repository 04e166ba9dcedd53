"""A talk whose robot did not give every cue the coach chose fails with its own exit status.

Session 13's walkthrough: on NAOqi, the robot lost 0.5 s into a 2.8 s cue, ``prezence run``
printed "scenario expectations met" and exited 0, so a CI job never saw the robot drop out.
The fake backend here is lost as the NAOqi backend is: the motions in progress end with
``ok=False`` and the error, and while it is gone ``play`` raises ``BackendUnavailable``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

import prezence.backends.registry as registry
import prezence.replay
import prezence.synthetic.runner
from prezence.backends.base import Backend, Motion
from prezence.backends.fake import FakeBackend
from prezence.cli import EXIT_EXPECTATIONS, EXIT_ROBOT, main
from prezence.errors import BackendUnavailable
from prezence.feedback.trajectory import Trajectory

LOST = "robot lost: disconnected"


class LosingBackend(FakeBackend):
    """A fake robot lost 0.5 s into its first cue (``at_open``: gone from the start).

    Args:
        back: it is back at once after the cue it cut (else it stays lost: later cues and the
            post-talk summary are dropped).
    """

    def __init__(self, *, back: bool, at_open: bool = False) -> None:
        super().__init__()
        self.back = back
        self.lost = at_open

    def _start_gesture(self, traj: Trajectory, motion: Motion) -> None:
        if self.lost and not self.back:
            raise BackendUnavailable(f"{LOST}; reconnecting")
        super()._start_gesture(traj, motion)

    def _advance(self, now: float) -> None:
        running = [m for m in self._running if not m.done]
        if not self.lost and running and now >= running[0].started_at + 0.5:
            self.lost = True
            for m in running:
                m.finish(running[0].started_at + 0.5, ok=False, error=LOST)
        super()._advance(now)


@pytest.fixture
def robot(monkeypatch: pytest.MonkeyPatch) -> dict[str, Any]:
    """``--backend fake`` gives a :class:`LosingBackend` made with these settings."""
    settings: dict[str, Any] = {"back": True}

    def make(name: str, **kwargs: Any) -> Backend:
        assert name == "fake"
        return LosingBackend(**settings)

    for module in (prezence.synthetic.runner, prezence.replay, registry):
        monkeypatch.setattr(module, "make_backend", make)
    return settings


def test_a_cue_cut_short_by_a_lost_robot_fails_a_run_that_met_its_expectations(
    robot: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status = main(["run", "short_talk", "--out", str(tmp_path / "s"), "--no-report"])
    out = capsys.readouterr().out
    assert "^ cut short (noticed after 0.5 s): robot lost: disconnected" in out
    assert "scenario expectations met\n" not in out
    assert (
        "scenario expectations met by the cues chosen, but the robot did not give them all: "
        "1 cue cut short (robot lost: disconnected)"
    ) in out
    assert status == EXIT_ROBOT == 4


def test_a_robot_that_stays_lost_counts_the_dropped_cues_and_the_unsaid_summary(
    robot: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot["back"] = False
    status = main(["run", "short_talk", "--out", str(tmp_path / "s")])
    out = capsys.readouterr().out
    assert status == EXIT_ROBOT
    counts = json.loads((tmp_path / "s" / "summary.json").read_text())["counts"]
    assert counts["cues_cut_short"] == 1 and counts["cues_dropped"] == 4  # slowDown, again
    line = next(ln for ln in out.splitlines() if "did not give them all" in ln)
    assert line.endswith(
        "1 cue cut short, 4 dropped, the post-talk summary not said (robot lost: disconnected)"
    ), line


def test_expectations_missed_are_exit_3_and_the_robot_is_said_too(
    robot: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot.update(back=False, at_open=True)
    status = main(["run", "short_talk", "--policy", "none", "--out", str(tmp_path / "s")])
    out = capsys.readouterr().out
    assert status == EXIT_EXPECTATIONS == 3
    assert "scenario expectations NOT met:" in out
    assert "and the robot did not give them all: the post-talk summary not said (robot lost" in out


def test_json_output_fails_the_same_way(
    robot: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", "short_talk", "--json", "--out", str(tmp_path / "s")]) == EXIT_ROBOT
    assert '"cues_cut_short": 1' in capsys.readouterr().out


def test_a_replay_on_a_robot_that_is_lost_fails_too(
    robot: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot["back"] = True
    from prezence.synthetic.runner import run_talk

    run_talk("short_talk", out=tmp_path / "rec", backend=FakeBackend())  # a sound robot
    status = main(["replay", str(tmp_path / "rec"), "--out", str(tmp_path / "r")])
    out = capsys.readouterr().out
    assert "the robot did not give every cue: 1 cue cut short (robot lost: disconnected)" in out
    assert status == EXIT_ROBOT


def test_a_talk_whose_robot_gave_everything_still_exits_0(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", "short_talk", "--out", str(tmp_path / "s")]) == 0
    out = capsys.readouterr().out
    assert "scenario expectations met\n" in out and "did not give" not in out


def test_expectations_missed_during_a_robot_outage_name_the_outage_as_the_likely_cause(
    robot: dict[str, Any], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Session 22: a robot gone for most of the talk gave exit 3 with nothing but 'expected
    slowDown … got none', which README defines as the coach missing what it should do."""
    robot.update(back=False, at_open=True)
    status = main(["run", "short_talk", "--out", str(tmp_path / "s")])
    out = capsys.readouterr().out
    assert status == EXIT_EXPECTATIONS
    assert "scenario expectations NOT met:" in out
    assert "the robot was lost during the talk (" in out
    assert "the outage is the likely cause of what was missed, not the coach" in out


def test_expectations_missed_with_the_robot_there_say_nothing_of_an_outage(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status = main(["run", "short_talk", "--policy", "none", "--out", str(tmp_path / "s")])
    assert status == EXIT_EXPECTATIONS
    assert "the robot was lost" not in capsys.readouterr().out
