"""``prezence up``: modules and processor in parallel, supervised, in real time (a few seconds)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from prezence.backends.fake import FakeBackend
from prezence.config.model import Check, Config, ProcessorSettings, Rule, TimeSettings
from prezence.launcher import ModuleSpec, up
from prezence.session import read_jsonl

PACE = Path(__file__).with_name("pace_module.py")

CONFIG = Config(
    rules=(Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown"),),
    processor=ProcessorSettings(
        threshold=40.0, stale_after_s=1.0, refractory_s=60.0, praise_after_s=0
    ),
    time=TimeSettings(allocated_s=None),
)


def pace(*extra: str) -> ModuleSpec:
    argv = [sys.executable, str(PACE), "--out", "{session}", "--t0", "{t0}", "--wpm", "260", *extra]
    return ModuleSpec("pace", argv, metrics=("speech_speed",))


@pytest.mark.slow
def test_up_runs_modules_and_coaches_live(tmp_path: Path) -> None:
    result = up(
        CONFIG, session_dir=tmp_path / "s", modules=[pace()], backend=FakeBackend(), duration_s=4.0
    )
    cues = read_jsonl(tmp_path / "s" / "cues.jsonl")
    assert [c["command"] for c in cues] == ["slowDown"]
    assert result.summary["metrics"]["speech_speed"]["samples"] >= 10
    assert result.summary["modules"]["pace"]["restarts"] == 0


@pytest.mark.slow
def test_crashed_module_is_restarted_and_the_talk_completes(tmp_path: Path) -> None:
    marker = tmp_path / "crashed"
    result = up(
        CONFIG,
        session_dir=tmp_path / "s",
        modules=[pace("--crash-after", "5", "--marker", str(marker))],
        backend=FakeBackend(),
        duration_s=5.0,
    )
    assert marker.exists()
    mod = result.summary["modules"]["pace"]
    assert mod["restarts"] == 1 and "status 3" in mod["crashes"][0]["why"]
    assert any("restarted" in e for e in result.events)
    samples = [
        float(ln.split()[0])
        for ln in (tmp_path / "s/streams/speech_speed.txt").read_text().splitlines()
    ]
    assert samples[-1] > mod["crashes"][0]["t"] + 1.0  # it wrote again after the restart
    assert (tmp_path / "s" / "summary.json").exists()


def test_module_spec_parse() -> None:
    spec = ModuleSpec.parse("pace=python pace.py --out {session}")
    assert spec.name == "pace" and spec.argv == ["python", "pace.py", "--out", "{session}"]
    with pytest.raises(ValueError, match="NAME=COMMAND"):
        ModuleSpec.parse("no command here")
