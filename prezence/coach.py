"""The coach: one decision loop shared by headless talks, live rehearsals and replays.

Each :meth:`Coach.tick` moves the robot to ``now``, hands the new samples to the processor,
writes the decision, and, when a cue is chosen, has the robot perform it (gesture and phrase
together). The robot is asked only when it is free, so no cue ever waits in a queue.

A clarity cue in a noisy room names the noise (session 21). Clarity (``speech_accuracy``)
falls where the speech is hard to hear, noise included, so "speak more clearly" would blame
the presenter's articulation for the room. When the processor cues ``speech_accuracy`` and
the speech module's latest fresh ``speech_snr`` (the same word window's estimated SNR) is
under :data:`prezence.metrics.NOISY_SNR_DB`, the cue gets the parameters ``noisy`` and
``snr_db`` and a reason that says so, and the robot says the command's ``phrase_noisy``
("This room is noisy or echoing: ..."; the SNR estimate cannot tell noise from an echo
filling the pauses).
The processor decides as before; only the cue's words change. The SNR is read from the
session's own ``streams/speech_snr.txt`` when such a cue comes, never per decision point, so
``up``, ``rehearse`` and ``replay`` (which copies the stream) read the same value; a talk
without the stream (synthetic, or recorded before session 21) is coached as before. A cue on
another metric, ``articulate`` on a metric of one's own included, is not about the noise.
"""

from __future__ import annotations

import logging
import math
from bisect import bisect_right
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field, replace
from os import PathLike
from typing import TYPE_CHECKING, Any

from prezence.backends.base import Backend, Motion
from prezence.errors import BackendUnavailable
from prezence.feedback.commands import get_command
from prezence.feedback.trajectory import Trajectory
from prezence.metrics import NOISY_METRIC, NOISY_SNR_DB, SNR_METRIC
from prezence.processor import Cue, Decision, Kind, Processor
from prezence.samples import Sample
from prezence.session import JsonlWriter, SessionDir
from prezence.streams.tail import StreamTailer

if TYPE_CHECKING:
    from prezence.feedback.gestures import GestureLibrary

log = logging.getLogger(__name__)


class RoomNoise:
    """The speech module's newest ``speech_snr`` at a time, read from its stream file when
    asked (a clarity cue), so that a decision point without one costs nothing.

    Args:
        path: ``streams/speech_snr.txt`` of the session (it may not exist yet, or ever).
        stale_after_s: a value older than this is not the room's state now (the speech
            metrics' staleness).
    """

    def __init__(self, path: str | PathLike[str], *, stale_after_s: float) -> None:
        self._tailer = StreamTailer(path, SNR_METRIC)
        self.stale_after_s = stale_after_s
        self._t: list[float] = []
        self._v: list[float] = []

    def snr_db(self, now: float) -> float | None:
        """The newest SNR stamped at or before ``now`` and at most ``stale_after_s`` old;
        None without one."""
        for s in self._tailer.poll(now):
            if not math.isfinite(s.value):
                continue
            if self._t and s.t < self._t[-1]:  # out of order: kept in time order
                i = bisect_right(self._t, s.t)
                self._t.insert(i, s.t)
                self._v.insert(i, s.value)
            else:
                self._t.append(s.t)
                self._v.append(s.value)
        i = bisect_right(self._t, now)
        if i == 0 or now - self._t[i - 1] > self.stale_after_s:
            return None
        return self._v[i - 1]


def name_the_noise(cue: Cue, snr_db: float | None) -> Cue:
    """``cue`` as given in a room whose estimated SNR is ``snr_db``: a clarity cue under
    :data:`prezence.metrics.NOISY_SNR_DB` says the room is noisy (parameters ``noisy`` and
    ``snr_db``, and its reason); any other cue, or no SNR, is returned as it is."""
    if (
        snr_db is None
        or not snr_db < NOISY_SNR_DB
        or cue.metric != NOISY_METRIC
        or cue.kind not in (Kind.STRICT, Kind.WEIGHTED)
        # a command with no words for the noise (a rules file's own choice) says its plain
        # phrase: the record must not say more than the robot did
        or get_command(cue.command).phrase_noisy is None
    ):
        return cue
    snr = round(snr_db, 1)
    return replace(
        cue,
        params={**cue.params, "noisy": True, "snr_db": snr},
        reason=f"{cue.reason}; the room is noisy or echoing (estimated SNR {snr:g} dB, under "
        f"{NOISY_SNR_DB:g} dB): the room may be why clarity reads low",
    )


#: Plans the gesture of a command: (gesture name, cue params) → trajectory.
GesturePlanner = Callable[[str, Mapping[str, Any]], Trajectory]


def default_planner(
    speed_fraction: float, *, library: GestureLibrary | None = None
) -> GesturePlanner:
    """The gesture library (default: the built-in one), retimed against the URDF's limits at
    ``speed_fraction``.

    Trajectories are cached by gesture and the parameters the gesture declares (a cue's other
    parameters, such as ``minutes_over`` for the phrase, change nothing in the motion).
    """
    from prezence.feedback.gestures import build_trajectory, load_library
    from prezence.feedback.limits import load_limits

    limits = load_limits()
    library = library if library is not None else load_library(limits)
    cache: dict[tuple[str, tuple[tuple[str, int], ...]], Trajectory] = {}

    def plan(gesture: str, params: Mapping[str, Any]) -> Trajectory:
        used = library[gesture].resolve_params(params)
        key = (gesture, tuple(sorted(used.items())))
        traj = cache.get(key)
        if traj is None:
            traj = build_trajectory(
                gesture, params=used, speed_fraction=speed_fraction, limits=limits, library=library
            )
            cache[key] = traj
        return traj

    return plan


@dataclass
class Performance:
    """A cue being performed: its gesture and its phrase."""

    cue: Cue
    phrase: str
    gesture: str
    motions: list[Motion] = field(default_factory=list)
    dropped: str | None = None

    @property
    def done(self) -> bool:
        return all(m.done for m in self.motions)

    def record(self) -> dict[str, Any]:
        """The cues.jsonl line for this cue."""
        rec = self.cue.to_dict()
        rec.update({"phrase": self.phrase, "gesture": self.gesture})
        if self.dropped is not None:
            rec.update({"dropped": True, "drop_reason": self.dropped, "ok": False})
            return rec
        ends = [m.finished_at for m in self.motions if m.finished_at is not None]
        rec["dropped"] = False
        rec["ok"] = all(m.ok for m in self.motions)
        rec["planned_s"] = round(max(m.planned_s for m in self.motions), 6)
        rec["measured_s"] = round(max(ends) - self.cue.t, 6) if ends else None
        for m in self.motions:
            prefix = m.kind.value
            rec[f"{prefix}_planned_s"] = round(m.planned_s, 6)
            rec[f"{prefix}_ok"] = m.ok  # the phrase and the gesture apart (one may fail alone)
            if m.finished_at is not None:
                rec[f"{prefix}_measured_s"] = round(m.finished_at - m.started_at, 6)
            for k, v in m.info.items():
                if k not in ("measured_s",):
                    rec[f"{prefix}_{k}"] = v
        return rec


class Coach:
    """Processor + robot + records, advanced one tick at a time.

    Args:
        processor: the Central Processor (owns the rules and the policy).
        backend: an opened robot backend.
        session: where decisions and cues are written.
        planner: turns a gesture name and cue parameters into a trajectory.
        on_cue: called with each cue when the robot starts it (closed-loop presenters listen).
        log_mode: the decision log (``decisions.jsonl``): ``changes`` writes a decision point
            where a cue is chosen, or the reason, the robot's state or a metric's state
            (fresh or stale, in range or on which side, strict cue pending) changed, with the
            candidates, the view of each metric whose state changed (of every metric on a cue's
            line and the first line); ``every`` writes every decision point with every view;
            ``off`` writes none. Views are the metrics' state after the decision (a metric
            just cued shows its weight spent and its refractory time begun).
            :attr:`decisions` counts every decision point.
        noise: the room's estimated SNR (the session's ``speech_snr`` stream): a clarity cue
            given in noise names it (:func:`name_the_noise`); None: never.
    """

    def __init__(
        self,
        processor: Processor,
        backend: Backend,
        session: SessionDir,
        *,
        planner: GesturePlanner,
        on_cue: Callable[[Cue], None] | None = None,
        log_mode: str = "changes",
        noise: RoomNoise | None = None,
    ) -> None:
        if log_mode not in ("changes", "every", "off"):
            raise ValueError(f"log_mode: changes, every or off, not {log_mode!r}")
        self.processor = processor
        self.backend = backend
        self.session = session
        self.planner = planner
        self.on_cue = on_cue
        self.log_mode = log_mode
        self.noise = noise
        self._decisions = JsonlWriter(session.decisions, flush=False)
        self._last_logged: tuple[Any, ...] | None = None
        self._cues = JsonlWriter(session.cues)
        self._current: Performance | None = None
        self._free_since: float | None = 0.0
        self.performed: list[dict[str, Any]] = []
        self.decisions = 0
        #: Until when a decision point with no new sample would change nothing but
        #: :attr:`decisions` (the robot moves nothing, the processor decides as at the last
        #: point, the decision log writes no line): such a point may be counted without a tick
        #: (:func:`prezence.talk.run_talk`). -inf: every point is ticked.
        self.quiet_until = -math.inf

    def tick(
        self,
        now: float,
        samples: Iterable[Sample],
        *,
        over: bool = False,
        spent: float | None = None,
    ) -> Decision:
        """One decision point at ``now`` with the samples that arrived since the last one
        (``over``: the talk ends at ``now``, so no cue is given; ``spent``: the time used,
        which the time warnings are judged on, None: ``now``)."""
        self.backend.advance(now)
        if self._current is not None:
            self._settle()
        free_since = self._free_since if not self.backend.busy else None
        decision = self.processor.step(
            now, samples, free_since=free_since, with_views=False, over=over, spent=spent
        )
        self.decisions += 1
        cue = decision.cue
        if cue is not None and cue.metric == NOISY_METRIC and self.noise is not None:
            named = name_the_noise(cue, self.noise.snr_db(now))
            if named is not cue:
                decision = decision._replace(cue=named, reason=named.reason)
        if self.log_mode == "every":
            rec = decision.to_dict()
            rec["metrics"] = self.processor.view_dicts(now)
            self._decisions.write(rec)
        elif self.log_mode == "changes":
            status = self.processor.status(now)
            key = (decision.reason, decision.busy, status)
            last = self._last_logged
            if decision.cue is not None or key != last:
                self._last_logged = key
                rec = decision.to_dict()
                if decision.cue is None and last is not None:
                    # only the metrics whose state changed; a cue's line has them all
                    rec["metrics"] = self.processor.view_dicts(
                        now,
                        [i for i, (a, b) in enumerate(zip(status, last[2], strict=True)) if a != b],
                    )
                else:
                    rec["metrics"] = self.processor.view_dicts(now)
                self._decisions.write(rec)
        if decision.cue is not None:
            self._perform(decision.cue, now)
            self.quiet_until = -math.inf
        elif self.log_mode != "every":
            idle = self.backend.idle_until()
            quiet = self.processor.quiet_until(free_since)
            self.quiet_until = -math.inf if idle is None else idle if idle < quiet else quiet
        return decision

    @property
    def current(self) -> Performance | None:
        """The cue being performed, if any."""
        return self._current

    @property
    def free_since(self) -> float | None:
        """When the robot last became free (None while a cue is being performed)."""
        return self._free_since

    def give(self, cue: Cue) -> bool:
        """Have the robot give ``cue`` at ``cue.t`` (an agent's own choice, not the
        processor's); the processor counts it as fired. False when the robot is busy."""
        self.backend.advance(cue.t)
        self._settle()
        if self.backend.busy or self._current is not None:
            return False
        self.quiet_until = -math.inf
        if cue.metric is not None:
            self.processor.fired(cue.metric, cue.t)
        if self.log_mode != "off":
            rec = {"t": round(cue.t, 6), "cue": cue.to_dict(), "reason": cue.reason}
            self._decisions.write(rec)
        self._perform(cue, cue.t)
        return True

    def _perform(self, cue: Cue, now: float) -> None:
        command = get_command(cue.command)
        perf = Performance(cue, command.say(cue.params), command.gesture)
        try:
            traj = self.planner(command.gesture, cue.params)
            perf.motions.append(self.backend.play(traj, now=now))
            perf.motions.append(self.backend.say(perf.phrase, now=now))
        except BackendUnavailable as e:
            # The robot is gone: drop the cue (never queue it); the talk goes on.
            log.warning("cue %s at %.1f s dropped: %s", cue.command, now, e)
            perf.dropped = str(e)
            self.processor.cue_dropped(cue)  # not given: no refractory, still due
        self._current = perf
        self._free_since = None
        if self.on_cue is not None and perf.dropped is None:
            self.on_cue(cue)
        self._settle()

    def _settle(self) -> None:
        perf = self._current
        if perf is None or (perf.dropped is None and not perf.done):
            return
        rec = perf.record()
        self._cues.write(rec)
        self.performed.append(rec)
        ends = [m.finished_at for m in perf.motions if m.finished_at is not None]
        self._free_since = max(ends) if ends else perf.cue.t
        self._current = None

    def drain(
        self,
        now: float,
        *,
        step_s: float,
        limit_s: float = 120.0,
        pace: Callable[[float], None] | None = None,
    ) -> float:
        """Let the cue in progress finish (no new decisions); returns the time it ended.

        Args:
            now: current time.
            step_s: how far to move the robot per step.
            limit_s: give up (the cue is recorded unfinished) after this long.
            pace: called with each step's time before the robot moves there; a real-time run
                sleeps in it until the wall clock gets there (a real robot moves in real time).
        """
        t = now
        while self._current is not None and t < now + limit_s:
            t = self._step(t + step_s, pace)
            self._settle()
        return t

    def post_talk(
        self,
        phrase: str,
        now: float,
        *,
        step_s: float,
        limit_s: float = 60.0,
        pace: Callable[[float], None] | None = None,
    ) -> dict[str, Any]:
        """After the talk: the summary gesture while the robot says ``phrase``; waits for both.

        Returns a record like a cue's (not written to ``cues.jsonl``: it is not coaching).
        """
        t = self.drain(now, step_s=step_s, limit_s=limit_s, pace=pace)
        command = get_command("summary")
        rec: dict[str, Any] = {"t": round(t, 6), "phrase": phrase, "gesture": command.gesture}
        try:
            motions = [
                self.backend.play(self.planner(command.gesture, {}), now=t),
                self.backend.say(phrase, now=t),
            ]
        except BackendUnavailable as e:
            log.warning("post-talk summary not given: %s", e)
            rec.update(ok=False, drop_reason=str(e))
            return rec
        end = t + limit_s
        while self.backend.busy and t < end:
            t = self._step(t + step_s, pace)
        rec["ok"] = all(m.done and m.ok for m in motions)
        rec["measured_s"] = round(t - rec["t"], 6)
        for (
            m
        ) in motions:  # the phrase and the gesture apart: a gesture's timeout is no unsaid phrase
            prefix = m.kind.value
            rec[f"{prefix}_ok"] = m.done and m.ok
            for k in ("error", "outcome"):
                if m.info.get(k):
                    rec[f"{prefix}_{k}"] = m.info[k]
        return rec

    def _step(self, t: float, pace: Callable[[float], None] | None) -> float:
        if pace is not None:
            pace(t)
        self.backend.advance(t)
        return t

    def close(self) -> None:
        if self._current is not None:
            rec = self._current.record()
            rec["unfinished"] = True
            self._cues.write(rec)
            self.performed.append(rec)
            self._current = None
        self._decisions.close()
        self._cues.close()
