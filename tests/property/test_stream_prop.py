"""Stream lines round-trip, and any chunking of a file gives the samples of the whole file."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from prezence.samples import Sample
from prezence.streams.codec import StreamLineError, format_line, parse_line
from prezence.streams.tail import MAX_LINE_BYTES, StreamTailer, read_stream

M = "m"
NOW = 7.0  # the reader's time for bare values, the same at every poll
SETTINGS = settings(deadline=None, suppress_health_check=[HealthCheck.too_slow])

finite = st.floats(allow_nan=False, allow_infinity=False)
times = st.floats(min_value=0.0, allow_nan=False, allow_infinity=False)


@given(times, finite)
def test_format_then_parse_is_exact(t: float, value: float) -> None:
    assert parse_line(format_line(t, value)) == (t, value)


@given(st.text())
def test_any_text_parses_to_finite_numbers_or_a_stream_line_error(text: str) -> None:
    try:
        t, value = parse_line(text)
    except StreamLineError as e:
        assert e.reason
    else:
        assert math.isfinite(value)
        assert t is None or (math.isfinite(t) and t >= 0.0)


# One line of a stream file: its bytes (no newline) and what a reader must make of it:
# a Sample, None for a blank line, or "bad".
Line = tuple[bytes, Sample | None | str]

valid = st.builds(
    lambda t, v, crlf: (format_line(t, v).rstrip("\n").encode() + crlf, Sample(M, t, v)),
    times,
    finite,
    st.sampled_from([b"", b"\r", b" \t"]),
)
bare = finite.map(lambda v: (repr(v).encode(), Sample(M, NOW, v)))
blank = st.sampled_from([b"", b" ", b"\t", b"\r", b"  \r"]).map(lambda b: (b, None))
bad = st.sampled_from(
    [
        b"hello",
        b"1 2 3",
        b"nan",
        b"1 inf",
        b"-1 5",
        b"1 1_000",
        b"\xff\xfe",
        b"2 \xc3",
        b"\xd9\xa3",  # an Arabic-Indic digit, valid UTF-8
        b"0x10",
        b"1 1e999",
        b"\x00",
        b"9" * (MAX_LINE_BYTES + 1),
    ]
).map(lambda b: (b, "bad"))
lines = st.lists(st.one_of(valid, bare, blank, bad), max_size=30)


def _chunks(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({c % (len(data) + 1) for c in cuts} | {0, len(data)})
    return [data[a:b] for a, b in zip(points, points[1:], strict=False)]


def _follow(path: Path, chunks: list[bytes]) -> tuple[list[Sample], StreamTailer]:
    """Append chunk, poll, repeat; then finish."""
    tail = StreamTailer(path, M)
    got = tail.poll(NOW)  # the file does not exist yet
    for chunk in chunks:
        with open(path, "ab") as f:
            f.write(chunk)
        got += tail.poll(NOW)
    tail.finish()
    return got, tail


@SETTINGS
@given(lines, st.binary(max_size=20), st.lists(st.integers(min_value=0), max_size=12))
def test_any_chunking_gives_the_samples_of_the_whole_file(
    spec: list[Line], torn: bytes, cuts: list[int]
) -> None:
    data = b"".join(b + b"\n" for b, _ in spec)
    torn = torn.replace(b"\n", b"")
    data += torn  # an unterminated last line is never parsed
    expected = [want for _, want in spec if isinstance(want, Sample)]
    bad_lines = [i + 1 for i, (_, want) in enumerate(spec) if want == "bad"]
    if torn:
        bad_lines.append(len(spec) + 1)
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "m.txt"
        got, tail = _follow(path, _chunks(data, cuts))
        whole, whole_stats = read_stream(path, M, now=NOW)
    assert whole == expected
    assert got == expected
    assert [p.line for p in tail.problems()] == bad_lines
    stats = tail.stats()
    assert stats.malformed == whole_stats.malformed == len(bad_lines)
    assert stats.samples == whole_stats.samples == len(expected)


tokens = st.sampled_from(
    [b"1", b"25", b".5", b" ", b"\t", b"\n", b"\r", b"-", b"e", b"E9", b"nan", b"inf", b"_"]
    + [b"\xff", b"\xc3", b"\xa9", b"\x00", b"x"]
)
noise = st.one_of(st.binary(max_size=200), st.lists(tokens, max_size=80).map(b"".join))


@SETTINGS
@given(noise, st.lists(st.integers(min_value=0), max_size=12))
def test_arbitrary_bytes_never_raise_and_chunking_does_not_matter(
    data: bytes, cuts: list[int]
) -> None:
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "m.txt"
        got, tail = _follow(path, _chunks(data, cuts))
        whole, whole_stats = read_stream(path, M, now=NOW)
    assert got == whole
    assert all(math.isfinite(s.value) and math.isfinite(s.t) and s.t >= 0.0 for s in got)
    stats = tail.stats()
    assert stats.samples == len(got)
    assert stats.malformed == whole_stats.malformed
    assert stats.out_of_order == whole_stats.out_of_order
