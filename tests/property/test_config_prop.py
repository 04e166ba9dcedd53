"""Property tests for the config front ends: round trips, and no stray exceptions on any text."""

from __future__ import annotations

import math
from pathlib import Path

from hypothesis import given
from hypothesis import strategies as st

from prezence.config.lines import command_table, format_rule, parse_lines
from prezence.config.load import default_path
from prezence.config.model import (
    Check,
    Config,
    Direction,
    ProcessorSettings,
    RoomProfile,
    Rule,
    TimeSettings,
)
from prezence.config.tomlconf import DAY_S, SETTING_BOUNDS, dumps_config, loads_config
from prezence.errors import ConfigError
from prezence.metrics import METRICS

COMMANDS = command_table()
RAISING = sorted(n for n, d in COMMANDS.items() if d is not Direction.LOWER)
LOWERING = sorted(n for n, d in COMMANDS.items() if d is not Direction.RAISE)

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)
positive = st.floats(min_value=1e-9, max_value=1e12, allow_nan=False)
# not a shipped metric's name: theirs have a physical range the random bounds would leave
metrics = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,15}", fullmatch=True).filter(
    lambda m: m not in METRICS
)
texts = st.text(
    st.characters(codec="utf-8", exclude_characters='"', exclude_categories=("Cc", "Cs", "Z")),
    max_size=12,
).filter(str.isprintable)
units = st.one_of(st.just(""), st.builds(lambda a, b: f"{a} {b}".strip(), texts, texts))
streams = st.one_of(
    st.just(""), st.from_regex(r"[a-z0-9_]{1,8}(/[a-z0-9_ #]{1,8})?\.txt", fullmatch=True)
)


@st.composite
def rules(draw: st.DrawFn, metric: str | None = None) -> Rule:
    check = draw(st.sampled_from(Check))
    a, b = sorted(draw(st.tuples(finite, finite)))
    low = a if check is not Check.MAX else None
    high = (b if check is Check.IN_RANGE else a) if check is not Check.MIN else None
    bounds = [x for x in (low, high) if x is not None]
    scale = draw(positive) if min(bounds) <= 0 else draw(st.none() | positive)
    offset = draw(st.just(0.0) | finite)
    return Rule(
        metric=metric if metric is not None else draw(metrics),
        check=check,
        low=low,
        high=high,
        strict=draw(st.booleans()),
        below=draw(st.none() | st.sampled_from(RAISING)) if low is not None else None,
        above=draw(st.none() | st.sampled_from(LOWERING)) if high is not None else None,
        scale=scale,
        gain=draw(st.just(1.0) | positive),
        offset=offset,
        stream=draw(streams),
        stale_after_s=draw(st.none() | positive),
        unit=draw(units),
        # a metric with a record has its range there; around the bounds, so that they fit
        physical_range=draw(enclosing(bounds)) if metric is None and offset == 0.0 else None,
    )


@st.composite
def enclosing(draw: st.DrawFn, bounds: list[float]) -> tuple[float, float] | None:
    """None, or a physical range around the bounds (a bound outside it is an error)."""
    if draw(st.booleans()):
        return None
    margin = st.floats(min_value=0.0, max_value=1e6)
    lo, hi = min(bounds) - draw(margin), max(bounds) + draw(margin)
    return (lo, hi) if math.isfinite(lo) and math.isfinite(hi) and lo < hi else None


@given(rules())
def test_format_rule_then_parse_gives_the_rule(rule: Rule) -> None:
    assert parse_lines(format_rule(rule), path="gen.txt") == (rule,)


@st.composite
def configs(draw: st.DrawFn) -> Config:
    names = draw(st.lists(metrics, max_size=4, unique=True))

    def within(key: str, zero: bool = False) -> st.SearchStrategy[float]:
        lo, hi = SETTING_BOUNDS[key]  # the sane bounds the TOML form enforces
        s = st.floats(min_value=lo, max_value=hi)
        return st.just(0.0) | s if zero else s

    processor = ProcessorSettings(
        threshold=draw(within("threshold")),
        decay_half_life_s=draw(within("decay_half_life_s")),
        min_gap_s=draw(within("min_gap_s")),
        refractory_s=draw(within("refractory_s")),
        stale_after_s=draw(within("stale_after_s")),
        decision_period_s=draw(within("decision_period_s")),
        praise_after_s=draw(within("praise_after_s", zero=True)),
        praise_command=draw(st.none() | st.sampled_from(sorted(COMMANDS))),
    )
    time = TimeSettings(
        allocated_s=draw(st.none() | within("allocated_s")),
        warn_at_s_left=tuple(
            draw(st.lists(st.floats(min_value=1e-3, max_value=DAY_S), max_size=3, unique=True))
        ),
        warn_command=draw(st.sampled_from(sorted(COMMANDS))),
        overtime_command=draw(st.sampled_from(sorted(COMMANDS))),
        overtime_repeat_s=draw(within("overtime_repeat_s", zero=True)),
    )
    laptop = draw(st.floats(min_value=0.01, max_value=100.0))
    room = RoomProfile(
        name=draw(st.text(max_size=10)),
        values=draw(st.dictionaries(st.from_regex(r"[A-Z][A-Z0-9_]{0,6}", fullmatch=True), finite)),
        laptop_distance_m=laptop,
        farthest_listener_m=draw(st.none() | st.floats(min_value=laptop, max_value=1000.0)),
    )
    return Config(
        rules=tuple(draw(rules(metric=n)) for n in names),
        processor=processor,
        time=time,
        room=room,
    )


@given(configs())
def test_dumps_config_then_load_gives_the_config(config: Config) -> None:
    assert loads_config(dumps_config(config), path="gen.toml") == config


WORDS = [
    "speech_speed", "cv_headGaze", "min", "max", "inRange", "INRANGE", "140", "-15", "0", "1e999",
    "ANGLE", "ANGEL", "strict", "speedUp", "slowDown", "encourage", "below=", "above=lookUp",
    "scale=10", "scale=0", "at=listener", "offset=-3", "stream=a.txt", 'unit="a b', 'unit="x"',
    "stale=x", "gain=-1", "#", "=", '"', "\t", "\r",
]  # fmt: skip


def assert_located(e: ConfigError, name: str) -> None:
    assert e.path == name
    assert str(e).startswith(name)


fuzz_lines = st.lists(
    st.builds(
        lambda m, c, values, rest: " ".join([m, c, *values, *rest]),
        st.sampled_from(["speech_speed", "cv_headGaze", "9x", ""]),
        st.sampled_from(["min", "max", "inRange", "INRANGE", "mni"]),
        st.lists(st.sampled_from(["140", "180", "-15", "0", "ANGLE", "1e999", ".5"]), max_size=3),
        st.lists(st.sampled_from(WORDS), max_size=5),
    ),
    max_size=4,
).map("\n".join)
rooms = st.sampled_from([RoomProfile(), RoomProfile(farthest_listener_m=8.0)])


@given(st.text() | fuzz_lines, rooms)
def test_any_text_gives_rules_or_a_located_error(text: str, room: RoomProfile) -> None:
    try:
        rules = parse_lines(text, path="fuzz.txt", room=room)
    except ConfigError as e:
        assert_located(e, "fuzz.txt")
        assert e.line is not None
    else:
        assert all(isinstance(r, Rule) for r in rules)


DEFAULT_TOML = default_path().read_text()


@st.composite
def mangled_default(draw: st.DrawFn) -> str:
    """The default config with a few random edits: mostly valid TOML, often invalid config."""
    text = DEFAULT_TOML
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(text)))
        j = draw(st.integers(i, min(len(text), i + 8)))
        text = (
            text[:i] + draw(st.sampled_from(["", "1", "-", '"', "x", "[", "\n", "true"])) + text[j:]
        )
    return text


@given(st.text() | mangled_default())
def test_any_toml_text_gives_a_config_or_a_located_error(text: str) -> None:
    try:
        cfg = loads_config(text, path="fuzz.toml", base_dir=Path("/nonexistent-prezence-dir"))
    except ConfigError as e:
        assert_located(e, "fuzz.toml")
        assert e.line is not None or e.key
    else:
        assert isinstance(cfg, Config)
