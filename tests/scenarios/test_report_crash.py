"""The report after a crash: the processor dies mid-talk, files are torn, the report still comes.

The talk is killed from inside (an exception at a fixed simulated time) rather than by killing
a process at a wall-clock moment, so the test is deterministic; then the last lines of
``cues.jsonl`` and of a stream are torn, as a power cut mid-write would leave them.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from prezence.processor import Decision
from prezence.report import build_report, write_report
from prezence.session import SessionDir, read_jsonl
from prezence.synthetic.runner import run_talk

ROOT = Path(__file__).resolve().parents[2]
CRASH_AT_S = 300.0


class ProcessorDied(RuntimeError):
    pass


def die_at(t: float) -> Callable[[Decision], None]:
    def on_decision(d: Decision) -> None:
        if d.t >= t:
            raise ProcessorDied(f"killed at {d.t}")

    return on_decision


@pytest.fixture(scope="module")
def crashed(tmp_path_factory: pytest.TempPathFactory) -> SessionDir:
    out = tmp_path_factory.mktemp("crash") / "session"
    with pytest.raises(ProcessorDied):
        run_talk("demo", out=out, seed=0, on_decision=die_at(CRASH_AT_S))
    session = SessionDir(out)
    with session.cues.open("a") as f:
        f.write('{"command":"lookUp","t":300.5,"me')  # torn mid-line
    with session.stream("speech_speed.txt").open("a") as f:
        f.write("300.7 21")  # torn mid-line: no newline
    return session


def test_crash_leaves_no_summary_or_truth(crashed: SessionDir) -> None:
    assert not crashed.summary.exists()
    assert not crashed.truth.exists()


def test_report_is_rebuilt_up_to_the_crash(crashed: SessionDir) -> None:
    report = build_report(crashed.root)
    assert report["complete"] is False
    assert CRASH_AT_S - 1.0 <= report["talk_s"] <= CRASH_AT_S
    whole = read_jsonl(crashed.cues)
    assert [c["t"] for c in report["cues"]] == [c["t"] for c in whole]
    assert all(c["t"] <= CRASH_AT_S for c in report["cues"])
    # The demo's first two problems (racing at 1:30, reading notes from 4:00) were coached.
    commands = [c["command"] for c in report["cues"]]
    assert "slowDown" in commands and "lookUp" in commands
    assert report["metrics"]["speech_speed"]["stream"]["malformed"] == 1  # the torn line
    assert {p["metric"] for p in report["priorities"]} <= set(report["metrics"])
    assert report["priorities"], "the racing and the notes must give things to work on"


def test_report_files_are_written_after_a_crash(crashed: SessionDir) -> None:
    page = write_report(crashed.root)
    assert "the coach stopped early" in page.read_text()
    data = json.loads((crashed.report / "report.json").read_text())
    assert data["complete"] is False


def test_screenshot_of_the_report_is_not_blank(crashed: SessionDir, tmp_path: Path) -> None:
    if not any(shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")):
        pytest.skip("chromium is not installed (apt-get install chromium)")
    image = pytest.importorskip("PIL.Image")
    page = write_report(crashed.root)
    shot = tmp_path / "shot.png"
    done = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "screenshot_report.py"), str(page), "-o", str(shot)],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert done.returncode == 0, done.stderr
    with image.open(shot) as im:
        assert im.size == (1200, 3000)
        colours = im.convert("L").getcolors(maxcolors=1 << 16)
    # A blank page has one or two shades; a rendered report has text, plots and tables.
    assert colours is None or len(colours) > 50


def test_a_cue_line_damaged_during_the_talk_is_skipped_and_named_in_the_summary(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # session 14: one bad line in the middle of cues.jsonl stopped the end of the talk with
    # 'error: …/cues.jsonl:2: not a JSON line': no summary.json, no report
    from prezence.cli import format_timeline

    out = tmp_path / "s"
    cues = out / "cues.jsonl"

    def damage_after_the_first_cue(d: Decision) -> None:
        if cues.exists() and cues.read_text().count("\n") == 1:
            with cues.open("a") as f:
                f.write('{"t": 12.0, "comm\n')

    run = run_talk("demo", out=out, seed=0, on_decision=damage_after_the_first_cue, report=True)
    where = f"{cues}:2: not a JSON line (Unterminated string starting at); line skipped"
    # warned once, though the spoken summary, summary.json and the report each read the file
    assert [r.getMessage() for r in caplog.records if "cues.jsonl:2" in r.getMessage()] == [where]
    # summary.json names the file inside the session folder (session 15)
    named = "cues.jsonl:2: not a JSON line (Unterminated string starting at); line skipped"
    assert run.summary["skipped_records"] == [named]
    assert run.summary["counts"]["skipped_records"] == 1
    written = json.loads((out / "summary.json").read_text())
    assert written["skipped_records"] == [named]
    kept = read_jsonl(cues, skipped=[])
    assert [c["t"] for c in run.cues] == [c["t"] for c in kept] and len(kept) >= 2
    assert [c["t"] for c in written["cues"]] == [c["t"] for c in kept]
    assert (out / "report" / "report.html").exists()
    assert "cues.jsonl:2: not a JSON line" in (out / "report" / "summary.txt").read_text()
    assert f"note: a damaged record line was left out, so a cue may be missing: {named}" in (
        format_timeline(run.summary)
    )


@pytest.mark.parametrize("damage", ["torn-last", "middle"])
def test_a_damaged_truth_line_is_skipped_and_named_in_the_report_and_the_replay(
    tmp_path: Path, caplog: pytest.LogCaptureFixture, damage: str
) -> None:
    # session 21: a torn last line of truth.jsonl was dropped without a word, so replay and
    # report printed a truth column that missed an out-of-range stretch (86 % in range, not 50 %)
    from prezence.cli import format_timeline
    from prezence.replay import replay
    from prezence.talk import RunOptions

    out = tmp_path / "s"
    run_talk("demo", out=out, seed=0)
    truth = out / "truth.jsonl"
    lines = truth.read_text().splitlines(keepends=True)
    assert len(lines) >= 2
    if damage == "torn-last":
        where, kept = len(lines), lines[:-1]
        truth.write_text("".join(lines)[:-15])
        why = (
            "not a JSON line (Unterminated string starting at); "
            "the last line is incomplete (no newline); line skipped"
        )
    else:
        where, kept = 1, lines[1:]
        truth.write_text('{"metric": 3\n' + "".join(lines[1:]))
        why = "not a JSON line (Expecting ',' delimiter); line skipped"
    named = f"truth.jsonl:{where}: {why}"
    assert build_report(out)["truth_skipped"] == [named]
    assert f"{truth}:{where}: {why}" in [r.getMessage() for r in caplog.records]
    write_report(out)
    note = f"a damaged ground-truth line was left out, so the truth figures may be wrong: {named}"
    assert note in (out / "report" / "summary.txt").read_text()
    # the other lines still make the truth column: the replay's truth is what was kept
    rp = replay(out, out=tmp_path / "rp", options=RunOptions.default())
    assert rp.summary["truth_skipped"] == [f"{truth.absolute()}:{where}: {why}"]
    assert "note: a damaged ground-truth line was left out" in format_timeline(rp.summary)
    copied = (tmp_path / "rp" / "truth.jsonl").read_text().splitlines()
    assert [json.loads(x) for x in copied] == [json.loads(x) for x in kept]
    assert build_report(tmp_path / "rp")["truth_skipped"] == rp.summary["truth_skipped"]


def test_a_torn_config_is_named_and_the_report_still_comes_out(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    # session 21, a second walkthrough: a config.toml torn mid-write stopped `prezence report`
    # with its file:line:col; with --config it came out silently, judged by the given file's 600 s
    from prezence.cli import main

    out = tmp_path / "s"
    assert main(["-q", "run", "short_talk", "--out", str(out), "--no-report"]) == 0  # 2:10
    capsys.readouterr()
    assert main(["report", str(out)]) == 0
    whole = capsys.readouterr().out.splitlines()
    config = out / "config.toml"
    text = config.read_text()
    cut = text.index("threshold =") + len("thre")
    config.write_text(text[:cut])  # cut short mid-write, in a key
    line = text[:cut].count("\n") + 1
    where = f"config.toml:{line}:5: TOML: Expected '=' after a key in a key/value pair"
    assert main(["report", str(out)]) == 0
    printed = capsys.readouterr().out
    said = (
        "note: the talk's config.toml is damaged, so it was judged by the built-in "
        f"configuration, with the allocated time its summary.json records (130 s): {where}"
    )
    assert said in printed
    assert f"{out / where}" in caplog.text  # the warning names the file in full
    # the built-in rules are short_talk's: the same report, the time used of 2:10 kept
    assert [ln for ln in whole if ln.startswith("  ")] == [
        ln for ln in printed.splitlines() if ln.startswith("  ") and "config.toml" not in ln
    ]
    # rules given: they judge, the recorded allocated time is kept, and the damage is said
    rules = tmp_path / "rules.txt"  # the seed's format: no time of its own (600 s)
    rules.write_text("speech_speed inRange 100 300\n")
    assert main(["report", str(out), "--config", str(rules)]) == 0
    printed = capsys.readouterr().out
    assert (
        "note: the talk's config.toml is damaged, so it was judged by the rules given "
        f"(--config), with the allocated time its summary.json records (130 s): {where}"
    ) in printed
    assert "You used 40 seconds of 2 minutes 10 seconds" in printed
    # no summary.json either: the built-in configuration, said
    (out / "summary.json").unlink()
    assert main(["report", str(out)]) == 0
    assert (
        "note: the talk's config.toml is damaged, so it was judged by the built-in "
        f"configuration (no summary.json records its allocated time): {where}"
    ) in capsys.readouterr().out
