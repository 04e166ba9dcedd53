"""The PyBullet NAO keeps the URDF's limits and the planned timing."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

pytest.importorskip("pybullet")

import pybullet as p  # noqa: E402

from prezence.errors import LimitViolation, UnknownName  # noqa: E402
from prezence.feedback.gestures import build_trajectory, load_library  # noqa: E402
from prezence.feedback.limits import load_limits  # noqa: E402
from prezence.feedback.trajectory import Trajectory  # noqa: E402
from sim.nao import ARRIVAL_TOL, VELOCITY_TOL, NaoSim  # noqa: E402

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


def _one_joint(joint: str, start: float, keys: list[tuple[float, float]]) -> Trajectory:
    """A trajectory of one joint: (time, angle) keys from ``start``."""
    return Trajectory(
        f"{joint} keys", (joint,), tuple(t for t, _ in keys), tuple((q,) for _, q in keys), (start,)
    )


def _planned_arrival(traj: Trajectory) -> float:
    """When the plan itself comes within ``ARRIVAL_TOL`` of its end pose for good (s)."""
    final = traj.sample(traj.duration)
    t = traj.duration
    while t > 0.0 and max(abs(traj.sample(t - 0.001) - final)) <= ARRIVAL_TOL:
        t -= 0.001
    return max(t, 0.0)


def _track_error(sim: NaoSim, plans: list[tuple[float, Trajectory]], until: float) -> float:
    """Step to ``until``; the worst distance (rad) between a joint and its plan on the way."""
    worst = 0.0
    while sim.time < until - 1e-9:
        sim.step_to(sim.time + 0.01)
        for t0, plan in plans:
            want = plan.sample(sim.time - t0)
            got = sim.positions(list(plan.joints))
            worst = max(worst, *(abs(g - w) for g, w in zip(got, want, strict=True)))
    return worst


def test_trajectories_with_different_time_lists_run_together(sim: NaoSim) -> None:
    # NAOqi's reference nod: HeadPitch down/up twice over 1.2 s while HeadYaw holds 0, given as
    # one trajectory per time list (what the virtual NAO does with angleInterpolation)
    sim.step_to(0.5)
    yaw0, pitch0 = sim.positions(["HeadYaw", "HeadPitch"])
    pitch = _one_joint("HeadPitch", pitch0, [(0.3, 0.25), (0.6, 0.0), (0.9, 0.25), (1.2, 0.0)])
    yaw = _one_joint("HeadYaw", yaw0, [(1.2, 0.0)])
    records = [sim.follow(pitch), sim.follow(yaw)]
    assert sim.trackings == tuple(records)
    assert _track_error(sim, [(0.5, pitch), (0.5, yaw)], 0.5 + 1.2) < 0.02
    sim.step_to(2.5)
    for rec in records:
        assert rec.done and rec.ok and rec.violations == 0
        assert rec.measured_s == pytest.approx(_planned_arrival(rec.traj), abs=0.03 * 1.2)
    assert not sim.following()


def test_overlapping_trajectories_on_different_joints_both_arrive_on_time(sim: NaoSim) -> None:
    sim.step_to(0.5)
    yaw = _one_joint("HeadYaw", sim.positions(["HeadYaw"])[0], [(1.5, -0.8)])
    first = sim.follow(yaw)
    sim.step_to(0.6)
    arm = _one_joint("LShoulderPitch", sim.positions(["LShoulderPitch"])[0], [(1.0, 0.5)])
    second = sim.follow(arm)
    assert _track_error(sim, [(0.5, yaw), (0.6, arm)], 2.0) < 0.02
    sim.step_to(3.0)
    for rec in (first, second):
        assert rec.done and rec.ok
        planned = rec.traj.duration
        assert rec.measured_s == pytest.approx(_planned_arrival(rec.traj), abs=0.03 * planned)
    assert sim.positions(["HeadYaw", "LShoulderPitch"]) == pytest.approx([-0.8, 0.5], abs=0.005)


def test_a_command_takes_over_its_joints_only(sim: NaoSim) -> None:
    sim.step_to(0.5)
    yaw0, pitch0 = sim.positions(["HeadYaw", "HeadPitch"])
    head = Trajectory("head", ("HeadYaw", "HeadPitch"), (1.5,), ((0.8, 0.3),), (yaw0, pitch0))
    rec = sim.follow(head)
    sim.step_to(1.0)
    sim.set_targets(["HeadPitch"], [-0.3], 1.0)  # HeadPitch leaves the trajectory …
    assert sim.following() and sim.trackings == (rec,)
    yaw = _one_joint("HeadYaw", yaw0, [(1.5, 0.8)])
    assert _track_error(sim, [(0.5, yaw)], 2.0) < 0.02
    sim.step_to(3.0)
    # … HeadYaw finished it on time; the record says the trajectory was not played whole
    assert rec.done and not rec.ok
    assert rec.measured_s == pytest.approx(_planned_arrival(yaw), abs=0.03 * 1.5)
    assert sim.positions(["HeadYaw", "HeadPitch"]) == pytest.approx([0.8, -0.3], abs=0.005)


def test_a_trajectory_whose_joints_are_all_taken_ends_at_once(sim: NaoSim) -> None:
    yaw0 = sim.positions(["HeadYaw"])[0]
    old = sim.follow(_one_joint("HeadYaw", yaw0, [(2.0, 1.0)]))
    sim.step_to(0.5)
    new = sim.follow(_one_joint("HeadYaw", sim.positions(["HeadYaw"])[0], [(0.5, -0.5)]))
    assert old.done and not old.ok and old.finished_at == sim.time
    assert sim.tracking is new and sim.trackings == (new,)
    sim.step_to(2.0)
    assert new.done and new.ok
    assert sim.positions(["HeadYaw"])[0] == pytest.approx(-0.5, abs=0.005)


def _link_poses(s: NaoSim) -> dict[str, tuple[float, ...]]:
    cid, robot = s.client, s.robot
    out = {}
    for i in range(p.getNumJoints(robot, physicsClientId=cid)):
        child = p.getJointInfo(robot, i, physicsClientId=cid)[12].decode()
        st = p.getLinkState(robot, i, computeForwardKinematics=True, physicsClientId=cid)
        out[child] = (*st[4], *st[5])
    return out


def test_a_frozen_joint_holds_its_angle_exactly_where_the_movable_one_would() -> None:
    # non-zero angles, the diagonal HipYawPitch axis included: the fixed joint's origin must be
    # the URDF origin turned by the angle about the joint's axis
    angles = {"LHipYawPitch": -0.3, "LHipPitch": -0.5, "LKneePitch": 0.6, "RAnkleRoll": 0.2}
    with NaoSim() as movable, NaoSim(frozen=angles) as frozen:
        for name, q in angles.items():
            p.resetJointState(
                movable.robot, movable._index[name], q, 0.0, physicsClientId=movable.client
            )
        want, got = _link_poses(movable), _link_poses(frozen)
        assert got.keys() == want.keys()
        for link, pose in want.items():
            assert got[link] == pytest.approx(pose, abs=1e-6), link
        assert set(frozen.joint_names) == set(LIMITS.names) - set(angles)
        frozen.step_to(2.0)  # and it stays there under gravity
        assert _link_poses(frozen)["l_sole"] == pytest.approx(want["l_sole"], abs=1e-6)


def test_a_frozen_joint_cannot_be_commanded_and_says_why() -> None:
    with NaoSim(frozen={"LKneePitch": 0.0}) as s:
        before = s.positions()
        with pytest.raises(ValueError, match="LKneePitch is held rigid"):
            s.set_targets(["LShoulderPitch", "LKneePitch"], [0.5, 0.5], 0.5)
        assert s.positions() == before  # nothing moved, not even the joint that was allowed
        with pytest.raises(ValueError, match="LKneePitch is held rigid"):
            s.follow(_one_joint("LKneePitch", 0.0, [(1.0, 0.3)]))
    with pytest.raises(UnknownName, match="did you mean 'LKneePitch'"):
        NaoSim(frozen={"LKnee": 0.0}).open()
    with pytest.raises(LimitViolation, match="LKneePitch"):
        NaoSim(frozen={"LKneePitch": 3.0}).open()  # beyond its limits


def test_freezing_the_legs_leaves_the_arms_motion_as_it_was() -> None:
    """The sim backend freezes the legs to halve the cost of a step; on a fixed base the arms
    must then move as they did with every joint simulated."""
    from sim.backend import LEGS

    traj = build_trajectory("gesture_more", speed_fraction=0.6, limits=LIMITS)
    paths = []
    for frozen in ({}, dict.fromkeys(LEGS, 0.0)):
        with NaoSim(timestep=1 / 100, frozen=frozen) as s:
            s.follow(traj, speed_fraction=0.6)
            path = []
            while s.time < traj.duration + 0.5:
                s.step_to(s.time + 0.05)
                path.append(s.positions(list(traj.joints)))
            tr = s.tracking
            assert tr is not None and tr.done and tr.ok and tr.violations == 0
            paths.append((path, tr.measured_s))
    (full, full_s), (legs_frozen, frozen_s) = paths
    worst = max(
        abs(a - b)
        for ra, rb in zip(full, legs_frozen, strict=True)
        for a, b in zip(ra, rb, strict=True)
    )
    assert worst < ARRIVAL_TOL  # rad, along the whole path (measured: 1 mrad)
    assert frozen_s == pytest.approx(full_s, abs=0.02)
