"""Joint-limit violations are a figure only where a backend measured them (the sim)."""

from __future__ import annotations

import json
from pathlib import Path

from prezence.cli import format_timeline
from prezence.synthetic.runner import run_talk


def test_the_fake_backend_says_joint_limits_were_not_measured_not_zero(tmp_path: Path) -> None:
    # session 21: the fake backend (the default) measures nothing, yet the run printed
    # "joint-limit violations 0" and summary.json counted 0: an unmeasured check read as passed
    out = tmp_path / "s"
    run = run_talk("demo", out=out, seed=0, report=True)
    written = json.loads((out / "summary.json").read_text())
    assert written["backend"] == "fake" and written["backend_stats"] == {}
    assert written["counts"]["joint_limit_violations"] is None
    line = next(x for x in format_timeline(run.summary).splitlines() if x.startswith("cues "))
    assert line.endswith(
        "joint-limit violations not measured (fake backend: --backend sim measures them)"
    )
    assert "joint-limit violations 0" not in format_timeline(run.summary)
    report = json.loads((out / "report" / "report.json").read_text())
    assert report["counts"]["joint_limit_violations"] is None
