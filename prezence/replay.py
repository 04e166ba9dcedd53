"""Replay: run the processor again over module files already recorded, on their own timestamps.

Any folder with stream files in the project's format works: a live talk, a recorded rehearsal, a
synthetic run, or files another tool wrote. The decision points fall at the same times as in a
live or headless talk (every ``decision_period_s``) and each point sees exactly the samples
stamped up to it, so replaying a synthetic run with the same config, policy and backend
reproduces its decision log byte for byte. The presenter cannot react to replayed cues: the
loop is open.
"""

from __future__ import annotations

import contextlib
import logging
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from prezence.backends.registry import make_backend
from prezence.coach import Coach, default_planner
from prezence.config.load import load_config
from prezence.config.model import Config
from prezence.config.tomlconf import dumps_config
from prezence.errors import ConfigError
from prezence.processor import Processor, make_policy
from prezence.samples import Sample
from prezence.session import (
    TRUTH_KEYS,
    SessionDir,
    read_jsonl,
    sample_time_limit,
)
from prezence.sessiondir import overlaps
from prezence.streams.tail import read_stream
from prezence.summary import summarize_session

log = logging.getLogger(__name__)


@dataclass
class ReplayResult:
    """What a replay or a rehearsal leaves: its folder, its cues, its summary, the report."""

    session: SessionDir
    cues: list[dict[str, Any]]
    summary: dict[str, Any]
    #: ``report/report.html``, when the report was written.
    report: Path | None = None


def locate_streams(src: Path, config: Config) -> dict[str, Path]:
    """The stream file of each rule that has one: ``src/streams/<file>``, else ``src/<file>``.

    The one stream discovery of replays, rehearsals and reports; rules without a file are
    left out.
    """
    found: dict[str, Path] = {}
    for rule in config.rules:
        for cand in (src / "streams" / rule.stream, src / rule.stream):
            if cand.is_file():
                found[rule.metric] = cand
                break
    return found


def no_streams_error(src: Path, config: Config) -> ConfigError:
    """The error for a folder in which :func:`locate_streams` finds nothing."""
    names = ", ".join(r.stream for r in config.rules)
    return ConfigError(
        f"no stream files found (looked for {names} in streams/ and the folder)", path=src
    )


def find_streams(src: Path, config: Config) -> dict[str, Path]:
    """:func:`locate_streams`, but at least one file must be there.

    Raises:
        ConfigError: no rule has a stream file in ``src`` (the message names the files).
    """
    found = locate_streams(src, config)
    if not found:
        raise no_streams_error(src, config)
    return found


def same_bands(a: Config, b: Config) -> bool:
    """Whether ``a`` and ``b`` judge every metric alike: same metrics, checks, bounds, offsets.

    Ground truth (the out-of-range stretches of a synthetic talk) holds only under the bands it
    was computed with; commands, weights and processor settings do not change it.
    """

    def bands(c: Config) -> dict[str, tuple[Any, ...]]:
        return {r.metric: (r.check, r.low, r.high, r.offset) for r in c.rules}

    return bands(a) == bands(b)


def replay(
    src: Path,
    *,
    out: Path,
    config: Config | None = None,
    policy: str = "weighted",
    backend: str = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    speed_fraction: float = 0.6,
    seed: int = 0,
    allocated_s: float | None = None,
    realtime: bool = False,
    report: bool = False,
) -> ReplayResult:
    """Re-run the processor over the recorded streams in ``src``; write a new session in ``out``.

    The recording's ground truth (``truth.jsonl``, synthetic talks only) is carried over when
    the rules judge every metric as the recorded ``config.toml`` does; with other bands it
    would call right cues false alarms, so it is dropped (a warning says so, and the summary's
    ``truth_dropped`` says why) and each cue is judged by the new rules on the recorded values.

    Args:
        src: a session folder (or any folder holding stream files).
        out: where the new decisions, cues and summary go (must differ from ``src``).
        config: rules and settings; None uses ``src/config.toml`` if present, else the default.
        policy: the conflict policy to try.
        backend: robot backend (``fake``, ``sim`` or ``naoqi``).
        speed_fraction: gesture speed.
        seed: for policies that use chance.
        allocated_s: the time allocated, seconds (None keeps the config's).
        realtime: pace the replay to the wall clock (a real robot moves in real time).
        report: write ``out/report/`` (HTML, plots, JSON) after the replay.

    Raises:
        ConfigError: ``out`` is ``src``, ``src`` holds no stream file, or a config is invalid.
    """
    src = Path(src)
    out = Path(out)
    if overlaps(out, src):
        raise ConfigError(
            f"--out must be another folder, outside the recording {src}: replay never writes "
            "into or over it",
            path=out,
        )
    src_session = SessionDir(src)
    recorded = load_config(src_session.config) if src_session.config.exists() else None
    if config is None:
        config = recorded if recorded is not None else load_config(None)
    if allocated_s is not None:
        config = config.with_allocated(allocated_s)
    meta = src_session.read_meta()
    paths = find_streams(src, config)
    # the talk's length by its own record (a streams/ folder given: its session's record)
    rec = src_session
    if not rec.meta.exists() and src.name == "streams" and SessionDir(src.parent).meta.exists():
        rec = SessionDir(src.parent)
    limit = sample_time_limit(rec, rec.read_meta())
    samples = load_samples(paths, max_t=limit)
    talk_s = float(meta.get("talk_s") or min(limit, samples[-1].t if samples else 0.0))

    session = SessionDir(out).create()
    session.config.write_text(dumps_config(config))
    for metric, path in paths.items():
        shutil.copyfile(path, session.stream(config.rule(metric).stream))
    session.write_meta(
        {
            "kind": "replay",
            "source": str(src),
            "policy": policy,
            "backend": backend,
            "talk_s": talk_s,
            **({"scenario": meta["scenario"]} if "scenario" in meta else {}),
        }
    )
    truth = (
        read_jsonl(src_session.truth, require=TRUTH_KEYS) if src_session.truth.exists() else None
    )
    extra: dict[str, Any] = {
        "replay_of": str(src),
        **({"scenario": meta["scenario"]} if "scenario" in meta else {}),
    }
    if truth is not None and (recorded is None or not same_bands(config, recorded)):
        why = (
            "the rules' bands differ from the recording's"
            if recorded is not None
            else f"{src_session.config} is missing, so the rules it holds for cannot be checked"
        )
        log.warning(
            "%s: ground truth not used (%s); cues are judged by the new rules on the "
            "recorded values",
            src_session.truth,
            why,
        )
        extra["truth_dropped"] = why
        truth = None
    else:
        with contextlib.suppress(OSError):
            shutil.copyfile(src_session.truth, session.truth)
    return process_recorded(
        session,
        config,
        samples,
        talk_s=talk_s,
        truth=truth,
        policy=policy,
        backend=backend,
        backend_kwargs=backend_kwargs,
        speed_fraction=speed_fraction,
        seed=seed,
        realtime=realtime,
        report=report,
        extra=extra,
    )


def load_samples(paths: dict[str, Path], *, max_t: float | None = None) -> list[Sample]:
    """Every sample of the given stream files, in time order (file order kept for ties).

    Samples stamped after ``max_t`` (the talk's end plus a margin) are skipped and counted.
    """
    samples: list[Sample] = []
    for metric, path in paths.items():
        ss, tail_stats = read_stream(path, metric, max_t=max_t)
        if tail_stats.malformed:
            log.warning("%s: %d malformed lines skipped", path, tail_stats.malformed)
        if tail_stats.beyond_talk:
            log.warning(
                "%s: %d samples stamped after the talk's end (%.0f s) skipped",
                path,
                tail_stats.beyond_talk,
                max_t,
            )
        samples.extend(ss)
    samples.sort(key=lambda s: s.t)
    return samples


def process_recorded(
    session: SessionDir,
    config: Config,
    samples: list[Sample],
    *,
    talk_s: float,
    truth: list[dict[str, Any]] | None = None,
    policy: str = "weighted",
    backend: str = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    speed_fraction: float = 0.6,
    seed: int = 0,
    realtime: bool = False,
    report: bool = False,
    extra: dict[str, Any] | None = None,
) -> ReplayResult:
    """Run the coach over recorded samples on their own clock; write decisions, cues, summary.

    Decision points fall every ``decision_period_s`` and each sees the samples stamped up to it,
    exactly as in a live or headless talk.

    Args:
        realtime: sleep before each decision point until the wall clock gets there (always
            on for the ``naoqi`` backend: a real robot moves in real time).
        report: write ``SESSION/report/`` afterwards (see
            :func:`prezence.report.build.write_report`).
    """
    bk = make_backend(backend, **(backend_kwargs or {}))
    processor = Processor(config, policy=make_policy(policy, seed=seed))
    dt = config.processor.decision_period_s
    wall0 = time.perf_counter()

    def pace(t: float) -> None:
        time.sleep(max(0.0, t - (time.perf_counter() - wall0)))

    paced = pace if realtime or bk.name == "naoqi" else None
    bk.open()
    coach = Coach(processor, bk, session, planner=default_planner(speed_fraction))
    try:
        i = 0
        n = int(round(talk_s / dt))
        for k in range(1, n + 1):
            now = k * dt
            j = i
            while j < len(samples) and samples[j].t <= now:
                j += 1
            if paced is not None:
                paced(now)
            coach.tick(now, samples[i:j])
            i = j
        end = coach.drain(n * dt, step_s=dt, pace=paced)
        backend_stats = bk.stats()
    finally:
        coach.close()
        bk.close()
    summary = summarize_session(
        session,
        config,
        talk_s=talk_s,
        truth=truth,
        backend_stats=backend_stats,
        processor=processor,
        extra={
            "policy": policy,
            "backend": bk.name,
            "decisions": coach.decisions,
            "ended_at_s": round(end, 3),
            "wall_s": round(time.perf_counter() - wall0, 4),
            **(extra or {}),
        },
    )
    page = None
    if report:
        from prezence.report.build import write_report

        page = write_report(session.root, config=config)
    return ReplayResult(session, read_jsonl(session.cues), summary, page)
