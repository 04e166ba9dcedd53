"""summary.json's per-metric figures, worked out by hand on a small stream."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from prezence.config.model import Check, Config, ProcessorSettings, Rule
from prezence.samples import Sample
from prezence.summary import build_summary

VOLUME = Rule("volume", Check.MIN, low=60.0, below="louder", stale_after_s=3.0)


def test_time_in_range_stretches_and_gaps_as_worked_out_by_hand() -> None:
    # Each value holds until the next sample, the stale time (3 s) or the talk's end (20 s).
    # Out, out, in, out x3 (the last held 3 s, then a gap), out, in (held 3 s, then a gap),
    # out until the end; one sample given out of order.
    values = [(0, 50), (1, 50), (2, 70), (3, 50), (5, 50), (4, 50), (12, 50), (13, 70), (19, 50)]
    cfg = Config(rules=(VOLUME,), processor=ProcessorSettings())
    summary = build_summary(
        cfg, {"volume": [Sample("volume", float(t), float(v)) for t, v in values]}, [], talk_s=20.0
    )
    m = summary["metrics"]["volume"]
    assert m["in_range_s"] == pytest.approx(4.0)  # 2-3, 13-16
    assert m["out_of_range_s"] == pytest.approx(9.0)  # 0-2, 3-8, 12-13, 19-20
    assert m["no_data_s"] == pytest.approx(7.0)  # 8-12, 16-19
    assert m["time_in_range"] == pytest.approx(4.0 / 13.0, abs=1e-4)
    assert m["longest_out_of_range_s"] == pytest.approx(5.0)  # 3-8: the gap ends it
    assert m["stale_episodes"] == 2  # 5 -> 12 and 13 -> 19
    assert m["samples"] == 9


def test_an_offset_moves_the_band_and_samples_after_the_end_do_not_count() -> None:
    # +15 dB offset: 50 dB reads 65 (in range), 40 reads 55 (out).
    rule = Rule("volume", Check.MIN, low=60.0, below="louder", offset=15.0, stale_after_s=3.0)
    cfg = Config(rules=(rule,), processor=ProcessorSettings())
    ss = [Sample("volume", float(t), v) for t, v in [(0, 50.0), (1, 40.0), (2, 50.0), (30, 40.0)]]
    m = build_summary(cfg, {"volume": ss}, [], talk_s=4.0)["metrics"]["volume"]
    assert (m["in_range_s"], m["out_of_range_s"], m["no_data_s"]) == (3.0, 1.0, 0.0)
    assert m["longest_out_of_range_s"] == 1.0


def test_summary_json_reads_back_as_written_with_one_record_per_line(tmp_path: Path) -> None:
    # The layout is for people (a cue per line); the content is standard JSON, exactly.
    import json
    import math

    from prezence.session import write_json

    cues = [{"t": 1.5 * k, "command": "louder", "params": {"k": k}, "r": [1, 2]} for k in range(3)]
    data = {
        "cues": cues,
        "counts": {"cues": 3, "nested": {"a": [], "b": {}}},
        "mean": math.inf,
        "ratio": math.nan,
        "text": 'a "quoted", {braced} line\nand another',
        "empty": [],
        "values": [0.1, None, True],
        "by_minute": {3: 1, 1: 2},
    }
    path = tmp_path / "summary.json"
    write_json(path, data)
    text = path.read_text()
    want = json.loads(json.dumps(data, sort_keys=True).replace("Infinity", "null"))
    want["ratio"] = None
    assert json.loads(text) == want
    lines = text.splitlines()
    for cue in cues:  # each cue whole on a line of its own
        assert sum(json.loads(ln.strip().rstrip(",")) == cue for ln in lines if "louder" in ln) == 1
    assert lines[0] == "{" and lines[-1] == "}" and len(lines) > len(data) + len(cues)


def test_summary_json_lays_out_tuples_as_lists_whether_or_not_a_value_is_infinite(
    tmp_path: Path,
) -> None:
    # session 26: a summary with only finite values is written without the walk that makes
    # infinities null (which also made tuples lists); its layout must not change by that
    import math

    from prezence.session import strict_json, write_json

    def data(mean: float) -> dict[str, Any]:
        spans = tuple({"from": float(k), "to": k + 0.5} for k in range(3))
        return {"spans": spans, "pairs": ((0.0, 2.0), (4.0, 6.0)), "mean": mean, "n": (1, 2)}

    for mean in (1.5, math.inf):
        write_json(tmp_path / "a.json", data(mean))
        write_json(tmp_path / "b.json", strict_json(data(mean)))
        a = (tmp_path / "a.json").read_text()
        assert a == (tmp_path / "b.json").read_text()
        assert '\n    {"from": 0.0, "to": 0.5},\n' in a  # a record per line, as a list's


def test_the_printed_summary_says_a_module_crashed_and_counts_unreadable_lines() -> None:
    # session 13: 'cues 0 ..., stale episodes 1' and nothing about 6 crashes or 246 bad lines
    from prezence.cli import format_timeline
    from prezence.config.model import Check, Config, Rule, TimeSettings

    rule = Rule("fidget_rate", Check.MAX, high=3.0, above="gestureLess")
    config = Config(rules=(rule,), time=TimeSettings(allocated_s=60.0))
    modules = {
        "fidget": {
            "restarts": 1,
            "crashes": [{"t": 5.7, "why": "exited with status 1"}],
            "metrics": ["fidget_rate"],
        }
    }
    summary = build_summary(
        config,
        {"fidget_rate": [Sample("fidget_rate", float(t), 6.0) for t in range(6)]},
        [],
        talk_s=45.0,
        stream_stats={"fidget_rate": {"malformed": 3}},
        problems=["s/streams/fidget_rate.txt:7: t is not finite: 'nan'"],
        modules=modules,
        extra={"modules": modules},
    )
    assert summary["metrics"]["fidget_rate"]["out_of_range_s"] == 5.7  # not held to 11 s
    assert summary["metrics"]["fidget_rate"]["lost"] == [
        {"module": "fidget", "from": 5.7, "to": 45.0}
    ]
    out = format_timeline(summary)
    assert (
        "note: module fidget crashed once (first at 0:06) and was restarted; fidget_rate was "
        "not measured from 0:06 to the end (0:45)" in out
    )
    assert (
        "note: 3 unreadable lines of fidget_rate skipped "
        "(e.g. s/streams/fidget_rate.txt:7: t is not finite: 'nan')" in out
    )


def test_cues_are_classed_as_the_evaluation_classes_them() -> None:
    # session 14: the report said '40 false alarms' where evaluation.csv said 3 and 37 stale;
    # both now use one definition (docs/evaluation.md, "What the columns mean")
    from prezence import evaluate
    from prezence.summary import STALE_WINDOW_S, classify_cue

    assert STALE_WINDOW_S == evaluate.STALE_WINDOW_S
    truth = [
        {"metric": "m", "start": 10.0, "end": 20.0, "side": "above"},
        {"metric": "m", "start": 24.0, "end": 26.0, "side": "below"},
        {"metric": "m", "start": 50.0, "end": 80.0, "side": "above"},
    ]
    for t in [x / 2 for x in range(0, 200)]:
        for side in ("above", "below"):
            mine, _ = classify_cue(truth, "m", side, t)
            assert mine == evaluate.classify_cue(truth, "m", side, decided=t, started=t), (t, side)


def _classify_by_scan(
    intervals: list[dict[str, Any]], metric: str, side: str, t: float, window_s: float
) -> tuple[str, float | None]:
    """The definition read literally: a pass over every stretch (what the index replaces)."""
    iv = sorted(
        (x["start"], x["end"]) for x in intervals if x["metric"] == metric and x["side"] == side
    )
    for a, b in iv:
        if a <= t <= b:
            return "relevant", a
    ended = [b for a, b in iv if a <= t and t - window_s <= b < t]
    return ("stale", max(ended)) if ended else ("false_alarm", None)


@given(
    st.lists(
        st.tuples(st.integers(0, 60), st.integers(0, 20), st.sampled_from(["above", "below"])),
        max_size=12,
    ),
    st.integers(-5, 90),
)
def test_the_indexed_classes_equal_a_pass_over_every_stretch(
    raw: list[tuple[int, int, str]], t2: int
) -> None:
    # a long replay has thousands of stretches per metric: cues are classed through an index
    # (session 14: the pass over every stretch for every cue cost a 6-hour replay 0.06 s);
    # overlapping and nested stretches included, on half-second steps
    from prezence.summary import STALE_WINDOW_S, classify_cue

    iv = [{"metric": "m", "start": a / 2, "end": (a + d) / 2, "side": s} for a, d, s in raw]
    t = t2 / 2
    for side in ("above", "below"):
        assert classify_cue(iv, "m", side, t) == _classify_by_scan(iv, "m", side, t, STALE_WINDOW_S)


def _stretches_by_scan(
    rule: Rule, samples: list[Sample], talk_s: float, stale_s: float, cuts: list[float]
) -> list[dict[str, Any]]:
    """What the recorded values' stretches are, read literally sample by sample."""
    ss = sorted(samples, key=lambda s: s.t)
    out: list[dict[str, Any]] = []
    for i, s in enumerate(ss):
        if s.t >= talk_s:
            break
        end = min(ss[i + 1].t if i + 1 < len(ss) else talk_s, s.t + stale_s, talk_s)
        end = min([end, *(c for c in cuts if c >= s.t)])
        side = rule.side(s.value)
        if side is None:
            continue
        if out and out[-1]["side"] == side and out[-1]["end"] >= s.t:
            out[-1]["end"] = max(out[-1]["end"], end)
        else:
            out.append({"metric": rule.metric, "start": s.t, "end": end, "side": side})
    return out


@given(
    st.lists(st.tuples(st.integers(0, 80), st.integers(0, 12)), max_size=30),
    st.lists(st.integers(0, 80), max_size=3),
    st.integers(1, 12),
)
def test_the_measured_stretches_equal_a_reading_sample_by_sample(
    raw: list[tuple[int, int]], raw_cuts: list[int], stale: int
) -> None:
    # the report judges a live talk's cues by these stretches; they are worked out for all
    # samples at once (a 6-hour replay has 200k), repeated stamps and module deaths included
    from prezence.summary import measured_intervals

    rule = Rule("m", Check.IN_RANGE, low=4.0, high=8.0, offset=-0.5)
    samples = [Sample("m", t / 2, float(v)) for t, v in raw]
    cuts = sorted(c / 2 for c in raw_cuts)
    talk_s = 35.0
    assert measured_intervals(rule, samples, talk_s, stale / 2, cuts) == _stretches_by_scan(
        rule, samples, talk_s, stale / 2, cuts
    )


def test_a_cue_after_the_recordings_end_is_not_judged() -> None:
    """Session 22's review: in `up` of files the coach's clock runs on while the modules stop,
    and the last value still holds, so a cue can come after the recordings' end; with the
    metrics stopped there, it read 'STALE: back in range 0 s before' of a pace out of range
    the whole recording."""
    from prezence.config.load import load_config

    cfg = load_config(None).with_allocated(60)
    rule = next(r for r in cfg.rules if r.metric == "speech_speed")
    pace = {"speech_speed": [Sample("speech_speed", float(t), 220.0) for t in range(1, 61)]}
    cue = {
        "t": 61.5,
        "command": rule.above,
        "metric": "speech_speed",
        "kind": "weighted",
        "onset": 50.0,
        "deviation": 1.0,
    }
    live = build_summary(cfg, pace, [cue], talk_s=63.0)
    assert live["cues"][0]["cue_class"] == "relevant"  # the clock's own end: measured
    files = build_summary(cfg, pace, [cue], talk_s=63.0, extra={"recording_s": 60.0})
    row = files["cues"][0]
    assert (row["cue_class"], row["not_measured_since"]) == ("unmeasured", 60.0), row
    assert files["counts"]["cues_unmeasured"] == 1
