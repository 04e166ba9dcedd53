"""Whole talks over the NAOqi protocol against a virtual NAO in another process (loopback).

These run in real time (a robot moves in real time): the 40-second ``short_talk`` scenario.
"""

from __future__ import annotations

import socket
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("pybullet")
pytest.importorskip("qi")

from dataclasses import replace  # noqa: E402

from prezence.cli import main  # noqa: E402
from prezence.config.load import load_config  # noqa: E402
from prezence.processor import Decision  # noqa: E402
from prezence.session import read_jsonl  # noqa: E402
from prezence.synthetic.runner import run_talk  # noqa: E402
from sim.virtual_nao import spawn, stop_spawned  # noqa: E402


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow
def test_whole_talk_over_naoqi_with_the_cli(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    proc, url = spawn("--port", "0", "--speech-log", str(tmp_path / "said.jsonl"))
    try:
        out = tmp_path / "s"
        assert (
            main(
                ["-q", "run", "short_talk", "--backend", "naoqi", "--robot", url, "--out", str(out)]
            )
            == 0
        )
    finally:
        stop_spawned(proc)
    cues = read_jsonl(out / "cues.jsonl")
    assert [c["command"] for c in cues] == ["timeLeft", "slowDown"]
    assert all(c["ok"] and not c["dropped"] for c in cues)
    said = [r.get("text") for r in read_jsonl(tmp_path / "said.jsonl")]
    assert "Slow down a little." in said  # the virtual robot really said it
    summary = (out / "report" / "report.html").exists()
    assert summary
    assert "scenario expectations met" in capsys.readouterr().out


@pytest.mark.slow
def test_robot_lost_mid_talk_drops_cues_and_comes_back(tmp_path: Path) -> None:
    port = free_port()
    base = load_config(None)
    # cue often so that some fall while the robot is away
    cfg = replace(
        base, processor=replace(base.processor, threshold=100.0, refractory_s=4.0, min_gap_s=1.0)
    )
    state: dict[str, Any] = {
        "proc": spawn("--port", str(port))[0],
        "lost_at": None,
        "back_at": None,
    }

    def chaos(d: Decision) -> None:
        if state["lost_at"] is None and d.t >= 12.0:
            stop_spawned(state["proc"], kill=True)
            state["lost_at"] = d.t
        elif state["back_at"] is None and state["lost_at"] is not None and d.t >= 24.0:
            state["proc"] = spawn("--port", str(port))[0]
            state["back_at"] = d.t

    try:
        result = run_talk(
            "short_talk",
            out=tmp_path / "s",
            backend="naoqi",
            backend_kwargs={"url": f"tcp://127.0.0.1:{port}", "reconnect_max_s": 1.0},
            config=cfg,
            # no persistence delay or escalation: cues must keep coming while the robot is away
            policy="weighted:persistence_s=0,escalate_after=0",
            on_decision=chaos,  # the NAOqi backend declares real time: the talk is paced
        )
    finally:
        stop_spawned(state["proc"])
    cues = result.cues
    lost, back = state["lost_at"], state["back_at"]
    # a cue still moving when the robot died is not ok: judge those that ended before
    before = [c for c in cues if c["t"] + c.get("planned_s", 0.0) < lost]
    during = [c for c in cues if lost + 2.0 <= c["t"] < back]
    after = [c for c in cues if c["t"] > back]
    assert before and all(c["ok"] for c in before)
    assert during and all(c["dropped"] for c in during)  # dropped, never queued
    assert any(c["ok"] and not c["dropped"] for c in after)  # it came back and coached again
    # no backlog: nothing performed after the return was decided while the robot was away
    assert all(c["t"] > back for c in after)
    # every decision point of the talk was taken; the log holds each cue's
    assert result.decisions == 80
    logged = read_jsonl(tmp_path / "s" / "decisions.jsonl")
    assert [r["t"] for r in logged if r["cue"]] == [c["t"] for c in cues]
    stats = result.summary["backend_stats"]
    assert stats["disconnects"] >= 1 and stats["connects"] >= 2
