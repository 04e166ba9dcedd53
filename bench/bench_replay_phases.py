"""Where ``prezence replay`` spends its time: imports, reading, decision points, summary.

    python bench/bench_replay_phases.py DIR [--repeat 3]

``DIR`` holds the peers' workload (``peers/mkload.py DIR 200000``). Each repeat is a fresh
process on one core (``taskset`` semantics via ``sched_setaffinity``, Linux) that imports the
product, then runs ``prezence replay DIR --config DIR/rules.conf --room DIR/room.toml
--no-report`` in process with timers around its phases; the median of each phase is printed.
The timers' own cost is included (about 2 µs per decision point), so the phases sum to a
little more than a bare run. Decision points are split by whether new samples came with them.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any


def child(load: Path, out: Path) -> dict[str, float]:
    """One timed replay in this process (imports included)."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {0})
    t0 = time.perf_counter()
    from prezence import cli
    from prezence import replay as replay_mod
    from prezence import talk as talk_mod
    from prezence.processor import core

    acc: dict[str, float] = {"imports": time.perf_counter() - t0}

    def timed(owner: Any, name: str, key: str) -> None:
        f = getattr(owner, name)

        def wrapper(*a: Any, **k: Any) -> Any:
            t = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                acc[key] = acc.get(key, 0.0) + time.perf_counter() - t

        setattr(owner, name, wrapper)

    timed(replay_mod, "read_streams", "reading the streams")
    timed(replay_mod, "merge_readings", "merging them in time order")
    timed(core.Processor, "step", "  of which the processor")
    timed(talk_mod, "summarize_session", "summary")
    step = talk_mod.Talk.step

    def talk_step(self: Any, now: float, **kw: Any) -> Any:
        src = self.source
        ss, i = src._samples, src._i
        key = (
            "decision points without a sample"
            if i >= len(ss) or ss[i].t > now
            else ("decision points with samples")
        )
        t = time.perf_counter()
        try:
            return step(self, now, **kw)
        finally:
            acc[key] = acc.get(key, 0.0) + time.perf_counter() - t

    talk_mod.Talk.step = talk_step  # type: ignore[method-assign]
    t1 = time.perf_counter()
    argv = ["replay", str(load), "--config", str(load / "rules.conf"), "--no-report", "-q"]
    if (load / "room.toml").exists():
        argv += ["--room", str(load / "room.toml")]
    with open(os.devnull, "w") as devnull:
        saved = sys.stdout
        sys.stdout = devnull
        try:
            cli.main([*argv, "--out", str(out)])
        except SystemExit:
            pass
        finally:
            sys.stdout = saved
    acc["the replay in process"] = time.perf_counter() - t1
    acc["whole (imports + replay)"] = acc["imports"] + acc["the replay in process"]
    return acc


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("load", type=Path)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        print(json.dumps(child(args.load, args.child)))
        return 0
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    runs: list[dict[str, float]] = []
    with tempfile.TemporaryDirectory() as d:
        for k in range(args.repeat + 1):  # the first run only warms the caches
            cmd = [sys.executable, __file__, str(args.load), "--child", f"{d}/r{k}"]
            p = subprocess.run(cmd, capture_output=True, text=True, env=env, check=True)
            if k:
                runs.append(json.loads(p.stdout.strip().splitlines()[-1]))
    order = [
        "imports",
        "reading the streams",
        "merging them in time order",
        "decision points with samples",
        "decision points without a sample",
        "  of which the processor",
        "summary",
        "the replay in process",
        "whole (imports + replay)",
    ]
    print(f"prezence replay {args.load}: median of {len(runs)} fresh processes on one core")
    for key in order:
        vals = [r.get(key, 0.0) for r in runs]
        print(f"  {key:<34} {statistics.median(vals):6.3f} s  ({min(vals):.3f}-{max(vals):.3f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
