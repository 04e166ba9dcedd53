"""Whole talks, headless: every scenario file, run through the pipeline, meets its expectations."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from prezence.session import read_jsonl
from prezence.streams.codec import StreamLineError, parse_line
from prezence.synthetic import runner
from prezence.synthetic.scenario import check_expectations, list_scenarios, load_scenario

SCENARIOS = list_scenarios()

pytestmark = pytest.mark.slow


def test_there_are_scenarios_to_run() -> None:
    assert len(SCENARIOS) >= 9


@pytest.mark.parametrize("name", SCENARIOS, ids=SCENARIOS)
def test_scenario_meets_its_expectations(name: str, tmp_path: Path) -> None:
    scenario = load_scenario(name)
    result = runner.run_talk(scenario, out=tmp_path, seed=scenario.seed, backend="fake")
    assert check_expectations(scenario, result.cues) == []


@pytest.mark.parametrize("name", SCENARIOS, ids=SCENARIOS)
def test_scenario_does_not_hinge_on_its_seed(name: str, tmp_path: Path) -> None:
    """Another seed (other noise, other reaction draws) must meet the same expectations."""
    scenario = load_scenario(name)
    result = runner.run_talk(scenario, out=tmp_path, seed=scenario.seed + 1, backend="fake")
    assert check_expectations(scenario, result.cues) == []


def test_same_seed_gives_identical_decision_log(tmp_path: Path) -> None:
    a = runner.run_talk("demo", out=tmp_path / "a", seed=0, backend="fake")
    b = runner.run_talk("demo", out=tmp_path / "b", seed=0, backend="fake")
    log_a = a.session.decisions.read_bytes()
    assert log_a, "the decision log is empty"
    assert log_a == b.session.decisions.read_bytes()
    assert a.cues == b.cues


def test_same_seed_gives_identical_decision_log_across_processes(tmp_path: Path) -> None:
    """Two processes (other hash seeds, other import orders) write the same bytes."""
    logs = []
    for i, hashseed in enumerate(("1", "2")):
        out = tmp_path / f"p{i}"
        subprocess.run(
            [
                sys.executable,
                "-m",
                "prezence",
                "run",
                "fast_talker",
                "--seed",
                "5",
                "--out",
                str(out),
                "--no-report",
                "-q",
            ],
            check=True,
            capture_output=True,
            env={**__import__("os").environ, "PYTHONHASHSEED": hashseed},
        )
        logs.append(((out / "decisions.jsonl").read_bytes(), (out / "cues.jsonl").read_bytes()))
    assert logs[0][0] and logs[0][1]
    assert logs[0] == logs[1]


def test_another_seed_gives_other_samples(tmp_path: Path) -> None:
    a = runner.run_talk("demo", out=tmp_path / "a", seed=0, backend="fake")
    b = runner.run_talk("demo", out=tmp_path / "b", seed=1, backend="fake")
    stream = "speech_speed.txt"
    assert a.session.stream(stream).read_bytes() != b.session.stream(stream).read_bytes()


def test_truth_file_records_the_scripted_problem(tmp_path: Path) -> None:
    """The note reader's head is down from 5:00: the truth file says so, whatever the coach did."""
    result = runner.run_talk("note_reader", out=tmp_path, seed=0, backend="fake")
    gaze = [row for row in read_jsonl(result.session.truth) if row["metric"] == "cv_headGaze"]
    assert gaze, "no truth interval for the head gaze"
    assert gaze[0]["start"] == 300.0
    assert gaze[0]["side"] == "below"
    assert all(row["start"] >= 300.0 and row["end"] <= 420.0 for row in gaze)


def _is_bad(line: str) -> bool:
    try:
        parse_line(line)
    except StreamLineError:
        return True
    return False


def test_garbage_lines_reach_the_module_files(tmp_path: Path) -> None:
    """camera_dropout writes garbage lines; its expectations (above) hold in spite of them."""
    result = runner.run_talk("camera_dropout", out=tmp_path, seed=0, backend="fake")
    lines = result.session.stream("cv_headGaze.txt").read_text().splitlines()
    bad = [line for line in lines if _is_bad(line)]
    assert 0.005 * len(lines) < len(bad) < 0.05 * len(lines)
    # ... and the summary says how many there were, and where.
    summary = result.summary
    assert summary["metrics"]["cv_headGaze"]["stream"]["malformed"] == len(bad)
    # named inside the session folder, so the record holds wherever it is copied (session 15)
    located = [p for p in summary["stream_problems"] if p.startswith("streams/cv_headGaze.txt:")]
    assert len(located) == min(len(bad), 100)
    line_no = int(located[0].split(":")[1])
    assert _is_bad(lines[line_no - 1])


def test_a_module_that_never_writes_is_one_stale_episode_as_long_as_the_talk(
    tmp_path: Path,
) -> None:
    from prezence.config.load import default_config
    from prezence.session import SessionDir
    from prezence.summary import summarize_session

    session = SessionDir(tmp_path).create()
    config = default_config()
    gaze_rule = next(r for r in config.rules if r.metric == "cv_headGaze")
    session.stream(gaze_rule.stream).touch()  # the module opened its file, then wrote nothing
    summary = summarize_session(session, config, talk_s=60.0)
    gaze = summary["metrics"]["cv_headGaze"]
    assert (gaze["samples"], gaze["stale_episodes"]) == (0, 1)


def test_a_metric_no_module_was_run_for_is_not_measured_not_stale(tmp_path: Path) -> None:
    # an audio-only rehearsal runs no camera module: its metrics have no file at all, and the
    # summary said "stale episodes 2" for a talk in which nothing went quiet
    from prezence.config.load import default_config
    from prezence.session import SessionDir
    from prezence.summary import summarize_session

    session = SessionDir(tmp_path).create()
    config = default_config()
    plausible = {"speech_speed": 150.0, "speech_volume": 65.0, "speech_accuracy": 0.8}
    for rule in config.rules:
        if rule.metric.startswith("speech_"):
            v = plausible[rule.metric]  # 150 is no clarity (0..1): such lines are skipped
            session.stream(rule.stream).write_text("".join(f"{t} {v}\n" for t in range(60)))
    summary = summarize_session(session, config, talk_s=60.0)
    gaze = summary["metrics"]["cv_headGaze"]
    assert (gaze["samples"], gaze["stale_episodes"], gaze["measured"]) == (0, 0, False)
    assert summary["counts"]["stale_episodes"] == 0


def test_every_record_is_standard_json(tmp_path: Path) -> None:
    """Time warnings have an infinite priority; strict parsers must still read every line."""
    import json

    def refuse(name: str) -> None:
        raise AssertionError(f"non-standard JSON constant {name}")

    result = runner.run_talk("overrunning", out=tmp_path, seed=0, backend="fake")
    s = result.session
    assert any(c.get("kind") == "time" for c in result.cues)
    for path in (s.decisions, s.cues, s.truth):
        for line in path.read_text().splitlines():
            json.loads(line, parse_constant=refuse)
    json.loads(s.summary.read_text(), parse_constant=refuse)


@pytest.mark.parametrize(("name", "policy", "seed"), [("fast_talker", "rhema", 1826701614)])
def test_no_cue_is_given_at_the_talks_end(
    name: str, policy: str, seed: int, tmp_path: Path
) -> None:
    """A cue at the talk's last instant came after the talk: the presenter could not act on it,
    yet it was counted, judged and performed (a 600 s fast_talker under rhema cued slowDown at
    10:00.0, a cue the Gymnasium env, whose agent acts before each step, could never give).
    The last decision point takes in its samples and says why it gives no cue."""
    scenario = load_scenario(name)
    result = runner.run_talk(scenario, out=tmp_path, seed=seed, backend="fake", policy=policy)
    end = scenario.duration_s
    assert result.cues, "the talk gave no cue at all: nothing to check"
    assert all(c["t"] < end for c in result.cues), [(c["t"], c["command"]) for c in result.cues]
    last = read_jsonl(result.session.decisions)[-1]
    assert (last["t"], last["cue"], last["reason"]) == (end, None, "the talk is over")
