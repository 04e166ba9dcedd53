"""summary.json's per-metric figures, worked out by hand on a small stream."""

from __future__ import annotations

import pytest

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
