"""Following stream files: partial, bad, missing, truncated and replaced files; waiting."""

from __future__ import annotations

import logging
import os
import threading
from pathlib import Path

import pytest

from prezence.samples import Sample
from prezence.streams.tail import (
    MAX_LINE_BYTES,
    MultiTailer,
    StreamProblem,
    StreamTailer,
    TailStats,
    inotify_available,
    read_stream,
)

M = "speech_speed"
WATCH_MODES = [
    "poll",
    pytest.param(
        "inotify",
        marks=pytest.mark.skipif(not inotify_available(), reason="inotify is Linux only"),
    ),
]


def append(path: Path, data: bytes) -> None:
    with open(path, "ab") as f:
        f.write(data)


def values(samples: list[Sample]) -> list[float]:
    return [s.value for s in samples]


@pytest.fixture
def stream(tmp_path: Path) -> Path:
    return tmp_path / "speech_speed.txt"


# -- lines ---------------------------------------------------------------------------------


def test_half_a_line_gives_nothing_until_its_newline(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"12.5 15")
    assert tail.poll(20.0) == []
    append(stream, b"3.25\n")
    assert tail.poll(20.0) == [Sample(M, 12.5, 153.25)]
    assert tail.poll(21.0) == []
    assert tail.stats().samples == 1


def test_only_new_lines_are_returned_by_each_poll(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"1 10\n2 20\n")
    assert values(tail.poll(2.0)) == [10.0, 20.0]
    append(stream, b"3 30\n")
    assert values(tail.poll(3.0)) == [30.0]


def test_blank_lines_are_skipped_silently(stream: Path, caplog: pytest.LogCaptureFixture) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"\n1 10\n   \n\t\r\n2 20\n")
    assert values(tail.poll(0.0)) == [10.0, 20.0]
    assert tail.stats().malformed == 0
    assert tail.problems() == []
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_bad_lines_are_skipped_counted_and_located_across_polls(
    stream: Path, caplog: pytest.LogCaptureFixture
) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"1 10\n\nhello\n2 nan\n")
    assert values(tail.poll(0.0)) == [10.0]
    append(stream, b"3 30\n1 2 3\n-4 40\ninf 5\n")
    assert values(tail.poll(0.0)) == [30.0]
    name = str(stream)
    assert [(p.path, p.line) for p in tail.problems()] == [
        (name, 3),
        (name, 4),
        (name, 6),
        (name, 7),
        (name, 8),
    ]
    reasons = [p.reason for p in tail.problems()]
    assert "not a number" in reasons[0]
    assert "not finite" in reasons[1]
    assert "3 fields" in reasons[2]
    assert "negative" in reasons[3]
    assert tail.stats().malformed == 5
    warned = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert f"{name}:3: " in warned[0]
    assert len(warned) == 5  # once per line


def test_problem_prints_as_file_line_reason() -> None:
    p = StreamProblem("s/v.txt", 7, "value is not a number: 'x'")
    assert str(p) == "s/v.txt:7: value is not a number: 'x'"
    assert tuple(p) == ("s/v.txt", 7, "value is not a number: 'x'")


def test_only_the_last_problems_are_kept(stream: Path) -> None:
    tail = StreamTailer(stream, M, max_problems=2)
    append(stream, b"a\nb\nc\n")
    tail.poll(0.0)
    assert [p.line for p in tail.problems()] == [2, 3]
    assert tail.stats().malformed == 3


def test_non_utf8_bytes_are_malformed_lines_not_errors(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"1 10\n\xff\xfe 2\n2 \xc3\n3 30\n")
    assert values(tail.poll(0.0)) == [10.0, 30.0]
    assert [p.line for p in tail.problems()] == [2, 3]
    assert "UTF-8" in tail.problems()[0].reason


def test_an_over_long_line_is_skipped_even_when_it_arrives_in_pieces(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"1 10\n" + b"9" * (MAX_LINE_BYTES + 10))
    assert values(tail.poll(0.0)) == [10.0]
    append(stream, b"9" * 100)
    assert tail.poll(0.0) == []
    append(stream, b"\n2 20\n")
    assert values(tail.poll(0.0)) == [20.0]
    assert [p.line for p in tail.problems()] == [2]
    assert "longer than" in tail.problems()[0].reason


def test_bare_values_are_stamped_with_the_poll_time(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"150\n")
    assert tail.poll(4.5) == [Sample(M, 4.5, 150.0)]
    append(stream, b"160\n")
    assert tail.poll(9.0) == [Sample(M, 9.0, 160.0)]


def test_backward_timestamps_are_kept_and_counted(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    append(stream, b"5 1\n3 2\n4 3\n4 4\n")
    assert [s.t for s in tail.poll(0.0)] == [5.0, 3.0, 4.0, 4.0]
    assert tail.stats().out_of_order == 1


def test_poll_rejects_a_non_finite_now(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    with pytest.raises(ValueError, match="finite"):
        tail.poll(float("nan"))


# -- files ---------------------------------------------------------------------------------


def test_a_missing_file_is_counted_once_and_read_when_it_appears(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    assert tail.poll(0.0) == []
    assert tail.poll(1.0) == []
    assert tail.stats().missing == 1
    stream.write_bytes(b"1 10\n")
    assert values(tail.poll(2.0)) == [10.0]
    assert tail.stats() == TailStats(samples=1, missing=1)


def test_a_deleted_then_recreated_file_is_read_from_its_start(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    stream.write_bytes(b"1 10\n2 20\n")
    tail.poll(0.0)
    stream.unlink()
    assert tail.poll(0.0) == []
    stream.write_bytes(b"5 50\n")
    assert values(tail.poll(0.0)) == [50.0]
    assert tail.stats().missing == 1  # it was there at the first poll: the deletion counts


def test_a_truncated_file_is_read_again_from_the_start(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    stream.write_bytes(b"1 10\n2 20\n3 30\n")
    assert len(tail.poll(0.0)) == 3
    stream.write_bytes(b"oops\n1 11\n")  # "w" mode: truncate, then write less
    assert values(tail.poll(0.0)) == [11.0]
    assert tail.stats().truncations == 1
    assert tail.problems()[-1].line == 1  # line numbers restart with the file


def test_a_file_rewritten_longer_between_polls_is_read_again(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    stream.write_bytes(b"10 1\n")
    tail.poll(0.0)
    stream.write_bytes(b"2 2\n3 3\n4 4\n")  # grew past the old offset, different bytes there
    assert values(tail.poll(0.0)) == [2.0, 3.0, 4.0]
    assert tail.stats().truncations == 1


def test_a_fixed_width_file_rewritten_in_place_is_read_again(stream: Path) -> None:
    # Fixed-width lines end in the same byte ("\n"), so one byte before the offset cannot tell.
    tail = StreamTailer(stream, M)
    stream.write_bytes(b"5 150.0\n6 151.0\n")
    assert values(tail.poll(6.0)) == [150.0, 151.0]
    stream.write_bytes(b"5 160.0\n6 161.0\n7 162.0\n8 163.0\n")  # truncated, then regrew
    assert values(tail.poll(8.0)) == [160.0, 161.0, 162.0, 163.0]
    assert tail.stats().truncations == 1


def test_lines_stamped_ahead_of_the_clock_are_skipped_with_file_and_line(stream: Path) -> None:
    tail = StreamTailer(stream, M, max_ahead_s=1.0)
    append(stream, b"1 150\n5000 230\n2.9 160\n")
    assert values(tail.poll(2.0)) == [150.0, 160.0]  # 2.9 is within a second of the clock
    (problem,) = tail.problems()
    assert (problem.line, tail.stats().malformed) == (2, 1)
    assert "ahead of the talk clock" in problem.reason
    assert values(StreamTailer(stream, M).poll(2.0)) == [150.0, 230.0, 160.0]  # opt-in only


def test_a_partial_line_is_dropped_when_the_file_is_truncated(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    stream.write_bytes(b"1 10\n2 2")
    tail.poll(0.0)
    stream.write_bytes(b"")
    tail.poll(0.0)
    append(stream, b"0\n")
    assert values(tail.poll(0.0)) == [0.0]


def test_a_replaced_file_is_read_from_its_start(stream: Path, tmp_path: Path) -> None:
    tail = StreamTailer(stream, M)
    stream.write_bytes(b"1 10\n2 20\n3 30\n")
    tail.poll(0.0)
    new = tmp_path / "new.txt"
    new.write_bytes(b"1 11\n2 22\n3 33\n4 44\n")
    os.replace(new, stream)
    assert values(tail.poll(0.0)) == [11.0, 22.0, 33.0, 44.0]
    assert tail.stats().replaced == 1
    assert tail.stats().truncations == 0


def test_an_unreadable_path_is_reported_once_and_does_not_keep_waking_wait(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    folder = tmp_path / "dir.txt"
    folder.mkdir()
    tail = StreamTailer(folder, M)
    assert tail.poll(0.0) == []
    assert tail.poll(1.0) == []
    assert tail.stats().missing == 1
    assert not tail.changed()
    assert len([r for r in caplog.records if "cannot be read" in r.getMessage()]) == 1
    folder.rmdir()
    folder.write_bytes(b"1 10\n")
    assert values(tail.poll(2.0)) == [10.0]


def test_changed_says_whether_poll_has_anything_to_look_at(stream: Path) -> None:
    tail = StreamTailer(stream, M)
    tail.poll(0.0)
    assert not tail.changed()
    append(stream, b"1 1")
    assert tail.changed()
    tail.poll(0.0)
    assert not tail.changed()
    stream.unlink()
    assert tail.changed()


# -- whole files ---------------------------------------------------------------------------


def test_read_stream_matches_polling_and_ignores_a_torn_last_line(stream: Path) -> None:
    stream.write_bytes(b"1 10\nbad\n2 20\n3 30\n4 4")
    samples, stats = read_stream(stream, M)
    assert values(samples) == [10.0, 20.0, 30.0]
    assert stats.malformed == 2  # "bad" and the torn "4 4"
    tail = StreamTailer(stream, M)
    assert tail.poll(0.0) == samples
    tail.finish()
    assert tail.problems()[-1].line == 5
    assert "incomplete" in tail.problems()[-1].reason


def test_read_stream_of_a_missing_file_is_empty(stream: Path) -> None:
    assert read_stream(stream, M) == ([], TailStats(missing=1))


def test_read_stream_skips_bare_values_no_live_reader_stamped(stream: Path) -> None:
    # Session 22's walkthrough: `rehearse` read a module's 52 bare values (51 s of talk) as
    # one instant ("measured for only 6 s", no advice, nothing flagged). Read afterwards, a
    # bare value has no time: it is a bad line, named with its file and line.
    stream.write_bytes(b"150\n2 160\n170\n")
    problems: list[StreamProblem] = []
    samples, stats = read_stream(stream, M, problems=problems)
    assert samples == [Sample(M, 2.0, 160.0)]
    assert (stats.samples, stats.malformed) == (1, 2)
    assert [str(p) for p in problems] == [
        f"{stream}:1: no time stamp: '150' (write '<t> <value>': only a live coach can time a "
        "bare value)",
        f"{stream}:3: no time stamp: '170' (write '<t> <value>': only a live coach can time a "
        "bare value)",
    ]
    # a time given by the caller stamps them, as a live reader does
    samples, _ = read_stream(stream, M, now=30.0)
    assert [s.t for s in samples] == [30.0, 2.0, 30.0]


def test_tail_stats_round_trip_through_a_dict() -> None:
    s = TailStats(samples=5, malformed=1, truncations=2, replaced=3, out_of_order=4, missing=6)
    assert s.to_dict()["replaced"] == 3
    assert TailStats.from_dict(s.to_dict()) == s


# -- several streams -----------------------------------------------------------------------


def test_multi_poll_merges_metrics_sorted_by_t_and_stable(tmp_path: Path) -> None:
    a, b = tmp_path / "a.txt", tmp_path / "b.txt"
    a.write_bytes(b"1 1\n3 3\n")
    b.write_bytes(b"0.5 5\n1 6\nbad\n")
    with MultiTailer({"a": a, "b": b}) as tails:
        got = [(s.metric, s.t) for s in tails.poll(0.0)]
        assert got == [("b", 0.5), ("a", 1.0), ("b", 1.0), ("a", 3.0)]
        assert tails.stats()["b"].malformed == 1
        assert [(p.path, p.line) for p in tails.problems()] == [(str(b), 3)]


@pytest.mark.parametrize("watch", WATCH_MODES)
def test_wait_returns_true_for_a_write_made_before_it(tmp_path: Path, watch: str) -> None:
    path = tmp_path / "a.txt"
    with MultiTailer({"a": path}, watch=watch) as tails:  # type: ignore[arg-type]
        tails.poll(0.0)
        assert tails.wait(0.0) is False
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
        os.write(fd, b"1 2\n")
        os.close(fd)
        assert tails.wait(30.0) is True
        assert values(tails.poll(1.0)) == [2.0]
        assert tails.wait(0.0) is False


@pytest.mark.parametrize("watch", WATCH_MODES)
def test_wait_wakes_on_a_write_from_another_thread(tmp_path: Path, watch: str) -> None:
    path = tmp_path / "later" / "a.txt"  # the folder does not exist yet either
    with MultiTailer({"a": path}, watch=watch) as tails:  # type: ignore[arg-type]
        tails.poll(0.0)
        writer = threading.Thread(target=lambda: _create_and_write(path))
        writer.start()
        try:
            assert tails.wait(30.0) is True
        finally:
            writer.join()
        assert values(tails.poll(0.0)) == [2.0]


def _create_and_write(path: Path) -> None:
    path.parent.mkdir()
    path.write_bytes(b"1 2\n")


@pytest.mark.skipif(not inotify_available(), reason="inotify is Linux only")
def test_inotify_notices_writes_and_ignores_other_files(tmp_path: Path) -> None:
    path = tmp_path / "a.txt"
    with MultiTailer({"a": path}, watch="inotify") as tails:
        tails.poll(0.0)
        watcher = tails._get_watcher()
        (tmp_path / "other.txt").write_bytes(b"x\n")
        assert watcher.block(0.0) is False  # an unwatched name does not wake it
        path.write_bytes(b"1 2\n")
        assert watcher.block(0.0) is True  # the event is queued by the write itself
        assert watcher.block(0.0) is False  # and consumed


@pytest.mark.skipif(not inotify_available(), reason="inotify is Linux only")
def test_wait_is_not_woken_by_changes_poll_already_consumed(tmp_path: Path) -> None:
    path = tmp_path / "a.txt"
    with MultiTailer({"a": path}, watch="inotify") as tails:
        tails.wait(0.0)  # create the watches
        path.write_bytes(b"1 2\n")
        tails.poll(0.0)
        assert tails.wait(0.01) is False


def test_wait_after_close_raises(tmp_path: Path) -> None:
    tails = MultiTailer({"a": tmp_path / "a.txt"})
    tails.close()
    tails.close()
    with pytest.raises(ValueError, match="closed"):
        tails.wait(0.0)


def test_wait_rejects_a_negative_timeout(tmp_path: Path) -> None:
    tails = MultiTailer({"a": tmp_path / "a.txt"})
    with pytest.raises(ValueError, match="timeout_s"):
        tails.wait(-1.0)


def test_an_unknown_watch_mode_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="watch must be"):
        MultiTailer({"a": tmp_path / "a.txt"}, watch="kqueue")  # type: ignore[arg-type]


def test_bare_values_read_afterwards_get_the_times_the_live_reader_gave_them(
    stream: Path,
) -> None:
    """The seed's bare ``<value>`` lines: the report and replay must see what the coach saw."""
    from prezence.streams.tail import stamps_path

    live = StreamTailer(stream, M, record_stamps=True)
    seen: list[Sample] = []
    for now, value in ((1.0, b"150\n"), (2.5, b"160\n170\n"), (4.0, b"3.0 180\n")):
        append(stream, value)
        seen += live.poll(now)
    assert [(s.t, s.value) for s in seen] == [(1.0, 150), (2.5, 160), (2.5, 170), (3.0, 180)]
    assert read_stream(stream, M)[0] == seen
    # A replaced file starts its line numbers again: the old stamps no longer apply.
    stream.unlink()
    append(stream, b"190\n")
    assert [s.t for s in live.poll(5.0)] == [5.0]
    assert read_stream(stream, M)[0] == [Sample(M, 5.0, 190.0)]
    assert stamps_path(stream).name == "speech_speed.txt.stamps"


_AHEAD_CASES = {
    # (what the module wrote, the coach's clock when it read it, lines it skipped)
    "line by line": (b"1.0 150\nhello world\n7.0 230\n100000.0 231\n2.5 160\n", 2.0, 3),
    # in time order and past BULK_MIN_BYTES: a reading afterwards takes it in one go
    "large read": (b"".join(b"%.2f 150\n" % (i / 100) for i in range(8000)) + b"85 160\n", 80.0, 1),
}


@pytest.mark.parametrize("case", list(_AHEAD_CASES), ids=list(_AHEAD_CASES))
def test_lines_the_coach_skipped_as_ahead_of_its_clock_are_skipped_when_read_again(
    stream: Path, case: str
) -> None:
    """Session 14: the end-of-talk summary said 246 unreadable lines, the report 205 and 41
    samples stamped after the end: the coach skips a line ahead of its clock, a reading
    afterwards has no clock. A line 5 s ahead was even a sample to the report."""
    data, now, n_skipped = _AHEAD_CASES[case]
    live = StreamTailer(stream, M, max_ahead_s=1.0, record_stamps=True)
    append(stream, data)
    seen = live.poll(now)
    again: list[StreamProblem] = []
    samples, stats = read_stream(stream, M, problems=again, max_t=now + 30.0)
    assert samples == seen
    assert (stats.malformed, stats.beyond_talk) == (live.stats().malformed, 0) == (n_skipped, 0)
    assert [str(p) for p in again] == [str(p) for p in live.problems()]
    assert f"is ahead of the talk clock ({now:.3f} s)" in again[-1].reason


# -- large reads in one go ------------------------------------------------------------------

_DEFECTS: dict[str, bytes] = {
    "clean": b"",
    "garbage": b"2499.75 abc\n",
    "three fields": b"2499.75 1 2\n",
    "one field": b"2499.75\n",
    "tab": b"2499.75\t3\n",
    "two spaces": b"2499.75  3\n",
    "leading space": b" 2499.75 3\n",
    "blank": b"\n",
    "nan": b"2499.75 nan\n",
    "inf time": b"inf 3\n",
    "overflow": b"2499.75 1e999\n",
    "back in time": b"0.25 3\n",
    "negative time": b"-1 3\n",
    "long line": b"2499.75 " + b"1" * (MAX_LINE_BYTES + 10) + b"\n",
    "crlf": b"2499.75 3\r\n",
    "exponent": b"2499.75 +3.5e-2\n",
    # fields that look numeric but are not all numbers float() takes
    "trailing point": b"2499.75 3.\n",
    "leading point": b"2499.75 .5e1\n",
    "double exponent": b"2499.75 1ee5\n",
    "dangling exponent": b"2499.75 1e+\n",
    "two points": b"2499.75 1.2.3\n",
    "sign inside": b"2499.75 5-3\n",
    "bare point": b"2499.75 .\n",
    "hex": b"2499.75 0x1p3\n",
    "underscore": b"2499.75 1_0\n",
}
#: Defects that float() takes as numbers, so the file still goes in one go.
_TAKEN = ("clean", "exponent", "trailing point", "leading point")


@pytest.mark.parametrize("defect", sorted(_DEFECTS))
@pytest.mark.parametrize("max_t", [None, 100.0, 5000.0])
def test_a_large_file_read_in_one_go_gives_what_line_by_line_gives(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, defect: str, max_t: float | None
) -> None:
    # 10,000 lines (~130 KB) with one defect in the middle: the one-go reader must take the
    # file exactly as the line-by-line reader does (same samples bit for bit, same counters
    # and problems) or leave it to it.
    import prezence.streams.tail as tail

    lines = [f"{k * 0.5!r} {140.0 + (k * 7919 % 97) / 3.0!r}\n".encode() for k in range(10_000)]
    body = b"".join(lines[:5000]) + _DEFECTS[defect] + b"".join(lines[5000:])
    path = tmp_path / "speech_speed.txt"
    path.write_bytes(body)
    taken: list[bool] = []
    one_go = tail.StreamTailer._feed_bulk

    def spy(self: StreamTailer, complete: bytes, now: float | None) -> list[Sample] | None:
        out = one_go(self, complete, now)
        taken.append(out is not None)
        return out

    monkeypatch.setattr(tail.StreamTailer, "_feed_bulk", spy)
    fast_problems: list[StreamProblem] = []
    fast = read_stream(path, M, problems=fast_problems, max_t=max_t)
    # a clean file (and one whose only oddity float() takes as it is) goes in one go
    # ("_" is Python's digit separator, which a stream line must not use: not even tried)
    assert taken == ([] if defect == "underscore" else [defect in _TAKEN])
    monkeypatch.setattr(tail, "BULK_MIN_BYTES", 1 << 40)
    slow_problems: list[StreamProblem] = []
    slow = read_stream(path, M, problems=slow_problems, max_t=max_t)
    assert fast[0] == slow[0]
    assert fast[1] == slow[1]
    assert fast_problems == slow_problems
    if defect == "clean" and max_t == 100.0:
        assert fast[1].beyond_talk == 10_000 - 201 and len(fast[0]) == 201


def test_a_large_read_while_following_gives_what_small_reads_give(stream: Path) -> None:
    # A module that wrote a lot before the tailer looked, then more: same samples as a tailer
    # that saw each line as it came.
    body = b"".join(f"{k * 0.25!r} {k % 13}.5\n".encode() for k in range(20_000))
    stream.write_bytes(body[: len(body) // 2 + 3])  # ends mid-line
    big = StreamTailer(stream, M)
    got = big.poll(5000.0)
    append(stream, body[len(body) // 2 + 3 :])
    got += big.poll(5000.0)
    want = [Sample(M, k * 0.25, float(f"{k % 13}.5")) for k in range(20_000)]
    assert got == want
    assert big.stats().malformed == 0


# -- physical ranges -------------------------------------------------------------------------


def test_values_outside_the_physical_range_are_bad_lines_with_file_and_line(
    stream: Path,
) -> None:
    # bad_speed.py of the walkthrough: 5000 and -50 wpm were fed to the processor ("5000 is
    # 2678 % above 180 wpm") and the summary's stream problems said nothing.
    stream.write_bytes(b"1 160\n2 5000\n3 -50\n4 400\n5 0\n")
    tailer = StreamTailer(stream, M, value_range=(0.0, 400.0))
    assert values(tailer.poll(10.0)) == [160.0, 400.0, 0.0]  # the bounds themselves are fine
    assert tailer.stats().malformed == 2
    assert [str(p) for p in tailer.problems()] == [
        f"{stream}:2: value 5000 is outside speech_speed's physical range 0..400",
        f"{stream}:3: value -50 is outside speech_speed's physical range 0..400",
    ]
    # bare values (the seed's format) too, and line numbers stay right across polls
    append(stream, b"7.5e3\n170\n")
    assert values(tailer.poll(11.0)) == [170.0]
    assert str(tailer.problems()[-1]).startswith(f"{stream}:6: value 7500 is outside")
    # without a range every finite value is taken, as before
    assert values(StreamTailer(stream, M).poll(11.0)) == [160, 5000, -50, 400, 0, 7500, 170]


def test_a_large_file_with_one_value_out_of_range_is_read_as_line_by_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import prezence.streams.tail as tail

    lines = [f"{k * 0.5!r} {150.0 + k % 7}\n".encode() for k in range(10_000)]
    path = tmp_path / "speech_speed.txt"
    path.write_bytes(b"".join(lines[:5000]) + b"2499.75 1e8\n" + b"".join(lines[5000:]))
    fast_problems: list[StreamProblem] = []
    fast = read_stream(path, M, problems=fast_problems, value_range=(0.0, 400.0))
    monkeypatch.setattr(tail, "BULK_MIN_BYTES", 1 << 40)
    slow_problems: list[StreamProblem] = []
    slow = read_stream(path, M, problems=slow_problems, value_range=(0.0, 400.0))
    assert fast == slow and fast_problems == slow_problems
    assert len(fast[0]) == 10_000 and fast[1].malformed == 1
    assert [str(p) for p in fast_problems] == [
        f"{path}:5001: value 1e+08 is outside speech_speed's physical range 0..400"
    ]


def test_multi_tailer_applies_each_metrics_range_only_to_it(tmp_path: Path) -> None:
    speed, rate = tmp_path / "speech_speed.txt", tmp_path / "gesture_rate.txt"
    speed.write_text("1 5000\n2 160\n")
    rate.write_text("1 -1.5\n")  # a metric without a range: negative values are its business
    with MultiTailer(
        {M: speed, "gesture_rate": rate}, watch="poll", ranges={M: (0.0, 400.0)}
    ) as tails:
        assert [(s.metric, s.value) for s in tails.poll(5.0)] == [
            ("gesture_rate", -1.5),
            (M, 160.0),
        ]
        assert [str(p) for p in tails.problems()] == [
            f"{speed}:1: value 5000 is outside speech_speed's physical range 0..400"
        ]


def test_a_time_of_inf_is_a_bad_line_not_a_sample(tmp_path: Path) -> None:
    # session 15 (found by the stream property test): 'inf 0' was read as a sample at
    # t = inf by the fast path for well-formed lines, and counted in summary.json's samples
    path = tmp_path / "m.txt"
    path.write_text("1 5\ninf 0\n2 6\n")
    problems: list[StreamProblem] = []
    samples, stats = read_stream(path, "m", problems=problems)
    assert [(s.t, s.value) for s in samples] == [(1.0, 5.0), (2.0, 6.0)]
    assert stats.malformed == 1 and problems[0].line == 2


def test_newest_stamp_reads_times_only_from_timed_lines(tmp_path: Path) -> None:
    # session 21's review: the newest stamp sets an `up` of files' time used; a `<value>`
    # line (the coach stamps it) read "12.5" as a time, and a last line over 256 bytes as 0
    from prezence.streams.tail import newest_stamp

    (tmp_path / "speech_speed.txt").write_text("1.0 150\n2.0 152\n")
    (tmp_path / "my_metric.txt").write_text("12.5\n")
    assert newest_stamp(tmp_path) == 2.0
    (tmp_path / "long.txt").write_text("3.5 " + "1" * 400 + "\n")
    assert newest_stamp(tmp_path) == 3.5
