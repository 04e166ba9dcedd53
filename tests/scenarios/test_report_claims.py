"""The report claims only what it measured (session 14's walkthrough, items 6, 8 and 10).

Whole synthetic talks, replays and an evaluated talk, fake backend: what the report says a cue
was followed by, which cues it judges at all, false alarms against stale cues, metrics a persona
does not play, the replay's head line and the head-pitch label.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from prezence.report import build_report, write_report
from prezence.report.build import metric_label
from prezence.synthetic.runner import run_talk
from prezence.talk import RunOptions

#: The walkthrough's persona: a bit fast from 3:00 to 4:10 by its script, and it never reacts.
IGNORER = """\
format = 1
name = "ignorer"
description = "Talks a bit fast from 3:00 to 4:10 and never reacts to any cue."
duration_s = "6:00"
allocated_s = "6:00"
seed = 1
[metrics.speech_speed]
baseline = 160.0
noise = 4.0
[metrics.speech_volume]
baseline = 67.0
noise = 1.0
[[episodes]]
metric = "speech_speed"
kind = "hold"
at = "3:00"
until = "4:10"
value = 202.0
[reactions.default]
probability = 0
"""


@pytest.fixture(scope="module")
def ignorer(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("ignorer")
    persona = root / "ignorer.toml"
    persona.write_text(IGNORER)
    out = root / "ign"
    run_talk(persona, out=out, backend="fake", report=True)
    return out


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("demo") / "src_demo"
    run_talk("demo", out=out, backend="fake", report=True)
    return out


def _replay(src: Path, out: Path, policy: str) -> Path:
    from prezence.replay import replay

    opts = RunOptions.default(policy=policy, report=True)
    replay(src, out=out, options=opts)
    return out


def test_a_cue_the_presenter_ignored_is_not_said_to_have_helped(ignorer: Path) -> None:
    # the walkthrough: 'after 1 of 1 corrections you got better … 3:54 slowDown … you got
    # better', while the persona ignores every cue and its script recovers by itself at 4:10
    text = (ignorer / "report" / "summary.txt").read_text()
    page = (ignorer / "report" / "report.html").read_text()
    assert "got better" not in text and "got better" not in page
    cue = next(c for c in build_report(ignorer)["cues"] if c["command"] == "slowDown")
    assert cue["effect"] == f"back in range after {cue['back_in_range_s']:.0f} s"
    assert cue["reacted"] is False and cue["reaction"] == "ignored the cue"
    assert "back in range after" in text and "the presenter ignored it" in text
    assert "the presenter did not react to it (ground truth)" in text
    assert "the presenter ignored it" in page


def test_the_synthetic_talk_records_whether_the_presenter_reacted(ignorer: Path) -> None:
    summary = json.loads((ignorer / "summary.json").read_text())
    slow = [r for r in summary["reactions"] if r["command"] == "slowDown"]
    assert slow and all(r["reacted"] is False for r in slow)


def test_replayed_cues_of_another_policy_are_not_judged(demo: Path, tmp_path: Path) -> None:
    # the walkthrough: a rhema replay of the demo said '2:00 slowDown … you got better', but
    # the slowing came from the recording's own cue, which rhema never gave
    rp = _replay(demo, tmp_path / "rp_rhema", "rhema")
    report = build_report(rp)
    recorded = {(c["t"], c["command"]) for c in build_report(demo)["cues"]}
    corrective = [c for c in report["cues"] if c.get("metric")]
    assert corrective
    for c in corrective:
        heard = (c["t"], c["command"]) in recorded
        assert c.get("heard", True) is heard
        if not heard:
            assert c["improved"] is None and c["effect"] is None
    text = (rp / "report" / "summary.txt").read_text()
    assert "not judged: this is a replay, whose speaker heard the recording's cues" in text
    assert "back in range after" not in text or any(
        (c["t"], c["command"]) in recorded for c in corrective
    )


def test_a_replay_with_the_recordings_cues_judges_them_on_the_recorded_talk(
    demo: Path, tmp_path: Path
) -> None:
    rp = _replay(demo, tmp_path / "rp_same", "weighted")
    mine, theirs = build_report(rp), build_report(demo)
    keys = ("t", "command", "effect", "back_in_range_s", "reacted")
    assert [{k: c.get(k) for k in keys} for c in mine["cues"]] == [
        {k: c.get(k) for k in keys} for c in theirs["cues"]
    ]
    assert "effects_not_judged" not in mine and mine["counts"]["cues_judged"] > 0


def test_a_replay_whose_recording_is_gone_judges_nothing(demo: Path, tmp_path: Path) -> None:
    import shutil

    src = tmp_path / "copy"
    shutil.copytree(demo, src)
    rp = _replay(src, tmp_path / "rp", "weighted")
    shutil.rmtree(src)
    report = build_report(rp)
    assert report["counts"]["cues_judged"] == 0
    assert "the recording's folder is not found" in report["effects_not_judged"]


def test_report_counts_false_alarms_and_stale_cues_as_the_evaluation_does(
    tmp_path: Path,
) -> None:
    # the walkthrough: evaluation.csv 3 false alarms and 37 stale; the report of the same kept
    # session '40 false alarms (cued while in range)', each '… s after onset'
    from prezence.evaluate import evaluate

    keep = tmp_path / "kept"
    (row,) = evaluate(
        ["fast_talker"], ["pz16"], [0], keep_sessions=keep, presenters=["cost+measured"]
    )
    (folder,) = list(keep.iterdir())
    write_report(folder, plots=False)
    report = build_report(folder)
    assert (report["counts"]["false_alarms"], report["counts"]["stale"]) == (
        row["false_alarms"],
        row["stale"],
    )
    assert row["stale"] > 0 and row["false_alarms"] > 0
    text = (folder / "report" / "summary.txt").read_text()
    assert f"{row['false_alarms']} false alarms (cued while in range, not out" in text
    assert f"{row['stale']} stale (cued within 10 s after the problem had ended)" in text
    for c in report["cues"]:
        if c["false_alarm"] or c["stale"]:
            assert c["latency_s"] is None  # no '20 s after onset' for a problem not there
    wrong = [c for c in report["cues"] if c["false_alarm"] or c["stale"]]
    assert not any("after onset" in line for line in text.splitlines() if "STALE" in line)
    assert len(wrong) == row["false_alarms"] + row["stale"]


def test_a_metric_the_persona_does_not_play_is_not_measured(ignorer: Path) -> None:
    # the walkthrough: 'no data' with 'longest out 0 s' for the metrics no module writes
    report = build_report(ignorer)
    for metric in ("speech_accuracy", "cv_headGaze", "cv_gestures"):
        assert report["metrics"][metric]["data"] == "not measured"
        assert report["metrics"][metric]["stale_episodes"] == 0
    text = (ignorer / "report" / "summary.txt").read_text()
    rows = [ln for ln in text.splitlines() if "not measured" in ln]
    assert len(rows) == 3 and not any(ln.endswith("0 s") for ln in rows)
    assert "no data" not in text


def test_the_run_timeline_shows_no_truth_for_a_metric_the_persona_does_not_play(
    ignorer: Path,
) -> None:
    from prezence.cli import format_timeline

    text = format_timeline(json.loads((ignorer / "summary.json").read_text()))
    row = next(ln for ln in text.splitlines() if ln.startswith("cv_headGaze"))
    assert row.split() == ["cv_headGaze", "-", "-", "-", "-"]


def test_the_text_summary_of_a_replay_names_its_policy_and_recording(
    demo: Path, tmp_path: Path
) -> None:
    rp = _replay(demo, tmp_path / "rp_recent", "recent")
    head = (rp / "report" / "summary.txt").read_text().splitlines()[0]
    assert head == f"Post-speech report: demo (policy recent, a replay of {demo})"
    assert f"a replay of {demo}" in (rp / "report" / "report.html").read_text()


def test_head_pitch_is_not_called_eye_contact(demo: Path) -> None:
    # cv_headGaze is the head's pitch to the audience direction: a presenter turned to the
    # slides with a level head reads in range, so 'eye contact' would claim what is not measured
    assert metric_label("cv_headGaze") == "head pitch"
    for name in ("summary.txt", "report.html", "spoken.txt"):
        assert "eye contact" not in (demo / "report" / name).read_text()
