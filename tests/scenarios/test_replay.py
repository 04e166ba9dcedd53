"""Replay: the processor re-run over recorded module files reproduces or varies the talk."""

from __future__ import annotations

from pathlib import Path

import pytest

from prezence.cli import main
from prezence.errors import ConfigError
from prezence.replay import replay
from sim.runner import run_talk


@pytest.fixture(scope="module")
def demo_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("talk") / "demo"
    run_talk("demo", out=out, seed=3, backend="fake")
    return out


def test_replay_with_same_policy_reproduces_the_decision_log(
    demo_session: Path, tmp_path: Path
) -> None:
    result = replay(demo_session, out=tmp_path / "r", policy="weighted", backend="fake")
    assert (tmp_path / "r" / "decisions.jsonl").read_bytes() == (
        demo_session / "decisions.jsonl"
    ).read_bytes()
    assert result.cues and result.summary["counts"]["cues"] == len(result.cues)


def test_replay_with_another_policy_changes_the_cues(demo_session: Path, tmp_path: Path) -> None:
    silent = replay(demo_session, out=tmp_path / "none", policy="none", backend="fake")
    assert silent.cues == []
    first = replay(demo_session, out=tmp_path / "first", policy="first_rule", backend="fake")
    assert first.cues
    assert first.summary["counts"]["false_alarms"] >= 0  # truth carried over from the recording


def test_replay_never_overwrites_the_recording(demo_session: Path) -> None:
    with pytest.raises(ConfigError, match="another folder"):
        replay(demo_session, out=demo_session)


def test_replay_of_a_folder_without_streams_names_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no stream files"):
        replay(tmp_path, out=tmp_path / "out")


def test_replay_cli_on_plain_stream_files(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # files another tool wrote in the stream format, no session.json: talk length from the data
    src = tmp_path / "rec"
    src.mkdir()
    lines = "".join(f"{t} {240.0 if t > 20 else 160.0}\n" for t in range(0, 121))
    (src / "speech_speed.txt").write_text(lines)
    assert main(["replay", str(src), "--out", str(tmp_path / "out")]) == 0
    out = capsys.readouterr().out
    assert "slowDown" in out
