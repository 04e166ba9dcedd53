"""Clocks. Time comes into the processor as an argument; these are the sources of it."""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    """Seconds since the talk began."""

    def now(self) -> float: ...


class MonotonicClock:
    """Wall-clock time since construction (live talks, ``--realtime``)."""

    def __init__(self) -> None:
        self._t0 = time.monotonic()

    def now(self) -> float:
        return time.monotonic() - self._t0


class ManualClock:
    """A clock that only moves when told to (tests, headless simulated talks)."""

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def now(self) -> float:
        return self._t

    def advance(self, dt: float) -> float:
        """Move forward by ``dt`` seconds (must be >= 0) and return the new time."""
        if not dt >= 0.0:
            raise ValueError(f"a clock cannot go backwards (dt={dt!r})")
        self._t += dt
        return self._t

    def set(self, t: float) -> None:
        """Jump to ``t``, which must not be earlier than the current time."""
        if not t >= self._t:
            raise ValueError(f"a clock cannot go backwards ({t!r} < {self._t!r})")
        self._t = float(t)
