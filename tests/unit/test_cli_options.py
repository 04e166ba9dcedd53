"""Command-line options shared by the commands: -q/-v anywhere, --room, --allocated."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from prezence.cli import build_parser, main, parse_seconds
from prezence.config.load import default_path

ROOM = 'format = 1\n[room]\nname = "hall"\n[room.values]\nFAST = 170\n'
RULES = "speech_speed inRange 140 FAST speedUp slowDown\n"


@pytest.fixture
def rules_and_room(tmp_path: Path) -> tuple[Path, Path]:
    rules, room = tmp_path / "my_rules.txt", tmp_path / "room.toml"
    rules.write_text(RULES)
    room.write_text(ROOM)
    return rules, room


def test_quiet_and_verbose_work_after_the_subcommand() -> None:
    args = build_parser().parse_args(["run", "demo", "-q"])
    assert args.sub_quiet and not args.quiet
    args = build_parser().parse_args(["-v", "replay", "x", "-vv"])
    assert args.verbose == 1 and args.sub_verbose == 2
    args = build_parser().parse_args(["gestures", "check"])
    assert not hasattr(args, "sub_quiet")  # absent unless given: main() merges them


def test_run_accepts_q_after_the_scenario(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "s"
    assert main(["run", "short_talk", "-q", "--no-report", "--out", str(out)]) == 0
    assert "session folder" in capsys.readouterr().out


def test_check_config_with_a_room(
    rules_and_room: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    rules, room = rules_and_room
    assert main(["check-config", str(rules), "--room", str(room)]) == 0
    assert f"{rules}: ok" in capsys.readouterr().out
    # without the room, the named value is unknown: the error names file, line and column
    assert main(["check-config", str(rules)]) == 1
    assert f"{rules}:1:" in capsys.readouterr().err


def test_a_threshold_outside_the_physical_range_is_refused_by_every_command(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # check-config said "ok" (exit 0) and run went on with a rule that could never be met
    rules = tmp_path / "p2.txt"
    rules.write_text("speech_accuracy min 1.5 articulate\n")
    want = f"{rules}:1:21: speech_accuracy is 0..1 (physical range); min 1.5 can never be met"
    assert main(["check-config", str(rules)]) == 1
    assert capsys.readouterr().err.strip() == want
    recording = tmp_path / "rec"
    recording.mkdir()
    (recording / "speech_speed.txt").write_text("1 150\n")
    for argv in (
        ["run", "short_talk", "--out", str(tmp_path / "a")],
        ["replay", str(recording), "--out", str(tmp_path / "b")],
        ["up", "--module", "x:speech_speed=true", "--out", str(tmp_path / "c")],
        ["rehearse", str(tmp_path / "talk.wav"), "--out", str(tmp_path / "d")],
    ):
        assert main([*argv, "-q", "--config", str(rules)]) == 2, argv
        assert capsys.readouterr().err.strip() == f"error: {want}", argv
    assert not any((tmp_path / d).exists() for d in "abcd")
    # a room whose named value is out of range is refused with the rule that uses it
    room = tmp_path / "room.toml"
    room.write_text("format = 1\n[room.values]\nANGLE = -200.0\n")
    assert main(["run", "short_talk", "-q", "--room", str(room), "--out", str(tmp_path / "e")]) == 2
    assert "min -200 is below every value it can take" in capsys.readouterr().err


def test_check_config_says_a_room_file_goes_to_room(
    rules_and_room: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    rules, room = rules_and_room
    assert main(["check-config", str(rules), str(room)]) == 1
    assert f"give it as --room {room}" in capsys.readouterr().err


def test_check_config_with_a_broken_room_names_it(
    rules_and_room: tuple[Path, Path], capsys: pytest.CaptureFixture[str]
) -> None:
    rules, room = rules_and_room
    room.write_text('[room]\nname = "hall"\n')
    assert main(["check-config", str(rules), "--room", str(room)]) == 1
    assert str(room) in capsys.readouterr().err


def test_run_with_rules_that_use_a_room(rules_and_room: tuple[Path, Path], tmp_path: Path) -> None:
    rules, room = rules_and_room
    out = tmp_path / "s"
    argv = ["run", "short_talk", "--config", str(rules), "--room", str(room), "--out", str(out)]
    assert main([*argv, "-q", "--no-report"]) == 0
    assert "high = 170" in (out / "config.toml").read_text()


@pytest.mark.parametrize(
    ("text", "seconds"), [("36", 36.0), ("36s", 36.0), ("10m", 600.0), ("9:30", 570.0)]
)
def test_parse_seconds(text: str, seconds: float) -> None:
    assert parse_seconds(text) == seconds


@pytest.mark.parametrize("text", ["ten", "0", "-5", "1:xx", "nan"])
def test_parse_seconds_refuses(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        parse_seconds(text)


def test_every_coaching_command_takes_the_new_options() -> None:
    p = build_parser()
    for argv in (
        ["up", "--audio", "mic", "--speech-args=--window 5", "--vision-args", "--fps 5"],
        ["rehearse", "talk.mp4", "--speech-args", "--window 5", "--seed", "2", "--realtime"],
        ["replay", "sessions/demo", "--realtime", "--seed", "1"],
    ):
        args = p.parse_args([*argv, "--allocated", "36", "--room", "room.toml"])
        assert args.allocated == 36.0 and args.room == "room.toml"
    with pytest.raises(SystemExit):  # a live talk is always real time: no such flag
        p.parse_args(["up", "--audio", "mic", "--realtime"])


def test_up_refuses_module_settings_for_a_module_it_does_not_start(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["up", "--audio", "mic", "--vision-args=--fps 5"]) == 2
    assert "--vision-args without --video" in capsys.readouterr().err


def test_run_fails_with_its_own_status_when_the_scenario_expectations_are_missed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # The fast talker must get slowDown; rules that never ask for it miss the expectation.
    rules = tmp_path / "lenient.txt"
    rules.write_text("speech_speed inRange 100 400 speedUp slowDown\n")
    argv = ["run", "fast_talker", "-q", "--no-report", "--out", str(tmp_path / "s")]
    assert main([*argv, "--config", str(rules)]) == 3
    assert "expectations NOT met" in capsys.readouterr().out
    assert main(argv) == 0


def test_check_config_warns_about_a_misspelt_metric(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    rules = tmp_path / "rules.txt"
    rules.write_text("speech_sped inRange 140 180\n")
    assert main(["check-config", str(rules)]) == 0  # a module of your own may write it
    err = capsys.readouterr().err
    assert f"warning: {rules}:1: " in err and "did you mean 'speech_speed'?" in err


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["demo", "--speed", "0"], "--speed: '0': the speed fraction must be in (0, 1]"),
        (["demo", "--speed", "nan"], "the speed fraction must be in (0, 1]"),
        (["replay", "x", "--speed", "1.5"], "the speed fraction must be in (0, 1]"),
        (["run", "demo", "--seed", "-1"], "--seed: '-1': must be 0 or more"),
        (["replay", "x", "--policy", "random", "--seed", "-1"], "must be 0 or more"),
        (["evaluate", "--seeds", "0"], "--seeds: '0': must be 1 or more"),
        (["evaluate", "--jobs", "0"], "--jobs: '0': must be 1 or more"),
        (["evaluate", "--first-seed", "-1"], "--first-seed: '-1': must be 0 or more"),
        (["evaluate", "--presenters", "cost:-1"], "presenter model 'cost:-1'"),
        (["rehearse", "x.wav", "--allocated", "99:99"], "'99:99' is not a length of time"),
        # a value with a dash is not taken for an option (argparse said "expected one argument")
        (["rehearse", "x.wav", "--allocated", "-5m"], "--allocated: '-5m': the time must be > 0"),
        (["up", "--audio", "x.wav", "--allocated", "-1:30"], "'-1:30': the time must be > 0"),
        (["up", "--audio", "x.wav", "--grace", "-30"], "--grace: '-30': must be 0 or more"),
    ],
)
def test_a_bad_value_is_an_error_line_not_a_traceback(
    argv: list[str], says: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as e:
        main(argv)
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert says in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("extra", "line", "says"),
    [
        (
            "[processor]\nthreshold = 5\n",
            4,
            "processor: unknown table 'processor' in a room file; it holds format and [room] "
            "only: give [processor] in the --config file",
        ),
        (
            '[[rules]]\nmetric = "x"\n',
            4,
            "rules: unknown table 'rules' in a room file; it holds format and [room] only: "
            "give [[rules]] in the --config file",
        ),
        ("[romm.values]\nA = 5\n", 4, "romm: unknown table 'romm'; did you mean 'room'?"),
    ],
    ids=["processor", "rules", "typo"],
)
def test_a_room_file_with_another_table_is_refused_naming_it(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], extra: str, line: int, says: str
) -> None:
    room = tmp_path / "room_extra.toml"
    room.write_text(f'format = 1\n[room]\nname = "x"\n{extra}')
    rules = default_path("rules.txt")
    assert main(["check-config", str(rules), "--room", str(room)]) == 1
    cap = capsys.readouterr()
    assert f"{room}:{line}: {says}" in cap.err
    assert ": ok" not in cap.out


def test_only_a_number_option_takes_a_dashed_value_and_nothing_after_a_double_dash() -> None:
    from prezence.cli import _glue_negative_values as glue

    assert glue(["up", "--allocated", "-5m"]) == ["up", "--allocated=-5m"]
    assert glue(["up", "--realtime", "-1"]) == ["up", "--realtime", "-1"]  # a flag takes none
    assert glue(["evaluate", "--", "-1"]) == ["evaluate", "--", "-1"]
    assert glue(["run", "x", "--", "--seed", "-1"]) == ["run", "x", "--", "--seed", "-1"]


@pytest.mark.parametrize(
    "command",
    [
        ["run", "short_talk"],
        ["demo"],
        ["replay", "x"],
        ["rehearse", "talk.wav"],
        ["up", "--module", "x=true {session}", "--duration", "2"],
    ],
    ids=["run", "demo", "replay", "rehearse", "up"],
)
def test_a_speed_at_which_built_in_gestures_take_too_long_is_refused_naming_the_lowest(
    command: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `gestures check --speed 0.05` failed 10 of 13 timings, and talks took that speed: the
    # robot gave no other cue, a time warning included, for up to 19 s at each cue
    out = tmp_path / "out"
    assert main(["-q", *command, "--speed", "0.05", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        "error: --speed 0.05: 10 built-in gestures would take longer than 10 s (articulate "
    ), err
    assert "a time warning included; the lowest speed at which every built-in gesture " in err
    assert err.count("\n") == 1
    assert not out.exists()


def test_the_lowest_speed_named_for_the_built_in_gestures_is_where_gestures_check_passes(
    capsys: pytest.CaptureFixture[str],
) -> None:
    from prezence.feedback.gesture_check import check_gestures

    assert main(["-q", "demo", "--speed", "0.1"]) == 2
    err = capsys.readouterr().err
    lowest = float(err.partition("every built-in gesture passes is ")[2].split()[0])
    assert 0.1 < lowest < 0.6
    assert check_gestures(lowest, as_json=False, collisions=False)[1] == 0
    assert check_gestures(round(lowest - 0.01, 2), as_json=False, collisions=False)[1] == 1


def test_the_built_in_gestures_pass_the_check_from_the_speed_a_talk_trusts() -> None:
    # a talk with the built-in gestures at BUILTIN_PASS_FROM_SPEED or faster skips the check
    # (it cost every process 0.15-0.2 s): the shipped gestures must pass there and above
    from prezence.feedback.gesture_check import GestureCheckFailed, check_talk_gestures
    from prezence.feedback.gestures import BUILTIN_PASS_FROM_SPEED

    for speed in (BUILTIN_PASS_FROM_SPEED, 0.2, 0.35, 0.6, 0.85, 1.0):
        check_talk_gestures(speed, library=None)  # raises if one fails
    with pytest.raises(GestureCheckFailed):
        check_talk_gestures(round(BUILTIN_PASS_FROM_SPEED - 0.01, 2), library=None)


def test_the_header_of_up_from_recordings_does_not_call_it_a_live_speaker() -> None:
    # Session 23's student: `up --audio talk.wav` printed "Talk: live" for a recording.
    from prezence.cli import talk_label

    assert talk_label({"kind": "live"}) == "live"
    played = talk_label({"kind": "live", "recording_s": 60.0})
    assert played == "live, from recordings played to their end"
