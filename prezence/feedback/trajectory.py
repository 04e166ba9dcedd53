"""A timed joint trajectory: what a backend is asked to play.

Keyframe times are absolute seconds from the start of the motion (NAOqi ``angleInterpolation``
with ``isAbsolute=True`` takes exactly this: names, one angle list and one time list per joint).
Between keyframes every joint follows the same smooth profile, so backends that sample the
trajectory (the PyBullet NAO) and backends that hand keyframes to the robot (NAOqi) agree on
where the robot is meant to be and when it is done.

The profile (one per segment, shared by all joints of the segment, so they start and stop
together and move along a straight line in joint space):

* a **trapezoidal velocity profile with short blends**: the joints speed up during a ramp of
  ``r = min(RAMP_S, T/2)`` seconds, cruise, and slow down during a mirrored ramp; inside each ramp
  the acceleration itself rises and falls linearly over ``BLEND_FRACTION × r`` (an S-curve), so the
  acceleration is continuous and the jerk is bounded;
* the robot stops at every keyframe (zero velocity and acceleration), which is what NAOqi's
  interpolation does at a keyframe it stops at.

A segment of duration ``T`` moving a joint by ``Δ`` reaches ``|Δ| / (T − r)`` at its peak and
accelerates at most ``|Δ| / ((T − r) · r · (1 − BLEND_FRACTION))``. The planner in
:mod:`prezence.feedback.gestures` picks ``T`` from these formulas (:func:`segment_duration`).

**Acceleration bound.** A joint capped at speed ``v`` (``fraction × URDF velocity``) may
accelerate at ``v / ACCEL_TIME_S``: at the bound it would reach its cap in ``ACCEL_TIME_S``
(0.18 s). The bound is tied to the cap so that a lower ``fractionMaxSpeed`` is gentler overall,
and, because the ratio of acceleration to speed bound is the same for every joint, the joint
that needs the longest time is the one limited on both, which makes the synchronised profile
exactly as fast as running each joint on its own. :func:`min_segment_duration` is the true
time-optimal (bang-coast-bang) segment time under the same two bounds; the blends cost at most
5.4 % over it (worst case at ``|Δ|/v = ACCEL_TIME_S``).
"""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

#: Length of the speed-up (and slow-down) ramp of a segment that reaches its cruise speed.
RAMP_S = 0.2
#: Share of each ramp spent raising or lowering the acceleration (the blends of the S-curve).
BLEND_FRACTION = 0.1
#: Time to reach a joint's speed cap at its acceleration bound: acceleration bound = v / this.
ACCEL_TIME_S = RAMP_S * (1.0 - BLEND_FRACTION)


def segment_duration(u: float) -> float:
    """Duration of a segment whose slowest joint needs ``u = |Δq| / v`` seconds at full speed.

    The shortest ``T`` for which this module's profile keeps that joint within ``v`` and within
    the acceleration bound ``v / ACCEL_TIME_S``.

    Example:
        >>> round(segment_duration(1.0), 3)   # long move: cruise 1 s plus one ramp
        1.2
        >>> round(segment_duration(0.05), 3)  # short move: never reaches cruise speed
        0.2
    """
    if not u >= 0.0:
        raise ValueError(f"u must be >= 0, got {u!r}")
    if u == 0.0:
        return 0.0
    return u + RAMP_S if u >= RAMP_S else 2.0 * math.sqrt(u * RAMP_S)


def min_segment_duration(u: float) -> float:
    """Time-optimal rest-to-rest time (bang-coast-bang) with speed ``v`` and acceleration
    ``v / ACCEL_TIME_S``, for a move of ``u = |Δq| / v`` seconds at full speed.

    Example:
        >>> round(min_segment_duration(1.0), 3)
        1.18
    """
    if not u >= 0.0:
        raise ValueError(f"u must be >= 0, got {u!r}")
    tau = ACCEL_TIME_S
    return u + tau if u >= tau else 2.0 * math.sqrt(u * tau)


def _ramp(t: float, r: float) -> tuple[float, float, float]:
    """Displacement, velocity and acceleration of a unit-cruise-speed ramp at ``0 <= t <= r``."""
    b = BLEND_FRACTION * r
    alpha = 1.0 / (r - b)  # peak acceleration that gains unit speed over the ramp
    if t <= b:
        return alpha * t**3 / (6.0 * b), alpha * t * t / (2.0 * b), alpha * t / b
    if t <= r - b:
        m = t - b / 2.0
        return alpha * b * b / 6.0 + alpha * (m * m - b * b / 4.0) / 2.0, alpha * m, alpha
    w = r - t
    return r / 2.0 - w + alpha * w**3 / (6.0 * b), 1.0 - alpha * w * w / (2.0 * b), alpha * w / b


def profile(t: float, T: float) -> tuple[float, float, float]:
    """Normalised position ``s`` (0 → 1), ``ds/dt`` and ``d²s/dt²`` of a segment of duration ``T``.

    Example:
        >>> [round(x, 3) for x in profile(0.6, 1.2)]   # midway: half done, at cruise speed
        [0.5, 1.0, 0.0]
    """
    if not T > 0.0:
        raise ValueError(f"segment duration must be > 0, got {T!r}")
    t = min(max(t, 0.0), T)
    r = min(RAMP_S, T / 2.0)
    span = T - r  # displacement of the unit-cruise profile
    if t < r:
        d, v, a = _ramp(t, r)
    elif t <= T - r:
        d, v, a = r / 2.0 + (t - r), 1.0, 0.0
    else:
        d, v, a = _ramp(T - t, r)
        d, a = span - d, -a
    return d / span, v / span, a / span


def profile_time(s: float, T: float) -> float:
    """The time at which a segment of duration ``T`` has covered the fraction ``s`` of its move.

    The inverse of :func:`profile`'s position (which rises monotonically from 0 to 1), found by
    bisection to well below a microsecond.

    Example:
        >>> round(profile_time(0.5, 1.2), 6)
        0.6
    """
    if not T > 0.0:
        raise ValueError(f"segment duration must be > 0, got {T!r}")
    s = min(max(float(s), 0.0), 1.0)
    lo, hi = 0.0, T
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if profile(mid, T)[0] < s:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def profile_peaks(T: float) -> tuple[float, float]:
    """Peak ``ds/dt`` and peak ``|d²s/dt²|`` of a segment of duration ``T`` (per unit move)."""
    r = min(RAMP_S, T / 2.0)
    span = T - r
    return 1.0 / span, 1.0 / (span * r * (1.0 - BLEND_FRACTION))


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
            raise ValueError(
                f"{self.name}: {len(self.times)} times for {len(self.positions)} keyframes"
            )
        if any(len(p) != len(self.joints) for p in self.positions) or len(self.start) != len(
            self.joints
        ):
            raise ValueError(f"{self.name}: every keyframe needs one value per joint")
        prev = 0.0
        for t in self.times:
            if not t > prev:
                raise ValueError(
                    f"{self.name}: keyframe times must increase from > 0, got {self.times}"
                )
            prev = t

    @property
    def duration(self) -> float:
        return self.times[-1] if self.times else 0.0

    @functools.cached_property
    def _knots(self) -> tuple[np.ndarray, np.ndarray]:
        knots_t = np.concatenate(([0.0], np.asarray(self.times, dtype=float)))
        knots_q = np.vstack(
            (np.asarray(self.start, dtype=float), np.asarray(self.positions, dtype=float))
        ).reshape(len(knots_t), len(self.joints))
        return knots_t, knots_q

    @functools.cached_property
    def _knot_times(self) -> tuple[float, ...]:
        return (0.0, *(float(x) for x in self.times))

    def _segment(self, t: float) -> tuple[int, float, float]:
        knots_t = self._knot_times  # plain floats: bisect beats searchsorted on a few knots
        k = bisect.bisect_right(knots_t, t) - 1
        k = min(max(k, 0), len(knots_t) - 2)
        return k, t - knots_t[k], knots_t[k + 1] - knots_t[k]

    def sample(self, t: float) -> np.ndarray:
        """Planned joint positions at time ``t`` (see the module docstring for the profile)."""
        knots_t, knots_q = self._knots
        if t <= 0.0 or len(knots_t) < 2:
            return knots_q[0].copy()
        if t >= knots_t[-1]:
            return knots_q[-1].copy()
        k, dt, seg = self._segment(t)
        s, _, _ = profile(dt, seg)
        return knots_q[k] + (knots_q[k + 1] - knots_q[k]) * s

    def velocity(self, t: float) -> np.ndarray:
        """Planned joint velocities at time ``t`` (zero before the start and after the end)."""
        knots_t, knots_q = self._knots
        if t <= 0.0 or len(knots_t) < 2 or t >= knots_t[-1]:
            return np.zeros(len(self.joints))
        k, dt, seg = self._segment(t)
        _, ds, _ = profile(dt, seg)
        return (knots_q[k + 1] - knots_q[k]) * ds

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """``(sample(t), velocity(t))`` with one segment lookup (the simulator's tracking calls
        it every physics step); the values are exactly those of the two methods."""
        knots_t, knots_q = self._knots
        if t <= 0.0 or len(knots_t) < 2:
            return knots_q[0].copy(), np.zeros(len(self.joints))
        if t >= knots_t[-1]:
            return knots_q[-1].copy(), np.zeros(len(self.joints))
        k, dt, seg = self._segment(t)
        s, ds, _ = profile(dt, seg)
        dq = knots_q[k + 1] - knots_q[k]
        return knots_q[k] + dq * s, dq * ds

    def peak_velocities(self) -> np.ndarray:
        """Each joint's highest planned speed (absolute, exact from the profile)."""
        return self._peaks()[0]

    def peak_accelerations(self) -> np.ndarray:
        """Each joint's highest planned absolute acceleration."""
        return self._peaks()[1]

    def _peaks(self) -> tuple[np.ndarray, np.ndarray]:
        knots_t, knots_q = self._knots
        pv = np.zeros(len(self.joints))
        pa = np.zeros(len(self.joints))
        for k in range(len(knots_t) - 1):
            dq = np.abs(knots_q[k + 1] - knots_q[k])
            vpk, apk = profile_peaks(float(knots_t[k + 1] - knots_t[k]))
            pv = np.maximum(pv, dq * vpk)
            pa = np.maximum(pa, dq * apk)
        return pv, pa

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
