"""Closed-loop evaluation throughput: talks per second with --jobs 1 vs 2 (and more).

Run::

    python bench/bench_evaluate.py [--scenarios demo ideal] [--policies weighted none]
        [--seeds 2] [--jobs 1 2]

Prints, per job count, the wall time of the grid, talks per second, the speed-up over one job
and the simulated talk seconds per wall second; also checks that every job count gives the
same table (the evaluation is deterministic per seed).
"""

from __future__ import annotations

import argparse
import os
import time

from prezence.evaluate import evaluate, markdown_table


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scenarios", nargs="+", default=["demo", "fast_talker", "note_reader"])
    p.add_argument("--policies", nargs="+", default=["weighted", "none"])
    p.add_argument("--seeds", type=int, default=2)
    p.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    args = p.parse_args(argv)

    print(
        f"cpus: {os.cpu_count()}; grid: {len(args.scenarios)} scenarios × "
        f"{len(args.policies)} policies × {args.seeds} seeds"
    )
    print(f"{'jobs':>4} {'talks':>6} {'wall s':>8} {'talks/s':>8} {'speed-up':>9} {'sim s/s':>9}")
    base: float | None = None
    tables: set[str] = set()
    for jobs in args.jobs:
        t0 = time.perf_counter()
        rows = evaluate(args.scenarios, args.policies, args.seeds, jobs=jobs)
        wall = time.perf_counter() - t0
        tables.add(markdown_table(rows))
        rate = len(rows) / wall
        base = base or rate
        sim_s = sum(float(r["talk_s"]) for r in rows)
        print(
            f"{jobs:>4} {len(rows):>6} {wall:>8.1f} {rate:>8.2f} {rate / base:>8.2f}× "
            f"{sim_s / wall:>9.0f}"
        )
    print(f"identical tables across job counts: {len(tables) == 1}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
