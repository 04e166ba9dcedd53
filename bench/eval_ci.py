"""Paired bootstrap intervals for ``prezence evaluate``'s time in range: a policy minus each anchor.

    python bench/eval_ci.py evaluation/evaluation.csv [--vs weighted] [--against rhema …]

For each presenter model in the CSV and each other policy (by default the anchors, ``pz16``,
``presentation_trainer``, ``rhema``, and any spec of theirs such as ``rhema:per_second=1``), the
difference in time in range is taken talk by talk (same scenario, same seed: a paired design),
and its mean is bootstrapped two ways (10 000 resamples, percentile 95 % interval, a fixed
seed so the table is the same at every run):

- **over scenarios**: the scenarios are drawn with replacement, each with all its seeds. The
  scenarios are the units that differ (the seeds vary only sensor noise and the cost model's
  draws, not what the scripted presenter does), so this is the interval to read;
- **over talks**: the (scenario, seed) pairs are drawn with replacement; narrower, since it
  treats three seeds of one script as three independent presenters.

An interval that contains 0 is said as such: the data cannot tell the two policies apart.
A second table gives, per presenter and policy, the median latency over every relevant
corrective cue (the tables' column) and over each talk's *first* one only. Under the ``cost``
presenter every cue's pause splits the real excursion, so a repeat cue's "onset" is the end of
the previous cue's pause and its latency is mostly the spacing between cues; a talk's first
relevant cue has a real onset (unless a cue about another metric came before it).

The last line says, for ``none``, in how many scenarios its time in range differs across seeds
(none gives no cue, so that is what the seeds alone change about the presenter).
"""

from __future__ import annotations

import argparse
import csv
import random
import statistics
import sys
from collections import defaultdict
from pathlib import Path

ANCHORS = ("pz16", "presentation_trainer", "rhema")
RESAMPLES = 10_000


def _interval(values: list[float]) -> tuple[float, float]:
    values = sorted(values)
    lo = values[int(0.025 * len(values))]
    hi = values[min(len(values) - 1, int(0.975 * len(values)))]
    return lo, hi


def bootstrap(
    diffs: dict[tuple[str, int], float], rng: random.Random
) -> tuple[float, tuple[float, float], tuple[float, float]]:
    """Mean paired difference, its interval over scenarios and over talks."""
    by_scenario: dict[str, list[float]] = defaultdict(list)
    for (scenario, _), d in diffs.items():
        by_scenario[scenario].append(d)
    scenarios = sorted(by_scenario)
    talks = list(diffs.values())
    mean = statistics.fmean(talks)
    over_scen = []
    for _ in range(RESAMPLES):
        pick = [by_scenario[rng.choice(scenarios)] for _ in scenarios]
        over_scen.append(statistics.fmean(d for ds in pick for d in ds))
    over_talks = [statistics.fmean(rng.choice(talks) for _ in talks) for _ in range(RESAMPLES)]
    return mean, _interval(over_scen), _interval(over_talks)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", type=Path, help="an evaluation.csv written by prezence evaluate")
    ap.add_argument("--vs", default="weighted", help="the policy compared (default: weighted)")
    ap.add_argument(
        "--against",
        nargs="+",
        help="the policies it is compared with (default: the anchors and their specs)",
    )
    args = ap.parse_args(argv)
    tir: dict[tuple[str, str], dict[tuple[str, int], float]] = defaultdict(dict)
    latencies: dict[tuple[str, str], list[list[float]]] = defaultdict(list)
    with args.csv.open(newline="") as f:
        for row in csv.DictReader(f):
            key = (row["scenario"], int(row["seed"]))
            tir[row["presenter"], row["policy"]][key] = float(row["time_in_range"])
            lat = [float(x) for x in row["latencies"].split(";") if x]
            latencies[row["presenter"], row["policy"]].append(lat)
    presenters = sorted({p for p, _ in tir})
    policies = sorted({q for _, q in tir})
    against = args.against or [q for q in policies if q in ANCHORS or q.split(":")[0] in ANCHORS]
    rng = random.Random(20261125)
    print(
        f"| presenter | {args.vs} minus | talks | mean (pp) | 95 % over scenarios | "
        "95 % over talks | talks it is ahead / behind | distinguishable from 0 "
        "(over scenarios) |"
    )
    print("|---|---|---:|---:|---|---|---|---|")
    for presenter in presenters:
        ours = tir.get((presenter, args.vs))
        if not ours:
            continue
        for other in against:
            theirs = tir.get((presenter, other))
            if not theirs:
                continue
            diffs = {k: 100 * (ours[k] - theirs[k]) for k in ours if k in theirs}
            if not diffs:
                continue
            mean, (slo, shi), (tlo, thi) = bootstrap(diffs, rng)
            ahead = sum(d > 1e-9 for d in diffs.values())
            behind = sum(d < -1e-9 for d in diffs.values())
            verdict = "yes" if slo > 0 or shi < 0 else "**no** (contains 0)"
            print(
                f"| {presenter} | {other} | {len(diffs)} | {mean:+.2f} | [{slo:+.2f}, {shi:+.2f}]"
                f" | [{tlo:+.2f}, {thi:+.2f}] | {ahead} / {behind} | {verdict} |"
            )
    print(
        "\n| presenter | policy | median latency, every relevant cue | "
        "median latency, each talk's first relevant cue | talks with one |"
    )
    print("|---|---|---:|---:|---:|")
    for (presenter, policy), lats in sorted(latencies.items()):
        every = [x for talk in lats for x in talk]
        first = [talk[0] for talk in lats if talk]
        if every:
            print(
                f"| {presenter} | {policy} | {statistics.median(every):.1f} s | "
                f"{statistics.median(first):.1f} s | {len(first)} |"
            )
    for presenter in presenters:
        none = tir.get((presenter, "none"))
        if not none:
            continue
        per: dict[str, set[float]] = defaultdict(set)
        for (scenario, _), v in none.items():
            per[scenario].add(v)
        varies = sum(len(v) > 1 for v in per.values())
        print(
            f"\n{presenter}: none's time in range differs across seeds in {varies} of "
            f"{len(per)} scenarios",
            end="",
        )
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
