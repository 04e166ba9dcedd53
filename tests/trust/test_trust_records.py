"""Issue 13: nothing recorded is lost, everything is bounded, bad files give clear errors.

Each test is one fault the issue reports, run as its reproducer.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import pytest

from prezence.cli import main
from prezence.config.tomlconf import loads_config
from prezence.errors import ConfigError
from prezence.replay import replay
from prezence.report.build import build_report, write_report
from prezence.session import SessionDir, read_jsonl
from prezence.sessiondir import claim_session_dir
from prezence.streams.tail import read_stream
from prezence.talk import RunOptions

DEMO_TOML = """format = 1
[processor]
decision_period_s = 0.5
[time]
allocated_s = 60
[[rules]]
metric = "speech_speed"
check = "inRange"
low = 140
high = 180
below = "speedUp"
above = "slowDown"
unit = "wpm"
"""


def live_session(root: Path, *, talk_s: float | None = 20.0, extra_line: str = "") -> SessionDir:
    """A small recorded live talk: 20 s of speech_speed at 2 Hz (fast, then in range)."""
    s = SessionDir(root)
    s.streams.mkdir(parents=True)
    s.config.write_text(DEMO_TOML)
    lines = [f"{i / 2:.1f} {200.0 if i < 20 else 160.0}" for i in range(40)]
    s.stream("speech_speed.txt").write_text("\n".join(lines) + "\n" + extra_line)
    meta = {"format": 1, "kind": "live", "t0_epoch": 1.7e9, "policy": "weighted"}
    if talk_s is not None:
        meta["talk_s"] = talk_s
    s.meta.write_text(json.dumps(meta))
    return s


def digest(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


# -- nothing recorded is deleted or overwritten ------------------------------------------------


def test_a_second_talk_into_the_same_folder_is_refused_and_the_first_kept(tmp_path: Path) -> None:
    s = live_session(tmp_path / "live")
    before = digest(s.root)
    with pytest.raises(ConfigError, match="never overwritten"):
        SessionDir(s.root).create()
    with pytest.raises(ConfigError, match="not empty"):
        claim_session_dir(s.root, "live")
    # the CLI refuses before any module starts (the robot is not even needed)
    assert main(["up", "--module", "x=true", "--out", str(s.root), "-q"]) == 2
    assert digest(s.root) == before


def test_default_session_folders_are_new_each_time(tmp_path: Path) -> None:
    a = claim_session_dir(None, "live", root=tmp_path)
    (a / "session.json").write_text("{}")
    b = claim_session_dir(None, "live", root=tmp_path)
    assert a != b and a.name.startswith("live-") and b.is_dir()
    assert (a / "session.json").exists()


def test_force_moves_the_old_folder_aside_and_deletes_nothing(tmp_path: Path) -> None:
    s = live_session(tmp_path / "live")
    before = digest(s.root)
    new = claim_session_dir(s.root, "live", force=True)
    assert new == s.root and not any(new.iterdir())
    (aside,) = [p for p in tmp_path.iterdir() if p.name.startswith("live.old-")]
    assert digest(aside) == before


def test_replay_of_the_streams_folder_into_its_session_is_refused(tmp_path: Path) -> None:
    s = live_session(tmp_path / "S")
    before = digest(s.root)
    assert main(["replay", str(s.streams), "--out", str(s.root), "-q"]) == 2
    assert main(["replay", str(s.streams), "--out", str(s.root), "--force", "-q"]) == 2
    assert main(["replay", str(s.root), "--out", str(s.streams / "x"), "-q"]) == 2
    with pytest.raises(ConfigError, match="another folder"):
        replay(s.streams, out=s.root, options=RunOptions.default())
    assert digest(s.root) == before


def test_a_restarted_module_appends_to_its_streams(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from prezence.modules.common import StreamSet

    (tmp_path / "streams").mkdir()
    old = tmp_path / "streams" / "speech_speed.txt"
    old.write_text("1.0 150\n2.0 151\n")
    monkeypatch.setenv("PREZENCE_APPEND", "1")  # what the launcher sets for its modules
    with StreamSet(tmp_path, ["speech_speed"], fresh=True) as ss:
        ss.write("speech_speed", 30.0, 160.0)
    assert old.read_text().splitlines() == ["1.0 150", "2.0 151", "30.0 160.0"]


# -- bounded everything -------------------------------------------------------------------------


def test_a_stamp_of_1e9_is_skipped_and_counted_not_replayed_for_30_years(tmp_path: Path) -> None:
    s = live_session(tmp_path / "S", extra_line="1e9 170\n")
    res = replay(s.root, out=tmp_path / "R", options=RunOptions.default())
    assert res.summary["talk_s"] == 20.0
    lines = (tmp_path / "R" / "decisions.jsonl").read_text().count("\n")
    assert lines <= 60  # 20 s at 0.5 s, plus the drain
    samples, stats = read_stream(s.stream("speech_speed.txt"), "speech_speed", max_t=50.0)
    assert stats.beyond_talk == 1 and len(samples) == 40


def test_report_after_a_coach_crash_is_capped_by_the_sessions_own_record(tmp_path: Path) -> None:
    # no talk_s (the coach died); a module's clock wrote 1e9: the talk is not 30 years long
    s = live_session(tmp_path / "S", talk_s=None, extra_line="1e9 170\n")
    t0 = 1.7e9
    meta = json.loads(s.meta.read_text())
    meta["t0_epoch"] = t0
    s.meta.write_text(json.dumps(meta))
    os.utime(s.stream("speech_speed.txt"), (t0 + 21.0, t0 + 21.0))
    report = build_report(s.root)
    assert 19.0 <= report["talk_s"] <= 60.0
    assert report["beyond_talk"] == {"speech_speed": 1}
    assert "clock went wrong" in write_report(s.root).read_text()


@pytest.mark.parametrize("period", ["1e-4", "1e-300", "0", "100"])
def test_absurd_decision_periods_are_refused_naming_the_key(period: str) -> None:
    text = DEMO_TOML.replace("decision_period_s = 0.5", f"decision_period_s = {period}")
    with pytest.raises(ConfigError, match=r"processor\.decision_period_s: must be between"):
        loads_config(text, path="c.toml")


def _returns_within(fn: object, seconds: float) -> bool:
    t = threading.Thread(target=fn, daemon=True)  # type: ignore[arg-type]
    t.start()
    t.join(seconds)
    return not t.is_alive()


def test_a_fifo_at_a_stream_path_is_refused_not_waited_on(tmp_path: Path) -> None:
    s = live_session(tmp_path / "S")
    fifo = s.stream("speech_speed.txt")
    fifo.unlink()
    os.mkfifo(fifo)
    got: list[object] = []
    assert _returns_within(lambda: got.append(read_stream(fifo, "speech_speed")), 10.0)
    samples, stats = got[0]  # type: ignore[misc]
    assert samples == [] and stats.missing == 1
    assert _returns_within(lambda: got.append(build_report(s.root)), 20.0)


def test_a_link_to_dev_zero_is_refused_not_read_until_memory_runs_out(tmp_path: Path) -> None:
    s = live_session(tmp_path / "S")
    link = s.stream("speech_speed.txt")
    link.unlink()
    link.symlink_to("/dev/zero")
    got: list[object] = []
    assert _returns_within(lambda: got.append(read_stream(link, "speech_speed")), 10.0)
    assert got[0][0] == []  # type: ignore[index]


# -- clear errors, not tracebacks ---------------------------------------------------------------


@pytest.mark.parametrize("content", ['{"format": 1, "kind": "li', "[1, 2]", '"x"', ""])
def test_a_truncated_or_non_object_session_json_is_a_clear_error(
    tmp_path: Path, content: str, capsys: pytest.CaptureFixture[str]
) -> None:
    s = live_session(tmp_path / "S")
    s.meta.write_text(content)
    assert main(["replay", str(s.root), "--out", str(tmp_path / "R"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "session.json" in err and "Traceback" not in err
    # the report goes on without it (the streams and cues still tell a lot)
    assert main(["report", str(s.root), "-q"]) == 0


def test_a_bad_line_in_truth_jsonl_names_file_and_line(tmp_path: Path) -> None:
    s = live_session(tmp_path / "S")
    s.truth.write_text('{"metric": "speech_speed", "start": 0, "end": 10}\nnot json\n{}\n')
    with pytest.raises(ConfigError, match=r"truth\.jsonl:2: not a JSON line"):
        read_jsonl(s.truth)
    # since session 21 the report skips the damaged lines and names them (as for cues.jsonl)
    assert main(["report", str(s.root), "-q"]) == 0
    skipped = json.loads((s.report / "report.json").read_text())["truth_skipped"]
    assert [x.split(": ")[0] for x in skipped] == ["truth.jsonl:2", "truth.jsonl:3"]


def test_deeply_nested_toml_in_check_config_is_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    f = tmp_path / "deep.toml"
    f.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    assert main(["check-config", str(f)]) == 1
    assert "nested too deeply" in capsys.readouterr().err


@pytest.mark.parametrize("unit", ["$\\frac$", "US$ $5", "$"])
def test_a_dollar_in_a_unit_does_not_break_the_plots(tmp_path: Path, unit: str) -> None:
    pytest.importorskip("matplotlib")
    s = live_session(tmp_path / "S")
    s.config.write_text(DEMO_TOML.replace('unit = "wpm"', f"unit = {json.dumps(unit)}"))
    write_report(s.root)
    assert (s.report / "timeline_speech_speed.png").stat().st_size > 1000


def test_piping_into_head_ends_quietly(tmp_path: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    cmd = f"{sys.executable} -m prezence run demo --out {tmp_path / 'd'} -q --json | head -1"
    p = subprocess.run(
        ["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, env=env
    )
    assert p.stdout.strip() == "{"
    assert "Traceback" not in p.stderr and "BrokenPipe" not in p.stderr
    assert p.returncode in (0, 141)  # 0 when it all fitted in the pipe before head left
    # a reader that is gone before anything is written: the write fails for certain
    cmd = f"{sys.executable} -m prezence run demo --out {tmp_path / 'e'} -q --json | true"
    p = subprocess.run(
        ["bash", "-o", "pipefail", "-c", cmd], capture_output=True, text=True, env=env
    )
    assert p.stderr == "" and p.returncode == 141


# -- the report says the truth ------------------------------------------------------------------


def test_a_false_alarm_is_shown_as_such_not_as_improved(tmp_path: Path) -> None:
    s = live_session(tmp_path / "S")
    # ground truth: the pace was never really out of range; the robot cued anyway
    s.truth.write_text("")
    cue = {"t": 5.0, "command": "slowDown", "metric": "speech_speed", "kind": "weighted",
           "deviation": 11.0, "reason": "test", "ok": True, "dropped": False}  # fmt: skip
    s.cues.write_text(json.dumps(cue) + "\n")
    report = build_report(s.root)
    (row,) = report["cues"]
    assert row["false_alarm"] is True and row["improved"] is None
    html = write_report(s.root).read_text()
    assert "false alarm" in html and "you got better</span></td></tr>" not in html
    assert "%·s" not in html


def test_a_session_json_of_a_newer_format_is_refused_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], caplog: pytest.LogCaptureFixture
) -> None:
    s = live_session(tmp_path / "S")
    s.meta.write_text(json.dumps({**json.loads(s.meta.read_text()), "format": 2}))
    said = f"{s.meta}: format: 2 is newer than this Prezence reads (format 1)"
    assert main(["replay", str(s.root), "--out", str(tmp_path / "R"), "-q"]) == 2
    assert said in capsys.readouterr().err
    assert not (tmp_path / "R").exists()
    # the report goes on without it, and says so
    assert main(["report", str(s.root), "-q"]) == 0
    assert any(said in r.getMessage() for r in caplog.records if r.levelname == "WARNING")


def test_a_guessed_end_never_cuts_off_recorded_samples(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # no session.json, no config.toml: the end is guessed; the coach's last decision line
    # (written when something changes) is at 560 s, the samples go on to 595 s
    s = SessionDir(tmp_path / "S")
    s.streams.mkdir(parents=True)
    s.stream("speech_speed.txt").write_text("".join(f"{t}.0 160\n" for t in range(596)))
    s.decisions.write_text(json.dumps({"t": 560.0, "cue": None, "winner": None}) + "\n")
    report = build_report(s.root)
    assert report["time"]["used_s"] == pytest.approx(595.0)
    result = replay(s.root, out=tmp_path / "R", options=RunOptions.default(report=False))
    assert result.summary["talk_s"] == pytest.approx(595.0)
    assert not [r for r in caplog.records if "after the talk's end" in r.getMessage()]


def test_a_truth_file_whose_every_line_is_damaged_gives_no_truth_figures(tmp_path: Path) -> None:
    # session 21's second review: every line skipped left an empty ground truth, read as a
    # talk always in range (truth 100 % and every cue a false alarm)
    s = live_session(tmp_path / "S")
    s.truth.write_text("not json\n{}\n")
    assert main(["report", str(s.root), "-q"]) == 0
    report = json.loads((s.report / "report.json").read_text())
    assert len(report["truth_skipped"]) == 2
    assert all(m.get("truth_time_in_range") is None for m in report["metrics"].values())
