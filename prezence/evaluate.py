"""Closed-loop evaluation: scenarios × policies × seeds of whole synthetic talks.

Each talk runs through :func:`prezence.synthetic.runner.run_talk` (presenter → module files →
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
- ``violations``: joint-limit violations reported by the backend; empty (None) where it measures
  none (only the sim backend does: ``--backend sim``), and a table shows "–", not 0;
- ``cues_per_minute_max``: the most cues (of any kind) the robot started in any 60 s.

Every talk runs under a *presenter model* (``presenter`` column; see
:mod:`prezence.synthetic.presenters`):
``free`` (a cue costs nothing), ``cost`` (a presenter who pays for every interruption),
``cost:K`` (its assumptions × K), each with ``+measured`` for module noise set from the modules'
measured errors. The summary adds, per presenter model, the *gain per corrective cue*: the
policy's time in range minus that of ``none`` on the same talks (same scenarios and seeds), in
percentage points, divided by its corrective cues per talk.

``prezence evaluate`` calls :func:`evaluate_main`. ``sim`` is imported only inside the workers.
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import csv
import importlib
import io
import json
import logging
import math
import signal
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from prezence.argtypes import non_negative_int, positive_int
from prezence.errors import ConfigError, PrezenceError

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
    "cues_per_minute_max",
    "presenter",
)

#: The anchors (other systems' published policies), compared with Prezence's default.
ANCHORS = ("pz16", "presentation_trainer", "rhema")
#: Prezence's default policy.
DEFAULT_POLICY = "weighted"
#: Presenter models run by default: both, with the modules' measured noise.
DEFAULT_PRESENTERS = ("free+measured", "cost+measured")


@dataclass(frozen=True, order=True)
class Task:
    """One talk of the grid."""

    scenario: str
    policy: str
    seed: int
    backend: str = "fake"
    keep: str | None = None  # a folder to keep the session in (None: a temp folder)
    # the presenter model (prezence.synthetic.presenters.parse_presenter_model)
    presenter: str = "free"


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
        # None: the backend measured none (only the sim does), not a check passed
        "violations": (
            None if (jlv := summary["counts"].get("joint_limit_violations")) is None else int(jlv)
        ),
        "cues_per_minute_max": max_in_window([float(c["t"]) for c in cues], 60.0),
    }


def max_in_window(times: Sequence[float], window_s: float) -> int:
    """The most of ``times`` inside any half-open window ``[t, t + window_s)``.

    Example:
        >>> max_in_window([0.0, 10.0, 59.0, 60.0, 200.0], 60.0)
        3
    """
    ts = sorted(times)
    best = 0
    j = 0
    for i, t in enumerate(ts):
        while ts[j] <= t - window_s:
            j += 1
        best = max(best, i - j + 1)
    return best


# -- running -----------------------------------------------------------------------------------


def run_task(task: Task) -> dict[str, Any]:
    """Run one talk and score it (in a worker process; imports the simulator)."""
    from prezence.backends.registry import make_backend
    from prezence.processor import Decision
    from prezence.session import read_jsonl
    from prezence.synthetic.presenters import presenter_model
    from prezence.synthetic.runner import run_talk

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
            Path(task.keep) / f"{task.scenario}-{task.policy}-{task.seed}-{task.presenter}"
            if task.keep
            else Path(tmp) / "talk"
        )
        with presenter_model(task.presenter):
            result = run_talk(
                task.scenario,
                out=out,
                seed=task.seed,
                backend=backend,
                policy=task.policy,
                on_decision=on_decision,
            )
        if result.interrupted:
            # the talk caught Ctrl-C (or SIGTERM) to finish its folder; the evaluation stops
            # too: a talk cut short is no row to score as if it ran to its end
            raise KeyboardInterrupt
        truth = read_jsonl(result.session.truth, skipped=[])  # a damaged line: warned, skipped
        sides: dict[str, str] = {}
        from prezence.config.load import load_config

        for r in load_config(result.session.config).rules:
            if r.below:
                sides.setdefault(r.below, "below")
            if r.above:
                sides.setdefault(r.above, "above")
        row: dict[str, Any] = {"scenario": task.scenario, "policy": task.policy, "seed": task.seed}
        row.update(score_talk(result.summary, truth, result.cues, sides, started, decided))
        row["presenter"] = task.presenter
    return row


def _worker_init(level: int, modules: Sequence[str] = ()) -> None:
    """Workers log at the parent's level, but no lower than ERROR unless it is verbose: the
    tailer's per-line warnings about deliberately garbled streams would flood the terminal.
    They import ``modules``, which register policies of one's own (``register_policy``)."""
    logging.getLogger().setLevel(_talk_log_level(level))
    # Ctrl-C reaches every process of the terminal's group: the parent alone stops the
    # evaluation, and ends the workers (SIGTERM, sent to the parent alone, ends them the same way)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_sigterm)
    for m in modules:
        importlib.import_module(m)


def _exit_on_sigterm(signum: int, frame: Any) -> None:
    """A worker ended by the parent (:func:`_end_workers`) unwinds: its talk's temporary
    folder is removed on the way out, not left in the temp dir."""
    raise SystemExit(128 + signum)


def _talk_log_level(level: int) -> int:
    """The log level while the evaluation's talks run (see :func:`_worker_init`)."""
    return level if level < logging.WARNING else logging.ERROR


@contextlib.contextmanager
def _talk_logging() -> Iterator[None]:
    """Within, the root logger is at :func:`_talk_log_level`: ``--jobs 1`` (talks in this
    process) logs as the workers of ``--jobs 2`` do, not a warning per garbled line of a
    temporary folder that is gone when it is read."""
    root = logging.getLogger()
    before = root.level
    root.setLevel(_talk_log_level(root.getEffectiveLevel()))
    try:
        yield
    finally:
        root.setLevel(before)


def _end_workers(pool: ProcessPoolExecutor) -> None:
    """Stop the pool at once: queued talks cancelled, running ones ended (their temporary
    folders removed: :func:`_exit_on_sigterm`), no worker left behind (killed after 5 s)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.terminate()
    for proc in procs:
        with contextlib.suppress(Exception):
            proc.join(timeout=5)
            if proc.is_alive():
                proc.kill()


def _grid(
    scenarios: Iterable[str],
    policies: Iterable[str],
    seeds: int | Iterable[int],
    backend: str,
    keep: Path | None,
    presenters: Sequence[str] = ("free",),
) -> list[Task]:
    seed_list = list(range(seeds)) if isinstance(seeds, int) else list(seeds)
    if not seed_list:
        raise ValueError("no seeds")
    return sorted(
        Task(s, p, int(seed), backend, str(keep) if keep else None, m)
        for s in scenarios
        for p in policies
        for seed in seed_list
        for m in presenters
    )


#: With it set to 0 before ``import ray``, Ray takes the node's address to be loopback and
#: every server of a local cluster (GCS, raylet, workers) listens on 127.0.0.1 only (checked
#: with ``ss -ltnp``; without it they listen on all interfaces).
RAY_LOOPBACK_ENV = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"


def _import_ray(*, local: bool) -> Any:
    """``ray``; with ``local``, set so that a local cluster started now listens on 127.0.0.1
    only.

    Ray reads :data:`RAY_LOOPBACK_ENV` once, when it is first imported. When something
    imported it before (a notebook, a test runner), setting the variable comes too late and
    the cluster would listen on every interface: the constant Ray derived from it is set
    instead. A Ray that no longer has that constant is refused rather than exposed.
    """
    if local:
        import os

        os.environ[RAY_LOOPBACK_ENV] = "0"
    try:
        import ray
    except ImportError as e:
        raise PrezenceError('--ray needs ray: pip install "prezence[ray]"') from e
    if local:
        try:
            from ray._private import ray_constants
        except ImportError:
            ray_constants = None  # type: ignore[assignment]
        if getattr(ray_constants, "ENABLE_RAY_CLUSTER", None) is None:
            raise PrezenceError(
                f"ray {ray.__version__}: Prezence cannot make sure a local cluster listens on "
                "loopback only; use --ray auto with a cluster you started yourself"
            )
        ray_constants.ENABLE_RAY_CLUSTER = False
    return ray


def _run_ray(tasks: Sequence[Task], address: str, jobs: int) -> list[dict[str, Any]]:
    ray = _import_ray(local=address == "local")
    if not ray.is_initialized():
        if address == "local":
            # a new cluster here (never one found through RAY_ADDRESS or an earlier
            # `ray start`), on loopback only: nothing of it is reachable from outside
            ray.init(
                address="local",
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
    presenters: Sequence[str] = ("free",),
) -> list[dict[str, Any]]:
    """Run every scenario × policy × seed × presenter model; one scored row per talk, sorted.

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
        presenters: presenter models (``free``, ``cost``, ``cost:K``, ``…+measured``).

    Raises:
        ValueError: ``jobs`` < 1, no seeds or an unknown presenter model.
        UnknownName: an unknown scenario or policy (before any talk runs).
        ConfigError: a scenario file or a policy spec that is not valid, or a scenario, policy
            or presenter model given twice however spelt (``pt`` and ``presentation_trainer``),
            which would run its talks twice and double its summed counts (likewise).
    """
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    from prezence.processor import make_policy
    from prezence.processor.resolve import canonical_spec, worker_imports
    from prezence.synthetic.presenters import parse_presenter_model
    from prezence.synthetic.scenario import load_scenario

    scenarios = list(scenarios)
    for s in scenarios:
        load_scenario(s)  # here, not in a worker: the error is the same for any --jobs
    _refuse_repeats("scenario", scenarios, _scenario_file)
    given = list(policies)
    for p in given:
        make_policy(p)  # an unknown name fails here, before any talk runs
    # one spelling per policy (pt is presentation_trainer, a default value named is no
    # parameter): the rows are named by it, and the conclusions know an anchor by it
    policies = _refuse_repeats("policy", given, canonical_spec)
    imports = worker_imports(policies) if jobs > 1 and ray is None else []
    for m in presenters:
        parse_presenter_model(m)
    _refuse_repeats(
        "presenter model",
        presenters,
        lambda m: (parse_presenter_model(m).cost, parse_presenter_model(m).measured_noise),
    )
    tasks = _grid(scenarios, policies, seeds, backend, keep_sessions, presenters)
    if keep_sessions is not None:
        keep_sessions.mkdir(parents=True, exist_ok=True)
    rows: list[dict[str, Any]] = []
    if ray is not None:
        rows = _run_ray(tasks, ray, jobs)
    elif jobs == 1:
        with _talk_logging():
            for i, t in enumerate(tasks):
                rows.append(run_task(t))
                if progress is not None:
                    progress(i + 1, len(tasks))
    else:
        # spawn: workers start clean (no inherited threads or open files), on every platform.
        pool = ProcessPoolExecutor(
            max_workers=jobs,
            mp_context=get_context("spawn"),
            initializer=_worker_init,
            initargs=(logging.getLogger().getEffectiveLevel(), imports),
        )
        try:
            for i, row in enumerate(pool.map(run_task, tasks, chunksize=1)):
                rows.append(row)
                if progress is not None:
                    progress(i + 1, len(tasks))
        except BaseException:
            _end_workers(pool)  # Ctrl-C, SIGTERM or an error: no talk goes on without us
            raise
        pool.shutdown()
    return sorted(
        rows, key=lambda r: (r.get("presenter", ""), r["scenario"], r["policy"], r["seed"])
    )


def _scenario_file(name_or_path: str) -> Path:
    """The file a scenario name or path reads (``demo`` and ``scenarios/demo.toml`` are one)."""
    from prezence.synthetic.scenario import scenarios_dir

    text = str(name_or_path)
    if text.endswith(".toml") or "/" in text or "\\" in text:
        return Path(text).resolve()
    return (scenarios_dir() / f"{text}.toml").resolve()


def _refuse_repeats(kind: str, given: Sequence[str], key: Callable[[str], Any]) -> list[str]:
    """``given`` as the grid runs it (a policy in its canonical spelling, anything else as
    given), or a :class:`ConfigError` naming the first one given twice, however spelt: each of
    its talks would run twice and its summed counts (false alarms, stale cues) double."""
    seen: dict[Any, str] = {}
    out: list[str] = []
    for g in given:
        k = key(g)
        if k in seen:
            first = seen[k]
            if first == g:
                same = f"{kind} {g} is given twice"
            else:
                one = f", {k}" if isinstance(k, str) else ""
                same = f"{kind} {first} and {g} are one {kind}{one}"
            raise ConfigError(
                f"{same}: each of its talks would run twice and its summed counts (false "
                "alarms, stale cues) double; give it once"
            )
        seen[k] = g
        out.append(k if isinstance(k, str) else g)
    return out


# -- tables ------------------------------------------------------------------------------------


def _mean(xs: Sequence[float]) -> float | None:
    return sum(xs) / len(xs) if xs else None


def _presenters(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    out: list[str] = []
    for r in rows:
        m = str(r.get("presenter", "free"))
        if m not in out:
            out.append(m)
    return out


def aggregate(rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row per policy (per presenter model when there are several), over every scenario
    and seed, in first-seen order, with the gain per corrective cue against ``none``."""
    out = []
    for model in _presenters(rows):
        mrows = [r for r in rows if str(r.get("presenter", "free")) == model]
        order: list[str] = []
        for r in mrows:
            if r["policy"] not in order:
                order.append(r["policy"])
        silent = {
            (r["scenario"], r["seed"]): r["time_in_range"]
            for r in mrows
            if r["policy"] == "none" and r["time_in_range"] is not None
        }
        for p in order:
            rs = [r for r in mrows if r["policy"] == p]
            tirs = [r["time_in_range"] for r in rs if r["time_in_range"] is not None]
            lats = [x for r in rs for x in r["latencies"]]
            n = len(rs)
            paired = [
                r["time_in_range"] - silent[(r["scenario"], r["seed"])]
                for r in rs
                if r["time_in_range"] is not None and (r["scenario"], r["seed"]) in silent
            ]
            corrective = sum(r["corrective"] for r in rs) / n
            gain = _mean(paired) if len(paired) == n else None
            out.append(
                {
                    "presenter": model,
                    "policy": p,
                    "talks": n,
                    "time_in_range": _mean(tirs),
                    "gain_vs_none": gain,
                    "gain_per_corrective": (
                        gain / corrective if gain is not None and corrective > 0 else None
                    ),
                    "cues_per_talk": sum(r["cues"] for r in rs) / n,
                    "corrective_per_talk": corrective,
                    "latency_s": statistics.median(lats) if lats else None,
                    "false_alarms": sum(r["false_alarms"] for r in rs),
                    "stale": sum(r["stale"] for r in rs),
                    "cues_per_minute_max": max(int(r.get("cues_per_minute_max", 0)) for r in rs),
                    "backlog_s": max(r["backlog_s"] for r in rs),
                    "waited": sum(r["waited"] for r in rs),
                    # measured talks only; None when no talk's backend measured any
                    "violations": (
                        sum(v for v in measured)
                        if (
                            measured := [r["violations"] for r in rs if r["violations"] is not None]
                        )
                        else None
                    ),
                }
            )
    return out


def _f(x: float | None, fmt: str) -> str:
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)


def _pct(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:.1f} %"


def _secs(x: float | None) -> str:
    return "–" if x is None else f"{x:.1f} s"


def _pp(x: float | None) -> str:
    return "–" if x is None else f"{100 * x:+.2f}"


def conclusions(
    agg: Sequence[Mapping[str, Any]],
    *,
    default: str = DEFAULT_POLICY,
    anchors: Sequence[str] = ANCHORS,
) -> list[dict[str, Any]]:
    """Per presenter model: does the default policy beat every anchor on gain per corrective
    cue, with 0 stale cues and no more false alarms than any anchor? And which policy has the
    most gain per cue, the most time in range, the fewest false alarms (ties: all listed)."""
    out = []
    for model in dict.fromkeys(a["presenter"] for a in agg):
        rows = {a["policy"]: a for a in agg if a["presenter"] == model}
        d = rows.get(default)
        # an anchor run with parameters (rhema:window_s=30) is still that anchor
        counted = [p for p in rows if _anchor_of(p) in anchors]
        present = [rows[p] for p in counted]

        def best(key: str, rows_: Mapping[str, Mapping[str, Any]], low: bool = False) -> str:
            vals = {p: r[key] for p, r in rows_.items() if r[key] is not None and p != "none"}
            if not vals:
                return "–"
            top = min(vals.values()) if low else max(vals.values())
            return ", ".join(p for p, v in vals.items() if v == top)

        rec: dict[str, Any] = {
            "presenter": model,
            "most_gain_per_cue": best("gain_per_corrective", rows),
            "most_time_in_range": best("time_in_range", rows),
            "fewest_false_alarms": best("false_alarms", rows, low=True),
        }
        if d is not None and present:
            rec["anchors"] = counted
            g = d["gain_per_corrective"]
            rec["default_beats_anchors_per_cue"] = g is not None and all(
                a["gain_per_corrective"] is None or g > a["gain_per_corrective"] for a in present
            )
            rec["default_stale"] = d["stale"]
            rec["default_false_alarms_le_anchors"] = d["false_alarms"] <= min(
                a["false_alarms"] for a in present
            )
        out.append(rec)
    return out


def _anchor_of(policy: str) -> str:
    """The registered policy a row's spec names, aliases resolved (``pt:…`` →
    ``presentation_trainer``); a policy of one's own (``MODULE:CLASS``) is itself."""
    from prezence.processor.resolve import ALIASES, split_spec

    head, _ = split_spec(policy)
    return ALIASES.get(head, head)


def _summary_lines(agg: Sequence[Mapping[str, Any]]) -> list[str]:
    lines = [
        "| policy | talks | time in range | gain vs none (pp) | gain per corrective cue (pp) "
        "| cues / talk | corrective / talk | median latency | false alarms | stale "
        "| max cues in 60 s | backlog (max) | joint-limit violations |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for a in agg:
        lines.append(
            f"| {a['policy']} | {a['talks']} | {_pct(a['time_in_range'])} "
            f"| {_pp(a['gain_vs_none'])} | {_pp(a['gain_per_corrective'])} "
            f"| {a['cues_per_talk']:.1f} | {a['corrective_per_talk']:.1f} "
            f"| {_secs(a['latency_s'])} | {a['false_alarms']} | {a['stale']} "
            f"| {a['cues_per_minute_max']} | {a['backlog_s']:g} s | {_f(a['violations'], 'd')} |"
        )
    return lines


def _scenario_lines(rows: Sequence[Mapping[str, Any]], policies: Sequence[str]) -> list[str]:
    scenarios = sorted({r["scenario"] for r in rows})
    lines = [
        "| scenario | " + " | ".join(policies) + " |",
        "|---|" + "---:|" * len(policies),
    ]
    for s in scenarios:
        cells = []
        for p in policies:
            rs = [r for r in rows if r["scenario"] == s and r["policy"] == p]
            tirs = [r["time_in_range"] for r in rs if r["time_in_range"] is not None]
            m = _mean(tirs)
            cell = _f(None if m is None else 100 * m, ".1f")
            if rs and m is not None and p != "none":
                n = len(rs)
                cell += (
                    f" ({sum(r['corrective'] for r in rs) / n:.1f}"
                    f"/{sum(r['false_alarms'] + r['stale'] for r in rs) / n:.1f})"
                )
            cells.append(cell)
        lines.append(f"| {s} | " + " | ".join(cells) + " |")
    return lines


def markdown_table(rows: Sequence[Mapping[str, Any]]) -> str:
    """Per presenter model: the summary per policy, then policies × scenarios; then, with
    several models, which conclusions hold under each (the sensitivity table)."""
    agg = aggregate(rows)
    models = _presenters(rows)
    lines: list[str] = []
    for model in models:
        magg = [a for a in agg if a["presenter"] == model]
        mrows = [r for r in rows if str(r.get("presenter", "free")) == model]
        if len(models) > 1:
            lines += [f"### Presenter model `{model}`", ""]
        lines += _summary_lines(magg)
        lines += [
            "",
            "Time in range % (truth, mean over metrics and seeds) per scenario; in brackets "
            "corrective cues per talk / false alarms + stale cues per talk:",
            "",
        ]
        lines += _scenario_lines(mrows, [a["policy"] for a in magg])
        lines.append("")
    if len(models) > 1:
        lines += conclusion_lines(conclusions(agg))
    return "\n".join(lines).rstrip("\n") + "\n"


def conclusion_lines(concl: Sequence[Mapping[str, Any]]) -> list[str]:
    """The sensitivity table: one row per presenter model, the conclusions under it."""

    def yn(x: Any) -> str:
        return "–" if x is None else ("yes" if x else "no")

    # which rows counted as anchors, said when not the three anchors as named by default
    counted = list(dict.fromkeys(a for c in concl for a in c.get("anchors", ())))
    which = f" ({', '.join(counted)})" if counted and set(counted) != set(ANCHORS) else ""
    lines = [
        "Conclusions under each presenter model (a row per model; `cost:0.5` / `cost:1.5` scale "
        "every assumed cost by 0.5 / 1.5):",
        "",
        f"| presenter model | most gain per cue | most time in range | fewest false alarms "
        f"| {DEFAULT_POLICY} beats every anchor{which} per cue | {DEFAULT_POLICY} stale "
        f"| {DEFAULT_POLICY} false alarms <= anchors' |",
        "|---|---|---|---|---|---:|---|",
    ]
    for c in concl:
        lines.append(
            f"| {c['presenter']} | {c['most_gain_per_cue']} | {c['most_time_in_range']} "
            f"| {c['fewest_false_alarms']} | {yn(c.get('default_beats_anchors_per_cue'))} "
            f"| {c.get('default_stale', '–')} | {yn(c.get('default_false_alarms_le_anchors'))} |"
        )
    return lines


def evaluation_json(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """``evaluation.json``: ``policies`` (under the first ``cost`` presenter model, else the
    first model) and every model's in ``presenters``; time in range as a fraction."""
    agg = aggregate(rows)
    models = _presenters(rows)
    primary = next((m for m in models if m.startswith("cost") and ":" not in m), models[0])

    def table(model: str) -> dict[str, Any]:
        mrows = [r for r in rows if str(r.get("presenter", "free")) == model]
        pols = {
            a["policy"]: {k: v for k, v in a.items() if k not in ("policy", "presenter")}
            for a in agg
            if a["presenter"] == model
        }
        for p, rec in pols.items():
            rec["scenarios"] = {
                s: _mean(
                    [
                        r["time_in_range"]
                        for r in mrows
                        if r["policy"] == p
                        and r["scenario"] == s
                        and r["time_in_range"] is not None
                    ]
                )
                for s in sorted({r["scenario"] for r in mrows})
            }
        return pols

    return {
        "presenter": primary,
        "policies": table(primary),
        "presenters": {m: {"policies": table(m)} for m in models},
        "conclusions": conclusions(agg),
        "talks": len(rows),
    }


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
    """Write ``evaluation.csv``, ``evaluation.md`` and ``evaluation.json`` into ``out``;
    returns the paths of the first two."""
    out.mkdir(parents=True, exist_ok=True)
    c, m = out / "evaluation.csv", out / "evaluation.md"
    c.write_text(csv_text(rows), encoding="utf-8")
    m.write_text(markdown_table(rows), encoding="utf-8")
    (out / "evaluation.json").write_text(
        json.dumps(evaluation_json(rows), indent=1, sort_keys=True) + "\n", encoding="utf-8"
    )
    return c, m


# -- command line ------------------------------------------------------------------------------


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="prezence evaluate",
        description="Closed-loop evaluation: scenarios × policies × seeds of synthetic talks.",
    )
    p.add_argument("--scenarios", nargs="+", help="scenario names or files (default: all)")
    p.add_argument(
        "--policies",
        nargs="+",
        help="policy specs, e.g. weighted pz16 rhema 'weighted:escalate_after=3', or one of "
        "your own as MODULE:CLASS (docs/evaluation.md) (default: all)",
    )
    p.add_argument(
        "--presenters",
        nargs="+",
        type=_presenter_spec,
        default=list(DEFAULT_PRESENTERS),
        help="presenter models: free, cost, cost:K (assumptions x K, K from 0 to 5), each "
        "optionally +measured (module noise from the measured errors) (default: "
        f"{' '.join(DEFAULT_PRESENTERS)})",
    )
    p.add_argument("--seeds", type=positive_int, default=3, help="N seeds per pair (default 3)")
    p.add_argument(
        "--first-seed",
        type=non_negative_int,
        default=0,
        help="seeds K..K+N-1 (default 0); another K gives held-out talks for a tuned policy",
    )
    p.add_argument("--jobs", type=positive_int, default=1, help="worker processes (default 1)")
    p.add_argument("--backend", default="fake", help="robot backend (default fake)")
    p.add_argument(
        "--out",
        help="folder for the CSV, Markdown and JSON; one that exists and is not empty is refused "
        "(default: evaluation, or evaluation-2, -3 … when it holds earlier results)",
    )
    p.add_argument(
        "--force",
        action="store_true",
        help="when --out exists and is not empty, move it aside to OUT.old-<time> (nothing is "
        "ever deleted) instead of refusing",
    )
    p.add_argument("--keep-sessions", action="store_true", help="keep each talk's folder")
    p.add_argument(
        "--ray",
        metavar="auto|local|ADDRESS",
        help="run the talks on Ray: 'local' starts one here, 'auto' or an address joins one",
    )
    # as every command takes them, before or after its name (prezence sets the logging)
    p.add_argument("-v", "--verbose", action="count", default=0, help="more logging")
    p.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="errors only on stderr (no progress bar, no closing line); the table still on stdout",
    )
    return p


def _presenter_spec(text: str) -> str:
    """A presenter model the grid can run (``free``, ``cost``, ``cost:K``, ``…+measured``)."""
    from prezence.synthetic.presenters import parse_presenter_model

    try:
        parse_presenter_model(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text


def evaluate_main(argv: Sequence[str] | None = None) -> int:
    """``prezence evaluate``: run the grid, write the tables, print the Markdown; returns 0.

    Earlier results are never overwritten: the output folder is claimed as a session folder is
    (:func:`prezence.sessiondir.claim_session_dir`), before any talk runs.
    """
    from prezence.processor import policy_names
    from prezence.session import release_folder
    from prezence.sessiondir import claim_session_dir, drop_if_left_empty
    from prezence.synthetic.scenario import list_scenarios

    args = build_parser().parse_args(argv)
    scenarios = args.scenarios or list_scenarios()
    policies = args.policies or policy_names()
    out = claim_session_dir(args.out, "evaluation", force=args.force, default=Path("evaluation"))
    try:
        with drop_if_left_empty(out):
            return _evaluate_into(out, args, scenarios, policies)
    finally:
        release_folder(out)  # held from its claim: no second evaluation wrote into it meanwhile


def _evaluate_into(
    out: Path, args: argparse.Namespace, scenarios: Sequence[str], policies: Sequence[str]
) -> int:
    t0 = time.perf_counter()

    from prezence.bars import progress_bar

    done = [0, 0]  # talks done, talks in all

    bar = contextlib.nullcontext(None) if args.quiet else progress_bar("talks")
    with bar as show:  # ended before the table is printed

        def counted(n: int, total: int) -> None:
            done[:] = [n, total]
            if show is not None:
                show(n, total)

        try:
            rows = evaluate(
                scenarios,
                policies,
                range(args.first_seed, args.first_seed + args.seeds),
                jobs=args.jobs,
                backend=args.backend,
                ray=args.ray,
                keep_sessions=out / "sessions" if args.keep_sessions else None,
                progress=counted,
                presenters=args.presenters,
            )
        except KeyboardInterrupt:
            # the tables need every talk of the grid (a mean over part of it misleads)
            kept = " (the talks' folders kept under --keep-sessions)" if args.keep_sessions else ""
            when = f"after {done[0]} of {done[1]} talks" if done[1] else "before a talk ended"
            print(f"evaluation stopped {when}: no tables written{kept}", file=sys.stderr)
            raise
    wall = time.perf_counter() - t0
    c, m = write_tables(rows, out)
    print(markdown_table(rows), end="")
    if not args.quiet:
        print(
            f"{len(rows)} talks in {wall:.1f} s ({len(rows) / wall:.2f} talks/s, "
            f"jobs {args.jobs}); wrote {c}, {m} and {out / 'evaluation.json'}",
            file=sys.stderr,
        )
    return 0
