"""The session folder as a researcher reads it with their own scripts (session 15)."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path
from typing import Any

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


# -- docs/session_folder.md against what the talks write --------------------------------------

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "session_folder.md"
#: The doc's section for each JSON file.
SECTIONS = {
    "session.json": "session.json",
    "cues.jsonl": "cues.jsonl",
    "decisions.jsonl": "decisions.jsonl",
    "truth.jsonl": "truth.jsonl",
    "summary.json": "summary.json",
    "report/report.json": "report/report.json",
}


def documented() -> dict[str, dict[str, str]]:
    """Per file, each field the doc's tables name (first column) → its row, with the
    shorthand ``.x`` after a field read as a sibling of it, and the fields an object's row
    names in its text (``cue.t``)."""
    out: dict[str, dict[str, str]] = {}
    section = None
    for line in DOC.read_text().splitlines():
        if line.startswith("## "):
            title = line[3:].strip()
            section = next((f for f, t in SECTIONS.items() if t == title), None)
            out.setdefault(section or "", {})
            continue
        if section is None or not line.startswith("| `"):
            continue
        first, rest = line[1:].split("|", 1)
        names = re.findall(r"`([^`]+)`", first)
        fields: list[str] = []
        for n in names:
            if n.startswith(".") and fields:  # `a.b.c`, `.d`: a.b.d
                fields.append(fields[0].rsplit(".", 1)[0] + n)
            else:
                fields.append(n)
        for n in list(fields):  # an object's row naming its fields; not a file's name
            fields += [
                x
                for x in re.findall(r"`([^`]+)`", rest)
                if x.startswith(n + ".") and not re.search(r"\.(jsonl?|txt|toml|md)$", x)
            ]
        for f in fields:
            out[section][f] = line
    return out


def _norm(key: str, metrics: set[str]) -> str:
    parts = key.split(".")
    for i, p in enumerate(parts):
        bare = p.removesuffix("[]")
        if bare in metrics:
            parts[i] = "<metric>" + p[len(bare) :]
        elif i and parts[i - 1] in ("modules", "module_failures"):
            parts[i] = "<module>" + p[len(bare) :]
    return ".".join(parts)


def _walk(x: Any, pre: str, acc: set[str]) -> None:
    if isinstance(x, dict):
        for k, v in x.items():
            _walk(v, f"{pre}.{k}" if pre else k, acc)
    elif isinstance(x, list) and x and all(isinstance(v, dict) for v in x):
        for v in x:
            _walk(v, pre + "[]", acc)
    else:
        acc.add(pre)


def written(folders: list[Path]) -> dict[str, set[str]]:
    from prezence.metrics import METRICS

    out: dict[str, set[str]] = {f: set() for f in SECTIONS}
    for folder in folders:
        metrics = set(METRICS) | {p.stem for p in (folder / "streams").glob("*.txt")}
        for f in SECTIONS:
            path = folder / f
            if not path.is_file():
                continue
            text = path.read_text()
            docs = (
                [json.loads(x) for x in text.splitlines() if x.strip()]
                if f.endswith(".jsonl")
                else [json.loads(text)]
            )
            acc: set[str] = set()
            for d in docs:
                _walk(d, "", acc)
            out[f] |= {_norm(k, metrics) for k in acc}
    return out


def covered(f: str, key: str, doc: dict[str, dict[str, str]]) -> bool:
    """Whether the doc describes ``key`` of file ``f``: its own table (an empty list of
    objects is its ``X[].y`` rows), or the table it says the file shares fields with."""
    own = doc[f]
    if key in own or any(k.startswith(key + "[].") for k in own):
        return True
    if f == "summary.json" and key.startswith("cues[]."):
        return key[len("cues[].") :] in doc["cues.jsonl"]  # copied from cues.jsonl
    if f == "report/report.json":
        return covered("summary.json", key, doc)  # the summary's fields, recomputed
    return False


@pytest.fixture(scope="module")
def talks(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Talks of every kind that runs without devices: synthetic (fake, and sim when PyBullet
    is there), a replay under another policy, and one with bad stream lines and overtime."""
    import importlib.util

    root = tmp_path_factory.mktemp("talks")
    out = []
    for name, scenario, backend in [
        ("demo", "demo", "fake"),
        ("dropout", "camera_dropout", "fake"),
        ("over", "overrunning", "fake"),
        ("fast", "fast_talker", "fake"),
        *([("sim", "short_talk", "sim")] if importlib.util.find_spec("pybullet") else []),
    ]:
        runner.run_talk(scenario, out=root / name, seed=0, backend=backend, report=True)
        out.append(root / name)
    assert main(["replay", str(root / "demo"), "--policy", "rhema", "--out", str(root / "rp")]) == 0
    out.append(root / "rp")
    # as after gestures.toml was edited in place (no PyBullet to check it: a second's check less)
    from prezence.feedback import collision

    record = {**collision.builtin_record(), "gestures_sha256": "0" * 64}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(collision, "builtin_record", lambda: record)
        mp.setattr(collision, "pybullet_available", lambda: False)
        runner.run_talk("short_talk", out=root / "edited", seed=0, backend="fake", report=True)
    assert "built_in_gestures" in json.loads((root / "edited/session.json").read_text())
    return [*out, root / "edited"]


def test_every_field_a_talk_writes_is_in_the_session_folder_doc(talks: list[Path]) -> None:
    doc = documented()
    for f, keys in written(talks).items():
        missing = sorted(k for k in keys if not covered(f, k, doc))
        assert not missing, f"{f}: written but not in docs/session_folder.md: {missing}"


def test_every_field_in_the_session_folder_doc_is_written_or_said_to_be_conditional(
    talks: list[Path],
) -> None:
    doc = documented()
    seen = written(talks)
    source = "\n".join(p.read_text() for p in (ROOT / "prezence").rglob("*.py"))
    source += "\n".join(p.read_text() for p in (ROOT / "sim").rglob("*.py"))
    wrong = []
    for f, fields in doc.items():
        if f not in SECTIONS:
            continue
        for key, row in fields.items():
            if key in seen[f] or any(k.startswith((key + ".", key + "[]")) for k in seen[f]):
                continue
            if f == "report/report.json" and key in doc["summary.json"]:
                continue
            # not written by these talks: the doc must say when it is (only …), and the
            # name must be one the code writes
            if "only" not in row and "sim backend" not in row:
                wrong.append(f"{f}: {key} is documented as always written; no talk wrote it")
            last = [p for p in re.split(r"[.\[\]]+", key) if p and not p.startswith("<")][-1]
            if not re.search(rf"\b{re.escape(last)}\b", source):
                wrong.append(f"{f}: {key}: the code writes no such name")
    assert not wrong, "\n".join(wrong)


def test_a_replays_report_rebuilt_from_elsewhere_is_the_one_written_after_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the replay recorded its recording as given ('s/demo', relative to where it ran): a
    # report rebuilt from another folder found no recording and judged none of its cues
    # ('what followed 5 corrections is not judged … the recording's folder is not found')
    from prezence.report import write_report

    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    monkeypatch.chdir(tmp_path / "a")
    runner.run_talk("demo", out=Path("s/demo"), seed=0, backend="fake", report=False)
    assert main(["replay", "s/demo", "--out", str(tmp_path / "x" / "rp")]) == 0
    written = (tmp_path / "x" / "rp" / "report" / "summary.txt").read_text()
    assert "not judged" not in written and "5 corrections: 3 back in range" in written
    monkeypatch.chdir(tmp_path / "b")
    write_report(tmp_path / "x" / "rp")
    assert (tmp_path / "x" / "rp" / "report" / "summary.txt").read_text() == written


def test_a_talk_judged_by_rules_in_the_seeds_format_keeps_its_units(tmp_path: Path) -> None:
    # the seed's line format names no unit: summary.json's units were "" and the report said
    # "your volume was below the lowest good value, 60, for 12 s in all"
    runner.run_talk("demo", out=tmp_path / "demo", seed=0, backend="fake", report=False)
    rules = tmp_path / "rules.txt"
    rules.write_text(
        "speech_speed inRange 140 180\nspeech_volume min 60 scale=6\n"
        "speech_accuracy min 0.5\ncv_headGaze min ANGLE\n"
    )
    out = tmp_path / "rp"
    assert main(["replay", str(tmp_path / "demo"), "--config", str(rules), "--out", str(out)]) == 0
    units = {
        k: m["unit"] for k, m in json.loads((out / "summary.json").read_text())["metrics"].items()
    }
    # prezence/metrics.py's units; clarity is a 0..1 score, not a unit
    assert units == {
        "speech_speed": "wpm",
        "speech_volume": "dB SPL",
        "speech_accuracy": "",
        "cv_headGaze": "degrees",
    }
    text = (out / "report" / "summary.txt").read_text()
    assert "below the lowest good value, 60 dB SPL, for" in text
    assert "below the lowest good value, -15 degrees, for" in text
