"""Whole-process speed of the one talk loop: ``prezence demo`` and ``prezence replay``.

    python bench/bench_loop.py [--repeat 3] [--load DIR [--replay-only]]

Prints, on one core (``taskset -c 0``), the median wall time of ``prezence demo --backend fake``
and ``--backend sim`` (with the report, as a user runs it, and with ``--no-report``) as times
real time, and, when ``--load DIR`` holds the peers' workload (``mkload.py DIR 200000``),
``prezence replay`` (its default policy, the seed's weighted one) against
``peers/replay.py --policy seed --tick 0.5 --allocated 0`` on the
same files, with peak memory (``/usr/bin/time -v``).

A talk stops at 6 h (``prezence.session.MAX_TALK_S``: a stamp beyond it is a module's clock gone
wrong), and the 200k workload's streams run 40,000 s (11.1 h), so ``prezence replay`` replays
the first 21,600 s of it and counts the rest as ``beyond_talk`` while ``peers/replay.py`` goes
through all of it: the bench prints how much each covered. For equal work, give it a workload
that fits in 6 h: ``mkload.py DIR 100000`` (20,000 s).

Each command runs once untimed first, with ``PYTHONDONTWRITEBYTECODE`` removed from its
environment: a user's installed package has its modules compiled, and a development shell that
sets the variable would otherwise make every timed run compile ~50 modules (~0.1 s).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PEERS = Path("/work/shared/peers")
DEMO_S = 595.0  # the demo scenario's length


def run(argv: list[str]) -> tuple[float, int, float]:
    """Wall seconds, peak RSS (kB) and CPU seconds (user + system) of one process on core 0.

    CPU seconds are given too because the development machine is shared: under load the wall
    time includes waiting for the core."""
    cmd = ["/usr/bin/time", "-v", "taskset", "-c", "0", *argv]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    if p.returncode not in (0, 3):
        raise SystemExit(f"{argv} failed:\n{p.stderr[-2000:]}")
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    cpu = sum(float(x) for x in re.findall(r"(?:User|System) time \(seconds\): ([\d.]+)", p.stderr))
    return wall, int(m.group(1)) if m else 0, cpu


def median_of(argv: list[str], n: int) -> tuple[float, int, float]:
    run(argv)  # warm-up: writes the bytecode caches, fills the page cache
    runs = [run(argv) for _ in range(n)]
    return (
        statistics.median(r[0] for r in runs),
        max(r[1] for r in runs),
        statistics.median(r[2] for r in runs),
    )


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--load", type=Path)
    ap.add_argument(
        "--replay-only", action="store_true", help="only the replay against the peers' (--load)"
    )
    args = ap.parse_args()
    py = sys.executable
    with tempfile.TemporaryDirectory() as d:
        for backend in () if args.replay_only else ("fake", "sim"):
            for extra in ([], ["--no-report"]):
                argv = [py, "-m", "prezence", "demo", "--backend", backend, "-q"]
                wall, _, cpu = median_of([*argv, "--out", f"{d}/demo", *extra], args.repeat)
                tag = " ".join(["demo", "--backend", backend, *extra])
                print(
                    f"{tag:<36} wall {wall:5.2f} s = {DEMO_S / wall:5.0f}x real time; "
                    f"CPU {cpu:5.2f} s = {DEMO_S / cpu:5.0f}x"
                )
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
                "--out",
                f"{d}/r",
                "--no-report",
                "--force",  # each repeat moves the previous one aside
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
            w1, m1, c1 = median_of(ours, args.repeat)
            w2, m2, c2 = median_of(peer, args.repeat)
            print(
                f"prezence replay          wall {w1:5.2f} s  CPU {c1:5.2f} s  {m1 / 1024:4.0f} MB"
            )
            print(
                f"peers/replay.py seed     wall {w2:5.2f} s  CPU {c2:5.2f} s  {m2 / 1024:4.0f} MB"
            )
            print(f"ratio prezence / peers   wall {w1 / w2:5.2f}    CPU {c1 / c2:5.2f}")
            summary = json.loads(Path(f"{d}/r/summary.json").read_text())
            beyond = sum(
                m.get("stream", {}).get("beyond_talk", 0) for m in summary["metrics"].values()
            )
            span = max(
                float(line.split()[0])
                for f in src.glob("*.txt")
                for line in f.read_text().splitlines()[-1:]
                if line.strip()
            )
            print(
                f"prezence replayed {summary['talk_s']:.0f} s of the workload's {span:.0f} s "
                f"({beyond} samples beyond a 6 h talk counted, not replayed); "
                "peers/replay.py all of it"
            )


if __name__ == "__main__":
    main()
