"""Any keyframes within the position limits retime to a trajectory within every limit, or are
refused because the straight path between them leaves the head anti-collision range."""

from __future__ import annotations

from collections.abc import Sequence
from types import MappingProxyType

import numpy as np
import pytest
from hypothesis import assume, event, given, settings
from hypothesis import strategies as st

from prezence.errors import LimitViolation
from prezence.feedback.gestures import (
    Gesture,
    GestureLibrary,
    Keyframe,
    Step,
    build_trajectory,
    load_library,
    time_optimal_minimum,
)
from prezence.feedback.limits import HEAD_PITCH_TABLE, load_limits
from prezence.feedback.trajectory import ACCEL_TIME_S, Trajectory

LIMITS = load_limits()
NEUTRAL = load_library(LIMITS).neutral
MOVABLE = [j for c in ("Head", "LArm", "RArm") for j in LIMITS.expand(c)] + ["LHipYawPitch"]
#: the blends cost at most this much over bang-coast-bang (trajectory.py)
WORST_BLEND_COST = 1.0541


@st.composite
def keyframes(draw: st.DrawFn) -> list[Keyframe]:
    joints = draw(st.lists(st.sampled_from(MOVABLE), min_size=1, max_size=6, unique=True))
    joints.sort(key=MOVABLE.index)  # HeadYaw before HeadPitch, whose range depends on it
    frames = []
    for k in range(draw(st.integers(1, 5))):
        pose: dict[str, float] = {}
        for j in joints:
            lo, hi = LIMITS.lower[j], LIMITS.upper[j]
            if j == "HeadPitch":
                lo, hi = LIMITS.head_pitch_range(pose.get("HeadYaw", NEUTRAL["HeadYaw"]))
            pose[j] = draw(st.floats(lo, hi, allow_nan=False))
        if "HeadYaw" in pose and "HeadPitch" not in pose:
            lo, hi = LIMITS.head_pitch_range(pose["HeadYaw"])
            pose["HeadPitch"] = min(max(NEUTRAL["HeadPitch"], lo), hi)
        hold = draw(st.sampled_from([0.0, 0.0, 0.1, 0.5]))
        frames.append(Keyframe(MappingProxyType(pose), hold, f"keyframes[{k}]"))
    return frames


def head_path_excess(frames: Sequence[Keyframe]) -> float:
    """How far (rad) the straight joint-space path neutral → frames → neutral goes outside the
    head anti-collision range at worst (<= 0: never outside).

    Worked out here without the planner: each segment is sampled densely and at every ``s``
    where ``|HeadYaw|`` meets a point of the head table (the range's corners).
    """
    poses = [(NEUTRAL["HeadYaw"], NEUTRAL["HeadPitch"])]
    for kf in frames:
        yaw, pitch = poses[-1]
        poses.append((kf.pose.get("HeadYaw", yaw), kf.pose.get("HeadPitch", pitch)))
    poses.append((NEUTRAL["HeadYaw"], NEUTRAL["HeadPitch"]))
    worst = -np.inf
    for (y0, p0), (y1, p1) in zip(poses, poses[1:], strict=False):
        s = list(np.linspace(0.0, 1.0, 201))
        if y1 != y0:
            s += [(sign * row[0] - y0) / (y1 - y0) for row in HEAD_PITCH_TABLE for sign in (1, -1)]
        s_arr = np.clip(np.asarray(s), 0.0, 1.0)
        yaw, pitch = y0 + (y1 - y0) * s_arr, p0 + (p1 - p0) * s_arr
        lo, hi = LIMITS.head_pitch_ranges(yaw)
        worst = max(worst, float(np.max(np.maximum(lo - pitch, pitch - hi))))
    return worst


def plan_or_refusal(frames: Sequence[Keyframe], fraction: float) -> Trajectory | None:
    """The planned trajectory, or None when the planner refuses it for a path that really
    leaves the head range."""
    lib = GestureLibrary(
        NEUTRAL, {"random": Gesture("random", "", tuple(Step((kf,)) for kf in frames))}
    )
    excess = head_path_excess(frames)
    try:
        traj = build_trajectory("random", speed_fraction=fraction, limits=LIMITS, library=lib)
    except LimitViolation as e:
        assert "straight path" in str(e) and "HeadPitch" in str(e), str(e)
        assert excess > 1e-10, f"refused, yet the path stays {-excess:.2e} rad inside: {e}"
        return None
    assert excess <= 1e-8, f"planned, yet the path leaves the head range by {excess:.2e} rad"
    return traj


def assert_samples_within_every_limit(traj: Trajectory, n: int = 400) -> None:
    """Every sampled pose within the URDF bounds and the head anti-collision range."""
    still = {j: v for j, v in NEUTRAL.items() if j not in traj.joints}
    for t in np.linspace(0.0, traj.duration, n):
        q = dict(zip(traj.joints, traj.sample(float(t)), strict=True))
        assert not LIMITS.violations(q, pose=still), (float(t), LIMITS.violations(q, pose=still))


@settings(max_examples=150, deadline=None)
@given(frames=keyframes(), fraction=st.floats(0.05, 1.0))
def test_random_keyframes_retime_within_every_limit(
    frames: list[Keyframe], fraction: float
) -> None:
    # a gesture that never leaves neutral is refused by design (it would say nothing)
    assume(any(abs(v - NEUTRAL[j]) > 1e-12 for kf in frames for j, v in kf.pose.items()))
    traj = plan_or_refusal(frames, fraction)
    if traj is None:
        return

    vmax = np.array([LIMITS.velocity[j] for j in traj.joints])
    assert np.all(traj.peak_velocities() <= fraction * vmax * (1 + 1e-9))
    assert np.all(traj.peak_accelerations() <= fraction * vmax / ACCEL_TIME_S * (1 + 1e-9))

    lo = np.array([LIMITS.lower[j] for j in traj.joints])
    hi = np.array([LIMITS.upper[j] for j in traj.joints])
    for t in np.linspace(0.0, traj.duration, 200):
        q = traj.sample(float(t))
        assert np.all(q >= lo - 1e-9) and np.all(q <= hi + 1e-9)
        v = np.abs(traj.velocity(float(t)))
        assert np.all(v <= fraction * vmax * (1 + 1e-9))
    assert_samples_within_every_limit(traj)

    t_min = time_optimal_minimum(traj, speed_fraction=fraction, limits=LIMITS)
    assert t_min <= traj.duration * (1 + 1e-12)
    assert traj.duration <= WORST_BLEND_COST * t_min

    # the robot is exactly at every keyframe at its time
    for t, pose in zip(traj.times, traj.positions, strict=True):
        assert np.allclose(traj.sample(t), pose, atol=1e-12)


@st.composite
def head_keyframes(draw: st.DrawFn) -> list[Keyframe]:
    """Head poses within the range, often at its edge, where straight paths cut corners."""
    frames = []
    for k in range(draw(st.integers(1, 4))):
        yaw = draw(st.floats(LIMITS.lower["HeadYaw"], LIMITS.upper["HeadYaw"]))
        lo, hi = LIMITS.head_pitch_range(yaw)
        pitch = draw(st.one_of(st.sampled_from([lo, hi]), st.floats(lo, hi)))
        pose = {"HeadYaw": yaw, "HeadPitch": pitch}
        frames.append(Keyframe(MappingProxyType(pose), 0.0, f"keyframes[{k}]"))
    return frames


@settings(max_examples=150, deadline=None)
@given(frames=head_keyframes(), fraction=st.floats(0.05, 1.0))
def test_head_paths_are_planned_only_when_they_keep_to_the_head_range(
    frames: list[Keyframe], fraction: float
) -> None:
    traj = plan_or_refusal(frames, fraction)
    event("refused" if traj is None else "planned")
    if traj is not None:
        assert_samples_within_every_limit(traj)


def test_a_corner_cutting_head_path_is_refused_naming_time_and_joint() -> None:
    # both keyframes are allowed; halfway, at |HeadYaw| 1.53 rad, HeadPitch may reach 11.5°
    frames = [
        Keyframe(MappingProxyType({"HeadYaw": 0.0, "HeadPitch": 0.5}), 0.0, "keyframes[0]"),
        Keyframe(MappingProxyType({"HeadYaw": 2.0, "HeadPitch": 0.3}), 0.0, "keyframes[1]"),
    ]
    assert head_path_excess(frames) > 0.1
    lib = GestureLibrary(NEUTRAL, {"g": Gesture("g", "", tuple(Step((kf,)) for kf in frames))})
    with pytest.raises(
        LimitViolation, match=r"gesture 'g' at \d+\.\d+ s, on the way to keyframes\[1\]: HeadPitch"
    ):
        build_trajectory("g", speed_fraction=0.6, limits=LIMITS, library=lib)
