"""Headless speed: simulated seconds per wall second for the 10-minute demo talk.

Runs the whole pipeline (presenter → module files → tailer → processor → robot → records) on one
core. Targets: >= 300x real time with the fake backend, >= 100x with the PyBullet NAO.

    python bench/bench_headless.py [--backends fake sim] [--repeat 3] [--scenario demo]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from prezence.synthetic.runner import run_talk

TARGET = {"fake": 300.0, "sim": 100.0}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--backends", nargs="+", default=["fake", "sim"])
    ap.add_argument("--scenario", default="demo")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    for backend in args.backends:
        walls = []
        cues = 0
        talk_s = 0.0
        for i in range(args.repeat):
            with tempfile.TemporaryDirectory() as d:
                t0 = time.perf_counter()
                r = run_talk(args.scenario, out=Path(d) / "s", seed=i, backend=backend)
                walls.append(time.perf_counter() - t0)
                cues = len(r.cues)
                talk_s = r.summary["talk_s"]
        best = min(walls)
        print(
            f"{backend:>5}: {talk_s:.0f} s talk in {best:.3f} s wall (best of {args.repeat}, "
            f"median {sorted(walls)[len(walls) // 2]:.3f} s) = {talk_s / best:.0f}x real time; "
            f"{cues} cues; target {TARGET.get(backend, 0):.0f}x -> ratio "
            f"{talk_s / best / TARGET.get(backend, 1.0):.2f}"
        )


if __name__ == "__main__":
    main()
