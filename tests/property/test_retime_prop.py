"""Any keyframes within the position limits retime to a trajectory within every limit."""

from __future__ import annotations

from types import MappingProxyType

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from prezence.feedback.gestures import (
    Gesture,
    GestureLibrary,
    Keyframe,
    Step,
    build_trajectory,
    load_library,
    time_optimal_minimum,
)
from prezence.feedback.limits import load_limits
from prezence.feedback.trajectory import ACCEL_TIME_S

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


@settings(max_examples=150, deadline=None)
@given(frames=keyframes(), fraction=st.floats(0.05, 1.0))
def test_random_keyframes_retime_within_every_limit(
    frames: list[Keyframe], fraction: float
) -> None:
    # a gesture that never leaves neutral is refused by design (it would say nothing)
    assume(any(abs(v - NEUTRAL[j]) > 1e-12 for kf in frames for j, v in kf.pose.items()))
    lib = GestureLibrary(
        NEUTRAL, {"random": Gesture("random", "", tuple(Step((kf,)) for kf in frames))}
    )
    traj = build_trajectory("random", speed_fraction=fraction, limits=LIMITS, library=lib)

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

    t_min = time_optimal_minimum(traj, speed_fraction=fraction, limits=LIMITS)
    assert t_min <= traj.duration * (1 + 1e-12)
    assert traj.duration <= WORST_BLEND_COST * t_min

    # the robot is exactly at every keyframe at its time
    for t, pose in zip(traj.times, traj.positions, strict=True):
        assert np.allclose(traj.sample(t), pose, atol=1e-12)
