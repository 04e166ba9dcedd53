"""The PyBullet NAO keeps the URDF's limits and the planned timing."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

pytest.importorskip("pybullet")

import pybullet as p  # noqa: E402

from prezence.feedback.gestures import build_trajectory, load_library  # noqa: E402
from prezence.feedback.limits import load_limits  # noqa: E402
from sim.nao import VELOCITY_TOL, NaoSim  # noqa: E402

LIMITS = load_limits()
#: measured speeds may exceed the cap by this share (Bullet's motor overshoots a step or two)
CAP_TOL = 0.02


@pytest.fixture
def sim() -> Iterator[NaoSim]:
    s = NaoSim(timestep=1 / 240)
    s.open()
    yield s
    s.close()


def test_loads_all_26_joints_standing(sim: NaoSim) -> None:
    assert sim.joint_names == LIMITS.names
    neutral = load_library(LIMITS).neutral
    assert sim.positions(["LShoulderPitch"])[0] == pytest.approx(neutral["LShoulderPitch"])
    # the soles touch the floor: fixed base at standing height
    cid, robot = sim.client, sim.robot
    sole = next(
        i
        for i in range(p.getNumJoints(robot, physicsClientId=cid))
        if p.getJointInfo(robot, i, physicsClientId=cid)[12].decode() == "l_sole"
    )
    z = p.getLinkState(robot, sole, physicsClientId=cid)[4][2]
    assert z == pytest.approx(0.0, abs=1e-6)


def test_pybullet_reads_the_urdf_limits(sim: NaoSim) -> None:
    cid, robot = sim.client, sim.robot
    for i in range(p.getNumJoints(robot, physicsClientId=cid)):
        info = p.getJointInfo(robot, i, physicsClientId=cid)
        name = info[1].decode()
        if name in LIMITS:
            assert (info[8], info[9]) == (
                pytest.approx(LIMITS.lower[name]),
                pytest.approx(LIMITS.upper[name]),
            )
            assert info[11] == pytest.approx(LIMITS.velocity[name])


@pytest.mark.parametrize("fraction", [0.1, 0.5, 1.0])
def test_set_targets_moves_no_faster_than_the_fraction(sim: NaoSim, fraction: float) -> None:
    sim.set_targets(["HeadYaw"], [1.5], fraction)
    sim.step_to(1.5 / (fraction * LIMITS.velocity["HeadYaw"]) + 0.5)
    assert sim.positions(["HeadYaw"])[0] == pytest.approx(1.5, abs=0.01)
    peak = sim.peak_velocity_ratio()["HeadYaw"]
    assert fraction * 0.95 <= peak <= fraction * (1 + CAP_TOL)


def test_target_beyond_the_limit_stops_at_the_limit(sim: NaoSim) -> None:
    sim.set_targets(["LShoulderRoll"], [3.0], 1.0)
    sim.step_to(1.0)
    assert sim.positions(["LShoulderRoll"])[0] == pytest.approx(
        LIMITS.upper["LShoulderRoll"], abs=0.005
    )
    assert sim.stats()["violations"] == 0


def test_nan_target_names_the_joint(sim: NaoSim) -> None:
    with pytest.raises(ValueError, match="RWristYaw target is nan"):
        sim.set_targets(["HeadYaw", "RWristYaw"], [0.1, float("nan")], 0.5)


def test_zero_speed_is_refused_not_unlimited(sim: NaoSim) -> None:
    with pytest.raises(ValueError, match=r"HeadYaw: speed fraction must be in \(0, 1\]"):
        sim.set_targets(["HeadYaw"], [0.5], 0.0)


def test_hip_yaw_pitch_moves_both_hips(sim: NaoSim) -> None:
    sim.set_targets(["LHipYawPitch"], [-0.5], 0.5)
    sim.step_to(1.0)
    left, right = sim.positions(["LHipYawPitch", "RHipYawPitch"])
    assert left == pytest.approx(-0.5, abs=0.01)
    assert right == pytest.approx(left, abs=0.01)


def test_head_pitch_is_kept_inside_the_anti_collision_range(sim: NaoSim) -> None:
    sim.set_targets(["HeadYaw"], [1.5], 1.0)
    sim.step_to(1.0)
    sim.set_targets(["HeadPitch"], [0.5], 1.0)
    sim.step_to(2.0)
    assert sim.positions(["HeadPitch"])[0] <= LIMITS.head_pitch_range(1.5)[1] + 0.005


def test_idle_robot_skips_physics_steps(sim: NaoSim) -> None:
    sim.step_to(1.0)
    steps = sim.steps
    sim.step_to(600.0)
    assert sim.time == 600.0
    assert sim.steps - steps < 10


@pytest.mark.parametrize("name", ["look_up", "speed_up"])
def test_gesture_is_tracked_within_limits_and_on_time(sim: NaoSim, name: str) -> None:
    fraction = 0.6
    traj = build_trajectory(name, speed_fraction=fraction, limits=LIMITS)
    sim.step_to(0.5)
    sim.follow(traj, speed_fraction=fraction)
    assert sim.following()
    sim.step_to(0.5 + traj.duration + 0.3)
    tr = sim.tracking
    assert tr is not None and tr.done and tr.ok
    assert tr.violations == 0
    assert tr.measured_s == pytest.approx(traj.duration, rel=0.03)
    ratio = max(v / LIMITS.velocity[j] for j, v in zip(traj.joints, tr.peak_speed, strict=True))
    assert ratio <= fraction * (1 + CAP_TOL)
    assert sim.positions(list(traj.joints)) == pytest.approx(list(tr.final), abs=0.005)
    assert sim.stats()["velocity_violations"] == 0
    assert VELOCITY_TOL > 0


def test_same_commands_give_the_same_motion() -> None:
    traj = build_trajectory("encourage", speed_fraction=0.8, limits=LIMITS)
    runs = []
    for _ in range(2):
        with NaoSim(timestep=1 / 100) as s:
            s.follow(traj, speed_fraction=0.8)
            samples = []
            for k in range(1, 31):
                s.step_to(k * 0.1)
                samples.append(s.positions())
            runs.append(samples)
    assert runs[0] == runs[1]


def test_close_twice_is_harmless() -> None:
    s = NaoSim()
    s.open()
    s.close()
    s.close()
    with pytest.raises(RuntimeError, match="not open"):
        s.positions()
