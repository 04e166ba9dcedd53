"""Live cue latency: a line written to a module file → the cue command issued to a free robot.

Runs the real ``prezence up`` loop (tailer wake-up on file change, processor, coach, backend) with
a writer thread standing in for a module. Every line the thread writes is out of range for a
strict rule, and the robot finishes each cue at once, so each line should produce one cue; the
latency is the time from the write to the backend's ``play`` call. Prints p50/p99 (target p99 <=
10 ms) for N lines written at random intervals.

    python bench/bench_live_latency.py [--lines 300]
"""

from __future__ import annotations

import argparse
import random
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from prezence.backends.base import Motion
from prezence.backends.fake import FakeBackend
from prezence.config.model import Check, Config, ProcessorSettings, Rule, TimeSettings
from prezence.feedback.trajectory import Trajectory
from prezence.launcher import up
from prezence.streams.writer import StreamWriter
from prezence.talk import RunOptions


class StampingBackend(FakeBackend):
    """Records when each cue reached the robot; motions end almost at once."""

    def __init__(self) -> None:
        super().__init__(time_scale=1e-6)
        self.play_times: list[float] = []

    def play(self, traj: Trajectory, *, now: float) -> Motion:
        self.play_times.append(time.perf_counter())
        return super().play(traj, now=now)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--lines", type=int, default=300)
    args = ap.parse_args()
    cfg = Config(
        rules=(Rule("speech_accuracy", Check.MIN, low=0.8, strict=True, below="articulate"),),
        processor=ProcessorSettings(min_gap_s=0.0, refractory_s=0.0, praise_after_s=0.0),
        time=TimeSettings(allocated_s=None),
    )
    backend = StampingBackend()
    writes: list[float] = []
    done = threading.Event()
    with tempfile.TemporaryDirectory() as d:
        session = Path(d) / "s"

        def writer() -> None:
            rng = random.Random(1)
            time.sleep(0.5)
            with StreamWriter(session / "streams" / "speech_accuracy.txt") as w:
                t0 = time.perf_counter()
                for _ in range(args.lines):
                    time.sleep(rng.uniform(0.02, 0.05))
                    writes.append(time.perf_counter())
                    w.write(writes[-1] - t0, 0.5)
            time.sleep(0.3)
            done.set()

        th = threading.Thread(target=writer)
        th.start()
        opts = RunOptions.default()
        up(cfg, session_dir=session, modules=[], backend=backend, options=opts, stop=done.is_set)
        th.join()
    # pair each play with the newest write before it
    lat = []
    wi = 0
    for p in backend.play_times:
        while wi + 1 < len(writes) and writes[wi + 1] <= p:
            wi += 1
        lat.append((p - writes[wi]) * 1000.0)
    a = np.array(lat)
    print(f"lines written {len(writes)}, cues issued {len(lat)}")
    print(
        f"live cue latency: p50 {np.percentile(a, 50):.2f} ms, p99 {np.percentile(a, 99):.2f} ms, "
        f"max {a.max():.2f} ms (target p99 <= 10 ms: ratio {np.percentile(a, 99) / 10:.2f})"
    )


if __name__ == "__main__":
    main()
