"""The backend interface every robot (fake, PyBullet NAO, NAOqi) implements.

Lifecycle: construct (cheap, no resources) → :meth:`Backend.open` (connect, load, validate) →
:meth:`Backend.play` / :meth:`Backend.say` → :meth:`Backend.close` (idempotent; ``with`` calls it).

Time is passed in. Simulated backends move their robot to ``now`` in :meth:`Backend.advance`
(the run's clock drives the physics; nothing free-runs); real backends use it to poll.
A backend never queues: :meth:`play` and :meth:`say` on a busy robot raise ``RuntimeError``; the
coach asks only when :attr:`busy` is False.
"""

from __future__ import annotations

import abc
import enum
import re
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, ClassVar

from prezence.feedback.trajectory import Trajectory

#: NAO's text-to-speech default rate is close to a calm presenter's; used to plan speech time.
TTS_WORDS_PER_MINUTE = 150.0


def estimate_speech_s(text: str, wpm: float = TTS_WORDS_PER_MINUTE) -> float:
    """Planned duration of saying ``text`` (a short lead-in plus words at ``wpm``).

    Example:
        >>> round(estimate_speech_s("Look up at your audience."), 2)
        2.3
    """
    words = len(re.findall(r"[\w']+", text))
    return 0.3 + words * 60.0 / wpm


class MotionKind(enum.Enum):
    GESTURE = "gesture"
    SPEECH = "speech"


@dataclass
class Motion:
    """A gesture or an utterance in progress; the backend fills in the outcome.

    Attributes:
        kind: gesture or speech.
        name: gesture name or the text said.
        started_at: clock time the backend accepted it.
        planned_s: duration known before it started.
        finished_at: clock time it ended (None while running).
        ok: False if it failed or was cut short (connection lost, killed).
        info: backend measurements (``measured_s``, ``peak_velocity_ratio``, ``violations``…).
    """

    kind: MotionKind
    name: str
    started_at: float
    planned_s: float
    finished_at: float | None = None
    ok: bool = True
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def done(self) -> bool:
        return self.finished_at is not None

    def finish(self, at: float, *, ok: bool = True, **info: Any) -> None:
        if self.finished_at is None:
            self.finished_at = at
            self.ok = ok
            self.info.update(info)


class Backend(abc.ABC):
    """Base class: owns the bookkeeping of running motions; subclasses fill in the hooks."""

    name: ClassVar[str] = "base"
    #: True when the robot moves on the wall clock by itself (a real NAO, a NAOqi server): a
    #: talk on simulated time must then be paced to the wall clock. Simulated and
    #: time-keeping backends, whose robot moves only when :meth:`advance` is called, say False.
    realtime: ClassVar[bool] = False
    #: True when the gestures move a physical body (a real NAO, or what may be one: NAOqi),
    #: which its own shell stops: a talk then plays only gestures whose self-collision was
    #: checked (:func:`~prezence.feedback.collision.require_collision_checked`). A simulated
    #: NAO has no self-collision and plays anything.
    physical: ClassVar[bool] = False

    def __init__(self) -> None:
        self._running: list[Motion] = []
        self._opened = False
        self._closed = False

    # -- lifecycle -------------------------------------------------------------------------
    def open(self) -> None:
        """Acquire resources (connect, load the model). Raises BackendUnavailable."""
        if self._opened:
            return
        self._open()
        self._opened = True

    def close(self) -> None:
        """Release resources; safe to call twice."""
        if self._closed or not self._opened:
            self._closed = True
            return
        self._closed = True
        self._close()

    def __enter__(self) -> Backend:
        self.open()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- actions ---------------------------------------------------------------------------
    def play(self, traj: Trajectory, *, now: float) -> Motion:
        """Start a gesture at ``now``; returns at once."""
        self._require_open()
        m = Motion(MotionKind.GESTURE, traj.name, now, traj.duration)
        self._start_gesture(traj, m)
        self._running.append(m)
        return m

    def say(self, text: str, *, now: float) -> Motion:
        """Start saying ``text`` at ``now``; returns at once."""
        self._require_open()
        m = Motion(MotionKind.SPEECH, text, now, estimate_speech_s(text))
        self._start_speech(text, m)
        self._running.append(m)
        return m

    def advance(self, now: float) -> None:
        """Move the (simulated) robot to ``now`` and finish motions that have ended."""
        self._advance(now)
        if self._running:
            self._running = [m for m in self._running if not m.done]

    def idle_until(self) -> float | None:
        """A time before which :meth:`advance` changes nothing (no motion ends), when the
        backend can tell (a robot that only keeps time); None: it cannot (a simulated or real
        robot moves at every advance), so every decision point is stepped."""
        return None

    @property
    def busy(self) -> bool:
        """True while any gesture or speech is running."""
        return bool(self._running) and any(not m.done for m in self._running)

    def stats(self) -> dict[str, Any]:
        """Backend-wide figures for the session summary (e.g. joint-limit violations)."""
        return {}

    # -- hooks -----------------------------------------------------------------------------
    @abc.abstractmethod
    def _open(self) -> None: ...

    @abc.abstractmethod
    def _close(self) -> None: ...

    @abc.abstractmethod
    def _start_gesture(self, traj: Trajectory, motion: Motion) -> None: ...

    @abc.abstractmethod
    def _start_speech(self, text: str, motion: Motion) -> None: ...

    @abc.abstractmethod
    def _advance(self, now: float) -> None: ...

    def _require_open(self) -> None:
        if not self._opened or self._closed:
            raise RuntimeError(f"{self.name} backend is not open")
