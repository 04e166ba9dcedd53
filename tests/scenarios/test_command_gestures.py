"""Every command a talk can give has its gesture, checked before the talk starts.

Session 22's module author added a command (``fewerFillers``, gesture ``fewer_fillers``) to the
command table and forgot the gesture, or misspelt it in ``--gestures``: ``check-config`` said
ok, ``gestures check`` said ok, and the talk stopped at the first such cue (``error: unknown
gesture 'fewer_fillers'``, exit 2), without its summary, report or spoken summary.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from prezence.cli import main
from prezence.feedback import commands as commands_module
from prezence.feedback.commands import Command, commands_path
from prezence.feedback.direction import Direction

#: where the added command is said to be defined (the table is patched, not the file)
LINE = 80
#: a library of one's own that misspells the new command's gesture
TYPO = """format = 1
[gestures.fewer_filers]
description = "A finger to the lips."
[[gestures.fewer_filers.keyframes]]
pose = { RShoulderPitch = 20.0 }
"""
#: the same, spelt right
RIGHT = TYPO.replace("fewer_filers", "fewer_fillers")
RULES = "speech_speed inRange 140 180\nspeech_fillers max 4 above=fewerFillers\n"


@pytest.fixture
def with_fewer_fillers(monkeypatch: pytest.MonkeyPatch) -> None:
    """The command table with ``fewerFillers`` added, as the walkthrough's commands.toml."""
    table = dict(commands_module.load_commands())
    table["fewerFillers"] = Command(
        "fewerFillers",
        Direction.LOWER,
        "fewer_fillers",
        "Try a short pause instead of saying um.",
        where=f"{commands_path()}:{LINE}",
    )
    monkeypatch.setattr(commands_module, "load_commands", lambda: table)


@pytest.fixture
def files(tmp_path: Path) -> tuple[Path, Path, Path]:
    rules = tmp_path / "myrules.txt"
    rules.write_text(RULES)
    typo = tmp_path / "g_typo.toml"
    typo.write_text(TYPO)
    right = tmp_path / "mine.toml"
    right.write_text(RIGHT)
    return rules, typo, right


TALKS = pytest.mark.parametrize(
    "command",
    [
        ["run", "short_talk"],
        ["rehearse", "talk.wav"],
        ["up", "--module", "x=true {session}", "--duration", "2"],
    ],
    ids=["run", "rehearse", "up"],
)


@TALKS
@pytest.mark.usefixtures("with_fewer_fillers")
def test_a_command_whose_gesture_is_missing_stops_every_talk_before_it_starts(
    files: tuple[Path, Path, Path],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    command: list[str],
) -> None:
    rules, typo, _ = files
    out = tmp_path / "out"
    argv = ["-q", *command, "--config", str(rules), "--out", str(out)]
    # the gesture forgotten: only the built-in library
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"error: {commands_path()}:{LINE}: command 'fewerFillers' plays gesture 'fewer_fillers', "
        "which is not in the built-in gestures; "
        f"{rules}:2 (above= of speech_fillers) gives fewerFillers: define "
        "[gestures.fewer_fillers] in a --gestures file"
    ), err
    assert not out.exists()
    # the gesture misspelt in the library of one's own: a did-you-mean, still before the talk
    assert main([*argv, "--gestures", str(typo)]) == 2
    err = capsys.readouterr().err
    assert (
        f"which is not in the built-in gestures nor in {typo} (did you mean 'fewer_filers'?)" in err
    ), err
    assert err.count("\n") == 1
    assert not out.exists()


@pytest.mark.usefixtures("with_fewer_fillers")
def test_a_talk_whose_rules_do_not_give_the_command_is_not_refused(tmp_path: Path) -> None:
    # the command is in the table, but these rules never give it: the talk plays nothing missing
    out = tmp_path / "out"
    assert main(["-q", "run", "short_talk", "--no-report", "--out", str(out)]) == 0
    assert (out / "summary.json").is_file()


@pytest.mark.usefixtures("with_fewer_fillers")
def test_with_the_gesture_in_a_library_of_ones_own_the_talk_runs(
    files: tuple[Path, Path, Path], tmp_path: Path
) -> None:
    rules, _, right = files
    out = tmp_path / "out"
    argv = ["-q", "run", "fast_talker", "--config", str(rules), "--gestures", str(right)]
    assert main([*argv, "--no-report", "--out", str(out)]) in (0, 3)  # 3: expectations
    assert (out / "summary.json").is_file()


@pytest.mark.usefixtures("with_fewer_fillers")
def test_a_replay_with_such_rules_is_refused_before_it_writes(
    files: tuple[Path, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rules, _, _ = files
    recording = tmp_path / "rec"
    assert main(["-q", "run", "short_talk", "--no-report", "--out", str(recording)]) == 0
    capsys.readouterr()
    out = tmp_path / "again"
    argv = ["-q", "replay", str(recording), "--config", str(rules), "--out", str(out)]
    assert main(argv) == 2
    assert "command 'fewerFillers' plays gesture 'fewer_fillers'" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.usefixtures("with_fewer_fillers")
def test_the_coachs_own_commands_are_checked_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # praise given by a command whose gesture is missing: refused as a rule's command is
    config = tmp_path / "praise.toml"
    config.write_text(
        'format = 1\n[processor]\npraise_command = "fewerFillers"\n'
        '[[rules]]\nmetric = "speech_speed"\ncheck = "inRange"\nlow = 140\nhigh = 180\n'
        'below = "speedUp"\nabove = "slowDown"\n'
    )
    out = tmp_path / "out"
    assert main(["-q", "run", "short_talk", "--config", str(config), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "command 'fewerFillers' plays gesture 'fewer_fillers'" in err
    assert "the coach's praise gives fewerFillers" in err, err
    assert not out.exists()


@pytest.mark.usefixtures("with_fewer_fillers")
def test_check_config_fails_rules_whose_command_has_no_gesture(
    files: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    rules, typo, right = files
    assert main(["check-config", str(rules)]) == 1
    captured = capsys.readouterr()
    assert f"{rules}: ok" not in captured.out
    assert captured.err.startswith(
        f"{commands_path()}:{LINE}: command 'fewerFillers' plays gesture 'fewer_fillers', "
        "which is not in the built-in gestures; "
        f"{rules}:2 (above= of speech_fillers) gives fewerFillers"
    ), captured.err
    assert main(["check-config", str(rules), "--gestures", str(typo)]) == 1
    assert "(did you mean 'fewer_filers'?)" in capsys.readouterr().err
    # with the library the talks will play, the rules are fine
    assert main(["check-config", str(rules), "--gestures", str(right)]) == 0
    assert f"{rules}: ok" in capsys.readouterr().out


@pytest.mark.usefixtures("with_fewer_fillers")
def test_gestures_check_fails_a_command_whose_gesture_is_in_no_library(
    files: tuple[Path, Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    _, typo, right = files
    assert main(["gestures", "check", str(typo), "--no-collisions"]) == 1
    out = capsys.readouterr().out
    assert (
        f"FAIL: {commands_path()}:{LINE}: command 'fewerFillers' plays gesture 'fewer_fillers', "
        f"which is not in the built-in gestures nor in {typo} (did you mean 'fewer_filers'?)"
    ) in out, out
    assert main(["gestures", "check", str(typo), "--no-collisions", "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["ok"] is False
    assert [m.split(": command ")[1][:14] for m in report["missing_gestures"]] == ["'fewerFillers'"]
    assert main(["gestures", "check", str(right), "--no-collisions"]) == 0
    assert "FAIL" not in capsys.readouterr().out


@pytest.mark.usefixtures("with_fewer_fillers")
def test_a_talk_built_in_code_is_refused_too(tmp_path: Path) -> None:
    """The Gymnasium env and any other code that builds a :class:`~prezence.talk.Talk` get the
    same check as the commands: refused when it is built, before anything runs."""
    from prezence.backends.registry import make_backend
    from prezence.config.load import load_config
    from prezence.feedback.gesture_check import GestureCheckFailed
    from prezence.session import SessionDir
    from prezence.talk import RunOptions, SourceBase, Talk

    rules = tmp_path / "myrules.txt"
    rules.write_text(RULES)
    with pytest.raises(GestureCheckFailed, match="command 'fewerFillers' plays gesture"):
        Talk(
            SourceBase(),  # type: ignore[arg-type]
            config=load_config(rules),
            session=SessionDir(tmp_path / "s"),
            backend=make_backend("fake"),
            options=RunOptions.default(),
        )
    assert not (tmp_path / "s").exists()
