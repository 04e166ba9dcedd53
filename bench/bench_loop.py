"""Whole-process speed of the one talk loop: ``prezence demo`` and ``prezence replay``.

    python bench/bench_loop.py [--repeat 3] [--load DIR]

Prints, on one core (``taskset -c 0``), the median wall time of ``prezence demo --backend fake``
and ``--backend sim`` (with the report, as a user runs it, and with ``--no-report``) as times
real time, and, when ``--load DIR`` holds the peers' workload (``mkload.py DIR 200000``),
``prezence replay`` against ``peers/replay.py --policy seed --tick 0.5 --allocated 0`` on the
same files, with peak memory (``/usr/bin/time -v``).
"""

from __future__ import annotations

import argparse
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PEERS = Path("/work/shared/peers")
DEMO_S = 595.0  # the demo scenario's length


def run(argv: list[str]) -> tuple[float, int]:
    """Wall seconds and peak RSS (kB) of one process on core 0."""
    cmd = ["/usr/bin/time", "-v", "taskset", "-c", "0", *argv]
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if p.returncode not in (0, 3):
        raise SystemExit(f"{argv} failed:\n{p.stderr[-2000:]}")
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    return wall, int(m.group(1)) if m else 0


def median_of(argv: list[str], n: int) -> tuple[float, int]:
    runs = [run(argv) for _ in range(n)]
    return statistics.median(r[0] for r in runs), max(r[1] for r in runs)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--load", type=Path)
    args = ap.parse_args()
    py = sys.executable
    with tempfile.TemporaryDirectory() as d:
        for backend in ("fake", "sim"):
            for extra in ([], ["--no-report"]):
                argv = [py, "-m", "prezence", "demo", "--backend", backend, "-q"]
                wall, _ = median_of([*argv, "--out", f"{d}/demo", *extra], args.repeat)
                tag = " ".join(["demo", "--backend", backend, *extra])
                print(f"{tag:<36} {wall:6.2f} s  {DEMO_S / wall:7.0f}x real time")
        if args.load:
            src = args.load
            ours = [
                py,
                "-m",
                "prezence",
                "replay",
                str(src),
                "--config",
                str(src / "rules.conf"),
                "--room",
                str(src / "room.toml"),
                "--policy",
                "seed",
                "--out",
                f"{d}/r",
                "--no-report",
                "-q",
            ]
            peer = [
                py,
                str(PEERS / "replay.py"),
                str(src),
                "--policy",
                "seed",
                "--tick",
                "0.5",
                "--allocated",
                "0",
                "--out",
                f"{d}/peer.jsonl",
            ]
            w1, m1 = median_of(ours, args.repeat)
            w2, m2 = median_of(peer, args.repeat)
            print(f"prezence replay (200k)               {w1:6.2f} s  {m1 / 1024:5.0f} MB")
            print(f"peers/replay.py --policy seed        {w2:6.2f} s  {m2 / 1024:5.0f} MB")
            print(f"ratio prezence / peers               {w1 / w2:6.2f}")


if __name__ == "__main__":
    main()
