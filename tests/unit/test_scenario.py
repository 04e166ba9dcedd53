"""Scenario files: parsing, times, errors with key paths, and the expectation checks."""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import pytest

from prezence.errors import ConfigError, UnknownName
from prezence.synthetic.scenario import (
    EpisodeKind,
    Scenario,
    check_expectations,
    format_time,
    list_scenarios,
    load_scenario,
    parse_time,
    read_scenario,
)

MINIMAL: dict[str, Any] = {
    "format": 1,
    "name": "tiny",
    "description": "A tiny talk.",
    "duration_s": "10:00",
    "metrics": {
        "speech_speed": {"baseline": 160.0, "noise": 5.0, "rate_hz": 1.0},
        "cv_headGaze": {"baseline": 0.0, "noise": 2.0, "rate_hz": 5.0},
    },
    "episodes": [
        {"metric": "speech_speed", "kind": "step", "at": "3:00", "value": 200.0},
        {"metric": "cv_headGaze", "kind": "hold", "at": "5:00", "until": "7:00", "value": -35.0},
    ],
}


def doc(**changes: Any) -> dict[str, Any]:
    """A deep copy of MINIMAL with top-level keys replaced (None removes a key)."""
    d = copy.deepcopy(MINIMAL)
    for k, v in changes.items():
        if v is None:
            d.pop(k, None)
        else:
            d[k] = v
    return d


def parse_error(d: dict[str, Any], path: str = "fast_talker.toml") -> ConfigError:
    with pytest.raises(ConfigError) as info:
        Scenario.from_dict(d, path=path)
    return info.value


def cue(t: float, command: str, metric: str | None = None) -> dict[str, Any]:
    return {"t": t, "command": command, "metric": metric}


# -- times ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("text", "seconds"),
    [
        ("3:00", 180.0),
        ("1:10.5", 70.5),
        ("0:07", 7.0),
        ("1:02:03", 3723.0),
        ("90", 90.0),
        (" 2:30 ", 150.0),
        (90, 90.0),
        (1.5, 1.5),
    ],
    ids=repr,
)
def test_parse_time_accepts_seconds_and_clock_strings(text: object, seconds: float) -> None:
    assert parse_time(text) == seconds


@pytest.mark.parametrize(
    "text", ["3:7x", "-1", -5, "3:60", "1:60:00", "nan", "inf", True, [1], "", "3:"], ids=repr
)
def test_parse_time_rejects_non_times(text: object) -> None:
    with pytest.raises(ValueError):
        parse_time(text)


@pytest.mark.parametrize("seconds", [0.0, 59.9, 70.5, 180.0, 3599.0])
def test_format_time_round_trips_through_parse_time(seconds: float) -> None:
    assert parse_time(format_time(seconds)) == pytest.approx(seconds)


# -- the built-in files -----------------------------------------------------------------------


def test_the_required_personas_exist() -> None:
    names = set(list_scenarios())
    required = {
        "ideal",
        "fast_talker",
        "quiet_speaker",
        "note_reader",
        "stiff_presenter",
        "overrunning",
        "report_conflict",
        "brief_glance",
        "demo",
    }
    assert required <= names


@pytest.mark.parametrize("name", list_scenarios(), ids=str)
def test_builtin_scenario_loads_and_round_trips(name: str) -> None:
    s = load_scenario(name)
    assert s.name == name
    assert s.description
    assert s.expect.cues or s.expect.forbidden, "every persona states what the coach must do"
    assert Scenario.from_dict(s.to_dict()) == s


def test_load_by_path_equals_load_by_name() -> None:
    by_name = load_scenario("demo")
    assert load_scenario(Path(by_name.source)) == by_name
    assert load_scenario(by_name.source) == by_name


def test_unknown_scenario_name_suggests_the_closest() -> None:
    with pytest.raises(UnknownName, match="did you mean 'fast_talker'"):
        load_scenario("fast_talkr")


def test_missing_scenario_file_is_a_config_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="no such scenario file"):
        load_scenario(tmp_path / "nope.toml")


# -- parsing ----------------------------------------------------------------------------------


def test_minimal_document_parses_with_times_in_seconds() -> None:
    s = Scenario.from_dict(doc())
    assert s.duration_s == 600.0
    assert s.allocated_s is None
    assert s.metric("speech_speed").rate_hz == 1.0
    hold = s.episodes[1]
    assert (hold.kind, hold.at, hold.until, hold.value) == (EpisodeKind.HOLD, 300.0, 420.0, -35.0)


def test_glance_is_given_by_its_length() -> None:
    episodes = [{"metric": "cv_headGaze", "kind": "glance", "at": "1:10", "duration_s": 1.5,
                 "value": -35.0}]  # fmt: skip
    s = Scenario.from_dict(doc(episodes=episodes))
    assert (s.episodes[0].at, s.episodes[0].until) == (70.0, 71.5)


def test_reaction_entries_inherit_from_default() -> None:
    reactions = {
        "default": {"probability": 0.5, "delay_s": [2, 4], "lasts_s": 30},
        "lookUp": {"probability": 0.0},
    }
    s = Scenario.from_dict(doc(reactions=reactions))
    look_up = s.reaction("lookUp")
    assert look_up.probability == 0.0
    assert look_up.delay_s == (2.0, 4.0)
    assert look_up.lasts_s == (30.0, 30.0)
    assert s.reaction("slowDown") == s.reactions["default"]


def test_window_with_within_s_is_relative_to_after() -> None:
    expect = {"cues": [{"command": "slowDown", "after": "3:00", "within_s": 45}]}
    s = Scenario.from_dict(doc(expect=expect))
    assert (s.expect.cues[0].after, s.expect.cues[0].before) == (180.0, 225.0)


def test_name_defaults_to_the_file_stem(tmp_path: Path) -> None:
    path = tmp_path / "my_persona.toml"
    path.write_text(
        'format = 1\ndescription = "x"\nduration_s = 60\n[metrics.speech_speed]\nbaseline = 150.0\n'
    )
    assert read_scenario(path).name == "my_persona"


def test_episode_error_names_file_and_key_path() -> None:
    d = doc()
    d["episodes"][1]["at"] = "3:7x"
    e = parse_error(d)
    assert str(e).startswith("fast_talker.toml: episodes[1].at: ")
    assert e.key == "episodes[1].at"


@pytest.mark.parametrize(
    ("fmt", "expected"), [(None, "found None"), (2, "found 2")], ids=["missing", "two"]
)
def test_format_is_checked(fmt: int | None, expected: str) -> None:
    e = parse_error(doc(format=fmt))
    assert e.key == "format"
    assert expected in str(e)


def test_unknown_top_level_key_suggests_the_closest() -> None:
    d = doc()
    d["duraton_s"] = 60
    e = parse_error(d)
    assert e.key == "duraton_s"
    assert "did you mean 'duration_s'" in str(e)


def test_unknown_metric_table_suggests_the_closest() -> None:
    metrics = {"speech_sped": {"baseline": 160.0}}
    e = parse_error(doc(metrics=metrics, episodes=[]))
    assert e.key == "metrics.speech_sped"
    assert "did you mean 'speech_speed'" in str(e)


def test_episode_metric_must_be_one_the_scenario_defines() -> None:
    d = doc()
    d["episodes"][0]["metric"] = "speech_sped"
    e = parse_error(d)
    assert e.key == "episodes[0].metric"
    assert "did you mean 'speech_speed'" in str(e)


def test_unknown_command_in_expectations_suggests_the_closest() -> None:
    e = parse_error(doc(expect={"cues": [{"command": "slowDwn"}]}))
    assert e.key == "expect.cues[0].command"
    assert "did you mean 'slowDown'" in str(e)


def test_unknown_reaction_command_suggests_the_closest() -> None:
    e = parse_error(doc(reactions={"lookUP": {"probability": 0.0}}))
    assert e.key == "reactions.lookUP"
    assert "did you mean 'lookUp'" in str(e)


def test_unknown_episode_kind_lists_the_kinds() -> None:
    d = doc()
    d["episodes"][0]["kind"] = "stepp"
    e = parse_error(d)
    assert e.key == "episodes[0].kind"
    assert "did you mean 'step'" in str(e)


def _set(d: dict[str, Any], dotted: str, value: Any) -> dict[str, Any]:
    node: Any = d
    parts = dotted.split(".")
    for p in parts[:-1]:
        node = node[int(p)] if isinstance(node, list) else node.setdefault(p, {})
    node[parts[-1]] = value
    return d


BAD_VALUES = [
    ("metrics.speech_speed.noise", -1.0, "metrics.speech_speed.noise"),
    ("metrics.speech_speed.rate_hz", 0, "metrics.speech_speed.rate_hz"),
    ("metrics.speech_speed.rate_hz", "fast", "metrics.speech_speed.rate_hz"),
    ("metrics.speech_speed.garbage", 1.5, "metrics.speech_speed.garbage"),
    ("metrics.speech_speed.baseline", math.nan, "metrics.speech_speed.baseline"),
    (
        "metrics.speech_speed.dropout",
        [{"from": "5:00", "to": "4:00"}],
        "metrics.speech_speed.dropout[0].to",
    ),
    ("duration_s", 0, "duration_s"),
    ("seed", -1, "seed"),
    ("seed", 1.5, "seed"),
    ("episodes.1.until", "4:00", "episodes[1].until"),
    ("episodes.0.until", "4:00", "episodes[0].until"),
    ("episodes.0.at", "11:00", "episodes[0].at"),
    ("episodes.0.value", "fast", "episodes[0].value"),
    ("metrics.speech_speed.baseline", 2500.0, "metrics.speech_speed.baseline"),
    ("episodes.0.value", 401.0, "episodes[0].value"),
    ("reactions.default.probability", 2.0, "reactions.default.probability"),
    ("reactions.default.size", [0.9, 0.1], "reactions.default.size"),
    ("reactions.default.delay_s", [1, 2, 3], "reactions.default.delay_s"),
    ("expect.max_cues", -1, "expect.max_cues"),
]


@pytest.mark.parametrize(
    ("dotted", "value", "key"), BAD_VALUES, ids=[f"{d}={v!r}" for d, v, _ in BAD_VALUES]
)
def test_bad_values_name_their_key(dotted: str, value: Any, key: str) -> None:
    e = parse_error(_set(doc(), dotted, value))
    assert e.key == key


def test_glance_needs_its_length() -> None:
    episodes = [{"metric": "cv_headGaze", "kind": "glance", "at": "1:10", "value": -35.0}]
    assert parse_error(doc(episodes=episodes)).key == "episodes[0].duration_s"


def test_a_window_takes_before_or_within_not_both() -> None:
    expect = {"none": [{"command": "lookUp", "after": 10, "before": 20, "within_s": 5}]}
    assert parse_error(doc(expect=expect)).key == "expect.none[0]"


def test_a_cue_cannot_be_both_expected_and_forbidden() -> None:
    expect = {"forbid": ["lookUp"], "cues": [{"command": "lookUp", "after": 10}]}
    assert parse_error(doc(expect=expect)).key == "expect.cues[0]"


def test_toml_syntax_error_reports_line_and_column(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text('format = 1\nname = "x"\nduration_s = = 3\n')
    with pytest.raises(ConfigError) as info:
        read_scenario(path)
    assert (info.value.line, info.value.col) == (3, 14)
    assert str(info.value).startswith(f"{path}:3:14: ")


def test_a_value_outside_the_physical_range_is_refused_with_file_line_and_key(
    tmp_path: Path,
) -> None:
    # baseline = 2500 ran, and the presenter was clamped to 400 wpm without a word
    path = tmp_path / "sc_bad.toml"
    path.write_text(
        'format = 1\ndescription = "x"\nduration_s = 60\n\n[metrics.speech_speed]\n'
        "baseline = 2500.0\nnoise = 5.0\n\n[metrics.speech_accuracy]\nbaseline = 0.9\n\n"
        '[[episodes]]\nmetric = "speech_accuracy"\nkind = "step"\nat = 10\nvalue = 1.5\n'
    )
    with pytest.raises(ConfigError) as info:
        read_scenario(path)
    assert str(info.value) == (
        f"{path}:6: metrics.speech_speed.baseline: speech_speed is 0..400 wpm (physical range); "
        "2500 is outside it (the presenter would be held at the edge)"
    )
    path.write_text(path.read_text().replace("2500.0", "400.0"))  # the edge itself is fine
    with pytest.raises(ConfigError) as info:
        read_scenario(path)
    assert str(info.value) == (
        f"{path}:16: episodes[0].value: speech_accuracy is 0..1 (physical range); 1.5 is "
        "outside it (the presenter would be held at the edge)"
    )
    # the type errors of before now carry their line too
    path.write_text(path.read_text().replace("1.5", "1.0").replace("5.0", '"five"'))
    with pytest.raises(ConfigError) as info:
        read_scenario(path)
    assert str(info.value) == f"{path}:7: metrics.speech_speed.noise: expected a number, got 'five'"


# -- expectations -----------------------------------------------------------------------------


def scenario_expecting(**expect: Any) -> Scenario:
    return Scenario.from_dict(doc(expect=expect))


def test_expected_cue_inside_its_window_passes() -> None:
    s = scenario_expecting(cues=[{"command": "slowDown", "metric": "speech_speed",
                                  "after": "3:00", "within_s": 45}])  # fmt: skip
    assert check_expectations(s, [cue(200.0, "slowDown", "speech_speed")]) == []


@pytest.mark.parametrize(
    "cues",
    [[], [cue(230.0, "slowDown", "speech_speed")], [cue(200.0, "slowDown", "cv_headGaze")]],
    ids=["none", "too-late", "other-metric"],
)
def test_expected_cue_missing_fails_with_a_sentence(cues: list[dict[str, Any]]) -> None:
    s = scenario_expecting(cues=[{"command": "slowDown", "metric": "speech_speed",
                                  "after": "3:00", "within_s": 45}])  # fmt: skip
    failures = check_expectations(s, cues)
    assert len(failures) == 1
    assert failures[0].startswith("expected slowDown (speech_speed) between 3:00 and 3:45")


def test_min_and_max_count() -> None:
    s = scenario_expecting(cues=[{"command": "gestureMore", "min_count": 2, "max_count": 3}])
    one = [cue(10.0, "gestureMore")]
    four = [cue(t, "gestureMore") for t in (10.0, 100.0, 200.0, 300.0)]
    assert check_expectations(s, one + [cue(20.0, "gestureMore")]) == []
    assert "at least 2×" in check_expectations(s, one)[0]
    assert "at most 3×" in check_expectations(s, four)[0]


def test_forbidden_cue_fails_only_inside_its_window() -> None:
    s = scenario_expecting(none=[{"command": "lookUp", "after": "4:07", "before": "5:00"}])
    assert check_expectations(s, [cue(240.0, "lookUp"), cue(305.0, "lookUp")]) == []
    failures = check_expectations(s, [cue(253.5, "lookUp")])
    assert failures == ["lookUp is forbidden between 4:07 and 5:00, but came at 4:13.5"]


def test_forbid_list_covers_the_whole_talk() -> None:
    s = scenario_expecting(forbid=["lookUp"])
    assert check_expectations(s, [cue(1.0, "encourage")]) == []
    assert check_expectations(s, [cue(590.0, "lookUp")]) != []


@pytest.mark.parametrize(
    ("cues", "ok"),
    [
        ([], True),
        ([cue(10.0, "lookUp")], True),
        ([cue(10.0, "lookUp"), cue(50.0, "articulate")], True),
        ([cue(10.0, "articulate"), cue(50.0, "lookUp")], False),
        ([cue(10.0, "articulate")], False),
    ],
    ids=["neither", "first-only", "in-order", "reversed", "then-only"],
)
def test_order(cues: list[dict[str, Any]], ok: bool) -> None:
    s = scenario_expecting(order=[{"first": "lookUp", "then": "articulate"}])
    assert (check_expectations(s, cues) == []) is ok


def test_only_allows_listed_and_expected_commands() -> None:
    s = scenario_expecting(only=["encourage"], cues=[{"command": "timeLeft", "after": "8:00"}])
    fine = [cue(150.0, "encourage"), cue(481.0, "timeLeft")]
    assert check_expectations(s, fine) == []
    failures = check_expectations(s, [*fine, cue(600.0, "overtime")])
    assert failures == ["unexpected cues: overtime at 10:00 (allowed: encourage, timeLeft)"]


def test_max_cues() -> None:
    s = scenario_expecting(max_cues=2)
    assert check_expectations(s, [cue(1.0, "encourage"), cue(2.0, "encourage")]) == []
    assert len(check_expectations(s, [cue(float(t), "encourage") for t in range(3)])) == 1


def test_a_talk_longer_than_six_hours_is_refused_before_any_sample_is_made() -> None:
    # a typo's 1e12 s once asked numpy for 72 TiB of samples
    e = parse_error(doc(duration_s=1e12))
    assert e.key == "duration_s" and "at most 21600 s" in str(e)
