"""Joint limits come from the URDF, and the rules a URDF cannot express are enforced."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from prezence.errors import LimitViolation, UnknownName
from prezence.feedback.limits import HEAD_PITCH_TABLE, JointLimits, load_limits
from prezence.resources import urdf_path


@pytest.fixture(scope="module")
def lim() -> JointLimits:
    return load_limits()


def test_limits_are_read_from_the_urdf_file_given(tmp_path: Path) -> None:
    text = urdf_path().read_text(encoding="utf-8")
    edited = tmp_path / "nao.urdf"
    edited.write_text(
        text.replace(
            'lower="-2.08567" upper="2.08567" effort="1.547" velocity="8.26797"',
            'lower="-1.0" upper="1.5" effort="1.547" velocity="3.0"',
            1,
        ),
        encoding="utf-8",
    )
    mine = load_limits(edited)
    assert (mine.lower["HeadYaw"], mine.upper["HeadYaw"], mine.velocity["HeadYaw"]) == (
        -1.0,
        1.5,
        3.0,
    )
    assert load_limits().velocity["HeadYaw"] == pytest.approx(8.26797)


def test_load_limits_is_cached(lim: JointLimits) -> None:
    assert load_limits() is lim
    assert load_limits(urdf_path()) is lim


def test_all_26_naoqi_joints_in_body_order(lim: JointLimits) -> None:
    assert len(lim.names) == 26
    assert lim.names[:2] == ("HeadYaw", "HeadPitch")
    assert lim.chains["Body"] == lim.names
    assert lim.expand("LArm")[-1] == "LHand"
    assert lim.expand("RLeg")[0] == "RHipYawPitch"
    assert lim.expand("HeadYaw") == ("HeadYaw",)


def test_unknown_chain_suggests_the_close_name(lim: JointLimits) -> None:
    with pytest.raises(UnknownName, match="did you mean 'LArm'"):
        lim.expand("LArn")


def test_check_names_the_joint_out_of_range(lim: JointLimits) -> None:
    with pytest.raises(LimitViolation, match=r"where: LShoulderRoll = 90\.0° is outside"):
        lim.check({"LShoulderRoll": math.radians(90)}, where="where")


def test_nan_target_is_a_value_error_naming_the_joint(lim: JointLimits) -> None:
    with pytest.raises(ValueError, match="RElbowYaw target is nan"):
        lim.clip({"RElbowYaw": float("nan")})


def test_clip_moves_targets_inside(lim: JointLimits) -> None:
    out = lim.clip({"HeadYaw": 5.0, "LElbowRoll": 0.5, "LHand": 1.7})
    assert out == {
        "HeadYaw": lim.upper["HeadYaw"],
        "LElbowRoll": lim.upper["LElbowRoll"],
        "LHand": 1.0,
    }


def test_one_hip_motor_target_goes_to_both_and_left_wins(lim: JointLimits) -> None:
    assert lim.couple({"RHipYawPitch": -0.3}) == {"RHipYawPitch": -0.3, "LHipYawPitch": -0.3}
    both = lim.clip({"LHipYawPitch": -0.2, "RHipYawPitch": 0.4})
    assert both["RHipYawPitch"] == both["LHipYawPitch"] == -0.2


def test_different_hip_values_are_refused(lim: JointLimits) -> None:
    with pytest.raises(LimitViolation, match="one motor"):
        lim.check({"LHipYawPitch": -0.2, "RHipYawPitch": 0.1})


def test_head_pitch_range_narrows_when_the_head_turns(lim: JointLimits) -> None:
    lo0, hi0 = lim.head_pitch_range(0.0)
    lo, hi = lim.head_pitch_range(1.5)
    assert (lo0, hi0) == (pytest.approx(-0.671951), pytest.approx(lim.upper["HeadPitch"]))
    assert lo > lo0 and hi < hi0
    assert lim.head_pitch_range(-1.5) == lim.head_pitch_range(1.5)
    # at a table point the table's own values apply
    yaw, pmin, pmax = HEAD_PITCH_TABLE[4]
    assert lim.head_pitch_range(yaw) == (pytest.approx(pmin), pytest.approx(pmax))


def test_head_pitch_legal_ahead_is_refused_with_the_head_turned(lim: JointLimits) -> None:
    pose = {"HeadYaw": 1.5, "HeadPitch": 0.45}
    lim.check({"HeadYaw": 0.0, "HeadPitch": 0.45})
    with pytest.raises(LimitViolation, match="HeadPitch .* anti-collision"):
        lim.check(pose)


def test_clip_uses_the_current_head_yaw(lim: JointLimits) -> None:
    out = lim.clip({"HeadPitch": 0.5}, pose={"HeadYaw": 1.5})
    assert out["HeadPitch"] == pytest.approx(lim.head_pitch_range(1.5)[1])


def test_hands_are_opening_fractions(lim: JointLimits) -> None:
    assert (lim.lower["LHand"], lim.upper["LHand"]) == (0.0, 1.0)
    with pytest.raises(LimitViolation, match=r"RHand = 1\.20 \(opening\)"):
        lim.check({"RHand": 1.2})


def test_worst_violation_finds_the_row_furthest_outside(lim: JointLimits) -> None:
    names = ("HeadYaw", "HeadPitch", "LHand")
    ok = [0.0, 0.0, 0.5]
    rows = np.array([ok, [1.5, 0.25, 0.5], [1.5, 0.30, 0.5], ok])  # max HeadPitch ~0.23 at 1.5
    assert lim.worst_violation(names, np.array([ok, ok])) is None
    hit = lim.worst_violation(names, rows)
    assert hit is not None
    i, problems = hit
    assert i == 2 and "HeadPitch" in problems[0] and "anti-collision" in problems[0]


def test_worst_violation_uses_the_yaw_of_the_pose_given(lim: JointLimits) -> None:
    rows = np.array([[0.45]])
    assert lim.worst_violation(("HeadPitch",), rows, pose={"HeadYaw": 0.0}) is None
    assert lim.worst_violation(("HeadPitch",), rows, pose={"HeadYaw": 1.5}) is not None


def test_worst_violation_names_a_nan(lim: JointLimits) -> None:
    with pytest.raises(ValueError, match="LElbowYaw target is nan"):
        lim.worst_violation(("HeadYaw", "LElbowYaw"), np.array([[0.0, math.nan]]))


def test_critical_fractions_are_where_the_yaw_crosses_the_table(lim: JointLimits) -> None:
    assert lim.critical_fractions({"HeadPitch": 0.0}, {"HeadPitch": 0.3}) == (0.0, 1.0)
    s = lim.critical_fractions({"HeadYaw": -1.0}, {"HeadYaw": 1.0})
    crossed = sorted(-1.0 + 2.0 * f for f in s[1:-1])
    expected = sorted(y for row in HEAD_PITCH_TABLE for y in {row[0], -row[0]} if abs(y) < 1.0)
    assert crossed == pytest.approx(expected)


def test_limits_are_cached_by_file_content_and_read_without_yourdfpy(tmp_path: Path) -> None:
    """The second process reads the cache (no yourdfpy import); an edited URDF is read again."""
    import os
    import subprocess
    import sys

    from prezence.resources import urdf_path

    urdf = tmp_path / "nao.urdf"
    urdf.write_bytes(urdf_path().read_bytes())
    code = (
        "import sys; from prezence.feedback.limits import load_limits;"
        f"l = load_limits({str(urdf)!r}); print(l.upper['HeadYaw'], 'yourdfpy' in sys.modules)"
    )
    env = {**os.environ, "PREZENCE_CACHE": str(tmp_path / "cache")}

    def run() -> list[str]:
        out = subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
        )
        return out.stdout.split()

    first, second = run(), run()
    assert first[1] == "True" and second[1] == "False"  # read once, then from the cache
    assert first[0] == second[0]
    text = urdf.read_text()
    assert 'name="HeadYaw"' in text
    edited = text.replace('upper="2.08567"', 'upper="1.5"', 1)
    assert edited != text, "the test's URDF edit did not apply"
    urdf.write_text(edited)
    third = run()
    assert third == ["1.5", "True"]  # new content: read again, new value
