"""The session folder as a researcher reads it with their own scripts (session 15)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from prezence.cli import main
from prezence.synthetic import runner


def test_a_session_folder_copied_elsewhere_still_names_its_bad_lines(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # summary.json named a skipped stream line by the path the command was given: an absolute
    # one with --out /abs, else one relative to the folder the command ran in, so a copied
    # folder (or a script run from elsewhere) pointed at a file that was not there; a replay
    # named the recording's folder
    monkeypatch.chdir(tmp_path)
    runner.run_talk("camera_dropout", out=Path("talk"), seed=0, backend="fake", report=False)
    assert main(["replay", "talk", "--out", str(tmp_path / "again"), "--no-report"]) == 0
    for name in ("talk", "again"):
        moved = shutil.copytree(tmp_path / name, tmp_path / "elsewhere" / name)
        problems = json.loads((moved / "summary.json").read_text())["stream_problems"]
        assert problems, name
        for p in problems:
            file, line, why = p.split(":", 2)
            assert file == "streams/cv_headGaze.txt" or file == "streams/cv_gestures.txt", p
            bad = (moved / file).read_text().splitlines()[int(line) - 1]
            # the line named is the line skipped: not a '<t> <value>' pair of finite numbers
            fields = bad.split()
            assert len(fields) != 2 or "nan" in bad or "?" in bad or "garbage" in bad, (p, bad)
