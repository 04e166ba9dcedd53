"""A timed joint trajectory: what a backend is asked to play.

Keyframe times are absolute seconds from the start of the motion (NAOqi ``angleInterpolation``
with ``isAbsolute=True`` takes exactly this: names, one angle list and one time list per joint).
Between keyframes every joint follows the same smooth profile, so backends that sample the
trajectory (the PyBullet NAO) and backends that hand keyframes to the robot (NAOqi) agree on
where the robot is meant to be and when it is done.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """Keyframes for a set of joints, with the time of each.

    Attributes:
        name: the gesture's name.
        joints: joint names (NAOqi names: ``HeadPitch``, ``LShoulderPitch``, ``LHand``…).
        times: keyframe times in seconds from the start, strictly increasing, first > 0.
        positions: ``positions[k][j]`` is joint ``j`` at keyframe ``k`` (radians; hands: opening
            fraction 0..1).
        start: the pose the timing was planned from (one value per joint).
    """

    name: str
    joints: tuple[str, ...]
    times: tuple[float, ...]
    positions: tuple[tuple[float, ...], ...]
    start: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.times) != len(self.positions):
            raise ValueError(f"{self.name}: {len(self.times)} times for {len(self.positions)} keyframes")
        if any(len(p) != len(self.joints) for p in self.positions) or len(self.start) != len(
            self.joints
        ):
            raise ValueError(f"{self.name}: every keyframe needs one value per joint")
        prev = 0.0
        for t in self.times:
            if not t > prev:
                raise ValueError(f"{self.name}: keyframe times must increase from > 0, got {self.times}")
            prev = t

    @property
    def duration(self) -> float:
        return self.times[-1] if self.times else 0.0

    def sample(self, t: float) -> np.ndarray:
        """Planned joint positions at time ``t`` (smoothstep between keyframes: zero velocity at
        each keyframe, which is what NAOqi's interpolation does at a keyframe it stops at)."""
        knots_t = np.concatenate(([0.0], np.asarray(self.times)))
        knots_q = np.vstack((np.asarray(self.start), np.asarray(self.positions)))
        if t <= 0.0:
            return knots_q[0].copy()
        if t >= knots_t[-1]:
            return knots_q[-1].copy()
        k = int(np.searchsorted(knots_t, t, side="right")) - 1
        s = (t - knots_t[k]) / (knots_t[k + 1] - knots_t[k])
        # minimum-jerk blend; gestures.py sets segment times so that its peak velocity
        # (1.875 × mean) stays within each joint's limit.
        h = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
        return knots_q[k] + (knots_q[k + 1] - knots_q[k]) * h

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "joints": list(self.joints),
            "times": list(self.times),
            "positions": [list(p) for p in self.positions],
            "start": list(self.start),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Trajectory:
        return cls(
            name=str(d["name"]),
            joints=tuple(d["joints"]),
            times=tuple(float(x) for x in d["times"]),
            positions=tuple(tuple(float(x) for x in p) for p in d["positions"]),
            start=tuple(float(x) for x in d["start"]),
        )
