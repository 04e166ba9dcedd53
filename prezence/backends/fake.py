"""A robot that only keeps time: each motion ends exactly when planned. No dependencies."""

from __future__ import annotations

import math
from typing import Any

from prezence.backends.base import Backend, Motion
from prezence.feedback.trajectory import Trajectory


class FakeBackend(Backend):
    """Stands in for the NAO in unit and scenario tests.

    Args:
        time_scale: measured duration = planned × this (test a slower robot with > 1).
    """

    name = "fake"

    def __init__(self, *, time_scale: float = 1.0) -> None:
        super().__init__()
        if not time_scale > 0:
            raise ValueError(f"time_scale must be > 0, got {time_scale!r}")
        self.time_scale = time_scale
        self.log: list[dict[str, Any]] = []

    def _open(self) -> None:
        pass

    def _close(self) -> None:
        pass

    def _start_gesture(self, traj: Trajectory, motion: Motion) -> None:
        self.log.append({"t": motion.started_at, "gesture": traj.name, "planned_s": traj.duration})

    def _start_speech(self, text: str, motion: Motion) -> None:
        self.log.append({"t": motion.started_at, "say": text, "planned_s": motion.planned_s})

    def advance(self, now: float) -> None:
        # nothing to move or finish while nothing runs (most decision points of a talk)
        if self._running:
            super().advance(now)

    def idle_until(self) -> float | None:
        """The first time a running motion ends (inf with none): before it, :meth:`advance`
        changes nothing. None (no promise) for a subclass that moves its motions its own way
        (overrides ``advance``, ``_advance`` or ``busy``): its motions may end earlier."""
        cls = type(self)
        if cls is not FakeBackend and (
            cls.advance is not FakeBackend.advance
            or cls._advance is not FakeBackend._advance
            or cls.busy is not FakeBackend.busy
        ):
            return None
        running = self._running
        if not running:
            return math.inf
        scale = self.time_scale
        return min([m.started_at + m.planned_s * scale for m in running])

    def _advance(self, now: float) -> None:
        for m in self._running:
            end = m.started_at + m.planned_s * self.time_scale
            if now >= end:
                m.finish(end, measured_s=end - m.started_at)
