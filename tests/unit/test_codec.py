"""One stream line per sample: formatting and parsing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from prezence.errors import PrezenceError
from prezence.streams.codec import StreamLineError, format_line, parse_line


@pytest.mark.parametrize(
    ("t", "value"),
    [(12.5, 153.25), (0.0, -3.0), (0.1, 0.2), (1e-300, 5e-324), (1e300, -1.7976931348623157e308)],
    ids=["plain", "zero-t-negative-value", "decimal-fractions", "tiny", "huge"],
)
def test_format_then_parse_gives_the_same_floats(t: float, value: float) -> None:
    line = format_line(t, value)
    assert line.endswith("\n") and line.count("\n") == 1
    assert parse_line(line) == (t, value)


def test_format_is_compact() -> None:
    assert format_line(12.5, 153.25) == "12.5 153.25\n"
    assert format_line(3, 60) == "3.0 60.0\n"


def test_format_accepts_numpy_scalars_and_writes_plain_numbers() -> None:
    assert format_line(np.float64(1.5), np.float32(0.5)) == "1.5 0.5\n"  # type: ignore[arg-type]


def test_format_writes_negative_zero_t_as_zero() -> None:
    assert format_line(-0.0, 1.0) == "0.0 1.0\n"


@pytest.mark.parametrize(
    ("t", "value", "match"),
    [
        (math.nan, 1.0, "t must be finite"),
        (math.inf, 1.0, "t must be finite"),
        (1.0, math.nan, "value must be finite"),
        (1.0, -math.inf, "value must be finite"),
        (-0.5, 1.0, "t must be >= 0"),
    ],
    ids=["nan-t", "inf-t", "nan-value", "neg-inf-value", "negative-t"],
)
def test_format_rejects_what_a_reader_would_skip(t: float, value: float, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        format_line(t, value)


def test_format_rejects_non_numbers() -> None:
    with pytest.raises(TypeError):
        format_line("1", object())  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("12.5 153.25\n", (12.5, 153.25)),
        ("12.5 153.25\r\n", (12.5, 153.25)),
        ("  7\t-1e-3  ", (7.0, -0.001)),
        ("0.82\n", (None, 0.82)),
        ("+3 .5", (3.0, 0.5)),
        ("-0.0 1", (0.0, 1.0)),
    ],
    ids=["two-fields", "crlf", "tabs-spaces", "bare-value", "signs-leading-dot", "neg-zero-t"],
)
def test_parse_reads_valid_lines(text: str, expected: tuple[float | None, float]) -> None:
    assert parse_line(text) == expected


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("", "blank line"),
        ("hello", "value is not a number: 'hello'"),
        ("12.5 fast", "value is not a number"),
        ("t12 3", "t is not a number"),
        ("1 2 3", "got 3 fields"),
        ("nan", "value is not finite"),
        ("1 NaN", "value is not finite"),
        ("inf 3", "t is not finite"),
        ("1 -Infinity", "value is not finite"),
        ("-1 3", "t is negative"),
        ("1 1_000", "not a plain decimal number"),
        ("1 \u0661\u0662", "not a plain decimal number"),
        ("0x10", "not a number"),
        ("1 1e999", "value is not finite"),
    ],
    ids=[
        "blank",
        "word",
        "word-value",
        "word-t",
        "three-fields",
        "nan",
        "nan-value",
        "inf-t",
        "neg-infinity",
        "negative-t",
        "underscore",
        "arabic-digits",
        "hex",
        "overflow",
    ],
)
def test_parse_rejects_bad_lines_with_a_reason(text: str, match: str) -> None:
    with pytest.raises(StreamLineError, match=match) as info:
        parse_line(text)
    assert match in info.value.reason


def test_parse_error_quotes_only_the_start_of_a_long_field() -> None:
    with pytest.raises(StreamLineError) as info:
        parse_line("x" * 1000)
    assert len(info.value.reason) < 100


def test_stream_line_error_is_a_value_error_and_a_prezence_error() -> None:
    assert issubclass(StreamLineError, ValueError)
    assert issubclass(StreamLineError, PrezenceError)
