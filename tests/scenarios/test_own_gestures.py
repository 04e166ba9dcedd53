"""A gesture library of one's own in a talk (``--gestures FILE``): played, recorded, replayed,
and refused before the talk starts when it cannot be played."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import pytest

from prezence.backends.fake import FakeBackend
from prezence.cli import main
from prezence.errors import GestureCheckFailed
from prezence.feedback.gesture_check import check_gestures
from prezence.feedback.gestures import build_trajectory, load_library_file
from prezence.feedback.limits import load_limits
from prezence.session import read_jsonl

#: slow_down as one pat of the right arm (the built-in pats twice with both arms)
MINE = """format = 1
[gestures.slow_down]
description = "One pat."
[[gestures.slow_down.keyframes]]
pose = { RShoulderPitch = 35.0, RHand = 1.0 }
hold = 0.2
[[gestures.slow_down.keyframes]]
pose = { RShoulderPitch = 60.0 }
"""


def _durations(folder: Path) -> dict[str, set[float]]:
    out: dict[str, set[float]] = {}
    for c in read_jsonl(folder / "cues.jsonl"):
        out.setdefault(c["gesture"], set()).add(c["gesture_planned_s"])
    return out


@pytest.fixture(scope="module")
def played(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A fast talker coached with slow_down from a library of one's own."""
    root = tmp_path_factory.mktemp("own")
    mine = root / "mine.toml"
    mine.write_text(MINE)
    out = root / "s"
    assert main(["-q", "run", "fast_talker", "--gestures", str(mine), "--out", str(out)]) == 0
    return mine, out


def test_a_talk_plays_the_gestures_of_your_own_library_and_the_built_in_rest(
    played: tuple[Path, Path],
) -> None:
    mine, out = played
    limits = load_limits()
    own = build_trajectory(
        "slow_down",
        speed_fraction=0.6,
        limits=limits,
        library=load_library_file(mine, limits=limits),
    ).duration
    built_in = build_trajectory("slow_down", speed_fraction=0.6, limits=limits).duration
    assert own != pytest.approx(built_in)
    got = _durations(out)
    assert got["slow_down"] == {round(own, 6)}
    encourage = build_trajectory("encourage", speed_fraction=0.6, limits=limits).duration
    assert got["encourage"] == {round(encourage, 6)}  # not in the file: the built-in one


def test_the_session_records_which_library_the_talk_played(played: tuple[Path, Path]) -> None:
    # so that a replay or a report can say what the robot did
    mine, out = played
    meta = json.loads((out / "session.json").read_text())
    summary = json.loads((out / "summary.json").read_text())
    for record in (meta["gestures"], summary["gestures"]):
        assert record["file"] == str(mine.resolve())
        assert record["defines"] == ["slow_down"]
        assert len(record["sha256"]) == 64
    assert (out / "gestures.toml").read_text() == MINE  # what was played, kept with the talk


def test_the_timeline_says_which_gestures_came_from_the_file(
    played: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mine, _ = played
    assert main(["-q", "run", "short_talk", "--gestures", str(mine), "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1] == f"gestures: slow_down from {mine.resolve()}; the others built in"


def test_a_replay_plays_the_recordings_own_gestures(
    played: tuple[Path, Path], tmp_path: Path
) -> None:
    _, out = played
    again = tmp_path / "r"
    assert main(["-q", "replay", str(out), "--out", str(again)]) == 0
    # the same gestures take the same time: the coach decides exactly as in the recording
    assert (again / "decisions.jsonl").read_bytes() == (out / "decisions.jsonl").read_bytes()
    meta = json.loads((again / "session.json").read_text())
    assert meta["gestures"]["file"] == str((out / "gestures.toml").resolve())
    # with another library given, slow_down is the built-in one again
    plain = tmp_path / "plain.toml"
    plain.write_text(
        "format = 1\n[gestures.encourage]\n[[gestures.encourage.keyframes]]\n"
        "pose = { HeadPitch = 10 }\n"
    )
    other = tmp_path / "o"
    assert main(["-q", "replay", str(out), "--out", str(other), "--gestures", str(plain)]) == 0
    assert _durations(other)["slow_down"] != _durations(out)["slow_down"]


def test_a_replay_whose_recorded_library_is_gone_says_so(
    played: tuple[Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import shutil

    _, out = played
    copy = tmp_path / "rec"
    shutil.copytree(out, copy)
    (copy / "gestures.toml").unlink()
    assert main(["-q", "replay", str(copy), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "session.json: gestures: the talk played the gestures of" in err
    assert "give them with --gestures FILE" in err
    assert not (tmp_path / "r").exists()


def test_a_synthetic_talk_run_again_without_the_library_keeps_no_copy(
    played: tuple[Path, Path], tmp_path: Path
) -> None:
    mine, _ = played
    out = tmp_path / "s"
    assert main(["-q", "run", "short_talk", "--gestures", str(mine), "--out", str(out)]) == 0
    assert (out / "gestures.toml").exists()
    assert main(["-q", "run", "short_talk", "--out", str(out)]) == 0
    assert not (out / "gestures.toml").exists()
    assert "gestures" not in json.loads((out / "session.json").read_text())


#: every command that runs a talk (RECORDING: the played session)
COMMANDS = pytest.mark.parametrize(
    "command",
    [
        ["run", "short_talk"],
        ["demo"],
        ["replay", "RECORDING"],
        ["rehearse", "talk.wav"],
        ["up", "--module", "x=true {session}", "--duration", "2"],
    ],
    ids=["run", "demo", "replay", "rehearse", "up"],
)


@COMMANDS
def test_a_library_that_cannot_be_played_stops_every_talk_before_it_starts(
    played: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    command: list[str],
) -> None:
    _, recording = played
    bad = tmp_path / "bad.toml"
    bad.write_text(MINE.replace("RShoulderPitch = 60.0", "RShoulderPitch = 150.0"))
    out = tmp_path / "out"
    argv = [str(recording) if a == "RECORDING" else a for a in command]
    assert main(["-q", *argv, "--gestures", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {bad}:7: gesture 'slow_down' keyframes[1]: RShoulderPitch"), err
    assert not out.exists()


#: articulate as both hands clasped in front: each joint within its limits, but the wrists
#: 18.5 mm through each other (the built-in articulate's keyframes before a review moved them)
CLASP = """format = 1
[gestures.articulate]
description = "Hands clasped in front."
[[gestures.articulate.keyframes]]
pose = { LShoulderPitch = -5.0, LShoulderRoll = -10.0, LElbowYaw = -40.0, LElbowRoll = -82.0, \
RShoulderPitch = -5.0, RShoulderRoll = 10.0, RElbowYaw = 40.0, RElbowRoll = 82.0 }
hold = 0.3
"""


def test_a_gesture_that_runs_into_the_robot_stops_the_talk_before_it_starts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # It passed the limit check and played in every talk (the simulated NAO has no
    # self-collision); only `gestures check` said FAIL, and a real NAO would have tried it.
    pytest.importorskip("pybullet", reason="the self-collision check needs the sim extra")
    clasp = tmp_path / "clasp.toml"
    clasp.write_text(CLASP)
    out = tmp_path / "out"
    assert main(["-q", "run", "short_talk", "--gestures", str(clasp), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {clasp}:2: gesture 'articulate': self-collision: "), err
    assert "between l_wrist and r_wrist" in err and "gestures check" in err
    assert err.count("\n") == 1  # one line: no PyBullet banner under -q
    assert not out.exists()


def test_gestures_check_names_the_line_of_a_gesture_that_runs_into_the_robot(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # session 23's gesture designer: a row out of a limit said `clasp.toml:4: …`, the
    # self-collision row only `FAIL: self-collision: …`, with no line to go to
    pytest.importorskip("pybullet", reason="the self-collision check needs the sim extra")
    clasp = tmp_path / "clasp.toml"
    clasp.write_text(CLASP)
    assert main(["-q", "gestures", "check", str(clasp)]) == 1
    [row] = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("articulate")]
    assert f"FAIL: {clasp}:2: self-collision: " in row, row
    [row] = json.loads(check_gestures(0.6, as_json=True, collisions=True, library=clasp)[0])[
        "gestures"
    ]
    assert row["error"].startswith(f"{clasp}:2: self-collision: "), row


def test_without_pybullet_a_talk_says_the_collision_check_was_not_made(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    from prezence.feedback import collision

    monkeypatch.setattr(collision, "pybullet_available", lambda: False)
    clasp = tmp_path / "clasp.toml"
    clasp.write_text(CLASP)
    with caplog.at_level("WARNING"):
        rc = main(
            ["-q", "run", "short_talk", "--gestures", str(clasp), "--out", str(tmp_path / "o")]
        )
    assert rc == 0
    said = [
        r.getMessage() for r in caplog.records if "self-collision not checked" in r.getMessage()
    ]
    assert len(said) == 1 and "prezence gestures check" in said[0], said


class _Robot(FakeBackend):
    """A fake backend that stands for a real NAO (what --backend naoqi may be)."""

    name = "robot"
    physical = True

    def open(self) -> None:
        self.opened = True
        super().open()


def test_without_pybullet_a_real_robot_is_refused_an_unchecked_library(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # session 23's walkthrough: on the `prezence[naoqi]` install (no PyBullet) the talk only
    # warned, and the virtual NAO was sent the crossing forearms of clasp_slow.toml
    from prezence.feedback import collision
    from prezence.synthetic.runner import run_talk
    from prezence.talk import RunOptions

    monkeypatch.setattr(collision, "pybullet_available", lambda: False)
    clasp = tmp_path / "clasp.toml"
    clasp.write_text(CLASP)
    robot = _Robot()
    out = tmp_path / "s"
    with pytest.raises(GestureCheckFailed) as e:
        run_talk(
            "short_talk", out=out, backend=robot, options=RunOptions.default(gestures=str(clasp))
        )
    assert str(e.value).startswith(f"{clasp}: the self-collision of its gestures was not checked")
    assert 'pip install "prezence[sim]"' in str(e.value)
    assert "--allow-unchecked-collision" in str(e.value)
    assert not getattr(robot, "opened", False) and not out.exists()
    # the command line: refused before the robot is reached (the port is closed)
    argv = ["-q", "run", "short_talk", "--backend", "naoqi", "--robot", "tcp://127.0.0.1:1"]
    assert main([*argv, "--gestures", str(clasp), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {clasp}: the self-collision of its gestures was not checked")
    assert not out.exists()


def test_an_unchecked_library_plays_on_a_robot_only_when_asked_and_is_recorded(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    from prezence.feedback import collision
    from prezence.synthetic.runner import run_talk
    from prezence.talk import RunOptions

    monkeypatch.setattr(collision, "pybullet_available", lambda: False)
    clasp = tmp_path / "clasp.toml"
    clasp.write_text(CLASP)
    opts = RunOptions.default(gestures=str(clasp), allow_unchecked_collision=True)
    with caplog.at_level("WARNING"):
        run_talk("short_talk", out=tmp_path / "s", backend=_Robot(), options=opts)
    meta = json.loads((tmp_path / "s" / "session.json").read_text())
    assert meta["self_collision_unchecked"] == [
        f"{clasp}: the self-collision of its gestures was not checked: PyBullet is not "
        "installed here"
    ]
    assert any("playing them unchecked on the robot" in r.getMessage() for r in caplog.records)
    # with PyBullet (or the built-in gestures only) nothing is recorded
    run_talk("short_talk", out=tmp_path / "b", backend=_Robot(), options=RunOptions.default())
    assert "self_collision_unchecked" not in json.loads((tmp_path / "b/session.json").read_text())


def test_built_in_gestures_not_the_ones_the_tests_checked_are_refused_on_a_robot_without_pybullet(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the built-in library is trusted on a robot without PyBullet because the shipped record
    # names the gestures.toml (and URDF) tests/sim/test_self_collision.py checked: an edited
    # gestures.toml is no longer that file, and nothing here can check it
    from prezence.feedback import collision
    from prezence.synthetic.runner import run_talk
    from prezence.talk import RunOptions

    monkeypatch.setattr(collision, "pybullet_available", lambda: False)
    record = {**collision.builtin_record(), "gestures_sha256": "0" * 64}
    monkeypatch.setattr(collision, "builtin_record", lambda: record)
    with pytest.raises(GestureCheckFailed, match="the built-in gestures.toml") as e:
        run_talk("short_talk", out=tmp_path / "s", backend=_Robot(), options=RunOptions.default())
    assert "and PyBullet is not installed here to check it" in str(e.value)
    assert 'pip install "prezence[sim]" where the talk runs' in str(e.value)
    assert not (tmp_path / "s").exists()


def _edited_built_in(monkeypatch: pytest.MonkeyPatch) -> None:
    """As if the built-in gestures.toml were edited since the shipped record (none checked)."""
    from prezence.feedback import collision

    record = {**collision.builtin_record(), "gestures_sha256": "0" * 64}
    monkeypatch.setattr(collision, "builtin_record", lambda: record)
    monkeypatch.setattr(collision, "_BUILTIN_CHECKED", {})


def test_with_pybullet_an_edited_built_in_library_is_checked_at_the_talk_not_refused(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    # session 23's review: a comment added to gestures.toml refused every naoqi talk (the
    # virtual NAO's too), telling a developer with PyBullet to pip install "prezence[sim]"
    pytest.importorskip("pybullet", reason="the self-collision check needs the sim extra")
    from prezence.feedback import collision
    from prezence.synthetic.runner import run_talk
    from prezence.talk import RunOptions

    _edited_built_in(monkeypatch)
    limits = load_limits()
    with caplog.at_level(logging.INFO, logger="prezence.feedback.collision"):
        assert collision.require_collision_checked(None, limits=limits, backend="naoqi") == []
    said = [r.getMessage() for r in caplog.records if "was checked here" in r.getMessage()]
    assert len(said) == 1 and "least clearance 8.1 mm" in said[0], said
    run_talk("short_talk", out=tmp_path / "s", backend=_Robot(), options=RunOptions.default())
    assert "self_collision_unchecked" not in json.loads((tmp_path / "s/session.json").read_text())


def test_a_talk_with_an_edited_built_in_library_records_the_edit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # session 23's verification: a --gestures file is recorded in session.json with its
    # SHA-256, but a talk after gestures.toml was edited in place said nothing of it
    from prezence.feedback import collision
    from prezence.feedback.gestures import GESTURES_FILE

    run = ["-q", "run", "short_talk", "--out"]
    assert main([*run, str(tmp_path / "shipped")]) == 0
    meta = json.loads((tmp_path / "shipped/session.json").read_text())
    assert "built_in_gestures" not in meta  # the files the shipped record names
    _edited_built_in(monkeypatch)
    monkeypatch.setattr(collision, "pybullet_available", lambda: False)
    assert main([*run, str(tmp_path / "edited")]) == 0
    meta = json.loads((tmp_path / "edited/session.json").read_text())
    got = meta["built_in_gestures"]
    limits = load_limits()
    assert got["gestures_sha256"] == collision.builtin_hashes(limits)["gestures_sha256"]
    assert got["gestures_sha256"] != collision.builtin_record()["gestures_sha256"]
    assert got["differs_from_record"] == [GESTURES_FILE]
    assert Path(got["file"]).is_absolute() and Path(got["file"]).name == GESTURES_FILE
    assert "least_clearance_mm" not in got  # not checked: self_collision_unchecked says why
    assert meta["self_collision_unchecked"]


def test_with_pybullet_a_talk_records_the_clearance_of_an_edited_built_in_library(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("pybullet", reason="the self-collision check needs the sim extra")
    from prezence.feedback import collision

    shipped = collision.builtin_record()["least_clearance_mm"]  # the same gestures, in fact
    _edited_built_in(monkeypatch)
    assert main(["-q", "run", "short_talk", "--out", str(tmp_path / "s")]) == 0
    meta = json.loads((tmp_path / "s/session.json").read_text())
    assert meta["built_in_gestures"]["least_clearance_mm"] == pytest.approx(shipped, abs=0.5)
    assert "self_collision_unchecked" not in meta


def test_with_pybullet_an_edited_built_in_gesture_that_runs_into_the_robot_stops_every_talk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # checked as a library of one's own is: refused on every backend, before anything starts
    pytest.importorskip("pybullet", reason="the self-collision check needs the sim extra")
    import dataclasses

    from prezence.feedback import collision

    clasp = tmp_path / "clasp.toml"
    clasp.write_text(CLASP)
    clasped = dataclasses.replace(load_library_file(clasp), source=None, text="", own=())
    _edited_built_in(monkeypatch)
    monkeypatch.setattr(collision, "load_library", lambda limits=None: clasped)
    out = tmp_path / "s"
    assert main(["-q", "run", "short_talk", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {clasp}:2: gesture 'articulate': self-collision: "), err
    assert "`prezence gestures check` shows" in err
    assert not out.exists()


def test_the_record_of_the_built_in_gestures_outlives_a_comment_and_a_crlf_checkout(
    tmp_path: Path,
) -> None:
    # its SHA-256 was over the raw bytes: a comment line, or a checkout with CRLF line endings
    # (there is no .gitattributes), made the built-in library unchecked
    from importlib import resources

    from prezence.feedback import collision

    record = collision.builtin_record()
    limits = load_limits()
    assert collision.builtin_hashes(limits) == {
        k: record[k] for k in ("gestures_sha256", "urdf_sha256")
    }
    text = resources.files("prezence.feedback").joinpath("data", "gestures.toml").read_text()
    edited = "# my note\r\n" + text.replace("\n", "\r\n") + "\r\n# another\r\n"
    assert collision.toml_digest(edited) == record["gestures_sha256"]
    layout = text.replace("\nhold = 0.15", "\nhold=0.150", 1)  # the same value
    assert layout != text and collision.toml_digest(layout) == record["gestures_sha256"]
    changed = text.replace("\nhold = 0.15", "\nhold = 0.25", 1)  # another library
    assert changed != text and collision.toml_digest(changed) != record["gestures_sha256"]
    urdf = Path(limits.source)
    crlf = tmp_path / urdf.name
    crlf.write_bytes(urdf.read_bytes().replace(b"\r\n", b"\n").replace(b"\n", b"\r\n"))
    assert collision.builtin_hashes(load_limits(crlf))["urdf_sha256"] == record["urdf_sha256"]


#: slow_down of four 5 s holds (the walkthrough's toolong.toml): each keyframe within its limits,
#: 21.6 s at --speed 0.6, more than 20 s at any speed
TOO_LONG = 'format = 1\n[gestures.slow_down]\ndescription = "long"\n' + "".join(
    f"[[gestures.slow_down.keyframes]]\npose = {{ RShoulderPitch = {a} }}\nhold = 5\n"
    for a in (80, 35, 80, 35)
)
#: the same with 1.5 s holds: within 10 s at 0.6, not at 0.08
SLOW_AT_LOW_SPEED = TOO_LONG.replace("hold = 5", "hold = 1.5")


@COMMANDS
def test_a_gesture_too_long_for_a_talk_stops_every_talk_before_it_starts(
    played: tuple[Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    command: list[str],
) -> None:
    # `gestures check` said FAIL (21.6 s > 10 s), but the talk played it and exited 0: the
    # robot gave no other cue, a time warning included, for 21.6 s
    _, recording = played
    before = sorted(p.relative_to(recording) for p in recording.rglob("*"))
    long = tmp_path / "toolong.toml"
    long.write_text(TOO_LONG)
    out = tmp_path / "out"
    argv = [str(recording) if a == "RECORDING" else a for a in command]
    assert main(["-q", *argv, "--gestures", str(long), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"error: {long}:2: gesture 'slow_down' fails `prezence gestures check {long} --speed 0.6`: "
        "takes 21.6 s > 10 s: while a gesture plays the robot gives no other cue"
    ), err
    assert "fewer holds or repeats" in err
    assert "no --speed makes it pass (at --speed 1 it still takes" in err
    assert err.count("\n") == 1
    assert not out.exists()
    assert sorted(p.relative_to(recording) for p in recording.rglob("*")) == before


def test_a_too_long_gesture_no_command_plays_does_not_stop_a_talk(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    # session 21's review: a spare gesture in one's file (no command plays it) stopped the
    # talk with "change the gesture", though a talk never plays it (loading it says so)
    spare = tmp_path / "spare.toml"
    spare.write_text(TOO_LONG.replace("slow_down", "my_spare_flourish"))
    out = tmp_path / "out"
    with caplog.at_level(logging.WARNING):
        assert main(["-q", "run", "short_talk", "--gestures", str(spare), "--out", str(out)]) == 0
    assert "no command plays 'my_spare_flourish'" in caplog.text
    assert (out / "summary.json").is_file()


def test_a_gesture_too_slow_at_the_talks_speed_names_the_speed_at_which_it_passes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mine = tmp_path / "mine.toml"
    mine.write_text(SLOW_AT_LOW_SPEED)
    out = tmp_path / "out"
    argv = ["-q", "run", "short_talk", "--gestures", str(mine), "--out", str(out)]
    assert main([*argv, "--speed", "0.08"]) == 2
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith(f"error: {mine}:2: gesture 'slow_down' fails "), first
    assert "> 10 s" in first
    speed = first.partition("or give --speed ")[2].partition(" or more")[0]
    assert speed, first
    # the speed named is the lowest at which `gestures check` passes it, and the talk plays it
    assert check_gestures(float(speed), as_json=False, collisions=False, library=mine)[1] == 0
    below = round(float(speed) - 0.01, 2)
    assert check_gestures(below, as_json=False, collisions=False, library=mine)[1] == 1
    assert main([*argv, "--speed", "0.3"]) == 0
    assert (out / "gestures.toml").exists()


def test_a_refused_talk_leaves_the_session_already_in_its_folder_as_it_was(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `run` writes over the session in --out: refused, it must not have begun to
    recording = tmp_path / "s"
    assert main(["-q", "run", "short_talk", "--out", str(recording)]) == 0
    before = {p: p.read_bytes() for p in recording.rglob("*") if p.is_file()}
    long = tmp_path / "toolong.toml"
    long.write_text(TOO_LONG)
    rc = main(["-q", "run", "short_talk", "--gestures", str(long), "--out", str(recording)])
    assert rc == 2 and "takes 21.6 s > 10 s" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in recording.rglob("*") if p.is_file()} == before


BEYOND = """format = 1
[gestures.gesture_more]
description = "arms too wide"
mirror = true
[[gestures.gesture_more.keyframes]]
pose = { LShoulderPitch = 35.0, LShoulderRoll = 95.0, LElbowRoll = -20.0, LHand = 1.0 }
"""


@pytest.mark.parametrize(
    ("text", "says"),
    [
        (BEYOND, ":5: gesture 'gesture_more' keyframes[0]: LShoulderRoll = 95.0° is outside"),
        (TOO_LONG, ":2: gesture 'slow_down' fails `prezence gestures check"),
        (CLASP, ":2: gesture 'articulate': self-collision: "),
    ],
    ids=["beyond-limit", "too-long", "self-collision"],
)
def test_check_config_with_a_library_fails_what_every_talk_refuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, says: str
) -> None:
    # session 23's walkthrough: `check-config RULES --gestures FILE` said `RULES: ok` (exit 0)
    # for libraries that every talk refused (exit 2)
    if "self-collision" in says:
        pytest.importorskip("pybullet", reason="the self-collision check needs the sim extra")
    rules = tmp_path / "myrules.txt"
    rules.write_text("speech_speed inRange 140 180 speedUp slowDown\n")
    mine = tmp_path / "mine.toml"
    mine.write_text(text)
    assert main(["-q", "check-config", str(rules), "--gestures", str(mine)]) == 1
    captured = capsys.readouterr()
    assert f"{rules}: ok" not in captured.out
    assert captured.err.startswith(f"{mine}{says}"), captured.err
    # and what a talk refuses, it refuses with the same words
    assert (
        main(["-q", "run", "short_talk", "--gestures", str(mine), "--out", str(tmp_path / "s")])
        == 2
    )
    assert f"{mine}{says}" in capsys.readouterr().err


#: a library of one's own that passes every check but self-collision, unchecked without PyBullet
RAISED = (
    'format = 1\n[gestures.articulate]\ndescription = ""\n'
    "[[gestures.articulate.keyframes]]\npose = { LShoulderPitch = 20.0 }\n"
)


def test_check_config_without_pybullet_fails_for_a_robot_what_a_robot_talk_refuses(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # session 23's review: without PyBullet, `check-config RULES --gestures FILE` said ok
    # (exit 0) for a library every talk on --backend naoqi refuses (exit 2)
    from prezence.feedback import collision

    monkeypatch.setattr(collision, "pybullet_available", lambda: False)
    rules = tmp_path / "myrules.txt"
    rules.write_text("speech_speed inRange 140 180 speedUp slowDown\n")
    mine = tmp_path / "mine.toml"
    mine.write_text(RAISED)
    unchecked = f"{mine}: the self-collision of its gestures was not checked"
    # the default backend (fake) plays it: ok, with a note that a robot talk would not
    assert main(["-q", "check-config", str(rules), "--gestures", str(mine)]) == 0
    captured = capsys.readouterr()
    assert f"{rules}: ok" in captured.out
    assert captured.err.startswith(f"warning: {unchecked}"), captured.err
    assert "a talk on a real robot (--backend naoqi) refuses it" in captured.err
    # the backend the talks use: refused as that talk refuses it, in its words
    argv = ["-q", "check-config", str(rules), "--gestures", str(mine), "--backend", "naoqi"]
    assert main(argv) == 1
    captured = capsys.readouterr()
    assert f"{rules}: ok" not in captured.out
    assert captured.err.startswith(unchecked), captured.err
    said = captured.err.strip()
    robot = ["--backend", "naoqi", "--robot", "tcp://127.0.0.1:1"]
    assert main(["-q", "run", "short_talk", *robot, "--gestures", str(mine)]) == 2
    assert capsys.readouterr().err.strip() == f"error: {said}"
    # an unknown backend is named
    assert main(["-q", "check-config", str(rules), "--backend", "nao"]) == 2
    assert "did you mean 'naoqi'?" in capsys.readouterr().err


def test_check_config_for_a_robot_passes_a_library_checked_here(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("pybullet", reason="the self-collision check needs the sim extra")
    rules = tmp_path / "myrules.txt"
    rules.write_text("speech_speed inRange 140 180 speedUp slowDown\n")
    mine = tmp_path / "mine.toml"
    mine.write_text(RAISED)
    argv = ["-q", "check-config", str(rules), "--gestures", str(mine), "--backend", "naoqi"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert f"{rules}: ok" in captured.out and not captured.err, captured.err


def test_a_library_of_every_gesture_is_not_said_to_leave_built_in_ones(tmp_path: Path) -> None:
    # Session 23's verification: a full library through --gestures printed "the other 0
    # gestures … are the built-in ones" and "the others built in".
    from importlib.resources import files

    from prezence.cli import format_timeline

    whole = tmp_path / "all.toml"
    text = (files("prezence.feedback") / "data" / "gestures.toml").read_text()
    whole.write_text("format = 1\n" + text[text.index("\n[gestures.") :])
    out = tmp_path / "s"
    assert main(["-q", "run", "short_talk", "--gestures", str(whole), "--out", str(out)]) in (0, 3)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["gestures"]["built_in"] == []
    assert "built in" not in format_timeline(summary).splitlines()[1]
    text, _ = check_gestures(0.6, as_json=False, library=whole)
    assert "the other 0 gestures" not in text
