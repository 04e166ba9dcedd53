"""The gesture library: one gesture per command, every one timed within the joint limits."""

from __future__ import annotations

import json
import logging
import math
import re
from pathlib import Path

import numpy as np
import pytest

from prezence.errors import ConfigError, LimitViolation, UnknownName
from prezence.feedback.commands import load_commands
from prezence.feedback.gesture_check import (
    MAX_DURATION_S,
    MAX_RATIO,
    check_gestures,
    gesture_rows,
)
from prezence.feedback.gestures import (
    DEFAULT_SPEED_FRACTION,
    GestureLibrary,
    build_trajectory,
    check_plannable,
    library_notes,
    load_library,
    load_library_file,
    parse_library,
    radians_like,
    time_optimal_minimum,
    unplayed,
)
from prezence.feedback.limits import LEGS, JointLimits, load_limits
from prezence.feedback.trajectory import ACCEL_TIME_S, Trajectory

LIMITS = load_limits()
LIBRARY = load_library(LIMITS)
FRACTIONS = [0.2, DEFAULT_SPEED_FRACTION, 1.0]


def _all_cases() -> list[tuple[str, dict[str, int] | None]]:
    out: list[tuple[str, dict[str, int] | None]] = []
    for name in LIBRARY.names:
        if LIBRARY[name].params:
            out += [(name, {"minutes": m}) for m in (1, 3, 5)]
        else:
            out.append((name, None))
    return out


CASES = _all_cases()
IDS = [n if p is None else f"{n}-{p['minutes']}" for n, p in CASES]


def _tiny_library(keyframes: str, limits: JointLimits = LIMITS) -> str:
    neutral = "\n".join(f"{j} = {0.5 if j.endswith('Hand') else 0.0}" for j in limits.names)
    neutral = neutral.replace("LElbowRoll = 0.0", "LElbowRoll = -10.0").replace(
        "RElbowRoll = 0.0", "RElbowRoll = 10.0"
    )
    return f"format = 1\n[neutral]\n{neutral}\n[gestures.wave]\n{keyframes}\n"


def test_every_command_has_a_gesture() -> None:
    wanted = {c.gesture for c in load_commands().values()}
    assert wanted <= set(LIBRARY.names)


@pytest.mark.parametrize("fraction", FRACTIONS)
@pytest.mark.parametrize(("name", "params"), CASES, ids=IDS)
def test_gesture_stays_within_every_limit(
    name: str, params: dict[str, int] | None, fraction: float
) -> None:
    traj = build_trajectory(name, params=params, speed_fraction=fraction, limits=LIMITS)
    vmax = np.array([LIMITS.velocity[j] for j in traj.joints])
    assert np.all(traj.peak_velocities() <= fraction * vmax * (1 + 1e-9))
    assert np.all(traj.peak_accelerations() <= fraction * vmax / ACCEL_TIME_S * (1 + 1e-9))
    for t in np.arange(0.0, traj.duration, 0.01):
        q = dict(zip(traj.joints, traj.sample(float(t)), strict=True))
        LIMITS.check(q, pose=dict(LIBRARY.neutral), where=f"{name} t={t:.2f}", tol=1e-9)
    # starts from and returns to the neutral pose
    neutral = [LIBRARY.neutral[j] for j in traj.joints]
    assert list(traj.start) == pytest.approx(neutral)
    assert list(traj.positions[-1]) == pytest.approx(neutral)


@pytest.mark.parametrize("fraction", FRACTIONS)
@pytest.mark.parametrize(("name", "params"), CASES, ids=IDS)
def test_planned_duration_is_near_the_time_optimal_minimum(
    name: str, params: dict[str, int] | None, fraction: float
) -> None:
    traj = build_trajectory(name, params=params, speed_fraction=fraction, limits=LIMITS)
    t_min = time_optimal_minimum(traj, speed_fraction=fraction, limits=LIMITS)
    assert t_min <= traj.duration <= MAX_RATIO * t_min


def test_the_slowest_joint_runs_at_its_cap_in_every_gesture() -> None:
    # the timing is tight: some joint reaches fraction x limit (or the move is too short to)
    traj = build_trajectory("look_up", speed_fraction=0.5, limits=LIMITS)
    ratios = traj.peak_velocities() / np.array([LIMITS.velocity[j] for j in traj.joints])
    assert ratios.max() == pytest.approx(0.5)


def test_a_faster_fraction_gives_a_shorter_gesture() -> None:
    slow = build_trajectory("louder", speed_fraction=0.3, limits=LIMITS)
    fast = build_trajectory("louder", speed_fraction=0.9, limits=LIMITS)
    assert fast.duration < slow.duration
    assert fast.positions == slow.positions


def test_time_left_taps_once_per_minute_capped_at_five() -> None:
    def plan(m: int) -> Trajectory:
        return build_trajectory(
            "time_left", params={"minutes": m}, speed_fraction=0.6, limits=LIMITS
        )

    one, three, five, nine = plan(1), plan(3), plan(5), plan(9)
    assert one.duration < three.duration < five.duration
    assert nine == five
    rsp = three.joints.index("RShoulderPitch")
    pitch = [three.start[rsp]] + [p[rsp] for p in three.positions[:-1]]  # without the return
    moves = [b - a for a, b in zip(pitch, pitch[1:], strict=False) if b != a]
    presses = sum(1 for d in moves if d > 0)  # pitch up = the hand goes down onto the wrist
    assert presses == 3


def test_time_left_defaults_to_one_minute_and_ignores_other_params() -> None:
    plain = build_trajectory("time_left", speed_fraction=0.6, limits=LIMITS)
    extra = build_trajectory(
        "time_left", params={"minutes": 1, "metric": "x"}, speed_fraction=0.6, limits=LIMITS
    )
    assert plain == extra


def test_minutes_must_be_a_whole_number() -> None:
    with pytest.raises(TypeError, match="minutes must be a whole number"):
        build_trajectory("time_left", params={"minutes": 2.5}, speed_fraction=0.6, limits=LIMITS)


def test_unknown_gesture_suggests_a_name() -> None:
    with pytest.raises(UnknownName, match="did you mean 'look_up'"):
        build_trajectory("look_upp", speed_fraction=0.6, limits=LIMITS)


@pytest.mark.parametrize("fraction", [0.0, -0.5, 1.5, float("nan")])
def test_speed_fraction_outside_0_1_is_refused(fraction: float) -> None:
    with pytest.raises(ValueError, match="speed_fraction"):
        build_trajectory("encourage", speed_fraction=fraction, limits=LIMITS)


def test_keyframe_outside_limits_names_gesture_keyframe_and_joint() -> None:
    lib = parse_library(
        _tiny_library(
            "[[gestures.wave.keyframes]]\npose = { HeadYaw = 30 }\n"
            "[[gestures.wave.keyframes]]\npose = { LShoulderRoll = 95 }\n"
        ),
        limits=LIMITS,
    )
    with pytest.raises(
        LimitViolation, match=r"gesture 'wave' keyframes\[1\]: LShoulderRoll = 95\.0°"
    ):
        build_trajectory("wave", speed_fraction=0.6, limits=LIMITS, library=lib)


def test_a_path_that_cuts_the_head_range_names_gesture_time_and_joint() -> None:
    # each keyframe is allowed; on the way, where |HeadYaw| passes 87°, HeadPitch may reach
    # only 11.5° but the straight path is near 20° there
    lib = parse_library(
        _tiny_library(
            "[[gestures.wave.keyframes]]\npose = { HeadYaw = 0, HeadPitch = 28 }\n"
            "[[gestures.wave.keyframes]]\npose = { HeadYaw = 115, HeadPitch = 17 }\n"
        ),
        limits=LIMITS,
    )
    with pytest.raises(LimitViolation) as err:
        build_trajectory("wave", speed_fraction=0.6, limits=LIMITS, library=lib)
    msg = str(err.value)
    assert re.match(
        r"gestures\.toml:\d+: gesture 'wave' at \d+\.\d{3} s, "
        r"on the way to keyframes\[1\]: HeadPitch",
        msg,
    )
    assert "anti-collision" in msg and "straight path" in msg
    t = float(msg.split(" at ", 1)[1].split(" s,", 1)[0])
    assert t > 0.0


def test_the_same_head_move_in_two_steps_is_planned() -> None:
    lib = parse_library(
        _tiny_library(
            "[[gestures.wave.keyframes]]\npose = { HeadYaw = 0, HeadPitch = 28 }\n"
            "[[gestures.wave.keyframes]]\npose = { HeadYaw = 0, HeadPitch = 5 }\n"
            "[[gestures.wave.keyframes]]\npose = { HeadYaw = 115, HeadPitch = 5 }\n"
            "[[gestures.wave.keyframes]]\npose = { HeadYaw = 115, HeadPitch = 17 }\n"
            "[[gestures.wave.keyframes]]\npose = { HeadPitch = 5 }\n"  # the return too
        ),
        limits=LIMITS,
    )
    traj = build_trajectory("wave", speed_fraction=0.6, limits=LIMITS, library=lib)
    for t in np.arange(0.0, traj.duration, 0.002):
        q = dict(zip(traj.joints, traj.sample(float(t)), strict=True))
        LIMITS.check(q, pose=dict(lib.neutral), where=f"t={t:.3f}")


def test_keyframe_in_a_repeated_sequence_is_located() -> None:
    lib = parse_library(
        _tiny_library(
            "[[gestures.wave.keyframes]]\nrepeat = 2\n"
            "sequence = [ { pose = { HeadYaw = 10 } }, { pose = { RHand = 1.5 } } ]\n"
        ),
        limits=LIMITS,
    )
    with pytest.raises(LimitViolation, match=r"keyframes\[0\]\.sequence\[1\]: RHand"):
        build_trajectory("wave", speed_fraction=0.6, limits=LIMITS, library=lib)


def test_nan_keyframe_is_a_value_error_naming_the_joint() -> None:
    with pytest.raises(ValueError, match="HeadPitch target is nan"):
        parse_library(
            _tiny_library("[[gestures.wave.keyframes]]\npose = { HeadPitch = nan }\n"),
            limits=LIMITS,
        )


def test_nan_start_pose_is_a_value_error_naming_the_joint() -> None:
    with pytest.raises(ValueError, match="LElbowYaw target is nan"):
        build_trajectory(
            "summary", speed_fraction=0.6, limits=LIMITS, start_pose={"LElbowYaw": math.nan}
        )


def test_unknown_joint_in_the_data_is_a_config_error_with_its_key() -> None:
    with pytest.raises(
        ConfigError, match=r"gestures\.wave\.keyframes\[0\]\.pose\.HeadYow.*HeadYaw"
    ):
        parse_library(
            _tiny_library("[[gestures.wave.keyframes]]\npose = { HeadYow = 5 }\n"), limits=LIMITS
        )


@pytest.mark.parametrize(
    "keyframes",
    [
        "[[gestures.wave.keyframes]]\npose = { LKneePitch = 30.0 }\n",
        "[[gestures.wave.keyframes]]\nrepeat = 2\n"
        "sequence = [ { pose = { HeadYaw = 10, RHipPitch = -20 } } ]\n",
    ],
    ids=["knee", "hip-in-a-sequence"],
)
def test_a_gesture_that_moves_a_leg_is_refused_naming_the_joint(keyframes: str) -> None:
    # Within the knee's limits, so the limit check would pass it; on a standing NAO it can fall.
    with pytest.raises(ConfigError, match=r"(LKnee|RHip)Pitch is a leg joint"):
        parse_library(_tiny_library(keyframes), limits=LIMITS)


@pytest.mark.parametrize(
    ("keyframes", "message"),
    [
        ("[[gestures.wave.keyframes]]\npose = { HeadYaw = 5 }\nhold = 1e9\n", "hold must be"),
        ("[[gestures.wave.keyframes]]\npose = { HeadYaw = 5 }\nhold = -0.1\n", "hold must be"),
        (
            "[[gestures.wave.keyframes]]\nrepeat = 1000000\n"
            "sequence = [ { pose = { HeadYaw = 10 } }, { pose = { HeadYaw = 0 } } ]\n",
            "repeat must be",
        ),
        (
            "params.n = { default = 1, min = 1, max = 1000000000 }\n"
            '[[gestures.wave.keyframes]]\nrepeat = "n"\n'
            "sequence = [ { pose = { HeadYaw = 10 } }, { pose = { HeadYaw = 0 } } ]\n",
            "a parameter needs",
        ),
    ],
    ids=["hold-1e9", "hold-negative", "repeat-1e6", "param-max-1e9"],
)
def test_a_gesture_too_long_to_plan_is_refused_not_allocated(keyframes: str, message: str) -> None:
    # hold = 1e9 asked the check for 745 GiB of samples (numpy's _ArrayMemoryError)
    with pytest.raises(ConfigError, match=message):
        parse_library(_tiny_library(keyframes), limits=LIMITS)


@pytest.mark.parametrize(
    ("joint", "degrees"), [("LShoulderRoll", -18.0), ("LShoulderRoll", 76.0), ("LElbowRoll", -2.0)]
)
def test_the_naos_documented_limit_is_accepted_and_reached_not_passed(
    joint: str, degrees: float
) -> None:
    # Session 23's gesture designer wrote LShoulderRoll = 76 from Aldebaran's joint table and
    # was refused: "76.00000° is outside [-17.99998°, 75.99999°]" (the URDF rounds the limits).
    lib = parse_library(
        _tiny_library(f"[[gestures.wave.keyframes]]\npose = {{ {joint} = {degrees} }}\n"),
        limits=LIMITS,
    )
    traj = build_trajectory("wave", speed_fraction=0.6, limits=LIMITS, library=lib)
    col = [p[traj.joints.index(joint)] for p in traj.positions]
    lo, hi = LIMITS.lower[joint], LIMITS.upper[joint]
    at_lower = abs(math.radians(degrees) - lo) < abs(math.radians(degrees) - hi)
    assert (min(col) == lo) if at_lower else (max(col) == hi)
    assert all(LIMITS.lower[joint] <= v <= LIMITS.upper[joint] for v in col)


@pytest.mark.parametrize("joint", ["HeadRoll", "LWristPitch"])
def test_a_misspelt_joint_is_not_pointed_at_a_leg_joint_a_gesture_may_not_move(joint: str) -> None:
    # Session 23's gesture designer: HeadRoll got "did you mean 'RHipRoll'?", LWristPitch
    # "'LHipPitch'", and the known list held the 12 leg joints, each then refused.
    with pytest.raises(ConfigError) as e:
        parse_library(
            _tiny_library(f"[[gestures.wave.keyframes]]\npose = {{ {joint} = 10 }}\n"),
            limits=LIMITS,
        )
    said = str(e.value)
    assert f"unknown joint '{joint}'" in said
    assert not any(leg in said for leg in LEGS), said


def test_mirror_with_right_arm_values_only_is_refused_not_played_one_armed() -> None:
    # Session 23's gesture designer wrote a mirrored gesture with right-arm values: mirror
    # copies left onto right, so the gesture played one-armed without a word.
    text = "mirror = true\n[[gestures.wave.keyframes]]\npose = { RShoulderPitch = 35.0 }\n"
    with pytest.raises(ConfigError, match=r"right-arm values only \(RShoulderPitch\)"):
        parse_library(_tiny_library(text), limits=LIMITS)
    both = "mirror = true\n[[gestures.wave.keyframes]]\npose = { LShoulderPitch = 35.0 }\n"
    lib = parse_library(_tiny_library(both), limits=LIMITS)
    (kf,) = lib["wave"].keyframes({})
    assert kf.pose["RShoulderPitch"] == kf.pose["LShoulderPitch"]


def test_a_value_just_past_a_limit_reads_past_it() -> None:
    # 0.01° past the documented -18° is refused, and the message shows the decimals that tell
    # the two apart (it said "-18.0° is outside [-18.0°, 76.0°]").
    lib = parse_library(
        _tiny_library("[[gestures.wave.keyframes]]\npose = { LShoulderRoll = -18.01 }\n"),
        limits=LIMITS,
    )
    with pytest.raises(LimitViolation) as e:
        build_trajectory("wave", speed_fraction=0.6, limits=LIMITS, library=lib)
    m = re.search(r"LShoulderRoll = (-?[\d.]+)° is outside \[(-?[\d.]+)°", str(e.value))
    assert m is not None, str(e.value)
    assert float(m.group(1)) < float(m.group(2)), str(e.value)


def test_start_pose_is_where_the_plan_begins() -> None:
    start = {"HeadYaw": 0.4}
    traj = build_trajectory("look_up", speed_fraction=0.6, limits=LIMITS, start_pose=start)
    assert traj.start[traj.joints.index("HeadYaw")] == pytest.approx(0.4)
    assert traj.positions[-1][traj.joints.index("HeadYaw")] == pytest.approx(
        LIBRARY.neutral["HeadYaw"]
    )


def test_mirrored_gestures_move_both_arms_symmetrically() -> None:
    traj = build_trajectory("gesture_more", speed_fraction=0.6, limits=LIMITS)
    j = traj.joints
    for pose in traj.positions:
        assert pose[j.index("RShoulderRoll")] == pytest.approx(-pose[j.index("LShoulderRoll")])
        assert pose[j.index("RShoulderPitch")] == pytest.approx(pose[j.index("LShoulderPitch")])


def test_trajectory_round_trips_through_a_dict() -> None:
    traj = build_trajectory("overtime", speed_fraction=0.6, limits=LIMITS)
    assert Trajectory.from_dict(json.loads(json.dumps(traj.to_dict()))) == traj


def test_sampled_velocity_is_the_derivative_of_the_sampled_position() -> None:
    traj = build_trajectory("speed_up", speed_fraction=0.6, limits=LIMITS)
    h = 1e-6
    for t in np.linspace(0.01, traj.duration - 0.01, 97):
        numeric = (traj.sample(t + h) - traj.sample(t - h)) / (2 * h)
        assert numeric == pytest.approx(traj.velocity(t), abs=1e-4)


def test_state_is_sample_and_velocity_in_one_call_bit_for_bit() -> None:
    # the simulator tracks with state(); it must command exactly what sample/velocity plan,
    # at the knots, between them, before the start and after the end
    traj = build_trajectory("time_left", params={"minutes": 3}, speed_fraction=0.6, limits=LIMITS)
    ts = [-1.0, 0.0, *traj.times, traj.duration + 1.0, *np.linspace(0.0, traj.duration, 211)]
    for t in ts:
        q, v = traj.state(float(t))
        assert q.tolist() == traj.sample(float(t)).tolist()
        assert v.tolist() == traj.velocity(float(t)).tolist()


def test_check_reports_every_gesture_and_passes() -> None:
    text, status = check_gestures(0.6, as_json=False, collisions=False)
    assert status == 0, text
    for name in LIBRARY.names:
        assert name in text
    assert "self-collision not checked" in text  # tests/sim/test_self_collision.py does
    report = json.loads(check_gestures(0.6, as_json=True, collisions=False)[0])
    assert report["ok"] is True
    assert all(row["peak_velocity_pct"] <= 60.0 + 1e-6 for row in report["gestures"])
    assert all(row["ratio"] <= MAX_RATIO for row in report["gestures"])


def test_check_refuses_a_bad_fraction() -> None:
    assert check_gestures(0.0, as_json=False, collisions=False)[1] == 2


def test_check_rows_give_positive_margins() -> None:
    rows = gesture_rows(1.0, collisions=False)
    assert all(r["ok"] and r["margin_deg"] >= 0.0 for r in rows)


# --- a library of one's own (gestures check FILE, --gestures FILE) ---------------------------
OWN_SLOW_DOWN = """format = 1
# my slow_down: one pat, right arm only
[gestures.slow_down]
description = "One pat."
[[gestures.slow_down.keyframes]]
pose = { RShoulderPitch = 35.0, RHand = 1.0 }
hold = 0.2
[[gestures.slow_down.keyframes]]
pose = { RShoulderPitch = 60.0 }
"""


def test_a_library_of_your_own_replaces_gestures_by_name_and_keeps_the_rest(
    tmp_path: Path,
) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(OWN_SLOW_DOWN)
    lib = load_library_file(path, limits=LIMITS)
    assert lib.own == ("slow_down",) and lib.source == str(path)
    assert lib.names == LIBRARY.names  # same names, same order: one replaced
    assert lib["slow_down"] != LIBRARY["slow_down"]
    assert lib["slow_down"].description == "One pat."
    assert all(lib[n] == LIBRARY[n] for n in LIBRARY.names if n != "slow_down")
    assert lib.neutral == LIBRARY.neutral
    mine = build_trajectory("slow_down", speed_fraction=0.6, limits=LIMITS, library=lib)
    assert mine.joints == ("RShoulderPitch", "RHand")
    assert lib.record()["defines"] == ["slow_down"]
    assert lib.record()["file"] == str(path.resolve())


@pytest.mark.parametrize(
    ("body", "where", "message"),
    [
        ("[gestures.x]\nkeyframes = [1, 2]\n", "2: gestures.x.keyframes[0]", "expected a table"),
        (
            "[gestures.x]\n[[gestures.x.keyframes]]\nrepeat = 2\nsequence = 5\n",
            "4: gestures.x.keyframes[0].sequence",
            "non-empty array",
        ),
        ("[gestures]\nx = 5\n", "2: gestures.x", "expected a table, got int"),
        ("gestures = 5\n", "1: gestures", "a table of [gestures.NAME]"),
        (
            "[gestures.x]\nparams = 3\n[[gestures.x.keyframes]]\npose = { HeadYaw = 5 }\n",
            "2: gestures.x.params",
            "expected a table",
        ),
        (
            "[gestures.x]\nmirorr = true\n[[gestures.x.keyframes]]\npose = { HeadYaw = 5 }\n",
            "2: gestures.x.mirorr",
            "unknown key 'mirorr'; did you mean 'mirror'?",
        ),
        (
            "[gestures.x]\nmirror = 'yes'\n[[gestures.x.keyframes]]\npose = { HeadYaw = 5 }\n",
            "2: gestures.x.mirror",
            "expected true or false",
        ),
        (
            "[gestures.x]\n[[gestures.x.keyframes]]\npose = { HeadYaw = 5 }\nhld = 0.2\n",
            "4: gestures.x.keyframes[0].hld",
            "did you mean 'hold'?",
        ),
        (
            "[gestures.x]\n[[gestures.x.keyframes]]\npose = { HeadPitch = nan }\n",
            "3: gestures.x.keyframes[0].pose.HeadPitch",
            "HeadPitch target is nan",
        ),
        (
            "[gestures.x]\n[[gestures.x.keyframes]]\npose = { LKneePitch = 30.0 }\n",
            "3: gestures.x.keyframes[0].pose.LKneePitch",
            "LKneePitch is a leg joint",
        ),
        (
            "[gesture.x]\n[[gesture.x.keyframes]]\npose = { HeadYaw = 5 }\n",
            "1: gesture",
            "unknown key 'gesture'; did you mean 'gestures'?",
        ),
    ],
    ids=[
        "keyframes-not-tables",
        "sequence-not-array",
        "gesture-not-table",
        "gestures-not-table",
        "params-not-table",
        "misspelt-gesture-key",
        "mirror-not-bool",
        "misspelt-keyframe-key",
        "nan",
        "knee",
        "misspelt-top-table",
    ],
)
def test_any_shape_of_library_gives_a_config_error_with_its_line(
    body: str, where: str, message: str
) -> None:
    # keyframes = [1, 2] raised TypeError, [gestures] x = 5 AttributeError, a NaN a bare
    # ValueError; mirorr, hld and [gesture.x] were ignored without a word; no error had a line
    text = "format = 1\n" + body
    with pytest.raises(ConfigError) as e:
        parse_library(text, limits=LIMITS, path="lib.toml")
    line, _, key = where.partition(": ")
    assert str(e.value).startswith(f"lib.toml:{int(line) + 1}: {key}: "), str(e.value)
    assert message in str(e.value)


@pytest.mark.parametrize(
    ("text", "start", "message"),
    [
        ("[gestures.x]\nkeyframes = 3\n", "mine.toml:1: ", "expected format = 1, found none"),
        (
            "format = 1\n[neutral]\nHeadYaw = 10\n" + OWN_SLOW_DOWN.removeprefix("format = 1\n"),
            "mine.toml:2: neutral: ",
            "a library of your own gives gestures only",
        ),
        ("format = 1\n", "mine.toml: ", "defines no gesture"),
        ("format = 1\n[gestures.x\n", "mine.toml:2:12: ", "TOML: "),
        (
            OWN_SLOW_DOWN.replace("hold = 0.2", "hold = 1e9"),
            "mine.toml:7: gestures.slow_down.keyframes[0].hold: ",
            "hold must be seconds in [0, 5]",
        ),
    ],
    ids=["no-format", "neutral", "no-gesture", "toml-syntax", "hold-1e9"],
)
def test_a_library_file_of_your_own_is_refused_with_file_line_and_key(
    tmp_path: Path, text: str, start: str, message: str
) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(text)
    with pytest.raises(ConfigError) as e:
        load_library_file(path, limits=LIMITS)
    assert str(e.value).startswith(f"{tmp_path}/{start}"), str(e.value)
    assert message in str(e.value)


def test_a_missing_library_file_is_a_config_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"nothere\.toml: cannot read"):
        load_library_file(tmp_path / "nothere.toml", limits=LIMITS)


def test_a_keyframe_of_your_own_out_of_the_limits_names_file_and_line(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(OWN_SLOW_DOWN.replace("RShoulderPitch = 60.0", "RShoulderPitch = 150.0"))
    lib = load_library_file(path, limits=LIMITS)
    with pytest.raises(LimitViolation) as e:  # at the keyframe's table
        check_plannable(lib, limits=LIMITS)
    assert str(e.value).startswith(
        f"{path}:8: gesture 'slow_down' keyframes[1]: RShoulderPitch = 150.0°"
    ), str(e.value)


def test_the_docs_errors_are_what_the_docs_own_library_gets(tmp_path: Path) -> None:
    # docs/gestures.md said `mine.toml:7` for keyframes[1] of its own example, which is at 8
    doc = (Path(__file__).parents[2] / "docs" / "gestures.md").read_text()
    [example] = re.findall(r"```toml\n(format = 1\n.*?)```", doc, re.S)
    path = tmp_path / "mine.toml"
    shown = re.search(r"error: (mine\.toml:\d+: gesture 'slow_down' keyframes\[1\]: .*?)`", doc)
    assert shown is not None
    path.write_text(example.replace("RShoulderPitch = 60.0", "RShoulderPitch = 150.0"))
    with pytest.raises(LimitViolation) as e:
        check_plannable(load_library_file(path, limits=LIMITS), limits=LIMITS)
    assert str(e.value) == f"{tmp_path}/{shown.group(1)}"
    leg = re.search(r"\n(mine\.toml:\d+: gestures\.slow_down\.keyframes\[0\]\.pose\.\w+: )", doc)
    assert leg is not None
    path.write_text(example.replace("RShoulderPitch = 35.0", "RKneePitch = 35.0"))
    with pytest.raises(ConfigError) as c:
        load_library_file(path, limits=LIMITS)
    assert str(c.value).startswith(f"{tmp_path}/{leg.group(1)}")


def test_a_gesture_no_command_plays_is_noted_with_a_suggestion(tmp_path: Path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(OWN_SLOW_DOWN.replace("slow_down", "slow_dwon"))
    lib = load_library_file(path, limits=LIMITS)
    [note] = unplayed(lib)
    assert note.startswith(f"{path}:3: gestures.slow_dwon: no command plays 'slow_dwon'")
    assert "did you mean 'slow_down'?" in note
    assert unplayed(load_library_file(_write(tmp_path, OWN_SLOW_DOWN), limits=LIMITS)) == []


OWN_TIME_LEFT = """format = 1
[gestures.time_left]
params.mins = { default = 2, min = 1, max = 5 }
[[gestures.time_left.keyframes]]
repeat = "mins"
sequence = [ { pose = { RHand = 1.0 } }, { pose = { RHand = 0.0 } } ]
"""


def test_a_parameter_no_cue_sets_is_noted_with_the_ones_cues_give(tmp_path: Path) -> None:
    # time_left counting with `mins`: the checks passed without a word and every cue showed
    # the default 2, whatever the minutes left
    lib = load_library_file(_write(tmp_path, OWN_TIME_LEFT), limits=LIMITS)
    [note] = library_notes(lib)
    assert note.startswith(f"{tmp_path}/lib.toml:2: gestures.time_left.params.mins: ")
    assert "no cue sets 'mins', so every cue plays it at its default 2" in note
    assert "did you mean 'minutes'?" in note
    good = OWN_TIME_LEFT.replace("mins", "minutes")
    assert library_notes(load_library_file(_write(tmp_path, good), limits=LIMITS)) == []


def test_a_gesture_written_in_radians_is_noted_with_what_it_would_do(tmp_path: Path) -> None:
    # LShoulderPitch = -1.0 (meant: -57°, the arm up) passed every check and the arm moved 1°
    text = "format = 1\n[gestures.look_up]\n[[gestures.look_up.keyframes]]\n"
    rad = text + "pose = { LShoulderPitch = -1.0, LShoulderRoll = 0.2, LHand = 1.0 }\n"
    lib = load_library_file(_write(tmp_path, rad), limits=LIMITS)
    check_plannable(lib, limits=LIMITS)  # within every limit: nothing else would say a word
    [note] = library_notes(lib)
    assert note.startswith(f"{tmp_path}/lib.toml:2: gestures.look_up: every angle is within ")
    assert "LShoulderPitch = -1 is -1°, not -57° (radians?" in note
    deg = text + "pose = { LShoulderPitch = -57.0, LShoulderRoll = 11.0, LHand = 1.0 }\n"
    assert library_notes(load_library_file(_write(tmp_path, deg), limits=LIMITS)) == []
    every = GestureLibrary(LIBRARY.neutral, LIBRARY.gestures, own=LIBRARY.names)
    assert radians_like(every) == []  # no built-in gesture looks like radians


def test_a_nod_in_radians_beside_a_yaw_in_degrees_is_noted(tmp_path: Path) -> None:
    # session 23's gesture designer: HeadPitch = 0.4 and -0.2 (radians) beside HeadYaw = 3.0
    # (degrees) passed `gestures check` with no note: the ±2.1 rule looked at every angle of
    # the gesture at once, and the robot nodded 0.4°
    head = "format = 1\n[gestures.encourage]\n[[gestures.encourage.keyframes]]\n"
    mixed = head + (
        "pose = { HeadPitch = 0.4, HeadYaw = 3.0 }\n"
        "[[gestures.encourage.keyframes]]\npose = { HeadPitch = -0.2 }\n"
    )
    text, status = check_gestures(
        0.6, as_json=False, collisions=False, library=_write(tmp_path, mixed)
    )
    assert status == 0, text  # within every limit: a note, not a failure
    [note] = [ln for ln in text.splitlines() if ln.startswith("note: ")]
    # the line of the keyframe that holds the value it names, as a keyframe out of a limit
    assert note.startswith(f"note: {tmp_path}/lib.toml:3: gestures.encourage: every HeadPitch "), (
        note
    )
    assert (
        "where HeadYaw = 3 is not; angles are degrees, so HeadPitch = 0.4 is 0.4°, not 23°" in note
    )
    # the same nod in degrees, and a small angle no radian could be (LShoulderRoll = -2 beside
    # degrees, as the built-in gesture_less writes it: -2 rad is past the joint's limit)
    for pose in (
        "{ HeadPitch = 23.0, HeadYaw = 3.0 }",
        "{ LShoulderRoll = -2.0, LShoulderPitch = 60.0 }",
    ):
        lib = load_library_file(_write(tmp_path, head + f"pose = {pose}\n"), limits=LIMITS)
        assert radians_like(lib) == [], pose


def test_a_gesture_that_keeps_the_robot_busy_too_long_fails_the_check(tmp_path: Path) -> None:
    # ten repeats of two 5 s holds: 113 s of one cue passed, and a talk gave no time warning
    # while it played
    long = OWN_SLOW_DOWN + (
        "[[gestures.slow_down.keyframes]]\nrepeat = 10\nsequence = [ { pose = { RHand = 0.0 }, "
        "hold = 5 }, { pose = { RHand = 1.0 }, hold = 5 } ]\n"
    )
    text, status = check_gestures(
        0.6, as_json=False, collisions=False, library=_write(tmp_path, long)
    )
    assert status == 1
    [row] = [ln for ln in text.splitlines() if ln.startswith("slow_down")]
    planned = float(row.split()[1])  # the figure the table prints
    assert planned > MAX_DURATION_S
    assert f"FAIL: takes {planned:.1f} s > {MAX_DURATION_S:g} s" in row, row
    assert "while a gesture plays the robot gives no other cue" in row
    text, status = check_gestures(
        0.6, as_json=False, collisions=False, library=_write(tmp_path, OWN_SLOW_DOWN)
    )
    assert status == 0, text


def test_every_parameter_of_the_built_in_gestures_is_set_by_its_cues() -> None:
    given = {c.gesture: set(c.params) for c in load_commands().values()}
    for name in LIBRARY.names:
        assert set(LIBRARY[name].params) <= given[name], name


def _write(tmp_path: Path, text: str, name: str = "lib.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_gestures_check_takes_a_library_file_of_your_own(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # `prezence gestures check` took no file: a pip-installed user could check nothing of
    # their own
    from prezence.cli import main

    path = _write(tmp_path, OWN_SLOW_DOWN, "mine.toml")
    assert main(["gestures", "check", str(path), "--no-collisions"]) == 0
    out = capsys.readouterr().out
    assert f"gestures of {path} at 60%" in out
    rows = [ln.split()[0] for ln in out.splitlines()[3:-3]]  # -3: the summary and two notes
    assert rows == ["slow_down"]  # its own gestures only: the built-in ones are checked alone
    assert "1/1 timings ok (1 gesture of" in out  # not "1 gestures"
    others = len(load_library().names) - 1  # the built-in ones but slow_down, whatever they are
    assert (
        f"the other {others} gestures a talk with --gestures {path} plays are the built-in" in out
    )
    assert main(["gestures", "check", str(path), "--no-collisions", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["settings"]["library"] == str(path) and report["notes"] == []
    assert [r["gesture"] for r in report["gestures"]] == ["slow_down"]


def test_gestures_check_fails_a_gesture_of_your_own_out_of_the_limits_with_its_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from prezence.cli import main

    text = (
        OWN_SLOW_DOWN
        + "[gestures.wavee]\n[[gestures.wavee.keyframes]]\npose = { LShoulderRoll = 95 }\n"
    )
    path = _write(tmp_path, text, "mine.toml")
    assert main(["gestures", "check", str(path), "--no-collisions"]) == 1
    out = capsys.readouterr().out
    assert f"FAIL: {path}:11: gesture 'wavee' keyframes[0]: LShoulderRoll = 95.0°" in out
    assert f"note: {path}:10: gestures.wavee: no command plays 'wavee'" in out


@pytest.mark.parametrize(
    ("text", "where"),
    [
        (OWN_SLOW_DOWN.replace("RHand = 1.0", "RKneePitch = 3"), ":6: gestures.slow_down."),
        ("format = 1\n[gestures.x]\n[[gestures.x.keyframes]]\npose = { HeadYaw = \n", ":4:"),
        (None, ": cannot read"),
    ],
    ids=["leg-joint", "toml-syntax", "missing"],
)
def test_gestures_check_of_a_file_that_is_no_library_fails_naming_file_and_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str | None, where: str
) -> None:
    from prezence.cli import main

    path = tmp_path / "mine.toml"
    if text is not None:
        path.write_text(text)
    assert main(["gestures", "check", str(path), "--no-collisions"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"{path}{where}"), err


def test_no_collisions_asked_for_is_not_blamed_on_a_missing_pybullet(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import prezence.feedback.gesture_check as gc

    monkeypatch.setattr(gc, "pybullet_available", lambda: True)  # as after pip install [sim]
    text, status = check_gestures(0.6, as_json=False, collisions=False)
    assert status == 0
    assert "self-collision not checked (--no-collisions)" in text
    assert "needs pybullet" not in text
    report = json.loads(check_gestures(0.6, as_json=True, collisions=False)[0])
    assert report["settings"]["self_collision"] == "not checked (--no-collisions)"


def test_no_collisions_with_pybullet_does_not_say_a_robot_would_refuse_the_library(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    # it said "a talk on a real robot (--backend naoqi) refuses them here", where PyBullet is
    # installed and that talk checks them itself
    import prezence.feedback.gesture_check as gc

    monkeypatch.setattr(gc, "pybullet_available", lambda: True)  # as after pip install [sim]
    mine = tmp_path / "mine.toml"
    mine.write_text(
        'format = 1\n[gestures.articulate]\ndescription = ""\n'
        "[[gestures.articulate.keyframes]]\npose = { LShoulderPitch = 20.0 }\n"
    )
    text, status = check_gestures(0.6, as_json=False, collisions=False, library=mine)
    assert status == 0
    assert "refuses them" not in text and "--allow-unchecked-collision" not in text, text
    assert f"self-collision of the gestures of {mine} not checked here (--no-collisions): " in text
    assert "a talk checks them before it starts" in text


def test_without_pybullet_gestures_check_prints_no_plain_ok(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    # session 23's walkthrough: each row said `ok` though its self-collision was not checked,
    # and a talk on a real robot then played crossing forearms
    import prezence.feedback.gesture_check as gc

    monkeypatch.setattr(gc, "pybullet_available", lambda: False)
    mine = tmp_path / "mine.toml"
    mine.write_text(
        'format = 1\n[gestures.articulate]\ndescription = ""\n'
        "[[gestures.articulate.keyframes]]\npose = { LShoulderPitch = 20.0 }\n"
    )
    text, status = check_gestures(0.6, as_json=False, library=mine)
    rows = [line for line in text.splitlines() if line.startswith("articulate")]
    assert rows and all(r.endswith("ok but self-collision not checked") for r in rows), text
    assert f"self-collision of the gestures of {mine} not checked: a talk on a real robot" in text
    assert "--allow-unchecked-collision" in text


def test_a_phrase_the_robots_voice_cannot_say_as_written_is_warned_of_with_its_line(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # session 22's walkthrough: a French phrase with an emoji went to NAO's text-to-speech,
    # whose language is English, with no word of it anywhere
    from prezence.feedback.commands import TTS_LANGUAGE, parse_commands

    text = (
        "format = 1\n"
        "[commands.fewerFillers]\n"
        'direction = "lower"\n'
        'gesture = "fewer_fillers"\n'
        'phrase = "Moins de « euh », s\\u2019il vous plaît 🙂"\n'
        "[commands.slowDown]\n"
        'direction = "lower"\n'
        'gesture = "slow_down"\n'
        'phrase = "Slow down a little."\n'
    )
    with caplog.at_level(logging.WARNING, logger="prezence.feedback.commands"):
        table = parse_commands(text, "mine/commands.toml")
    assert table["fewerFillers"].phrase.endswith("🙂")  # kept as written: a warning, not an error
    said = [r.getMessage() for r in caplog.records]
    assert len(said) == 1, said
    assert said[0].startswith(
        "mine/commands.toml:5: commands.fewerFillers.phrase: "
        "'\u2019' (RIGHT SINGLE QUOTATION MARK), 'î' (LATIN SMALL LETTER I WITH CIRCUMFLEX), "
        "'🙂' (SLIGHTLY SMILING FACE) may not be said as written"
    ), said
    assert f"its {TTS_LANGUAGE} voice" in said[0] and "emoji" in said[0]


def test_the_built_in_phrases_are_all_sayable_by_the_robots_voice(
    caplog: pytest.LogCaptureFixture,
) -> None:
    from importlib import resources

    from prezence.feedback.commands import COMMANDS_FILE, parse_commands

    text = resources.files("prezence.feedback").joinpath("data", COMMANDS_FILE).read_text()
    with caplog.at_level(logging.WARNING, logger="prezence.feedback.commands"):
        parse_commands(text, COMMANDS_FILE)
    assert caplog.records == []
