"""The one talk loop: a sample source, the processor and a robot backend, on a clock.

Every command that coaches runs a talk through :func:`run_talk`: ``run`` and ``demo`` (a
synthetic presenter), ``replay`` and ``rehearse`` (recorded streams), ``up`` (live input
modules), ``evaluate`` (thousands of synthetic talks) and the Gymnasium environment (which
drives a :class:`Talk` one step at a time and gives the cues itself). What differs between
them is only

- the **sample source** (:class:`SampleSource`): where samples come from, what the session
  folder's metadata and summary say about it, and who hears the cues;
- the **clock**: a :class:`SteppedClock` moves from one decision point to the next at once
  (simulated time: a synthetic talk or a recording), a :class:`WallClock` follows the wall
  clock and wakes when a module writes (a live talk);
- the :class:`RunOptions` (policy, seed, gesture speed, pacing, report).

Pacing is decided here and only here: a stepped run sleeps until the wall clock catches up
when ``RunOptions.realtime`` is set or the backend declares it moves in real time
(:attr:`prezence.backends.base.Backend.realtime`, true for a real NAO), never by its name.
"""

from __future__ import annotations

import contextlib
import logging
import math
import shutil
import time
from bisect import bisect_right
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from operator import attrgetter
from pathlib import Path
from time import time as unix_time
from typing import Any, Protocol

from prezence.backends.base import Backend
from prezence.clock import ManualClock, MonotonicClock
from prezence.coach import Coach, RoomNoise, default_planner
from prezence.config.model import Config
from prezence.config.tomlconf import dumps_config
from prezence.feedback.gestures import GestureLibrary, library_for_talk
from prezence.metrics import SNR_METRIC, default_stale_after_s
from prezence.processor import Cue, Decision, Processor, end_of_talk_notes, make_policy
from prezence.samples import Sample
from prezence.session import CUE_KEYS, FolderLock, SessionDir, dumps, read_jsonl
from prezence.streams.tail import MultiTailer, stamps_path
from prezence.summary import summarize_session

log = logging.getLogger(__name__)


class Terminated(KeyboardInterrupt):
    """SIGTERM (a CI runner's time limit, ``kill``), raised by the command line's handler: a
    talk stops as at Ctrl-C (its folder, summary and report written up to there) but the robot
    says no post-talk summary, so the process ends within moments, as the sender expects."""


#: The defaults of the command line, in one place (``prezence run --policy`` etc.).
DEFAULT_POLICY = "weighted"
DEFAULT_SPEED_FRACTION = 0.6

#: Progress callback: (talk seconds done, talk length).
Progress = Callable[[float, float], None]


@dataclass(frozen=True, kw_only=True)
class RunOptions:
    """How a talk is run. Every field that changes what the coach does is required.

    Attributes:
        policy: conflict policy name (``weighted``, ``seed``, ...; ``silent`` gives no cue).
        seed: for policies that use chance.
        speed_fraction: fraction of each joint's velocity limit the gestures use.
        realtime: pace a stepped run to the wall clock even when the backend does not need it.
        report: after the talk the robot says the spoken summary and ``report/`` is written.
        plots: the report draws its plots (matplotlib, about 1 s of CPU); without them it
            has its tables and says how to draw them (``prezence report DIR``).
        decision_log: ``changes`` (the default: a line where a cue is chosen or the reason,
            the robot's state or a metric's state changes), ``every`` (a line per decision
            point) or ``off``.
        gestures: a gesture library file of one's own (its gestures replace the built-in ones
            of the same name; the session records it and keeps a copy); None: the built-in one.
        speaker: who is rehearsing (``--speaker NAME``), recorded in ``session.json``: progress
            across rehearsals compares the talks of one speaker; None: not recorded.
        allow_unchecked_collision: on a backend that moves a physical body (naoqi), play
            gestures whose self-collision was not checked (no PyBullet) instead of refusing the
            talk; what was not checked is recorded in ``session.json``.
    """

    policy: str
    seed: int
    speed_fraction: float
    realtime: bool
    report: bool
    plots: bool = True
    decision_log: str = "changes"
    gestures: str | None = None
    speaker: str | None = None
    allow_unchecked_collision: bool = False

    def __post_init__(self) -> None:
        if not 0.0 < self.speed_fraction <= 1.0:
            raise ValueError(f"speed_fraction must be in (0, 1], got {self.speed_fraction!r}")
        if self.decision_log not in ("changes", "every", "off"):
            raise ValueError(f"decision_log: changes, every or off, not {self.decision_log!r}")

    @classmethod
    def default(cls, **changes: Any) -> RunOptions:
        """The command line's defaults with ``changes`` applied (tests, embedding)."""
        base = cls(
            policy=DEFAULT_POLICY,
            seed=0,
            speed_fraction=DEFAULT_SPEED_FRACTION,
            realtime=False,
            report=False,
        )
        return replace(base, **changes)


class SampleSource(Protocol):
    """Where a talk's samples come from (a presenter, recorded files, live modules).

    A source may also define ``time_used(now) -> float | None``: the time the presenter has
    used at talk time ``now``, when it is not ``now`` (an ``up`` of recordings, or its replay:
    the recordings' own clock, which the time warnings are judged on); None: ``now``. It is
    not required: a source without it (written before session 23) has the talk's clock
    (:meth:`SourceBase.time_used` gives None).
    """

    #: ``synthetic``, ``replay``, ``rehearsal`` or ``live`` (the session's ``kind``).
    kind: str
    #: The samples come from the session's own stream files: creating the session keeps them.
    keep_streams: bool
    #: Why the source stopped the talk early (None: it did not).
    error: str | None

    @property
    def talk_s(self) -> float | None:
        """The talk's length when known beforehand (None: until stopped)."""
        ...

    def start(self, session: SessionDir, config: Config) -> None:
        """Get ready to give samples into ``session`` (open files, start modules)."""
        ...

    def poll(self, now: float) -> Sequence[Sample]:
        """The samples stamped up to ``now`` not given before."""
        ...

    def wait(self, timeout_s: float) -> bool:
        """Block up to ``timeout_s`` for new data (live sources); True when some arrived."""
        ...

    def ended(self, now: float) -> bool:
        """True when the talk is over by the source's own account (live: time is up)."""
        ...

    def events(self, now: float) -> list[str]:
        """Supervision events since the last call (a module restarted...)."""
        ...

    def on_cue(self, cue: Cue) -> None:
        """The robot started ``cue`` (a closed-loop presenter reacts)."""
        ...

    def finish_input(self) -> None:
        """The talk is over: stop producing samples (live modules stop); those already
        written are still given by :meth:`poll`."""
        ...

    def stop(self) -> None:
        """Release what :meth:`start` took (idempotent; also called after an error)."""
        ...

    def meta(self) -> dict[str, Any]:
        """What ``session.json`` says about this source (besides the run's options)."""
        ...

    def summary_extra(self) -> dict[str, Any]:
        """What ``summary.json`` says about this source."""
        ...

    def truth(self) -> list[dict[str, Any]] | None:
        """Ground truth (synthetic talks; a recording's when it still holds), else None."""
        ...

    def tailer(self) -> MultiTailer | None:
        """The tailer that fed the processor (its counters go into the summary), if any."""
        ...

    def readings(self) -> Mapping[str, Any] | None:
        """The stream files as read beforehand (metric → samples, counters, problems), so
        that the summary does not read them again; None: it reads the session's files."""
        ...


class SourceBase:
    """Defaults for the optional parts of :class:`SampleSource`."""

    #: Why the source stopped the talk early: a module's own message about its input.
    error: str | None = None

    kind = "source"
    keep_streams = False

    def wait(self, timeout_s: float) -> bool:
        return False

    def ended(self, now: float) -> bool:
        return False

    def time_used(self, now: float) -> float | None:
        """The time used at ``now`` when it is not ``now`` (see :class:`SampleSource`)."""
        return None

    def events(self, now: float) -> list[str]:
        return []

    def on_cue(self, cue: Cue) -> None:
        return None

    def finish_input(self) -> None:
        return None

    def stop(self) -> None:
        return None

    def meta(self) -> dict[str, Any]:
        return {}

    def summary_extra(self) -> dict[str, Any]:
        return {}

    def truth(self) -> list[dict[str, Any]] | None:
        return None

    def tailer(self) -> MultiTailer | None:
        return None

    def readings(self) -> Mapping[str, Any] | None:
        return None


_sample_t = attrgetter("t")
#: Samples :meth:`RecordedSource.poll` steps over one by one before it bisects the rest.
_SCAN = 16


class RecordedSource(SourceBase):
    """Samples already recorded (a replay, a rehearsal's module files), in time order.

    ``clock``: every stamp the recording's modules wrote, in any stream file, sorted, when its
    time was judged on the recordings' clock (an ``up`` whose every input was a file,
    ``session.json``'s ``recorded_inputs``): :meth:`time_used` is then the newest of them
    given so far, as the live run's was (:meth:`prezence.launcher.LiveSource.time_used`), so
    that the replay, whose clock runs on to the live talk's end past the recordings', makes
    the live run's time decisions. None: the time used is the talk's clock.
    """

    kind = "replay"

    def __init__(
        self,
        samples: Sequence[Sample],
        *,
        talk_s: float,
        truth: list[dict[str, Any]] | None = None,
        meta: dict[str, Any] | None = None,
        extra: dict[str, Any] | None = None,
        copy_streams: dict[str, Path] | None = None,
        keep_streams: bool = False,
        kind: str = "replay",
        readings: Mapping[str, Any] | None = None,
        copy_files: dict[str, Path] | None = None,
        clock: Sequence[float] | None = None,
    ) -> None:
        self.kind = kind
        self._clock = clock
        self._ci = 0
        self._clock_t = 0.0
        self._copy_files = dict(copy_files or {})
        self._readings = readings
        self.keep_streams = keep_streams
        self._copy = dict(copy_streams or {})
        self._samples = samples
        self._talk_s = float(talk_s)
        self._truth = truth
        self._meta = dict(meta or {})
        self._extra = dict(extra or {})
        self._i = 0

    @property
    def talk_s(self) -> float | None:
        return self._talk_s

    def start(self, session: SessionDir, config: Config) -> None:
        """Copy the recorded stream files (file name → source) into ``session``, so that its
        summary and report read what the coach read, and the recording's other files (its
        modules' status records and logs) into its folder."""
        self._i = 0
        self._ci = 0
        self._clock_t = 0.0
        for name, path in self._copy_files.items():
            shutil.copyfile(path, session.root / name)
        for name, path in self._copy.items():
            shutil.copyfile(path, session.stream(name))
            stamps = stamps_path(path)  # what the coach alone knew of its lines
            if stamps.is_file():
                shutil.copyfile(stamps, stamps_path(session.stream(name)))

    def poll(self, now: float) -> Sequence[Sample]:
        ss = self._samples
        i = self._i
        n = len(ss)
        if i >= n or ss[i].t > now:
            return ()
        # A decision point takes a few samples (one per module): stepping over them costs
        # less than a bisection of the whole recording (17 key calls for 100k samples).
        j = i + 1
        while j < n and ss[j].t <= now:
            j += 1
            if j - i >= _SCAN:
                j = bisect_right(ss, now, lo=j, key=_sample_t)
                break
        self._i = j
        return ss[i:j]

    def next_t(self) -> float:
        """The time of the next sample :meth:`poll` will give (inf when none is left)."""
        ss = self._samples
        i = self._i
        return ss[i].t if i < len(ss) else math.inf

    def time_used(self, now: float) -> float | None:
        clock = self._clock
        if clock is None:
            return None
        i = self._ci
        if i < len(clock) and clock[i] <= now:
            i = bisect_right(clock, now, lo=i)
            self._ci = i
            self._clock_t = clock[i - 1]
        return self._clock_t

    def meta(self) -> dict[str, Any]:
        return {"talk_s": self._talk_s, **self._meta}

    def summary_extra(self) -> dict[str, Any]:
        return self._extra

    def truth(self) -> list[dict[str, Any]] | None:
        return self._truth

    def readings(self) -> Mapping[str, Any] | None:
        return self._readings


class SteppedClock:
    """Simulated time: decision points every ``dt`` seconds, reached at once.

    Args:
        dt: the decision period.
    """

    live = False
    drain_step_s: float
    drain_limit_s = 120.0

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self.drain_step_s = dt
        self._clock = ManualClock()

    def now(self) -> float:
        return self._clock.now()

    def points(self, talk_s: float) -> list[float]:
        """The decision points of a talk ``talk_s`` long (the first at ``dt``)."""
        n = int(round(talk_s / self.dt))
        return [k * self.dt for k in range(1, n + 1)]

    def set(self, t: float) -> None:
        self._clock.set(t)


class WallClock:
    """Live time: seconds since the talk began on the monotonic clock.

    Decision points fall every ``dt`` and as soon as a module writes (cue latency).
    """

    live = True
    drain_step_s = 0.05
    drain_limit_s = 10.0

    def __init__(self, dt: float) -> None:
        self.dt = dt
        self._clock = MonotonicClock()

    def now(self) -> float:
        return self._clock.now()


@dataclass
class TalkRun:
    """What a talk leaves: its folder, its cues and summary, and how it went."""

    session: SessionDir
    summary: dict[str, Any]
    cues: list[dict[str, Any]]
    decisions: int
    wall_s: float
    #: The talk stopped before its end (``stop`` said so, or Ctrl-C).
    truncated: bool = False
    interrupted: bool = False
    post_talk: dict[str, Any] | None = None
    #: ``report/report.html``, when the report was written.
    report: Path | None = None
    events: list[str] = field(default_factory=list)


class Talk:
    """One talk in progress: :meth:`start`, :meth:`step` at each decision point, :meth:`finish`.

    :func:`run_talk` drives it; the Gymnasium environment drives it itself and gives its
    agent's cues with :meth:`perform`.
    """

    def __init__(
        self,
        source: SampleSource,
        *,
        config: Config,
        session: SessionDir,
        backend: Backend,
        options: RunOptions,
        on_decision: Callable[[Decision], None] | None = None,
    ) -> None:
        self.source = source
        self.config = config
        self.session = session
        self.backend = backend
        self.options = options
        self.on_decision = on_decision
        self.processor = Processor(config, policy=make_policy(options.policy, seed=options.seed))
        # a library of one's own is read and planned, every command the talk can give
        # found in it, and every gesture the talk plays checked at its speed, before the
        # robot opens (the Gymnasium env and any caller of Talk included)
        if backend.name == "naoqi" and options.speed_fraction > _real_nao_speed_max():
            log.warning(
                "--speed %.2g plans gestures at %.0f%% of the URDF's joint velocities, which are "
                "no-load values a loaded real NAO joint does not reach; a real NAO may lag or "
                "clip them: use --speed %.1f or less on a real robot (docs/naoqi.md)",
                options.speed_fraction,
                100 * options.speed_fraction,
                _real_nao_speed_max(),
            )
        self.library = library_for_talk(
            options.gestures or None,
            speed_fraction=options.speed_fraction,
            commands=config.talk_commands(),
        )
        #: Why the self-collision of gestures this talk plays was not checked (empty: it was).
        #: A robot that moves a physical body refuses them unless the options allow them.
        self.unchecked_collision = _unchecked_collision(self.library, backend, options)
        #: The built-in gestures.toml or URDF where it is not the one the shipped record of their
        #: self-collision check names (edited in place), as session.json records it ({}: it is).
        self.builtin_edits = _builtin_edits()
        self.coach: Coach | None = None
        #: The folder held for this talk from :meth:`start` until it is finished or abandoned.
        self.hold: FolderLock | None = None
        #: SIGTERM stopped the talk: no post-talk summary (:class:`Terminated`).
        self.terminated = False
        self.wall0 = 0.0
        self._meta: dict[str, Any] = {}
        #: The samples the last :meth:`step` gave the processor.
        self.last_samples: Sequence[Sample] = ()
        #: The source's clock of the time used, when it has one (optional: see SampleSource).
        self._time_used: Callable[[float], float | None] | None = getattr(source, "time_used", None)
        #: When the source's next sample comes, when it can say (optional: a recording can).
        self._next_t: Callable[[], float] | None = getattr(source, "next_t", None)
        #: Until when a decision point would change nothing but the count of decisions
        #: (:attr:`Coach.quiet_until`, and no sample before it): :func:`run_talk` counts such
        #: points without stepping them. -inf: step every point.
        self.quiet_until = -math.inf

    @property
    def paced(self) -> bool:
        """Whether robot time must follow the wall clock (the option, or a real-time robot)."""
        return self.options.realtime or self.backend.realtime

    def start(self) -> None:
        """Open the robot, then write the folder's config and metadata and open the source.

        The robot comes first: an unreachable one fails before a session folder is written.
        The folder is then held until the talk is finished: a second talk into it at the same
        time is refused (:meth:`SessionDir.claim`).
        """
        self.backend.open()
        try:
            self.hold = self.session.claim()
            self.session.create(keep_streams=self.source.keep_streams)
            self.session.config.write_text(dumps_config(self.config))
            if self.library is not None:  # what the robot played, kept with the talk
                self.session.gestures.write_text(self.library.text)
            self.wall0 = time.perf_counter()
            self.source.start(self.session, self.config)
            self._meta = {  # after start: a live source's meta holds its start time
                "kind": self.source.kind,
                # when it was run (Unix time), so the order of rehearsals outlives a copy
                "started_at": round(unix_time(), 3),
                **self.source.meta(),
                "policy": self.options.policy,
                "backend": self.backend.name,
                "speed_fraction": self.options.speed_fraction,
                **({"gestures": self.library.record()} if self.library else {}),
                **({"built_in_gestures": self.builtin_edits} if self.builtin_edits else {}),
                **(
                    {"self_collision_unchecked": self.unchecked_collision}
                    if self.unchecked_collision
                    else {}
                ),
                **({"speaker": self.options.speaker} if self.options.speaker else {}),
            }
            self.session.write_meta(self._meta)
            self.coach = Coach(
                self.processor,
                self.backend,
                self.session,
                planner=default_planner(self.options.speed_fraction, library=self.library),
                on_cue=self.source.on_cue,
                log_mode=self.options.decision_log,
                # the speech module's own file (up, rehearse) or the recording's copy (replay)
                noise=RoomNoise(
                    self.session.stream(f"{SNR_METRIC}.txt"),
                    stale_after_s=default_stale_after_s(
                        SNR_METRIC, self.config.processor.stale_after_s
                    ),
                ),
            )
        except BaseException:
            try:
                self.source.stop()
            finally:
                self.release()
                self.backend.close()
            raise

    def release(self) -> None:
        """Let the session folder go (idempotent)."""
        hold, self.hold = self.hold, None
        if hold is not None:
            hold.release()

    def step(self, now: float, *, over: bool = False) -> Decision:
        """One decision point at ``now`` with the source's new samples (``over``: the talk
        ends at ``now``: the samples count, but no cue is given after the talk)."""
        assert self.coach is not None, "start() first"
        self.last_samples = self.source.poll(now)
        spent = None if self._time_used is None else self._time_used(now)
        d = self.coach.tick(now, self.last_samples, over=over, spent=spent)
        quiet = self.coach.quiet_until
        if quiet > now:  # and no sample comes before it
            next_t = self._next_t
            if next_t is None:
                quiet = -math.inf
            else:
                t = next_t()
                if t < quiet:
                    quiet = t
        self.quiet_until = quiet
        if self.on_decision is not None:
            self.on_decision(d)
        return d

    def perform(self, cue: Cue) -> bool:
        """Have the robot give ``cue`` now (an agent's choice); False when it is busy."""
        assert self.coach is not None, "start() first"
        self.quiet_until = -math.inf
        return self.coach.give(cue)

    def pace(self, t: float) -> None:
        """Sleep until the wall clock reaches talk time ``t`` (paced runs)."""
        ahead = t - (time.perf_counter() - self.wall0)
        if ahead > 0:
            time.sleep(ahead)

    def finish(
        self,
        now: float,
        *,
        clock: SteppedClock | WallClock,
        talk_s: float,
        completed: bool,
        truncated: bool = False,
        interrupted: bool = False,
        events: Sequence[str] = (),
    ) -> TalkRun:
        """End the talk at ``now``: the cue in progress finishes, then (with ``report``) the
        post-talk summary and the report; writes ``summary.json``.

        Args:
            completed: the talk ended as planned or by Ctrl-C (not by an error): only then is
                the post-talk summary said.
        """
        try:
            return self._finish(
                now,
                clock=clock,
                talk_s=talk_s,
                completed=completed,
                truncated=truncated,
                interrupted=interrupted,
                events=events,
            )
        finally:
            self.release()  # the folder is complete (or as complete as an error leaves it)

    def _finish(
        self,
        now: float,
        *,
        clock: SteppedClock | WallClock,
        talk_s: float,
        completed: bool,
        truncated: bool,
        interrupted: bool,
        events: Sequence[str],
    ) -> TalkRun:
        coach = self.coach
        assert coach is not None, "start() first"
        pace = self.pace if self.paced else None
        post: dict[str, Any] | None = None
        end = now
        try:
            end = coach.drain(
                now, step_s=clock.drain_step_s, limit_s=clock.drain_limit_s, pace=pace
            )
            # what the coach stopped repeating (escalation): said once at the end, reported
            notes = end_of_talk_notes(self.processor)
            if self.source.talk_s is None or truncated or interrupted:
                # the talk's length is where it stopped
                self.session.write_meta({**self._meta, "talk_s": round(talk_s, 3)})
            if self.options.report and completed and not self.terminated:
                post = self._post_talk(coach, end, notes, step_s=clock.drain_step_s, pace=pace)
            backend_stats = self.backend.stats()
        finally:
            coach.close()
            self.source.stop()
            self.backend.close()
        wall = time.perf_counter() - self.wall0
        truth = self.source.truth()
        if truth is not None:  # only a talk that ended has its ground truth written
            with self.session.truth.open("w") as f:
                for row in truth:
                    f.write(dumps(row, sort_keys=True) + "\n")
        extra: dict[str, Any] = {
            "policy": self.options.policy,
            "backend": self.backend.name,
            "decisions": coach.decisions,
            "ended_at_s": round(end, 3),
            "wall_s": round(wall, 4),
            **({"truncated": True} if truncated else {}),
            **self.source.summary_extra(),
            **({"stopped_repeating": notes} if notes else {}),
            **({"post_talk": post} if post is not None else {}),
            **({"gestures": self.library.record()} if self.library else {}),
        }
        if clock.live:
            extra["interrupted"] = interrupted
        elif interrupted:  # Ctrl-C or SIGTERM cut a synthetic talk short: say so, as live
            extra["interrupted"] = True
        if not clock.live and wall > 0:
            extra["realtime_factor"] = round(talk_s / wall, 1)
        summary = summarize_session(
            self.session,
            self.config,
            talk_s=talk_s,
            truth=truth,
            backend_stats=backend_stats,
            live=self.source.tailer(),
            processor=self.processor,
            readings=self.source.readings(),
            extra=extra,
        )
        page = None
        if self.options.report and completed:
            from prezence.report.build import write_report

            page = write_report(
                self.session.root, config=self.config, plots=self.options.plots, ended=True
            )
        return TalkRun(
            self.session,
            summary,
            # a damaged line is skipped here too (summary.json names it)
            read_jsonl(self.session.cues, require=CUE_KEYS, skipped=[]),
            coach.decisions,
            wall,
            truncated=truncated,
            interrupted=interrupted,
            post_talk=post,
            report=page,
            events=list(events),
        )

    def _post_talk(
        self,
        coach: Coach,
        now: float,
        notes: list[dict[str, Any]],
        *,
        step_s: float,
        pace: Callable[[float], None] | None,
    ) -> dict[str, Any] | None:
        """The robot says the post-talk summary (with ``notes``, what the coach stopped
        repeating); a Ctrl-C here skips it (None)."""
        from prezence.report.build import build_report
        from prezence.report.speech import summary_phrase

        # summary.json is not written yet: the modules' crashes come from the source
        extra = self.source.summary_extra()
        report = build_report(
            self.session.root,
            config=self.config,
            ended=True,
            modules=extra.get("modules"),
            stopped_at_limit=bool(extra.get("stopped_at_time_limit")),
            recording_s=extra.get("recording_s"),
            module_failures=extra.get("module_failures"),
        )
        report["stopped_repeating"] = notes  # summary.json is written after this
        phrase = summary_phrase(report)
        try:
            return coach.post_talk(phrase, now, step_s=step_s, pace=pace)
        except KeyboardInterrupt:
            log.info("post-talk summary skipped (Ctrl-C)")
            return None


def _real_nao_speed_max() -> float:
    # imported on use: the NAOqi client's module (sockets, threads) is for naoqi talks only
    from prezence.backends.naoqi import REAL_NAO_SPEED_MAX

    return REAL_NAO_SPEED_MAX


class View(Protocol):
    """A live view: told about every decision and every supervision event."""

    def decision(self, d: Decision) -> None: ...

    def event(self, now: float, text: str) -> None: ...


def run_talk(
    source: SampleSource,
    *,
    config: Config,
    session: SessionDir | Path,
    backend: Backend,
    options: RunOptions,
    clock: SteppedClock | WallClock | None = None,
    on_decision: Callable[[Decision], None] | None = None,
    progress: Progress | None = None,
    view: View | None = None,
    stop: Callable[[], bool] | None = None,
) -> TalkRun:
    """Run one talk from ``source`` against ``backend`` (unopened) and write its folder.

    Args:
        source: where the samples come from.
        config: rules and settings (the decision period sets the clock's step).
        session: the session folder (created; an earlier session's files are replaced).
        backend: an unopened robot backend; it is opened and closed here.
        options: policy, seed, speed, pacing, report.
        clock: None: stepped when the source knows the talk's length, else the wall clock.
        on_decision: called with every decision.
        progress: called after every decision point with (time, talk length).
        view: told about decisions and events (live talks).
        stop: polled at every decision point; True ends the talk early (truncated).
    """
    dt = config.processor.decision_period_s
    if clock is None:
        clock = SteppedClock(dt) if source.talk_s is not None else WallClock(dt)
    sess = session if isinstance(session, SessionDir) else SessionDir(Path(session))
    talk = Talk(
        source,
        config=config,
        session=sess,
        backend=backend,
        options=options,
        on_decision=on_decision,
    )
    with _each_warning_once():
        talk.start()
        events: list[str] = []
        now = talk_s = 0.0
        completed = truncated = interrupted = False
        try:
            if isinstance(clock, SteppedClock):
                length = float(source.talk_s or 0.0)
                pace = talk.pace if talk.paced else None
                points = clock.points(length)
                last = points[-1] if points else None
                # a point that would change nothing is counted, not stepped, when nothing
                # watches each point (a view, progress, a stop, pacing, on_decision)
                skip = (
                    view is None
                    and progress is None
                    and stop is None
                    and pace is None
                    and on_decision is None
                )
                coach = talk.coach
                assert coach is not None  # noqa: S101 - started above
                for now in points:
                    if skip and now < talk.quiet_until and now != last:
                        coach.decisions += 1
                        continue
                    clock.set(now)
                    if pace is not None:
                        pace(now)
                    d = talk.step(now, over=now == last)
                    if view is not None:
                        view.decision(_with_views(talk, d))
                    if progress is not None:
                        progress(now, length)
                    if stop is not None and stop():
                        truncated = True
                        break
                talk_s = now if truncated else length
            else:
                next_tick = 0.0
                while True:
                    now = clock.now()
                    if source.ended(now):
                        break
                    if stop is not None and stop():
                        break
                    source.wait(max(0.0, min(dt, next_tick - now)))  # new data: decide at once
                    now = clock.now()
                    d = talk.step(now)
                    next_tick = now + dt
                    if view is not None:
                        view.decision(_with_views(talk, d))
                    for ev in source.events(now):
                        events.append(f"{now:.1f} {ev}")
                        if view is not None:
                            view.event(now, ev)
            completed = source.error is None  # a module's bad input: no post-talk summary
        except KeyboardInterrupt as e:
            completed = interrupted = True
            talk.terminated = isinstance(e, Terminated)
            talk_s = now
            log.info("stopped by %s", "SIGTERM" if talk.terminated else "Ctrl-C")
        except BaseException:
            # the robot and the source are released; the error goes on
            _abandon(talk)
            raise
        if clock.live:
            talk_s = clock.now()
            talk.source.finish_input()
            talk.step(talk_s, over=True)  # the samples written while the modules stopped
            now = talk_s
        return talk.finish(
            now,
            clock=clock,
            talk_s=talk_s,
            completed=completed,
            truncated=truncated,
            interrupted=interrupted,
            events=events,
        )


#: The loggers whose warnings name a bad line of the talk's files (a stream line, a cue line).
_LINE_LOGGERS = ("prezence.streams.tail", "prezence.session")


def _builtin_edits() -> dict[str, Any]:
    """:func:`~prezence.feedback.collision.builtin_edits` of the project's URDF (after
    :func:`_unchecked_collision`, which checks an edited built-in library where it can)."""
    from prezence.feedback.collision import builtin_edits
    from prezence.feedback.limits import load_limits

    return builtin_edits(load_limits())


def _unchecked_collision(
    library: GestureLibrary | None, backend: Backend, options: RunOptions
) -> list[str]:
    """Why the self-collision of the gestures a talk plays was not checked (empty: it was).

    On a backend that moves a physical body (naoqi) such a talk is refused, before the robot
    opens and before a session folder is written, unless ``options`` allow it (then each reason
    is warned of); a simulated NAO has no self-collision and plays anything.

    Raises:
        GestureCheckFailed: naming the file and how to have it checked.
    """
    from prezence.feedback.collision import require_collision_checked, unchecked_collision
    from prezence.feedback.limits import load_limits

    limits = load_limits()
    if not backend.physical:
        return unchecked_collision(library, limits=limits)
    reasons = require_collision_checked(
        library,
        limits=limits,
        backend=backend.name,
        allow=options.allow_unchecked_collision,
    )
    for r in reasons:
        log.warning("%s: playing them unchecked on the robot, as asked", r)
    return reasons


class _Once(logging.Filter):
    """Lets each message through once."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        msg = record.getMessage()
        if msg in self.seen:
            return False
        self.seen.add(msg)
        return True


@contextlib.contextmanager
def _each_warning_once() -> Iterator[None]:
    """Within, a bad line is warned about once in the talk: the coach's reader names it
    while the talk runs, and the post-talk summary, ``summary.json`` and the report read
    the same files again (a damaged cue line was warned about five times)."""
    once = _Once()
    loggers = [logging.getLogger(name) for name in _LINE_LOGGERS]
    for lg in loggers:
        lg.addFilter(once)
    try:
        yield
    finally:
        for lg in loggers:
            lg.removeFilter(once)


def _with_views(talk: Talk, d: Decision) -> Decision:
    """``d`` with every metric's view (views are built only for those who show them)."""
    return d if d.metrics else d._replace(metrics=talk.processor.views(d.t))


def _abandon(talk: Talk) -> None:
    try:
        if talk.coach is not None:
            talk.coach.close()
    finally:
        try:
            talk.source.stop()
        finally:
            talk.release()
            talk.backend.close()
