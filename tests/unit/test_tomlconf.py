"""The TOML form: schema, key-path messages, rules_file, and dumps_config round trips."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from prezence.config.lines import parse_lines
from prezence.config.model import (
    Check,
    Config,
    ProcessorSettings,
    RoomProfile,
    Rule,
    TimeSettings,
)
from prezence.config.tomlconf import dumps_config, loads_config, loads_room
from prezence.errors import ConfigError

SPEED = """
[[rules]]
metric = "speech_speed"
check = "inRange"
low = 140
high = 180
below = "speedUp"
above = "slowDown"
"""


def load(text: str, **kw: object) -> Config:
    return loads_config(text, path="config.toml", **kw)  # type: ignore[arg-type]


def load_error(text: str) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load(text)
    return info.value


def test_minimal_config_takes_the_dataclass_defaults() -> None:
    cfg = load("format = 1\n" + SPEED)
    assert cfg.processor == ProcessorSettings()
    assert cfg.time == TimeSettings()
    assert cfg.room == RoomProfile()
    assert cfg.rules == parse_lines("speech_speed inRange 140 180 speedUp slowDown")


@pytest.mark.parametrize(
    ("text", "needle"),
    [(SPEED, "missing 'format = 1'"), ("format = 2\n" + SPEED, "format 2 is not supported")],
    ids=["missing", "newer"],
)
def test_format_is_required(text: str, needle: str) -> None:
    e = load_error(text)
    assert e.key == "format"
    assert needle in str(e)


def test_syntax_error_reports_tomllib_line_and_column() -> None:
    e = load_error("format = 1\n\n[[rules]\nmetric = 1\n")
    assert (e.path, e.line) == ("config.toml", 3)
    assert e.col is not None
    assert str(e).startswith("config.toml:3:")


def test_unknown_command_reports_the_key_path() -> None:
    text = (
        "format = 1\n"
        + SPEED
        + SPEED.replace("speech_speed", "speech_rate").replace('"slowDown"', '"slowDwn"')
    )
    e = load_error(text)
    assert e.key == "rules[1].above"
    assert e.line == text.splitlines().index('above = "slowDwn"') + 1
    assert str(e).endswith("rules[1].above: unknown command 'slowDwn'; did you mean 'slowDown'?")


@pytest.mark.parametrize(
    ("section", "key", "path", "suggestion"),
    [
        ("", "romm = 1", "romm", "room"),
        ("[processor]", "treshold = 5.0", "processor.treshold", "threshold"),
        ("[time]", "allocated = 5.0", "time.allocated", "allocated_s"),
        ("[room]", "farthest_listener = 5.0", "room.farthest_listener", "farthest_listener_m"),
        (
            "[[rules]]",
            'metric = "x"\ncheck = "min"\nlow = 1\nbelw = "louder"',
            "rules[0].belw",
            "below",
        ),
    ],
    ids=["top", "processor", "time", "room", "rule"],
)
def test_unknown_keys_suggest_the_right_one(
    section: str, key: str, path: str, suggestion: str
) -> None:
    rules = "" if section == "[[rules]]" else "rules = []\n"
    e = load_error(f"format = 1\n{rules}{section}\n{key}\n")
    assert e.key == path
    assert f"did you mean '{suggestion}'?" in str(e)


def test_reversed_pair_suggests_toml_syntax() -> None:
    e = load_error(
        "format = 1\n"
        + SPEED.replace("speedUp", "X").replace("slowDown", "speedUp").replace("X", "slowDown")
    )
    assert e.key == "rules[0].below"
    assert 'below = "speedUp" above = "slowDown"' in str(e)


def test_named_value_as_string_and_room_override() -> None:
    text = 'format = 1\n[room.values]\nANGLE = -20\n[[rules]]\nmetric = "cv_headGaze"\n'
    text += 'check = "min"\nlow = "ANGLE"\nscale = 10\nbelow = "lookUp"\n'
    assert load(text).rules[0].low == -20.0
    assert load(text, room=RoomProfile(values={"ANGLE": -3.0})).rules[0].low == -3.0


def test_unknown_named_value_lists_the_room() -> None:
    e = load_error('format = 1\n[[rules]]\nmetric = "g"\ncheck = "min"\nlow = "ANGEL"\nscale = 1\n')
    assert e.key == "rules[0].low"
    assert "ANGLE" in str(e)


def test_zero_bound_needs_scale_in_toml_too() -> None:
    e = load_error('format = 1\n[[rules]]\nmetric = "g"\ncheck = "max"\nhigh = 0\n')
    assert e.key == "rules[0].high"
    assert "scale = 10" in str(e)


def test_at_listener_uses_the_room_distances() -> None:
    text = "format = 1\n[room]\nlaptop_distance_m = 0.5\nfarthest_listener_m = 8.0\n"
    text += '[[rules]]\nmetric = "speech_volume"\ncheck = "min"\nlow = 60\nat = "listener"\n'
    cfg = load(text)
    assert cfg.rules[0].offset == pytest.approx(cfg.room.listener_offset_db())
    assert cfg.rules[0].offset == pytest.approx(-24.08, abs=0.01)  # 16x the distance


def test_duplicate_metric_points_at_both_rules() -> None:
    e = load_error("format = 1\n" + SPEED + SPEED)
    assert e.key == "rules[1].metric"
    assert "rules[0]" in str(e)


@pytest.mark.parametrize(
    ("body", "key"),
    [
        ("[processor]\nmin_gap_s = true", "processor.min_gap_s"),
        ("[processor]\nthreshold = -1", "processor.threshold"),
        ("[time]\nwarn_at_s_left = [60, 60]", "time.warn_at_s_left"),
        ('[time]\nwarn_command = "tiemLeft"', "time.warn_command"),
        ("[room]\nlaptop_distance_m = 2\nfarthest_listener_m = 1", "room.farthest_listener_m"),
        ("[room.values]\nangle = 1", "room.values.angle"),
        ("[processor]\ndecay_half_life_s = inf", "processor.decay_half_life_s"),
    ],
    ids=[
        "bool-for-number",
        "negative",
        "repeated-warning",
        "unknown-command",
        "listener-nearer",
        "lowercase-name",
        "infinite",
    ],
)
def test_bad_setting_values_name_their_key(body: str, key: str) -> None:
    e = load_error(f"format = 1\nrules = []\n{body}\n")
    assert e.key == key


def test_false_disables_praise_and_time_warnings() -> None:
    cfg = load(
        "format = 1\nrules = []\n[processor]\npraise_command = false\n[time]\nallocated_s = false\n"
    )
    assert cfg.processor.praise_command is None
    assert cfg.time.allocated_s is None
    assert load(dumps_config(cfg)) == cfg


def test_rules_file_is_read_relative_to_the_toml(tmp_path: Path) -> None:
    (tmp_path / "rules.txt").write_text("speech_speed inRange 140 180 speedUp slowDown\n")
    cfg = loads_config('format = 1\nrules_file = "rules.txt"\n', path=tmp_path / "c.toml")
    assert cfg.rules == load("format = 1\n" + SPEED).rules


def test_rules_file_errors_carry_that_file(tmp_path: Path) -> None:
    (tmp_path / "rules.txt").write_text("speech_speed inRange 140 180 slowDown speedUp\n")
    with pytest.raises(ConfigError) as info:
        loads_config('format = 1\nrules_file = "rules.txt"\n', path=tmp_path / "c.toml")
    assert (info.value.path, info.value.line) == (str(tmp_path / "rules.txt"), 1)


def test_rules_file_and_rules_together_are_an_error() -> None:
    e = load_error('format = 1\nrules_file = "rules.txt"\n' + SPEED)
    assert e.key == "rules_file"


def test_missing_rules_is_an_error() -> None:
    e = load_error("format = 1\n")
    assert "no rules" in str(e)


def test_dumps_round_trips_awkward_values() -> None:
    cfg = Config(
        rules=(
            Rule(
                "speech_volume",
                Check.MIN,
                low=60.0,
                below="louder",
                scale=6.0,
                offset=-12.5,
                unit="dB \\ # \u00e9",
                stream="mic/volume.txt",
            ),
            Rule("cv_gestures", Check.IN_RANGE, low=2, high=12, strict=True, gain=0.25),
        ),
        processor=ProcessorSettings(threshold=1e-3, min_gap_s=0.0),
        time=TimeSettings(allocated_s=300.0, warn_at_s_left=(30.0, 90.0, 5.5)),
        room=RoomProfile(
            name='Hall "\u00e9" #1\\\n\t\x7f',
            values={"ANGLE": -7.5, "X_2": 1e300},
            laptop_distance_m=0.7,
            farthest_listener_m=12.0,
        ),
    )
    assert load(dumps_config(cfg)) == cfg


def test_range_is_a_rule_key_and_round_trips() -> None:
    body = '[[rules]]\nmetric = "fidget_rate"\ncheck = "max"\nhigh = 3\nrange = [0, 60]\n'
    cfg = load("format = 1\n" + body)
    assert cfg.rules[0].physical_range == (0.0, 60.0)
    assert cfg.rules == parse_lines("fidget_rate max 3 range=0..60")
    assert load(dumps_config(cfg)) == cfg
    e = load_error("format = 1\n" + body.replace("[0, 60]", "[60, 0]"))
    assert "rules[0].range: range needs two finite numbers LO < HI, found [60, 0]" in str(e)
    e = load_error("format = 1\n" + body.replace("[0, 60]", '"0..60"'))
    assert "rules[0].range: range takes [LO, HI], two numbers" in str(e)


def test_a_bound_outside_the_physical_range_is_an_error_in_toml_too() -> None:
    e = load_error(
        'format = 1\n[room.values]\nANGLE = -200.0\n[[rules]]\nmetric = "cv_headGaze"\n'
        'check = "min"\nlow = "ANGLE"\nscale = 10\nbelow = "lookUp"\n'
    )
    assert str(e) == (
        "config.toml:7: rules[0].low: cv_headGaze is -90..90 degrees (physical range); min -200 "
        "is below every value it can take, so 'lookUp' is never given (ANGLE = -200 in room "
        "'default')"
    )


def test_loads_room_reads_the_room_table() -> None:
    room = loads_room('format = 1\n[room]\nname = "hall"\nvalues = { ANGLE = -5 }\n', path="r.toml")
    assert room == RoomProfile(name="hall", values={"ANGLE": -5.0})


def test_every_setting_field_is_a_toml_key() -> None:
    """A field added to the settings dataclasses must be readable from TOML."""
    cfg = load(dumps_config(Config(rules=())))
    for settings in (cfg.processor, cfg.time):
        for f in dataclasses.fields(settings):
            assert f.name in dumps_config(cfg)


@pytest.mark.parametrize("kind", ["gestures", "scenario", "config"])
def test_every_toml_file_reports_line_and_column_of_a_syntax_error(
    kind: str, tmp_path: Path
) -> None:
    """One reader for all: the position is given on Pythons whose tomllib keeps it only in the
    message (before 3.14) as on those with attributes."""
    from prezence.config.load import load_config
    from prezence.errors import ConfigError
    from prezence.feedback.gestures import parse_library
    from prezence.feedback.limits import load_limits
    from prezence.synthetic.scenario import read_scenario

    text = 'format = 1\nname = "x"\nbad = = 2\n'
    path = tmp_path / "f.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as e:
        if kind == "gestures":
            parse_library(text, limits=load_limits(), path=str(path))
        elif kind == "scenario":
            read_scenario(path)
        else:
            load_config(path)
    assert str(e.value).startswith(f"{path}:3:7: ")
