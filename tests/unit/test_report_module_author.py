"""What the summary, the report and the robot say when a module of one's own misbehaves: a
walkthrough of session 22 (a module author adds a filler-word counter), from hand-made session
folders (streams, summary.json) as the modules and the coach would leave them."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from prezence.config.model import Check, Config, Rule, TimeSettings
from prezence.config.tomlconf import dumps_config
from prezence.report import build_report, write_report
from prezence.session import SessionDir
from prezence.summary import summarize_session

SPEED = Rule(
    "speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp", above="slowDown", unit="wpm"
)
VOLUME = Rule("speech_volume", Check.MIN, low=60, scale=6, below="louder", unit="dB")
CONFIG = Config(rules=(SPEED, VOLUME), time=TimeSettings(allocated_s=60.0))


def folder(
    root: Path,
    streams: dict[str, list[tuple[float, float]] | None],
    *,
    talk_s: float,
    kind: str = "live",
    recorded: dict[str, Any] | None = None,
    cues: list[dict[str, Any]] | None = None,
    config: Config = CONFIG,
) -> SessionDir:
    """A finished talk's folder: the given stream files (None: the file is there, empty;
    others absent), its cues and the summary.json the coach wrote (``recorded``)."""
    session = SessionDir(root).create()
    session.config.write_text(dumps_config(config))
    meta: dict[str, Any] = {"kind": kind, "talk_s": talk_s, "policy": "weighted"}
    if kind == "rehearsal":
        meta["recording"] = "talk.wav"
    session.write_meta(meta)
    for metric, rows in streams.items():
        text = "".join(f"{t} {v}\n" for t, v in rows or ())
        session.stream(f"{metric}.txt").write_text(text)
    session.cues.write_text("".join(json.dumps(c) + "\n" for c in cues or ()))
    session.summary.write_text(json.dumps({"ended_at_s": talk_s, **(recorded or {})}))
    return session


def cue(t: float, command: str = "slowDown", metric: str = "speech_speed") -> dict[str, Any]:
    return {
        "t": t,
        "command": command,
        "metric": metric,
        "kind": "weighted",
        "reason": f"{metric} is above its band",
        "params": {},
        "onset": 5.0,
        "deviation": 20.0,
        "phrase": "Slow down a little.",
        "dropped": False,
    }


def steady(value: float, start: float, end: float) -> list[tuple[float, float]]:
    return [(float(t), value) for t in range(int(start), int(end))]


# -- finding 2: a cue just after a module died is not "stale" --------------------------------


def crashed_pace(root: Path) -> SessionDir:
    """Pace too fast from 5 s until its module crashed at 21 s (last value at 20 s, never back
    in range); a slowDown at 24.5 s, 3.5 s after the crash."""
    mods = {"speech": {"restarts": 0, "crashes": [{"t": 21.0, "why": "exited with status 1"}],
                       "metrics": ["speech_speed", "speech_volume"]}}  # fmt: skip
    streams = {
        "speech_speed": steady(160.0, 1, 5) + steady(200.0, 5, 21),
        "speech_volume": steady(66.0, 1, 21),
    }
    return folder(root, streams, talk_s=60.0, recorded={"modules": mods}, cues=[cue(24.5)])


def test_a_cue_after_its_module_died_is_not_judged_not_stale(tmp_path: Path) -> None:
    # session 22, finding 2: "STALE: back in range 3 s before" though the metric never came
    # back in range: it stopped being measured when its module died
    session = crashed_pace(tmp_path / "s")
    summary = summarize_session(
        session, CONFIG, talk_s=60.0, extra=json.loads(session.summary.read_text())
    )
    row = summary["cues"][0]
    assert row["cue_class"] == "unmeasured" and row["relevant"] is None
    assert row["not_measured_since"] == 21.0 and "ended_s_before" not in row
    assert summary["counts"]["stale"] == 0 and summary["counts"]["false_alarms"] == 0
    assert summary["counts"]["cues_unmeasured"] == 1
    write_report(session.root, plots=False)
    text = (session.report / "summary.txt").read_text()
    assert "STALE" not in text and "stale (cued" not in text
    assert "0:25  slowDown                         NOT JUDGED: not measured after 0:21" in text
    assert "1 not judged (cued while its metric was not measured" in text
    page = (session.report / "report.html").read_text()
    assert "not judged: not measured after 0:21" in page and "back in range" not in page
    report = json.loads((session.report / "report.json").read_text())
    c = report["cues"][0]
    assert c["unmeasured"] is True and c["stale"] is False and c["false_alarm"] is False
    assert "pace was not measured after 0:21, so whether it still was is not known" in c["why"]


def test_a_cue_after_the_metric_came_back_in_range_after_a_gap_is_stale_from_then(
    tmp_path: Path,
) -> None:
    # the module was restarted and its first value was in range: measured back in range then,
    # not when the last value out of range stopped holding
    mods = {"speech": {"restarts": 1, "crashes": [{"t": 21.0, "why": "exited with status 1"}],
                       "metrics": ["speech_speed"]}}  # fmt: skip
    streams = {
        "speech_speed": steady(200.0, 5, 21) + steady(160.0, 27, 60),
        "speech_volume": steady(66.0, 1, 60),
    }
    session = folder(
        tmp_path / "s", streams, talk_s=60.0, recorded={"modules": mods}, cues=[cue(29.0)]
    )
    row = build_report(session.root)["cues"][0]
    assert row["cue_class"] == "stale" and row["ended_s_before"] == 2.0
