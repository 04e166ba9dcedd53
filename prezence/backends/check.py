"""The backend contract, as one function every backend must pass (like Gymnasium's env checker)."""

from __future__ import annotations

import time

from prezence.backends.base import Backend, MotionKind
from prezence.clock import Clock, ManualClock
from prezence.errors import PrezenceError
from prezence.feedback.trajectory import Trajectory

#: A small, slow head movement every NAO (and every simulated one) can make.
CHECK_TRAJECTORY = Trajectory(
    name="contract_check",
    joints=("HeadYaw", "HeadPitch"),
    times=(0.6, 1.2),
    positions=((0.2, -0.1), (0.0, 0.0)),
    start=(0.0, 0.0),
)


class ContractError(PrezenceError, AssertionError):
    """A backend broke the interface contract."""


def _require(cond: bool, what: str) -> None:
    if not cond:
        raise ContractError(what)


def check_backend(
    backend: Backend, *, clock: Clock | None = None, step_s: float = 0.02, timeout_s: float = 15.0
) -> dict[str, float]:
    """Open ``backend``, play a gesture and a phrase, wait for both, close it twice.

    Args:
        backend: an unopened backend.
        clock: a ManualClock (default) for simulated backends; a MonotonicClock for backends
            that run in real time (NAOqi), in which case this function waits in real time.
        step_s: how far to move between polls.
        timeout_s: give up after this long on ``clock``.

    Returns:
        measured durations: ``{"gesture_s": …, "speech_s": …}``.

    Raises:
        ContractError: the first broken rule.
    """
    clock = clock or ManualClock()
    manual = isinstance(clock, ManualClock)
    _require(not backend.busy, "a new backend must not be busy")
    with backend:
        backend.advance(clock.now())
        _require(not backend.busy, "an opened, idle backend must not be busy")
        t0 = clock.now()
        g = backend.play(CHECK_TRAJECTORY, now=t0)
        s = backend.say("Contract check.", now=t0)
        _require(g.kind is MotionKind.GESTURE and s.kind is MotionKind.SPEECH, "motion kinds")
        _require(
            g.planned_s == CHECK_TRAJECTORY.duration, "gesture planned_s = trajectory duration"
        )
        _require(backend.busy, "busy right after play()/say()")
        while backend.busy:
            if manual:
                assert isinstance(clock, ManualClock)
                clock.advance(step_s)
            else:
                time.sleep(step_s)
            backend.advance(clock.now())
            _require(clock.now() - t0 < timeout_s, f"motions not finished after {timeout_s} s")
        _require(g.done and s.done, "not busy, yet a motion is unfinished")
        _require(g.ok and s.ok, f"motions failed: gesture {g.info}, speech {s.info}")
        assert g.finished_at is not None and s.finished_at is not None
        _require(g.finished_at >= t0 and s.finished_at >= t0, "finished before it started")
    backend.close()  # second close must be harmless
    return {"gesture_s": g.finished_at - t0, "speech_s": s.finished_at - t0}
