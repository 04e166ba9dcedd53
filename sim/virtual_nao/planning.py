"""Keyframe planning for ``ALMotion.angleInterpolation``: NAOqi's argument shapes, and NAO's
rules (joint ranges, head anti-collision, one hip motor, velocity limits) applied to keyframes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from prezence.feedback.limits import (
    HIP_YAW_PITCH,
    JointLimits,
)
from prezence.feedback.trajectory import RAMP_S, Trajectory, profile_peaks
from sim.virtual_nao.robot import _is_seq, _num


def _per_joint(values: object, n: int, what: str, method: str) -> list[list[float]]:
    """NAOqi's shapes for angle/time lists → one list per joint.

    A scalar (one joint), a flat list (one value per joint; for a single joint, its keyframes),
    or a list of lists. A flat list of length k with n > 1 joints and k != n is rejected.
    """
    if not _is_seq(values):
        if n != 1:
            raise ValueError(f"ALMotion.{method}: one {what} for {n} joints")
        return [[_num(values, what)]]
    seq = list(values)
    if n == 1 and all(not _is_seq(v) for v in seq):
        return [[_num(v, what) for v in seq]]
    if len(seq) != n:
        raise ValueError(f"ALMotion.{method}: {len(seq)} {what} lists for {n} joints")
    return [[_num(x, what) for x in v] if _is_seq(v) else [_num(v, what)] for v in seq]


#: A segment counts as too fast when its peak speed exceeds the joint's limit by this share.
SPEED_TOL = 1e-6


@dataclass(frozen=True)
class KeyframePlan:
    """What ``angleInterpolation`` plays once NAO's rules are applied (:func:`plan_keyframes`).

    Attributes:
        joints: the joints moved: the call's, plus the other HipYawPitch when one was given.
        angles: per joint, absolute angles after clipping.
        times: per joint, key times in seconds from the start (spread out where too fast).
        asked_s: the last key time asked.
        duration_s: the last key time played (``asked_s`` unless the motion was slowed down).
        capped: the segment furthest over its joint's velocity limit, as (joint, speed asked,
            limit) in rad/s (hands: fraction/s); None when every segment is within its limit.
    """

    joints: tuple[str, ...]
    angles: tuple[tuple[float, ...], ...]
    times: tuple[tuple[float, ...], ...]
    asked_s: float
    duration_s: float
    capped: tuple[str, float, float] | None = None


def min_segment_time(distance: float, velocity: float) -> float:
    """The shortest segment that moves ``distance`` with a peak speed of at most ``velocity``.

    Segments follow :mod:`prezence.feedback.trajectory`'s profile, whose peak over a segment of
    duration ``T`` is ``|distance| / (T − min(RAMP_S, T/2))``.

    Example:
        >>> round(min_segment_time(2.0, 8.0), 3)  # 0.25 s at full speed, plus one ramp
        0.45
    """
    u = abs(distance) / velocity
    return 2.0 * u if u < RAMP_S else u + RAMP_S


def plan_keyframes(
    limits: JointLimits,
    joints: Sequence[str],
    angles: Sequence[Sequence[float]],
    times: Sequence[Sequence[float]],
    pose: dict[str, float],
) -> KeyframePlan:
    """NAO's rules applied to ``angleInterpolation`` keyframes, as ``setAngles`` applies them.

    * **One hip motor**: a HipYawPitch's keys go to both hips (LHipYawPitch wins when both are
      given, as on NAO).
    * **Limits**: every key is clipped with :meth:`JointLimits.clip` (``setAngles``' function);
      a HeadPitch key against the anti-collision range at the HeadYaw planned for its time (the
      call's HeadYaw keyframes, or the current HeadYaw when the call leaves it alone).
    * **Velocity limits**: a segment whose peak speed would exceed its joint's limit is not
      followed late: the stretch of the call's timeline under it is slowed down until it fits,
      i.e. each key time after it moves later and every joint keeps its keys in step with the
      others'. ``capped`` names the worst segment so the caller can warn.

    Args:
        limits: the joint limits.
        joints: joint names.
        angles: per joint, absolute angles, one per key time.
        times: per joint, strictly increasing key times (seconds from the start, > 0).
        pose: every body joint's angle now (each joint's first segment starts there).
    """
    keys = {j: (list(a), list(t)) for j, a, t in zip(joints, angles, times, strict=True)}
    left, right = HIP_YAW_PITCH
    if left in keys:
        keys[right] = keys[left]
    elif right in keys:
        keys[left] = keys[right]
    for j, (a, t) in keys.items():
        if j != "HeadPitch":
            keys[j] = ([limits.clip({j: x}, pose=pose)[j] for x in a], t)
    if "HeadPitch" in keys:
        a, t = keys["HeadPitch"]
        yaw = [pose["HeadYaw"]] * len(t)
        if "HeadYaw" in keys:
            ya, yt = keys["HeadYaw"]
            traj = Trajectory(
                "HeadYaw", ("HeadYaw",), tuple(yt), tuple((x,) for x in ya), (pose["HeadYaw"],)
            )
            yaw = [float(traj.sample(tk)[0]) for tk in t]
        keys["HeadPitch"] = (
            [
                limits.clip({"HeadPitch": x}, pose={**pose, "HeadYaw": y})["HeadPitch"]
                for x, y in zip(a, yaw, strict=True)
            ],
            t,
        )
    # velocity limits: slow down the stretches of the timeline under too fast segments
    grid = sorted({0.0, *(x for _, t in keys.values() for x in t)})
    slot = {x: i for i, x in enumerate(grid)}
    factor = [1.0] * (len(grid) - 1)
    capped: tuple[str, float, float] | None = None
    for j, (a, t) in keys.items():
        limit = limits.velocity[j]
        q0, t0 = pose[j], 0.0
        for q, tk in zip(a, t, strict=True):
            asked = abs(q - q0) * profile_peaks(tk - t0)[0]
            if asked > limit * (1.0 + SPEED_TOL):
                f = min_segment_time(q - q0, limit) / (tk - t0)
                for i in range(slot[t0], slot[tk]):
                    factor[i] = max(factor[i], f)
                if capped is None or asked / limit > capped[1] / capped[2]:
                    capped = (j, asked, limit)
            q0, t0 = q, tk
    played = [0.0]
    for i, f in enumerate(factor):
        played.append(played[-1] + (grid[i + 1] - grid[i]) * f)
    when = dict(zip(grid, played, strict=True))
    return KeyframePlan(
        joints=tuple(keys),
        angles=tuple(tuple(a) for a, _ in keys.values()),
        times=tuple(tuple(when[x] for x in t) for _, t in keys.values()),
        asked_s=grid[-1],
        duration_s=played[-1],
        capped=capped,
    )
