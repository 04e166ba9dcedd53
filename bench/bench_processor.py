"""Processor throughput: samples per second through the decision loop, on one core.

A 10-minute talk's worth of samples for the five default metrics at a high rate (50 Hz each),
fed in batches as the coach does (one batch per 0.5 s decision period), every step deciding with
the robot free. Prints samples/s and decisions/s; the target is >= 200,000 samples/s.

    python bench/bench_processor.py [--rate-hz 50] [--repeat 3]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from prezence.config.load import load_config
from prezence.processor import Processor, make_policy
from prezence.samples import Sample


def make_batches(rate_hz: float, talk_s: float, period_s: float, seed: int) -> list[list[Sample]]:
    cfg = load_config(None)
    rng = np.random.default_rng(seed)
    centre = {
        "speech_speed": 175.0,
        "speech_volume": 61.0,
        "speech_accuracy": 0.82,
        "cv_headGaze": -12.0,
        "cv_gestures": 6.0,
    }
    spread = {
        "speech_speed": 25.0,
        "speech_volume": 3.0,
        "speech_accuracy": 0.05,
        "cv_headGaze": 8.0,
        "cv_gestures": 4.0,
    }
    n = int(talk_s * rate_hz)
    batches: list[list[Sample]] = [[] for _ in range(int(talk_s / period_s) + 1)]
    for r in cfg.rules:
        vals = centre.get(r.metric, 1.0) + spread.get(r.metric, 1.0) * rng.standard_normal(n)
        for i in range(n):
            t = i / rate_hz
            batches[int(t / period_s)].append(Sample(r.metric, t, float(vals[i])))
    return batches


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rate-hz", type=float, default=50.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    period = 0.5
    batches = make_batches(args.rate_hz, 600.0, period, seed=1)
    n = sum(len(b) for b in batches)
    best = float("inf")
    cues = 0
    for _ in range(args.repeat):
        p = Processor(load_config(None), policy=make_policy("weighted"))
        t0 = time.perf_counter()
        for i, b in enumerate(batches):
            d = p.step((i + 1) * period, b, free_since=0.0)
            cues += d.cue is not None
        best = min(best, time.perf_counter() - t0)
    print(f"samples: {n} over {len(batches)} decisions ({args.rate_hz:g} Hz x 5 metrics, 600 s)")
    print(
        f"processor: {n / best:,.0f} samples/s  ({len(batches) / best:,.0f} decisions/s,"
        f" best of {args.repeat})"
    )
    print(f"target >= 200,000 samples/s: ratio {n / best / 200_000:.2f}")


if __name__ == "__main__":
    main()
