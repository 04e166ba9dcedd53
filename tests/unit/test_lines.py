"""The seed line format: parsing, the checks shared with TOML, messages with file:line:col."""

from __future__ import annotations

import math

import pytest

from prezence.config.lines import format_rule, parse_lines
from prezence.config.model import Check, RoomProfile, Rule
from prezence.errors import ConfigError

SEED_REVERSED = "speech_speed inRange 140 180 slowDown speedUp"
SEED_ONE_LINE = "speech_speed inRange 140 180 speech_accuracy min 0.8 strict cv_headGaze min ANGLE"


def parse(text: str, room: RoomProfile | None = None) -> tuple[Rule, ...]:
    return parse_lines(text, path="rules.txt", room=room)


def parse_error(text: str, room: RoomProfile | None = None) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        parse(text, room)
    return info.value


def test_positional_commands_are_below_then_above() -> None:
    (r,) = parse("speech_speed inRange 140 180 speedUp slowDown")
    assert (r.check, r.low, r.high) == (Check.IN_RANGE, 140.0, 180.0)
    assert r.command_for(120.0) == "speedUp"
    assert r.command_for(200.0) == "slowDown"


def test_explicit_form_equals_positional_form() -> None:
    explicit = parse("speech_speed inRange 140 180 above=slowDown below=speedUp")
    assert explicit == parse("speech_speed inRange 140 180 speedUp slowDown")


@pytest.mark.parametrize(
    ("line", "low", "high", "below", "above"),
    [
        ("speech_accuracy min 0.8 articulate", 0.8, None, "articulate", None),
        ("cv_gestures max 12 gestureLess", None, 12.0, None, "gestureLess"),
        ("speech_volume min 60", 60.0, None, None, None),
    ],
    ids=["min-takes-below", "max-takes-above", "no-command"],
)
def test_single_bound_checks(
    line: str, low: float | None, high: float | None, below: str | None, above: str | None
) -> None:
    (r,) = parse(line)
    assert (r.low, r.high, r.below, r.above) == (low, high, below, above)


@pytest.mark.parametrize("word", ["inRange", "inrange", "INRANGE", "InRange"])
def test_check_is_case_insensitive_and_normalised(word: str) -> None:
    (r,) = parse(f"cv_gestures {word} 2 12")
    assert r.check is Check.IN_RANGE
    assert f" {Check.IN_RANGE.value} " in format_rule(r)


def test_unknown_check_suggests_the_right_one() -> None:
    e = parse_error("speech_speed inRnage 140 180")
    assert str(e).startswith("rules.txt:1:14: unknown check 'inRnage'; did you mean 'inRange'?")


def test_seed_reversed_example_explains_the_order() -> None:
    e = parse_error(SEED_REVERSED)
    msg = str(e)
    assert (e.line, e.col) == (1, SEED_REVERSED.index("slowDown") + 1)
    assert "<below> <above>" in msg
    assert "below=speedUp above=slowDown" in msg


def test_explicit_reversed_pair_suggests_the_swap() -> None:
    e = parse_error("speech_speed inRange 140 180 below=slowDown above=speedUp")
    assert "below=speedUp above=slowDown" in str(e)


@pytest.mark.parametrize(
    ("line", "fits"),
    [
        ("speech_speed min 140 slowDown", "speedUp"),
        ("speech_speed max 180 above=speedUp", "slowDown"),
        ("speech_speed inRange 140 180 below=speedUp above=louder", "softer"),
    ],
    ids=["min-with-lowering-command", "max-with-raising-command", "one-side-wrong"],
)
def test_command_pointing_the_wrong_way_is_rejected(line: str, fits: str) -> None:
    e = parse_error(line)
    assert fits in str(e)  # the message lists commands that would fit


def test_neutral_commands_fit_either_side() -> None:
    (r,) = parse("talk_time inRange 1 2 encourage encourage")
    assert (r.below, r.above) == ("encourage", "encourage")


@pytest.mark.parametrize(
    ("line", "token"),
    [
        ("x\n\nspeech_speed inRange 140 180 speedUp slowDwn", "slowDwn"),
        ("x\n\nspeech_speed inRange 140 180 below=speedUp above=slowDwn", "slowDwn"),
    ],
    ids=["positional", "explicit"],
)
def test_unknown_command_gives_file_line_col_and_suggestion(line: str, token: str) -> None:
    text = line.replace("x\n", "# rules\n", 1)
    col = text.splitlines()[2].index(token) + 1
    e = parse_error(text)
    assert str(e) == f"rules.txt:3:{col}: unknown command 'slowDwn'; did you mean 'slowDown'?"


def test_named_value_comes_from_the_room() -> None:
    room = RoomProfile(name="hall", values={"ANGLE": -5.0, "FAST": 200.0})
    (gaze, speed) = parse("cv_headGaze min ANGLE lookUp scale=10\nspeech_speed max FAST", room)
    assert gaze.low == -5.0
    assert speed.high == 200.0


def test_unknown_named_value_lists_the_known_ones() -> None:
    room = RoomProfile(name="hall", values={"ANGLE": -5.0, "FAST": 200.0})
    e = parse_error("cv_headGaze min TILT lookUp scale=10", room)
    assert e.col == 17
    assert "unknown named value 'TILT'" in str(e)
    assert "ANGLE, FAST" in str(e)


@pytest.mark.parametrize(
    "line",
    [
        "speech_speed inRange 140",
        "speech_speed inRange 140 180 200",
        "speech_speed min",
        "speech_speed max 1 2",
        "speech_speed",
    ],
    ids=["inRange-one-value", "inRange-three-values", "min-no-value", "max-two-values", "no-check"],
)
def test_wrong_number_of_values(line: str) -> None:
    e = parse_error(line)
    assert e.line == 1
    assert e.col is not None


def test_in_range_needs_low_not_above_high() -> None:
    e = parse_error("speech_speed inRange 180 140")
    assert "low <= high" in str(e)
    (r,) = parse("speech_speed inRange 150 150")
    assert r.low == r.high == 150.0


def test_seed_one_line_text_asks_for_one_rule_per_line() -> None:
    e = parse_error(SEED_ONE_LINE)
    assert "one rule per line" in str(e)
    assert e.col == SEED_ONE_LINE.index("speech_accuracy") + 1


def test_duplicate_metric_names_both_lines() -> None:
    e = parse_error("speech_speed min 140\n# again\nspeech_speed max 180")
    assert e.line == 3
    assert "line 1" in str(e)


@pytest.mark.parametrize(
    "line",
    ["x min 0", "x max -1", "cv_headGaze min ANGLE", "x inRange -5 5", "x inRange 0 5"],
    ids=["zero-low", "negative-high", "named-negative", "straddles-zero", "zero-low-in-range"],
)
def test_bound_at_or_below_zero_needs_scale(line: str) -> None:
    e = parse_error(line, RoomProfile(scales={}))  # a room that gives ANGLE no scale
    assert "scale" in str(e)
    (r,) = parse(f"{line} scale=10")
    bound = r.low if r.low is not None else r.high
    assert bound is not None
    outside = bound - 10.0 if r.low is not None else bound + 10.0
    assert r.deviation(outside) == pytest.approx(100.0)  # one scale outside = 100 %


def test_the_seeds_gaze_line_takes_the_scale_of_its_named_value_from_the_room() -> None:
    (r,) = parse("cv_headGaze min ANGLE")  # exactly as the seed writes it; default room
    assert (r.low, r.scale) == (-15.0, 10.0)
    assert r.deviation(-25.0) == pytest.approx(100.0)
    room = RoomProfile(values={"ANGLE": -20.0}, scales={"ANGLE": 5.0})
    (r,) = parse("cv_headGaze min ANGLE", room)
    assert (r.low, r.scale) == (-20.0, 5.0)
    (r,) = parse("cv_headGaze min ANGLE scale=8", room)  # the rule's own scale wins
    assert r.scale == 8.0


def test_at_listener_applies_the_inverse_square_estimate() -> None:
    room = RoomProfile(laptop_distance_m=1.0, farthest_listener_m=4.0)
    (r,) = parse("speech_volume min 60 louder scale=6 at=listener", room)
    assert r.offset == pytest.approx(-20 * math.log10(4.0))  # -12.04 dB at 4x the distance
    assert r.command_for(70.0) == "louder"  # 70 dB at the laptop is about 58 dB at the back


def test_at_listener_without_a_distance_is_an_error() -> None:
    e = parse_error("speech_volume min 60 louder scale=6 at=listener")
    assert "farthest_listener_m" in str(e)


def test_keys_set_rule_fields() -> None:
    (r,) = parse(
        "speech_volume min 60 strict below=louder scale=6 gain=2 stale=3 "
        'stream=mic.txt unit="dB SPL"'
    )
    assert (r.strict, r.scale, r.gain, r.stale_after_s) == (True, 6.0, 2.0, 3.0)
    assert (r.stream, r.unit) == ("mic.txt", "dB SPL")


def test_range_declares_the_physical_range_of_a_metric_of_your_own() -> None:
    (r,) = parse("fidget_rate max 3 gestureLess unit=1/min range=0..60")
    assert r.physical_range == (0.0, 60.0) and r.value_range == (0.0, 60.0)
    (g,) = parse("gesture_rate inRange 2 12 scale=2 range=-1.5..60")
    assert g.physical_range == (-1.5, 60.0)


@pytest.mark.parametrize(
    ("line", "col", "needle"),
    [
        (
            "fidget_rate max 3 range=60..0",
            25,
            "range needs two finite numbers LO < HI, found 60..0",
        ),
        ("fidget_rate max 3 range=0-60", 25, "range= takes LO..HI, two numbers, e.g. range=0..60"),
        (
            "speech_speed inRange 140 180 range=0..500",
            36,
            "speech_speed has its physical range 0..400 wpm from its record",
        ),
    ],
)
def test_a_bad_range_says_where_and_why(line: str, col: int, needle: str) -> None:
    e = parse_error(line)
    assert needle in str(e) and e.col == col


@pytest.mark.parametrize(
    ("line", "col", "message"),
    [
        (
            "speech_speed inRange 140 9000 speedUp slowDown",
            26,
            "speech_speed is 0..400 wpm (physical range); high 9000 is above every value it "
            "can take, so 'slowDown' is never given",
        ),
        (
            "speech_accuracy min 1.5 articulate",
            21,
            "speech_accuracy is 0..1 (physical range); min 1.5 can never be met",
        ),
        (
            "cv_headGaze min -200 lookUp scale=10",
            17,
            "cv_headGaze is -90..90 degrees (physical range); min -200 is below every value it "
            "can take, so 'lookUp' is never given",
        ),
        (
            "speech_volume min 200 louder scale=6",
            19,
            "speech_volume is 0..130 dB SPL (physical range); min 200 can never be met",
        ),
        (
            "speech_volume min 128 louder offset=-6",
            19,
            "speech_volume is -6..124 dB SPL (physical range, with offset -6); min 128 can never "
            "be met",
        ),
        (
            "fidget_rate max 90 gestureLess range=0..60 unit=1/min",
            17,
            "fidget_rate is 0..60 1/min (physical range); max 90 is above every value it can "
            "take, so 'gestureLess' is never given",
        ),
    ],
)
def test_a_bound_outside_the_physical_range_is_an_error(line: str, col: int, message: str) -> None:
    # check-config said "ok" to each of these (the walkthrough's p1-p4)
    e = parse_error(line)
    assert str(e) == f"rules.txt:1:{col}: {message}"


def test_a_bound_on_the_edge_of_the_physical_range_is_fine() -> None:
    rules = parse("speech_accuracy min 1 articulate\ncv_gestures inRange 0 60 scale=2")
    assert [(r.low, r.high) for r in rules] == [(1.0, None), (0.0, 60.0)]


def test_a_named_value_outside_the_physical_range_names_the_room() -> None:
    room = RoomProfile(name="hall", values={"ANGLE": -200.0})
    e = parse_error("cv_headGaze min ANGLE lookUp scale=10", room)
    assert e.col == 17
    assert str(e).endswith("so 'lookUp' is never given (ANGLE = -200 in room 'hall')")


def test_unknown_key_suggests_the_right_one() -> None:
    e = parse_error("speech_volume min 60 louder scael=6")
    assert "unknown key 'scael'; did you mean 'scale'?" in str(e)
    assert e.col == 29


def test_comments_and_blank_lines_are_ignored() -> None:
    rules = parse('# header\n\n   \nspeech_volume min 60 louder unit="#dB"  # trailing\n')
    assert [(r.metric, r.unit) for r in rules] == [("speech_volume", "#dB")]
    assert rules[0].source == "rules.txt:4"


def test_errors_are_collected_when_asked() -> None:
    errors: list[ConfigError] = []
    rules = parse_lines(
        "speech_speed min 140 slowDwn\nspeech_volume min 60\ncv_gestures max x",
        path="rules.txt",
        errors=errors,
    )
    assert [r.metric for r in rules] == ["speech_volume"]
    assert [e.line for e in errors] == [1, 3]


@pytest.mark.parametrize(
    "rule",
    [
        Rule("speech_speed", Check.IN_RANGE, low=140, high=180, below="speedUp", above="slowDown"),
        Rule("cv_headGaze", Check.MIN, low=-15, scale=10, below="lookUp", unit="deg"),
        Rule("speech_volume", Check.MIN, low=60.5, offset=-6.02, gain=0.5, stream="a b#.txt"),
        Rule("x", Check.MAX, high=1e20, strict=True, stale_after_s=2.5, unit="dB SPL"),
        Rule("fidget_rate", Check.MAX, high=3, physical_range=(-0.5, 60)),
    ],
    ids=["in-range", "negative-bound", "offset-and-quoted-stream", "strict-max", "range"],
)
def test_format_rule_round_trips(rule: Rule) -> None:
    assert parse(format_rule(rule)) == (rule,)


def test_format_rule_rejects_a_rule_the_format_cannot_hold() -> None:
    with pytest.raises(ValueError, match="bounds"):
        format_rule(Rule("x", Check.MIN, low=1.0, high=2.0))
