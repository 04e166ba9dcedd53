"""NAOqi bridge latency on loopback, against the virtual NAO in another process.

Prints:
- call round trip: a synchronous ``ALMotion.getAngles`` from a plain qi client, p50/p99;
- cue start latency: ``NaoqiBackend.play()`` called → the virtual NAO's ALMotion has started
  the motion (its JSONL record's ``mono`` stamp; both processes read the same
  CLOCK_MONOTONIC), p50/p99, and the same for ``say()``;
- the ratio of the p99 cue start latency to the issue's target (20 ms).

Usage: python bench/bench_naoqi.py [--cues 100] [--calls 2000] [--model pybullet|kinematic]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import qi

from prezence.backends.naoqi import NaoqiBackend
from prezence.clock import MonotonicClock
from prezence.feedback.trajectory import Trajectory

REPO = Path(__file__).resolve().parents[1]
TARGET_P99_MS = 20.0


def pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, round(q / 100 * (len(ordered) - 1)))]


def start_server(model: str, record: Path) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.virtual_nao", "--port", "0", "--model", model]
        + ["--speech-log", str(record)],
        cwd=REPO,
        stdout=subprocess.PIPE,
        text=True,
    )
    assert proc.stdout is not None
    for line in proc.stdout:
        if line.startswith("listening on "):
            return proc, line.split()[-1]
    raise RuntimeError("virtual NAO did not start")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cues", type=int, default=100)
    p.add_argument("--calls", type=int, default=2000)
    p.add_argument("--model", choices=("pybullet", "kinematic"), default="pybullet")
    args = p.parse_args()
    qi.logging.setLevel(qi.logging.ERROR)

    with tempfile.TemporaryDirectory() as tmp:
        record = Path(tmp) / "record.jsonl"
        proc, url = start_server(args.model, record)
        try:
            session = qi.Session()
            session.connect(url)
            motion = session.service("ALMotion")
            rtt = []
            for _ in range(args.calls):
                t0 = time.perf_counter()
                motion.getAngles("HeadYaw", True)
                rtt.append(1000 * (time.perf_counter() - t0))
            session.close()

            clock = MonotonicClock()
            backend = NaoqiBackend(url=url)
            backend.open()
            sent_play, sent_say = [], []
            for i in range(args.cues):
                q = 0.05 if i % 2 else -0.05
                traj = Trajectory("tick", ("HeadYaw",), (0.05,), ((q,),), (-q,))
                t0 = time.monotonic()
                backend.play(traj, now=clock.now())
                sent_play.append(t0)
                backend.wait_idle(5.0, clock.now)
            for _ in range(max(1, args.cues // 5)):
                t0 = time.monotonic()
                backend.say("Ok.", now=clock.now())
                sent_say.append(t0)
                backend.wait_idle(5.0, clock.now)
            stats = backend.stats()
            backend.close()
        finally:
            proc.terminate()
            proc.wait()
        recs = [json.loads(x) for x in record.read_text().splitlines()]
    starts_play = [
        r["mono"] for r in recs if r["event"] == "start" and r["call"] == "angleInterpolation"
    ]
    starts_say = [r["mono"] for r in recs if r["event"] == "start" and r["call"] == "say"]
    play_ms = [1000 * (s - t) for s, t in zip(starts_play, sent_play, strict=True)]
    say_ms = [1000 * (s - t) for s, t in zip(starts_say, sent_say, strict=True)]

    print(f"virtual NAO model: {args.model}; loopback {url}")
    print(
        f"call round trip (getAngles, n={len(rtt)}): p50 {pct(rtt, 50):.3f} ms, "
        f"p99 {pct(rtt, 99):.3f} ms, mean {statistics.fmean(rtt):.3f} ms"
    )
    print(
        f"cue start latency play() -> ALMotion started (n={len(play_ms)}): "
        f"p50 {pct(play_ms, 50):.3f} ms, p99 {pct(play_ms, 99):.3f} ms, max {max(play_ms):.3f} ms"
    )
    print(
        f"cue start latency say() -> ALTextToSpeech started (n={len(say_ms)}): "
        f"p50 {pct(say_ms, 50):.3f} ms, p99 {pct(say_ms, 99):.3f} ms"
    )
    print(
        f"p99 play start / target {TARGET_P99_MS:.0f} ms: "
        f"{pct(play_ms, 99) / TARGET_P99_MS:.3f} (< 1 meets it)"
    )
    print(
        f"backend heartbeat rtt p50/p99: {stats['call_rtt_ms_p50']} / {stats['call_rtt_ms_p99']} ms"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
