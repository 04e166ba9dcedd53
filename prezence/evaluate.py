"""Closed-loop evaluation: scenarios × policies × seeds of whole synthetic talks.

Each talk runs through :func:`sim.runner.run_talk` (synthetic presenter → module files →
processor → robot backend → the presenter reacts), in a temporary session folder, and is scored
against the presenter's ground truth. Talks run in parallel worker processes (or on a Ray
cluster); every talk is deterministic given its seed, and rows come back sorted, so the tables do
not depend on the number of workers.

Figures per talk (one row):

- ``time_in_range``: share of the talk every metric was really (noise-free) in range, mean
  over metrics;
- ``cues``: cues the robot gave; ``corrective``: those about a metric;
- ``latency_s``: median, over the corrective cues that were relevant, of the time from the
  real onset of the problem to the cue;
- ``false_alarms``: corrective cues given while the metric was really in range and had not
  been out of range (on the cued side) in the :data:`STALE_WINDOW_S` before: noise, not a problem;
- ``stale``: corrective cues given while the metric was really in range but had been out of range
  in the :data:`STALE_WINDOW_S` before, when the robot started them: the problem had just ended;
- ``backlog_s``: the largest delay between a cue's decision and the robot starting it, and
  ``waited``: the cues with any delay. The processor decides only when the robot is free, so both
  are 0 by design; they are measured (at the backend's ``play`` call) to show it;
- ``violations``: joint-limit violations reported by the backend.

``prezence evaluate`` calls :func:`evaluate_main`. ``sim`` is imported only inside the workers.
"""

from __future__ import annotations

import argparse
import bisect
import csv
import io
import logging
import math
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from prezence.errors import PrezenceError

log = logging.getLogger(__name__)

#: A cue within this many seconds after a real problem ended is "stale", not a false alarm.
STALE_WINDOW_S = 10.0

#: The per-talk columns, in CSV order.
COLUMNS = (
    "scenario",
    "policy",
    "seed",
    "talk_s",
    "time_in_range",
    "cues",
    "corrective",
    "relevant",
    "false_alarms",
    "stale",
    "latency_s",
    "latencies",
    "backlog_s",
    "waited",
    "violations",
)


@dataclass(frozen=True, order=True)
class Task:
    """One talk of the grid."""

    scenario: str
    policy: str
    seed: int
    backend: str = "fake"
    keep: str | None = None  # a folder to keep the session in (None: a temp folder)


# -- scoring -----------------------------------------------------------------------------------


def _intervals(truth: Sequence[Mapping[str, Any]], metric: str) -> list[tuple[float, float, str]]:
    return sorted(
        (float(x["start"]), float(x["end"]), str(x.get("side")))
        for x in truth
        if x.get("metric") == metric
    )


def classify_cue(
    truth: Sequence[Mapping[str, Any]],
    metric: str,
    side: str,
    *,
    decided: float,
    started: float,
    window_s: float = STALE_WINDOW_S,
) -> str:
    """``"relevant"``, ``"stale"`` or ``"false_alarm"`` for a corrective cue (see the module doc).

    Args:
        truth: ground-truth out-of-range intervals (``metric``, ``start``, ``end``, ``side``).
        metric: the metric the cue is about.
        side: ``"below"`` or ``"above"``: which problem the cue corrects.
        decided: when the processor chose the cue.
        started: when the robot started it.
        window_s: how recent a problem must be for a late cue to count as stale.

    Example:
        >>> truth = [{"metric": "m", "start": 10.0, "end": 20.0, "side": "above"}]
        >>> [classify_cue(truth, "m", "above", decided=t, started=t) for t in (15.0, 25.0, 40.0)]
        ['relevant', 'stale', 'false_alarm']
    """
    iv = [(a, b) for a, b, s in _intervals(truth, metric) if s == side]
    starts = [a for a, _ in iv]

    def out_at(t: float) -> bool:
        i = bisect.bisect_right(starts, t) - 1
        return i >= 0 and iv[i][0] <= t <= iv[i][1]

    def ended_within(t: float) -> bool:
        return any(t - window_s <= b < t for a, b in iv if a <= t)

    if out_at(decided) and out_at(started):
        return "relevant"
    if ended_within(started) or (out_at(decided) and not out_at(started)):
        return "stale"
    return "false_alarm"


def score_talk(
    summary: Mapping[str, Any],
    truth: Sequence[Mapping[str, Any]],
    cues: Sequence[Mapping[str, Any]],
    sides: Mapping[str, str],
    started: Sequence[float],
    decided: Sequence[float],
) -> dict[str, Any]:
    """One row of figures for a finished talk.

    Args:
        summary: the talk's ``summary.json``.
        truth: its ground truth.
        cues: its ``cues.jsonl`` records.
        sides: command → ``"below"``/``"above"`` (from the rules).
        started: when the robot started each cue (backend ``play`` calls), in order.
        decided: when the processor chose each cue, in order.
    """
    tirs = [
        m["truth_time_in_range"]
        for m in summary["metrics"].values()
        if m.get("truth_time_in_range") is not None
    ]
    rows = summary.get("cues", [])
    kinds = {"relevant": 0, "stale": 0, "false_alarm": 0}
    latencies: list[float] = []
    backlog = [s - d for s, d in zip(started, decided, strict=False)]
    for i, (c, row) in enumerate(zip(cues, rows, strict=True)):
        metric = c.get("metric")
        if metric is None or c["command"] not in sides:
            continue
        t = float(c["t"])
        start = started[i] if i < len(started) else t
        k = classify_cue(truth, metric, sides[c["command"]], decided=t, started=start)
        kinds[k] += 1
        if k == "relevant" and row.get("latency_s") is not None:
            latencies.append(float(row["latency_s"]))
    return {
        "talk_s": summary["talk_s"],
        "time_in_range": round(sum(tirs) / len(tirs), 4) if tirs else None,
        "cues": len(cues),
        "corrective": sum(kinds.values()),
        "relevant": kinds["relevant"],
        "false_alarms": kinds["false_alarm"],
        "stale": kinds["stale"],
        "latency_s": round(statistics.median(latencies), 3) if latencies else None,
        "latencies": [round(x, 3) for x in latencies],
        "backlog_s": round(max(backlog, default=0.0), 6),
        "waited": sum(1 for b in backlog if b > 1e-9),
        "violations": int(summary["counts"].get("joint_limit_violations", 0)),
    }


# -- running -----------------------------------------------------------------------------------


def run_task(task: Task) -> dict[str, Any]:
    """Run one talk and score it (in a worker process; imports the simulator)."""
    from prezence.backends.registry import make_backend
    from prezence.processor import Decision
    from prezence.session import read_jsonl
    from sim.runner import run_talk

    backend = make_backend(task.backend)
    started: list[float] = []
    decided: list[float] = []
    play = backend.play

    def recording_play(traj: Any, *, now: float) -> Any:
        started.append(now)
        return play(traj, now=now)

    backend.play = recording_play  # type: ignore[method-assign]

    def on_decision(d: Decision) -> None:
        if d.cue is not None:
            decided.append(d.t)

    with tempfile.TemporaryDirectory(prefix="prezence-eval-") as tmp:
        out = (
            Path(task.keep) / f"{task.scenario}-{task.policy}-{task.seed}"
            if task.keep
            else Path(tmp) / "talk"
        )
        result = run_talk(
            task.scenario,
            out=out,
            seed=task.seed,
            backend=backend,
            policy=task.policy,
            on_decision=on_decision,
        )
        truth = read_jsonl(result.session.truth)
        sides: dict[str, str] = {}
        from prezence.config.load import load_config

        for r in load_config(result.session.config).rules:
            if r.below:
                sides.setdefault(r.below, "below")
            if r.above:
                sides.setdefault(r.above, "above")
        row = {"scenario": task.scenario, "policy": task.policy, "seed": task.seed}
        row.update(score_talk(result.summary, truth, result.cues, sides, started, decided))
    return row


def _worker_init(level: int) -> None:
    """Workers log at the parent's level, but no lower than ERROR unless it is verbose: the
    tailer's per-line warnings about deliberately garbled streams would flood the terminal."""
    logging.getLogger().setLevel(level if level < logging.WARNING else logging.ERROR)


def _grid(
    scenarios: Iterable[str],
    policies: Iterable[str],
    seeds: int | Iterable[int],
    backend: str,
    keep: Path | None,
) -> list[Task]:
    seed_list = list(range(seeds)) if isinstance(seeds, int) else list(seeds)
    if not seed_list:
        raise ValueError("no seeds")
    return sorted(
        Task(s, p, int(seed), backend, str(keep) if keep else None)
        for s in scenarios
        for p in policies
        for seed in seed_list
    )


#: With it set to 0 before ``import ray``, Ray takes the node's address to be loopback and
#: every server of a local cluster (GCS, raylet, workers) listens on 127.0.0.1 only (checked
#: with ``ss -ltnp``; without it they listen on all interfaces).
RAY_LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"


def _run_ray(tasks: Sequence[Task], address: str, jobs: int) -> list[dict[str, Any]]:
    if address == "local":
        import os

        os.environ.setdefault(RAY_LOOPBACK_ENV, "0")
    try:
        import ray
    except ImportError as e:
        raise PrezenceError('--ray needs ray: pip install "prezence[ray]"') from e
    if not ray.is_initialized():
        if address == "local":
            # a local cluster listens on loopback only: nothing of it is reachable from outside
            ray.init(
                num_cpus=max(1, jobs),
                include_dashboard=False,
                log_to_driver=False,
                dashboard_host="127.0.0.1",
            )
        else:
            ray.init(address=address, log_to_driver=False)
    remote = ray.remote(run_task)
    return list(ray.get([remote.remote(t) for t in tasks]))


def evaluate(
    scenarios: Iterable[str],
    policies: Iterable[str],
    seeds: int | Iterable[int],
    jobs: int = 1,
    backend: str = "fake",
    *,
    ray: str | None = None,
    keep_sessions: Path | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> list[dict[str, Any]]:
    """Run every scenario × policy × seed and return one scored row per talk, sorted.

    Args:
        scenarios: scenario names or paths.
        policies: conflict resolution policy names (``weighted``, ``none``…).
        seeds: a number N (seeds 0..N-1) or the seeds themselves.
        jobs: worker processes (1: in this process).
        backend: robot backend for every talk (``fake`` or ``sim``).
        ray: None for local processes; ``local`` to start a Ray instance here, ``auto`` or an
            address to use a running Ray cluster (needs the ``ray`` extra).
        keep_sessions: keep each talk's session folder under this folder.
        progress: called with (talks done, talks in all).

    Raises:
        ValueError: ``jobs`` < 1 or no seeds.
        UnknownName: an unknown scenario or policy (raised by the first talk).
    """
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    from prezence.processor import make_policy

    policies = list(policies)
    for p in policies:
        make_policy(p)  # an unknown name fails here, before any talk runs
    tasks = _grid(scenarios, policies, seeds, backend, keep_sessions)
    if keep_sessions is not None:
        keep_sessions.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    if ray is not None:
        rows = _run_ray(tasks, ray, jobs)
    elif jobs == 1:
        for i, t in enumerate(tasks):
            rows.append(run_task(t))
            if progress is not None:
                progress(i + 1, len(tasks))
    else:
        # spawn: workers start clean (no inherited threads or open files), on every platform.
        with ProcessPoolExecutor(
            max_workers=jobs,
            mp_context=get_context("spawn"),
            initializer=_worker_init,
            initargs=(logging.getLogger().getEffectiveLevel(),),
        ) as pool:
            for i, row in enumerate(pool.map(run_task, tasks, chunksize=1)):
                rows.append(row)
                if progress is not None:
                    progress(i + 1, len(tasks))
    return sorted(rows, key=lambda r: (r["scenario"], r["policy"], r["seed"]))


# -- tables ------------------------------------------------------------------------------------


def _mean(xs: Sequence[float]) -> float | None:
    return sum(xs) / len(xs) if xs else None


def aggregate(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row per policy, over every scenario and seed (policies in first-seen order)."""
    order: list[str] = []
    for r in rows:
        if r["policy"] not in order:
            order.append(r["policy"])
    out = []
    for p in order:
        rs = [r for r in rows if r["policy"] == p]
        tirs = [r["time_in_range"] for r in rs if r["time_in_range"] is not None]
        lats = [x for r in rs for x in r["latencies"]]
        n = len(rs)
        out.append(
            {
                "policy": p,
                "talks": n,
                "time_in_range": _mean(tirs),
                "cues_per_talk": sum(r["cues"] for r in rs) / n,
                "corrective_per_talk": sum(r["corrective"] for r in rs) / n,
                "latency_s": statistics.median(lats) if lats else None,
                "false_alarms": sum(r["false_alarms"] for r in rs),
                "stale": sum(r["stale"] for r in rs),
                "backlog_s": max(r["backlog_s"] for r in rs),
                "waited": sum(r["waited"] for r in rs),
                "violations": sum(r["violations"] for r in rs),
            }
        )
    return out


def _f(x: float | None, fmt: str) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def _secs(x: float | None) -> str:
    return "–" if x is None else f"{x:.1f} s"


def markdown_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """The per-policy table (Markdown), then time in range per scenario × policy."""
    agg = aggregate(rows)
    lines = [
        "| policy | talks | time in range | cues / talk | corrective / talk | median latency "
        "| false alarms | stale | backlog (max) | cues that waited | joint-limit violations |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for a in agg:
        lines.append(
            f"| {a['policy']} | {a['talks']} | {_pct(a['time_in_range'])} "
            f"| {a['cues_per_talk']:.1f} | {a['corrective_per_talk']:.1f} "
            f"| {_secs(a['latency_s'])} | {a['false_alarms']} | {a['stale']} "
            f"| {a['backlog_s']:g} s | {a['waited']} | {a['violations']} |"
        )
    policies = [a["policy"] for a in agg]
    scenarios = sorted({r["scenario"] for r in rows})
    lines += [
        "",
        "Time in range (truth, mean over metrics and seeds) per scenario:",
        "",
        "| scenario | " + " | ".join(policies) + " |",
        "|---|" + "---:|" * len(policies),
    ]
    for s in scenarios:
        cells = []
        for p in policies:
            tirs = [
                r["time_in_range"]
                for r in rows
                if r["scenario"] == s and r["policy"] == p and r["time_in_range"] is not None
            ]
            m = _mean(tirs)
            cells.append(_f(None if m is None else 100 * m, ".1f"))
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def csv_text(rows: Sequence[Mapping[str, Any]]) -> str:
    """The per-talk rows as CSV (``latencies`` joined with ``;``)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        d = {k: r.get(k) for k in COLUMNS}
        d["latencies"] = ";".join(f"{x:g}" for x in r.get("latencies", []))
        w.writerow(d)
    return buf.getvalue()


def write_tables(rows: Sequence[Mapping[str, Any]], out: Path) -> tuple[Path, Path]:
    """Write ``evaluation.csv`` and ``evaluation.md`` into ``out``; returns their paths."""
    out.mkdir(parents=True, exist_ok=True)
    c, m = out / "evaluation.csv", out / "evaluation.md"
    c.write_text(csv_text(rows), encoding="utf-8")
    m.write_text(markdown_table(rows), encoding="utf-8")
    return c, m


# -- command line ------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="prezence evaluate",
        description="Closed-loop evaluation: scenarios × policies × seeds of synthetic talks.",
    )
    p.add_argument("--scenarios", nargs="+", help="scenario names or files (default: all)")
    p.add_argument("--policies", nargs="+", help="policy names (default: all)")
    p.add_argument("--seeds", type=int, default=3, help="seeds 0..N-1 per pair (default 3)")
    p.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    p.add_argument("--backend", default="fake", help="robot backend (default fake)")
    p.add_argument("--out", default="evaluation", help="folder for the CSV and Markdown")
    p.add_argument("--keep-sessions", action="store_true", help="keep each talk's folder")
    p.add_argument(
        "--ray",
        metavar="auto|local|ADDRESS",
        help="run the talks on Ray: 'local' starts one here, 'auto' or an address joins one",
    )
    return p


def evaluate_main(argv: Sequence[str] | None = None) -> int:
    """``prezence evaluate``: run the grid, write the tables, print the Markdown; returns 0."""
    from prezence.processor.resolve import POLICIES
    from sim.scenario import list_scenarios

    args = build_parser().parse_args(argv)
    scenarios = args.scenarios or list_scenarios()
    policies = args.policies or list(POLICIES)
    out = Path(args.out)
    t0 = time.perf_counter()

    from prezence.bars import progress_bar

    with progress_bar("talks") as show:  # ended before the table is printed
        rows = evaluate(
            scenarios,
            policies,
            args.seeds,
            jobs=args.jobs,
            backend=args.backend,
            ray=args.ray,
            keep_sessions=out / "sessions" if args.keep_sessions else None,
            progress=show,
        )
    wall = time.perf_counter() - t0
    c, m = write_tables(rows, out)
    print(markdown_table(rows), end="")
    print(
        f"{len(rows)} talks in {wall:.1f} s ({len(rows) / wall:.2f} talks/s, jobs {args.jobs}); "
        f"wrote {c} and {m}",
        file=sys.stderr,
    )
    return 0
