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
import gc
import json
import logging
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from operator import attrgetter
from pathlib import Path
from typing import Any

from prezence.backends.registry import make_backend
from prezence.config.load import keep_recorded_time, load_config
from prezence.config.model import Config
from prezence.errors import ConfigError
from prezence.feedback.gestures import library_for_talk
from prezence.metrics import METRICS
from prezence.samples import GESTURES_SOURCE, Sample
from prezence.session import (
    TRUTH_KEYS,
    SessionDir,
    read_jsonl,
    sample_time_limit,
)
from prezence.sessiondir import overlaps
from prezence.streams.locate import locate_streams, no_streams_error
from prezence.streams.tail import StreamProblem, TailStats, read_stream
from prezence.summary import GESTURES_FROM_MOTION, SPEECH_STATUS, VISION_STATUS
from prezence.talk import RecordedSource, RunOptions, run_talk

log = logging.getLogger(__name__)

__all__ = [
    "ReplayResult",
    "find_streams",
    "load_samples",
    "locate_streams",
    "merge_readings",
    "no_streams_error",
    "process_recorded",
    "read_streams",
    "replay",
    "same_bands",
    "unused_inputs",
]


@dataclass
class ReplayResult:
    """What a replay or a rehearsal leaves: its folder, its cues, its summary, the report."""

    session: SessionDir
    cues: list[dict[str, Any]]
    summary: dict[str, Any]
    #: ``report/report.html``, when the report was written.
    report: Path | None = None


def find_streams(src: Path, config: Config) -> dict[str, Path]:
    """:func:`locate_streams`, but at least one file must be there.

    Raises:
        ConfigError: no rule has a stream file in ``src`` (the message names the files).
    """
    found = locate_streams(src, config)
    if not found:
        raise no_streams_error(src, config)
    return found


#: The rules file a folder of stream files may carry (the peers' workload, mkload.py, writes one).
RULES_FILE = "rules.conf"


def _looks_like_stream(path: Path) -> bool:
    """Whether ``path``'s first data line is in the stream format (``t value``, or a bare
    value): a notes file beside the streams is not one."""
    try:
        with path.open(encoding="utf-8", errors="replace") as f:
            for _, line in zip(range(20), f, strict=False):
                fields = line.split()
                if not fields or fields[0].startswith("#"):
                    continue
                try:
                    [float(x) for x in fields]
                except ValueError:
                    return False
                return len(fields) <= 3
    except OSError:
        return False
    return False


def unused_inputs(src: Path, config: Config, *, recorded: bool = False) -> list[str]:
    """What ``src`` holds that a replay under ``config`` would silently leave aside: one line
    for its stream files no rule reads (named; those of Prezence's own metrics are the
    context the report reads, not left aside), one for a ``rules.conf`` that is not the rules
    used. None for a Prezence session folder.

    Args:
        src: the folder replayed.
        config: the rules it is replayed under.
        recorded: the rules are the folder's own ``config.toml``.
    """
    read = {r.stream for r in config.rules}
    # every stream Prezence's modules write (not by importing the vision module: it needs
    # OpenCV, which a replay does not, and cost 17 MB of the replay's peak memory)
    own = {*METRICS, GESTURES_SOURCE}
    unread: list[str] = []
    for folder in (src / "streams", src):
        if folder.is_dir():
            unread += [
                p.name
                for p in sorted(folder.glob("*.txt"))
                if p.name not in read
                and p.stem not in own
                and p.name not in unread
                and _looks_like_stream(p)
            ]
    notes = []
    if unread:
        notes.append(
            f"{src}: {', '.join(unread)}: stream file(s) no rule reads, not judged (the rules "
            f"read {', '.join(sorted(read))})"
        )
    rules = src / RULES_FILE
    used = Path(config.source).resolve() if config.source else None
    if rules.is_file() and used != rules.resolve():
        room = src / "room.toml"
        from prezence.config.load import default_path

        if recorded:
            mine = "the recording's config.toml"
        elif used is None or used == Path(default_path()).resolve():
            mine = "Prezence's default rules"
        else:
            mine = str(config.source)
        notes.append(
            f"{rules}: not used (the rules are {mine}); to judge by it, pass --config {rules}"
            + (
                f" --room {room}"
                if room.is_file()
                else " (and --room FILE if its rules name room values)"
            )
        )
    return notes


def same_bands(a: Config, b: Config) -> bool:
    """Whether ``a`` and ``b`` judge every metric alike: same metrics, checks, bounds, offsets.

    Ground truth (the out-of-range stretches of a synthetic talk) holds only under the bands it
    was computed with; commands, weights and processor settings do not change it.
    """

    def bands(c: Config) -> dict[str, tuple[Any, ...]]:
        return {r.metric: (r.check, r.low, r.high, r.offset) for r in c.rules}

    return bands(a) == bands(b)


#: Summary keys of the recording that say what its modules did (a module that could not run,
#: crashes and restarts: a replay's report explains the same gaps) and how long its
#: recordings lasted (``up`` of files: the time used).
RECORDED_SUMMARY_KEYS = ("module_failures", "modules", "recording_s")


def _read_json_or_empty(path: Path) -> dict[str, Any]:
    """A JSON object file, or {} when it is missing or unreadable (a recording's summary)."""
    try:
        value = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return value if isinstance(value, dict) else {}


def replay(
    src: Path,
    *,
    out: Path,
    options: RunOptions,
    config: Config | None = None,
    backend: str = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    allocated_s: float | None = None,
) -> ReplayResult:
    """Re-run the processor over the recorded streams in ``src``; write a new session in ``out``.

    The recording's ground truth (``truth.jsonl``, synthetic talks only) is carried over when
    the rules judge every metric as the recorded ``config.toml`` does; with other bands it
    would call right cues false alarms, so it is dropped (a warning says so, and the summary's
    ``truth_dropped`` says why) and each cue is judged by the new rules on the recorded values.

    Args:
        src: a session folder (or any folder holding stream files).
        out: where the new decisions, cues and summary go (must differ from ``src``).
        options: policy, seed, gesture speed, pacing (``realtime``: at the recording's pace on
            the wall clock; a real robot is always paced), report.
        config: rules and settings; None uses ``src/config.toml`` if present, else the default.
            Likewise the gestures: with ``options.gestures`` None, a recording that played a
            library of one's own is replayed with its copy (``src/gestures.toml``).
        backend: robot backend name (see :mod:`prezence.backends.registry`).
        allocated_s: the time allocated, seconds (None: the recording's, from its
            ``config.toml``, whatever ``config`` says; else the config's).

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
    # the talk's own record (a streams/ folder given: its session's)
    rec = src_session
    if not rec.meta.exists() and src.name == "streams" and SessionDir(src.parent).meta.exists():
        rec = SessionDir(src.parent)
    recorded = load_config(rec.config) if rec.config.exists() else None
    if config is None:
        config = recorded if recorded is not None else load_config(None)
    if allocated_s is not None:
        config = config.with_allocated(allocated_s)
    else:
        config = keep_recorded_time(config, recorded, rec.config)
    meta = src_session.read_meta()
    paths = find_streams(src, config)
    for note in unused_inputs(src, config, recorded=recorded is not None):
        log.warning("%s", note)
    rec_meta = rec.read_meta()
    limit = sample_time_limit(rec, rec_meta)
    if options.gestures is None and rec_meta.get("gestures"):
        # the robot plays what it played in the recording, as the rules are the recording's
        options = replace(options, gestures=str(recorded_gestures(rec, rec_meta)))
    # before anything is written: a command these rules (the recording's, or the ones given)
    # can give whose gesture the library lacks would stop the talk at its first cue
    library_for_talk(
        options.gestures or None,
        speed_fraction=options.speed_fraction,
        commands=config.talk_commands(),
    )
    with _collector_paused():
        readings = read_streams(paths, max_t=limit, ranges=config.value_ranges())
        readings = _without_fallback_gestures(readings, (src, rec.streams))
        samples = merge_readings(readings)
    talk_s = float(meta.get("talk_s") or min(limit, samples[-1].t if samples else 0.0))

    # a damaged line (a torn last one) is skipped and named, in the summary and report too:
    # the truth column lacks it (the replay's own truth.jsonl is written without it)
    bad_truth: list[str] = []
    truth = (
        read_jsonl(src_session.truth.absolute(), require=TRUTH_KEYS, skipped=bad_truth)
        if src_session.truth.exists()
        else None
    )
    if bad_truth and not truth:  # every line damaged: no truth, not a talk always in range
        truth = None
    # absolute: a relative path means nothing once the command's folder is gone (a report
    # rebuilt from elsewhere could not find the recording its cues were heard in)
    source = str(src.absolute())
    extra: dict[str, Any] = {
        "replay_of": source,
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
    elif bad_truth:
        extra["truth_skipped"] = bad_truth
    # what the coach and the report read besides the rules' streams: when the voice was heard
    # (late first words, a time-limit stop's wording), whether the gesture rate counted every
    # arm, and the room's SNR (a clarity cue names the noise, as in the recorded talk)
    judged = {r.stream for r in config.rules}
    # every stream the recording measured beyond the rules' (a session folder's; a folder of
    # stream files: those named after a metric), so that the replay's coach and report read
    # what the recording's did: when a voice was heard, whether a gesture rate counted every
    # arm, the room's SNR (a clarity cue in noise names it), head turns, …
    context: dict[str, Path] = {}
    for folder, known_only in ((rec.streams, False), (src, True)):
        if folder.is_dir():
            context.update(
                (p.name, p)
                for p in sorted(folder.glob("*.txt"))
                if p.name not in judged
                and p.name not in context
                and (not known_only or p.stem in METRICS)
            )
    # the modules' status records (an uncalibrated volume, head pose off) and the logs the
    # report's notes point at ("speech.log says which")
    files = {
        p.name: p
        for p in sorted(src.glob("*"))
        if p.is_file() and (p.name in (SPEECH_STATUS, VISION_STATUS) or p.suffix == ".log")
    }
    # an `up` whose every input was a file judged its time on the recordings' clock, the
    # newest stamp its modules wrote: the replay's clock runs on to the live talk's end (the
    # coach's clock, past the recordings'), so it judges time on the recordings' too
    clock = (
        recordings_clock(samples, context.values(), max_t=limit)
        if rec_meta.get("recorded_inputs")
        else None
    )
    recorded_summary = _read_json_or_empty(rec.summary)
    stopped = recorded_summary.get("stopped_at_time_limit")
    if stopped:  # the recorded talk was cut at its time limit: so is its replay
        extra["stopped_at_time_limit"] = stopped
    for key in RECORDED_SUMMARY_KEYS:
        if recorded_summary.get(key):
            extra[key] = recorded_summary[key]
    session = SessionDir(out)
    with _collector_spares_what_is_read():
        return process_recorded(
            session,
            config,
            samples,
            talk_s=talk_s,
            truth=truth,
            options=options,
            backend=backend,
            backend_kwargs=backend_kwargs,
            copy_streams=paths,
            context_streams=context,
            copy_files=files,
            readings=readings,
            clock=clock,
            meta={
                "source": source,
                **({"scenario": meta["scenario"]} if "scenario" in meta else {}),
            },
            extra=extra,
        )


@contextlib.contextmanager
def _collector_paused() -> Iterator[None]:
    """The cyclic garbage collector paused while the recording is read: reading makes one
    tuple per line (108k in the peers' 200k workload, none of them garbage) and the collector,
    started every 700 of them, walked the growing lists again and again (1% of a replay's
    instructions). Nothing read makes a reference cycle; the collector runs again after."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


@contextlib.contextmanager
def _collector_spares_what_is_read() -> Iterator[None]:
    """While the talk is replayed, the objects there are before it (the modules, the
    recording's samples, the rules) are frozen out of the cyclic garbage collector
    (:func:`gc.freeze`): they live through the replay, and each of its collections walked
    them all (1.6% of a replay's instructions). They are unfrozen after it, so that any cycle
    among them is collected as before; a process that froze objects itself is left as it is.
    """
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def recordings_clock(
    samples: Sequence[Sample], others: Iterable[Path], *, max_t: float
) -> list[float]:
    """Every stamp of ``samples`` and of the stream files ``others`` (those no rule judges:
    in a pause the speech module writes ``speech_activity`` alone), up to ``max_t``, sorted:
    the recordings' clock of an ``up`` of files (:class:`prezence.talk.RecordedSource`)."""
    stamps = [s.t for s in samples]
    for path in others:
        stamps.extend(s.t for s in read_stream(path, path.stem, max_t=max_t)[0])
    stamps.sort()
    return stamps


def recorded_gestures(rec: SessionDir, meta: Mapping[str, Any]) -> Path:
    """The copy of the gesture library of one's own a recorded talk played.

    Raises:
        ConfigError: ``session.json`` names one and the copy is gone.
    """
    kept = rec.gestures
    if not kept.is_file():
        played = (meta.get("gestures") or {}).get("file")
        raise ConfigError(
            f"gestures: the talk played the gestures of {played}, but their copy {kept} is "
            "missing; give them with --gestures FILE",
            path=rec.meta,
        )
    return kept


#: One stream file as read: its samples in file order, its counters, the lines skipped.
Reading = tuple[list[Sample], TailStats, list[StreamProblem]]


def read_streams(
    paths: dict[str, Path],
    *,
    max_t: float | None = None,
    ranges: Mapping[str, tuple[float, float]] | None,
) -> dict[str, Reading]:
    """Read each stream file once (metric → file); warns about malformed lines.

    Samples stamped after ``max_t`` (the talk's end plus a margin) are skipped and counted.
    Values outside ``ranges[metric]`` (:meth:`Config.value_ranges`, the metrics' physical
    ranges) are skipped as malformed lines; None, or a metric not in it: every finite value.
    """
    out: dict[str, Reading] = {}
    for metric, path in paths.items():
        problems: list[StreamProblem] = []
        ss, tail_stats = read_stream(
            path,
            metric,
            problems=problems,
            max_t=max_t,
            value_range=(ranges or {}).get(metric),
        )
        if tail_stats.malformed:
            log.warning("%s: %d malformed lines skipped", path, tail_stats.malformed)
        if tail_stats.beyond_talk:
            log.warning(
                "%s: %d samples stamped after the talk's end (%.0f s) skipped",
                path,
                tail_stats.beyond_talk,
                max_t,
            )
        out[metric] = (ss, tail_stats, problems)
    return out


def load_samples(
    paths: dict[str, Path],
    *,
    max_t: float | None = None,
    ranges: Mapping[str, tuple[float, float]] | None,
) -> list[Sample]:
    """Every sample of the given stream files, in time order (file order kept for ties);
    ``max_t`` and ``ranges`` as in :func:`read_streams`."""
    return merge_readings(read_streams(paths, max_t=max_t, ranges=ranges))


def _without_fallback_gestures(
    readings: dict[str, Reading], folders: Sequence[Path]
) -> dict[str, Reading]:
    """``readings`` without the ``cv_gestures`` samples a folder written before session 23 took
    from the frame-difference fallback (``cv_gestures_source`` 2 at the same time). Since then
    the vision module writes that rate as ``cv_gestures_motion``, which no default rule judges,
    as the report says ("less reliable, so no advice on it"); a replay of an older folder cued
    "Use your hands more" from it on a video with no one in view."""
    if "cv_gestures" not in readings:
        return readings
    fallback: set[float] = set()
    for folder in folders:
        path = folder / f"{GESTURES_SOURCE}.txt"
        if path.is_file():
            marks, _ = read_stream(path, GESTURES_SOURCE, problems=[])
            fallback = {x.t for x in marks if x.value == GESTURES_FROM_MOTION}
            break
    if not fallback:
        return readings
    ss, stats, problems = readings["cv_gestures"]
    kept = [x for x in ss if x.t not in fallback]
    if len(kept) < len(ss):
        log.warning(
            "cv_gestures: %d samples from the frame-difference fallback (cv_gestures_source "
            "2, a folder written before session 23) not replayed: no rule judges that rate now",
            len(ss) - len(kept),
        )
    return {**readings, "cv_gestures": (kept, stats, problems)}


def merge_readings(readings: dict[str, Reading]) -> list[Sample]:
    """Every sample of ``readings`` in time order (file order kept for ties)."""
    samples: list[Sample] = []
    for ss, _, _ in readings.values():
        samples.extend(ss)
    samples.sort(key=attrgetter("t"))
    return samples


class _SaidAlready(logging.Filter):
    """Drops the stream reader's warnings about the files in one folder."""

    def __init__(self, folder: Path) -> None:
        super().__init__()
        self.prefix = f"{folder}{os.sep}"

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(self.prefix)


@contextlib.contextmanager
def _said_already(folder: Path) -> Iterator[None]:
    """While the new session's summary and report read its stream files (copies of the
    source's, or a rehearsal's own), their bad lines are not warned about again: they were,
    once, naming the source, when the coach's samples were read (:func:`read_streams`)."""
    tail_log = logging.getLogger(read_stream.__module__)
    said = _SaidAlready(folder)
    tail_log.addFilter(said)
    try:
        yield
    finally:
        tail_log.removeFilter(said)


def process_recorded(
    session: SessionDir,
    config: Config,
    samples: list[Sample],
    *,
    talk_s: float,
    options: RunOptions,
    truth: list[dict[str, Any]] | None = None,
    backend: str = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    copy_streams: dict[str, Path] | None = None,
    context_streams: dict[str, Path] | None = None,
    copy_files: dict[str, Path] | None = None,
    readings: dict[str, Reading] | None = None,
    kind: str = "replay",
    meta: dict[str, Any] | None = None,
    extra: dict[str, Any] | None = None,
    clock: Sequence[float] | None = None,
) -> ReplayResult:
    """Run the coach over recorded samples on their own clock; write decisions, cues, summary.

    Decision points fall every ``decision_period_s`` and each sees the samples stamped up to it,
    exactly as in a live or headless talk (:func:`prezence.talk.run_talk` on a stepped clock).

    Args:
        copy_streams: stream files to copy into the new session (metric → file), so that
            its summary and report read what the coach read. None: the samples were read
            from ``session``'s own stream files (a rehearsal), which are kept.
        context_streams: stream files no rule judges that the report reads (file name → file),
            copied too.
        copy_files: other files of the recording copied into the session folder (file name
            → file): its modules' status records and logs, which the report's notes read and
            name.
        readings: the stream files as read (:func:`read_streams`): the summary then does not
            read them again.
        kind: the session's kind (``replay``, ``rehearsal``).
        meta: more for ``session.json``.
        extra: more for ``summary.json``.
        clock: the recordings' clock, which the time is judged on (see
            :class:`prezence.talk.RecordedSource`); None: the talk's clock.
    """
    source = RecordedSource(
        samples,
        talk_s=talk_s,
        truth=truth,
        meta=meta,
        extra=extra,
        copy_streams={
            **(context_streams or {}),
            **{config.rule(m).stream: p for m, p in (copy_streams or {}).items()},
        },
        keep_streams=copy_streams is None,
        kind=kind,
        readings=readings,
        copy_files=copy_files,
        clock=clock,
    )
    bk = make_backend(backend, **(backend_kwargs or {}))
    with _said_already(session.streams):
        run = run_talk(source, config=config, session=session, backend=bk, options=options)
    return ReplayResult(run.session, run.cues, run.summary, run.report)
