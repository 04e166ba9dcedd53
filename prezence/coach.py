"""The coach: one decision loop shared by headless talks, live rehearsals and replays.

Each :meth:`Coach.tick` moves the robot to ``now``, hands the new samples to the processor,
writes the decision, and, when a cue is chosen, has the robot perform it (gesture and phrase
together). The robot is asked only when it is free, so no cue ever waits in a queue.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from prezence.backends.base import Backend, Motion
from prezence.errors import BackendUnavailable
from prezence.feedback.commands import get_command
from prezence.feedback.trajectory import Trajectory
from prezence.processor import Cue, Decision, Processor
from prezence.samples import Sample
from prezence.session import JsonlWriter, SessionDir

if TYPE_CHECKING:
    from prezence.feedback.gestures import GestureLibrary

log = logging.getLogger(__name__)

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
    ) -> None:
        if log_mode not in ("changes", "every", "off"):
            raise ValueError(f"log_mode: changes, every or off, not {log_mode!r}")
        self.processor = processor
        self.backend = backend
        self.session = session
        self.planner = planner
        self.on_cue = on_cue
        self.log_mode = log_mode
        self._decisions = JsonlWriter(session.decisions, flush=False)
        self._last_logged: tuple[Any, ...] | None = None
        self._cues = JsonlWriter(session.cues)
        self._current: Performance | None = None
        self._free_since: float | None = 0.0
        self.performed: list[dict[str, Any]] = []
        self.decisions = 0

    def tick(self, now: float, samples: Iterable[Sample]) -> Decision:
        """One decision point at ``now`` with the samples that arrived since the last one."""
        self.backend.advance(now)
        self._settle()
        free_since = self._free_since if not self.backend.busy else None
        decision = self.processor.step(now, samples, free_since=free_since, with_views=False)
        self.decisions += 1
        if self.log_mode == "every":
            rec = decision.to_dict()
            rec["metrics"] = [m.to_dict() for m in self.processor.views(now)]
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
                    views = self.processor.views(
                        now,
                        [i for i, (a, b) in enumerate(zip(status, last[2], strict=True)) if a != b],
                    )
                else:
                    views = self.processor.views(now)
                rec["metrics"] = [m.to_dict() for m in views]
                self._decisions.write(rec)
        if decision.cue is not None:
            self._perform(decision.cue, now)
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
