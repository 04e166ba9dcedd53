"""Gestures from the body: the wrist rule on made-up keypoints, then the module on rendered
presenters with known gestures (``material_video/gestures_a.mp4``, tuned on, and
``gestures_b.mp4``, used to diagnose the hands at the face), where the head turns, the
background pans and a hand rests at the face without any of it being a gesture.

The video tests need mediapipe's pose model, which lives in the vision env: they run the module
there as a subprocess and skip, naming the install command, when that env does not exist.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from prezence.modules import vision_env
from prezence.modules.vision import (
    BodyGestureDetector,
    BodyKeypoints,
    HeadPose,
    PresenterBody,
    PresenterFace,
)

MATERIAL = Path(__file__).parent / "material_video"
MANIFEST: dict[str, Any] = json.loads((MATERIAL / "manifest.json").read_text())
MATCH_S = 0.6  # a gesture found within this of a true start is a hit

# --------------------------------------------------------------------------------------------
# The rule on made-up keypoints (pixels; shoulders 100 px apart, nose 90 px above them)


ELBOWS_AT_REST = ((160.0, 270.0), (40.0, 270.0))


def body(
    left: tuple[float, float] = (120.0, 300.0),
    right: tuple[float, float] = (80.0, 300.0),
    nose: tuple[float, float] = (100.0, 110.0),
    shift: float = 0.0,
    elbows: tuple[tuple[float, float], tuple[float, float]] | None = None,
) -> BodyKeypoints:
    """A presenter facing the camera; ``shift`` moves the whole body sideways. Without
    ``elbows`` there are no elbow keypoints (the arm rules do not apply)."""
    s = np.array([shift, 0.0])
    return BodyKeypoints(
        nose=np.array(nose) + s,
        shoulders=(np.array([150.0, 200.0]) + s, np.array([50.0, 200.0]) + s),
        wrists=(np.array(left) + s, np.array(right) + s),
        wrist_visibility=(0.9, 0.9),
        elbows=None if elbows is None else (np.array(elbows[0]) + s, np.array(elbows[1]) + s),
    )


def feed(det: BodyGestureDetector, frames: list[BodyKeypoints | None], fps: float = 8.0) -> None:
    for i, b in enumerate(frames):
        det.update(i / fps, b)


def swing(n: int, hz: float = 2.0, fps: float = 8.0, side: int = 1) -> list[BodyKeypoints]:
    """The left (side 1) or right hand beating out to the side, ``n`` frames."""
    out = []
    for i in range(n):
        dx = 40.0 * math.sin(2 * math.pi * hz * i / fps + 0.5)
        if side == 1:
            out.append(body(left=(190.0 + dx, 250.0)))
        else:
            out.append(body(right=(10.0 - dx, 250.0)))
    return out


def rest(n: int) -> list[BodyKeypoints]:
    return [body() for _ in range(n)]


def test_a_hand_beating_away_from_the_face_is_one_gesture() -> None:
    det = BodyGestureDetector()
    feed(det, rest(16) + swing(12) + rest(16))
    assert det.bursts == [pytest.approx(2.0)]  # the frame the hand leaves its rest


def test_both_hands_together_are_one_gesture_and_two_apart_are_two() -> None:
    det = BodyGestureDetector()
    both = [
        body(left=(190.0 + 40 * math.sin(i), 250.0), right=(10.0 - 40 * math.sin(i), 250.0))
        for i in range(10)
    ]
    feed(det, rest(16) + both + rest(16) + swing(8, side=-1) + rest(16))
    assert len(det.bursts) == 2


def test_head_motion_and_body_sway_are_not_gestures() -> None:
    det = BodyGestureDetector()
    frames = []
    for i in range(80):
        nod = 30.0 * math.sin(2 * math.pi * 1.5 * i / 8)  # the head shakes fast
        sway = 40.0 * math.sin(2 * math.pi * 0.5 * i / 8)  # the whole body sways
        frames.append(body(nose=(100.0 + nod, 110.0), shift=sway))
    feed(det, frames)
    assert det.bursts == []


def test_a_hand_going_to_the_face_scratching_and_back_is_not_a_gesture() -> None:
    det = BodyGestureDetector()
    up = [body(left=(120.0 - 4 * k, 300.0 - 40 * k)) for k in range(5)]  # to (100, 140)
    scratch = [body(left=(100.0 + 8 * math.sin(2 * i), 140.0)) for i in range(24)]
    feed(det, rest(16) + up + scratch + up[::-1] + rest(16))
    assert det.bursts == []


def test_a_hand_under_the_chin_is_at_the_face_though_the_wrist_is_far_from_the_nose() -> None:
    # The wrist hangs a hand's length under the chin: 0.75 shoulder widths below the nose,
    # beyond the old 0.7 radius around it (video b's first false gestures).
    det = BodyGestureDetector()
    up = [body(left=(120.0 - 4 * k, 300.0 - 25 * k)) for k in range(5)]  # to (100, 185)
    scratch = [body(left=(100.0 + 6 * math.sin(2 * i), 185.0)) for i in range(24)]
    feed(det, rest(16) + up + scratch + up[::-1] + rest(16))
    assert det.bursts == []


def test_a_brief_touch_of_the_chin_straight_up_and_back_is_not_a_gesture() -> None:
    det = BodyGestureDetector()
    up = [body(left=(120.0 - 4 * k, 300.0 - 28 * k)) for k in range(5)]  # to (100, 172)
    feed(det, rest(16) + up + up[-1:] + up[::-1] + rest(16))
    assert det.bursts == []


def test_a_beat_beside_the_head_is_still_a_gesture() -> None:
    # The hand beats at face height but 0.75 shoulder widths out to the side: away from it.
    det = BodyGestureDetector()
    beat = [
        body(left=(175.0 + 12 * math.sin(2 * math.pi * 2 * i / 8 + 0.5), 150.0)) for i in range(12)
    ]
    up = [body(left=(120.0 + 11 * k, 300.0 - 30 * k)) for k in range(1, 5)]
    feed(det, rest(16) + up + beat + up[::-1] + rest(16))
    assert len(det.bursts) == 1


def test_a_hand_the_pose_model_loses_is_not_a_gesture() -> None:
    # At the face the model may lose the hand: its wrist drops onto the chest and jumps about,
    # and its visibility falls to half its usual level.
    det = BodyGestureDetector()
    lost = []
    for i in range(24):
        b = body(left=(110.0 + 25 * math.sin(1.7 * i), 260.0 + 30 * math.cos(2.3 * i)))
        lost.append(BodyKeypoints(b.nose, b.shoulders, b.wrists, wrist_visibility=(0.35, 0.9)))
    feed(det, rest(16 * 8) + lost + rest(16))
    assert det.bursts == []


def jumping_wrist(elbows: bool) -> list[BodyKeypoints]:
    """The left wrist jumps about on the chest at its usual visibility; the elbow rests."""
    e = ELBOWS_AT_REST if elbows else None
    jumps = [
        body(left=(110.0 + 25 * math.sin(1.7 * i), 260.0 + 30 * math.cos(2.3 * i)), elbows=e)
        for i in range(24)
    ]
    return [body(elbows=e) for _ in range(16)] + jumps + [body(elbows=e) for _ in range(16)]


def test_a_wrist_that_jumps_while_its_elbow_stays_where_it_rests_is_not_a_gesture() -> None:
    # The pose model losing the hand at the face, or during a head turn, with a visibility as
    # usual (videos c and d): the elbow, a bigger joint, stays where it rests.
    det = BodyGestureDetector()
    feed(det, jumping_wrist(elbows=True))
    assert det.bursts == []
    det = BodyGestureDetector()  # the same wrist without elbow keypoints: the old rule counts it
    feed(det, jumping_wrist(elbows=False))
    assert len(det.bursts) == 1


def chin_beat(elbows: bool) -> list[BodyKeypoints]:
    """A left-hand beat out to the side, the elbow out with it; the model draws the wrist at
    the chin in two frames of each cycle (as on video c)."""
    out = [body(elbows=ELBOWS_AT_REST if elbows else None) for _ in range(16)]
    for i in range(16):
        dx = 40.0 * math.sin(2 * math.pi * 2.0 * i / 8 + 0.5)
        wrist = (100.0, 170.0) if i % 6 in (3, 4) else (190.0 + dx, 250.0)
        e = ((220.0 + dx / 4, 220.0), ELBOWS_AT_REST[1]) if elbows else None
        out.append(body(left=wrist, elbows=e))
    return out + [body(elbows=ELBOWS_AT_REST if elbows else None) for _ in range(16)]


def test_a_beat_the_model_draws_at_the_chin_is_a_gesture_when_the_elbow_is_out() -> None:
    det = BodyGestureDetector()
    feed(det, chin_beat(elbows=True))
    assert len(det.bursts) == 1
    det = BodyGestureDetector()  # without elbows the face zone swallows it, as before
    feed(det, chin_beat(elbows=False))
    assert det.bursts == []


def test_a_hand_brought_to_the_chin_with_the_elbow_barely_moving_is_not_a_gesture() -> None:
    det = BodyGestureDetector()
    e0 = ELBOWS_AT_REST
    up = [
        body(left=(120.0 - 4 * k, 300.0 - 32 * k), elbows=((160.0 - 2 * k, 270.0 - 5 * k), e0[1]))
        for k in range(5)
    ]  # to (100, 172), the elbow up by 0.2 shoulder widths
    scratch = [
        body(left=(100.0 + 8 * math.sin(2 * i), 172.0), elbows=((152.0, 250.0), e0[1]))
        for i in range(24)
    ]
    rest_e = [body(elbows=e0) for _ in range(16)]
    feed(det, rest_e + up + scratch + up[::-1] + rest_e)
    assert det.bursts == []


def test_a_single_glitch_of_the_keypoints_is_not_a_gesture() -> None:
    det = BodyGestureDetector()
    glitch = body(left=(300.0, 100.0))
    feed(det, rest(16) + [glitch] + rest(16))
    assert det.bursts == []


def test_no_body_in_view_is_not_measured_rather_than_zero_gestures() -> None:
    det = BodyGestureDetector(window_s=30.0, min_window_s=10.0)
    frames: list[BodyKeypoints | None] = [*rest(8 * 12), *([None] * (8 * 20))]
    rates = {}
    for i, b in enumerate(frames):
        det.update(i / 8, b)
        rates[i / 8] = det.rate(i / 8)
    assert rates[11.0] == 0.0  # in view: truly no gesture
    assert rates[20.0] == 0.0  # 12 s of the 20 seen had the body: still measured
    assert rates[31.875] is None  # 20 s of the last 30 without a body


def seen_as(b: BodyKeypoints, **kw: Any) -> BodyKeypoints:
    """``b`` with some fields replaced (the image about the arms, the wrists' visibility)."""
    fields = {k: getattr(b, k) for k in BodyKeypoints.__dataclass_fields__}
    return BodyKeypoints(**{**fields, **kw})


def rates_of(det: BodyGestureDetector, frames: list[BodyKeypoints | None]) -> dict[float, Any]:
    out = {}
    for i, b in enumerate(frames):
        det.update(i / 8, b)
        out[i / 8] = det.rate(i / 8)
    return out


def test_a_presenter_standing_still_in_a_well_lit_image_is_measured_as_no_gestures() -> None:
    lit = [seen_as(b, clipped=0.01, spread=40.0) for b in rest(8 * 32)]
    rates = rates_of(BodyGestureDetector(window_s=30.0, min_window_s=10.0), list(lit))
    assert rates[10.0] == 0.0 and rates[31.875] == 0.0


def test_arms_too_dark_to_see_are_not_measured_rather_than_zero_gestures() -> None:
    # Session 18: on a dark video (brightness -0.35, contrast 0.5) the pose model kept its
    # wrists' visibility at 0.6-0.9 but lost 2 of 7 gestures, and 0/min was written as a
    # measurement. The image about the arms was 40-70 % black: not measured, and why.
    det = BodyGestureDetector(window_s=30.0, min_window_s=10.0)
    dark = [seen_as(b, clipped=0.6, spread=13.0) for b in rest(8 * 12)]
    flat = [seen_as(b, clipped=0.0, spread=7.0) for b in rest(8 * 12)]
    rates = rates_of(det, [*dark, *flat])
    assert all(r is None for r in rates.values())
    assert "cannot be told from the background" in det.why_not_seen()


def test_a_body_whose_wrists_the_pose_model_does_not_see_is_not_measured() -> None:
    det = BodyGestureDetector(window_s=30.0, min_window_s=10.0)
    unseen = [seen_as(b, wrist_visibility=(0.3, 0.2)) for b in rest(8 * 12)]
    one_hand = [seen_as(b, wrist_visibility=(0.1, 0.8)) for b in rest(8 * 12)]
    rates = rates_of(det, [*unseen, *one_hand])
    assert rates[11.0] is None and "does not see the presenter's hands" in det.why_not_seen()
    assert rates[23.875] == 0.0  # one hand seen well (the other in a pocket): measured


def test_an_arm_the_pose_model_does_not_see_makes_no_gestures_and_is_not_measured() -> None:
    # Session 19: an overlay hid the presenter's left arm on two_faces.mp4; the pose model drew
    # it at wrist visibility 0.1-0.36, elbow 0.2-0.44, swinging it about, and 2 false gestures
    # were counted (the rule wanted both wrists unseen). Here the right arm is hidden and
    # "swings" (the model's guess) while the left hand beats out twice, seen well.
    def hidden(b: BodyKeypoints) -> BodyKeypoints:
        return seen_as(b, wrist_visibility=(0.9, 0.2), elbow_visibility=(0.9, 0.3))

    guessed = [hidden(b) for b in [*swing(12, side=-1), *rest(8), *swing(12, side=-1)]]
    det = BodyGestureDetector(window_s=30.0, min_window_s=10.0)
    frames = [*rest(16), *guessed, *rest(16), *swing(12), *rest(16), *swing(12), *rest(40)]
    rates_of(det, frames)
    t_left = [i / 8 for i in (16 + len(guessed) + 16, 16 + len(guessed) + 16 + 12 + 16)]
    assert len(det.bursts) == 2, det.bursts  # the seen hand's two beats, not the guesses
    assert all(any(abs(b - t) <= 0.5 for b in det.bursts) for t in t_left), det.bursts
    # ... and the rate, which cannot count the hidden arm, is not written while it is hidden
    hid = [seen_as(b, wrist_visibility=(0.9, 0.2), elbow_visibility=(0.9, 0.3)) for b in rest(96)]
    det = BodyGestureDetector(window_s=30.0, min_window_s=10.0)
    rates = rates_of(det, hid)
    assert rates[11.0] is None and "does not see one of the presenter's arms" in det.why_not_seen()
    # A hand in a pocket: the wrist not seen, its elbow is: still measured.
    pocket = [
        seen_as(b, wrist_visibility=(0.9, 0.1), elbow_visibility=(0.9, 0.9)) for b in rest(96)
    ]
    rates = rates_of(BodyGestureDetector(window_s=30.0, min_window_s=10.0), pocket)
    assert rates[11.0] == 0.0


def test_a_body_that_jumps_to_another_place_and_size_is_not_the_presenters() -> None:
    # Session 18: the pose model left the presenter for an audience head, and the few wrist
    # movements it drew there were written as the presenter's rate (2.0/min, true 8.9).
    who = PresenterBody()
    det = BodyGestureDetector(window_s=30.0, min_window_s=10.0)
    other = [body(shift=160.0) for _ in range(8 * 20)]  # 1.6 shoulder widths to the side
    frames: list[BodyKeypoints | None] = [*rest(8 * 12), *other]
    rates = {}
    for i, b in enumerate(frames):
        t = i / 8
        assert b is not None
        det.update(t, b, presenter=who.check(t, b, None))
        rates[t] = det.rate(t)
    assert rates[11.0] == 0.0 and rates[31.875] is None
    assert "another person" in det.why_not_seen()
    # With the presenter's face known, a body under another face is someone else's.
    assert PresenterBody().check(0.0, body(), (80, 80, 120, 140))
    assert not PresenterBody().check(0.0, body(), (200, 150, 260, 220))


def face(x0: int, y0: int, size: int, yaw: float = 0.0) -> HeadPose:
    return HeadPose(yaw, 0.0, (x0, y0, x0 + size, y0 + size))


def test_head_pose_follows_the_presenters_face_not_a_bigger_one_in_the_audience() -> None:
    # Session 18: FaceMesh (one face) tracked an audience head in the lower right, bigger than
    # the presenter's; its turns were written as the presenter's (facing 0.70 for 0.90).
    pf = PresenterFace()
    presenter, audience = face(135, 50, 50), face(210, 140, 62, yaw=30.0)
    assert pf.choose(0.0, [audience, presenter], frame_height=240) is presenter  # room below
    moved = face(140, 52, 50)
    assert pf.choose(0.125, [audience, moved], frame_height=240) is moved
    assert pf.choose(0.25, [audience], frame_height=240) is None  # not someone else's
    # the body under a face tells them apart at the start
    pf = PresenterFace()
    nose = np.array([240.0, 170.0])
    assert pf.choose(0.0, [presenter, audience], frame_height=400, nose=nose) is audience


# --------------------------------------------------------------------------------------------
# The module on rendered presenters (vision env)

VISION_PY = vision_env.find_python()
needs_vision_env = pytest.mark.skipif(
    VISION_PY is None,
    reason=f"no vision env (mediapipe 0.10.21); create it with: {vision_env.INSTALL_HINT}",
)
VIDEOS = ("gestures_a", "gestures_b")
#: c and d were held out until issue 11's arm rule; they became development material then.
RATE_VIDEOS = (*VIDEOS, "gestures_c", "gestures_d")


def read_stream(path: Path) -> list[tuple[float, float]]:
    return [(float(t), float(v)) for t, v in (ln.split() for ln in path.read_text().splitlines())]


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, Any]]:
    assert VISION_PY is not None
    out: dict[str, dict[str, Any]] = {}
    for key in RATE_VIDEOS:
        entry = MANIFEST[key]
        stderr, s = run_module(
            MATERIAL / entry["file"],
            "--gesture-window",
            str(entry["duration_s"]),
            out=tmp_path_factory.mktemp(key),
        )
        out[key] = {
            "entry": entry,
            "stderr": stderr,
            "found": [float(x) for x in re.findall(r"gesture at ([0-9.]+) s", stderr)],
            "rate": s["cv_gestures"],
            "source": s["cv_gestures_source"],
        }
    return out


@needs_vision_env
@pytest.mark.slow
@pytest.mark.parametrize("key", VIDEOS)
def test_the_stream_and_log_say_the_rate_comes_from_the_body(
    runs: dict[str, dict[str, Any]], key: str
) -> None:
    r = runs[key]
    assert {v for _, v in r["source"]} == {1.0}
    assert [t for t, _ in r["source"]] == [t for t, _ in r["rate"]]
    assert "gesture rate from the body" in r["stderr"]


@needs_vision_env
@pytest.mark.slow
@pytest.mark.parametrize("key", VIDEOS)
def test_every_true_gesture_is_found(runs: dict[str, dict[str, Any]], key: str) -> None:
    r = runs[key]
    truth = [g["start"] for g in r["entry"]["gestures"]]
    missed = [t for t in truth if all(abs(f - t) > MATCH_S for f in r["found"])]
    assert len(missed) <= 1, (missed, r["found"])


def false_gestures(r: dict[str, Any], *, outside_face: bool) -> list[float]:
    """Gestures found away from every true one (and, if asked, from every hand at the face)."""
    truth = [(g["start"], g["end"]) for g in r["entry"]["gestures"]]
    if outside_face:
        truth += [(h["start"], h["end"] + MATCH_S) for h in r["entry"]["hands_at_face"]]
    return [f for f in r["found"] if all(not (s - MATCH_S <= f <= e) for s, e in truth)]


@needs_vision_env
@pytest.mark.slow
@pytest.mark.parametrize("key", VIDEOS)
def test_head_turns_and_a_panning_background_are_not_gestures(
    runs: dict[str, dict[str, Any]], key: str
) -> None:
    false = false_gestures(runs[key], outside_face=True)
    assert len(false) <= 1, (false, runs[key]["found"])


# b's hands at the face (6 false gestures before) were used to find what failed, so b checks
# the fix but is no longer held out; c and d (the pose model errs more there) were looked at to
# find the arm rule, so only their rate is asserted here; the held-out presenters made after
# that live outside the repository (see the README).


@needs_vision_env
@pytest.mark.slow
@pytest.mark.parametrize("key", VIDEOS)
def test_hands_at_the_face_are_not_gestures(runs: dict[str, dict[str, Any]], key: str) -> None:
    false = false_gestures(runs[key], outside_face=False)
    assert len(false) <= 1, (false, runs[key]["found"])


@needs_vision_env
@pytest.mark.slow
@pytest.mark.parametrize("key", RATE_VIDEOS)
def test_the_gesture_rate_over_the_whole_video_is_within_one_gesture(
    runs: dict[str, dict[str, Any]], key: str
) -> None:
    r = runs[key]
    entry = r["entry"]
    t_end, rate = r["rate"][-1]
    n_true = sum(1 for g in entry["gestures"] if g["start"] <= t_end)
    one = 60.0 / min(entry["duration_s"], t_end)  # one gesture in the video seen, per minute
    assert rate == pytest.approx(n_true * one, abs=one + 0.01)  # the stream has 3 decimals


def run_module(
    video: Path, *args: str, out: Path
) -> tuple[str, dict[str, list[tuple[float, float]]]]:
    """Run the vision module (verbose) on ``video`` into the session folder ``out``; its log
    and its gesture and head streams."""
    assert VISION_PY is not None
    env = dict(os.environ)
    env.pop("PREZENCE_VISION_REEXEC", None)
    proc = subprocess.run(
        [str(VISION_PY), "-m", "prezence.modules.vision", "-v", "--video", str(video)]
        + ["--out", str(out), *args],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
        env=env,
    )
    assert proc.returncode == 0, proc.stderr
    names = ("cv_gestures", "cv_gestures_source", "cv_headYaw", "cv_facingAudience")
    return proc.stderr, {n: read_stream(out / "streams" / f"{n}.txt") for n in names}


def no_rate_off_the_truth(rates: list[tuple[float, float]], truth: list[float]) -> list[Any]:
    """Rates more than one gesture off the true count of their window (a gesture counts from
    when it starts; it may be judged up to 2 s later): ``(t, rate, least, most)``, ``rate`` as
    the count read."""
    bad = []
    for t, rate in rates:
        seen = min(30.0, t)
        got = rate * seen / 60.0
        least = sum(1 for s in truth if t - 30.0 < s <= t - 2.0)
        most = sum(1 for s in truth if t - 30.0 < s <= t)
        if not least - 1.01 <= got <= most + 1.01:  # the stream has 3 decimals
            bad.append((t, got, least, most))
    return bad


@needs_vision_env
@pytest.mark.slow
def test_a_second_face_in_view_is_not_measured_as_the_presenter(tmp_path: Path) -> None:
    # two_faces.mp4: gestures_a's first 30 s with head_astronaut (turning, looped) in the lower
    # right, bigger than the presenter's face (session 18; session 17 saw facing 0.70):
    #   ffmpeg -i gestures_a.mp4 -stream_loop -1 -i head_astronaut.mp4 -filter_complex \
    #     "[1:v]scale=160:120[a];[0:v][a]overlay=160:120:shortest=1" -t 30 \
    #     -c:v libx264 -crf 28 -pix_fmt yuv420p -an two_faces.mp4
    entry = MANIFEST["gestures_a"]
    stderr, s = run_module(MATERIAL / "two_faces.mp4", out=tmp_path)
    assert "2 faces in view at 0.0 s" in stderr
    moves = [(m["start"] - 0.5, m["end"] + 0.5) for m in entry["head_moves"]]
    still = [y for t, y in s["cv_headYaw"] if not any(a <= t <= b for a, b in moves)]
    assert len(still) > 100
    turned = [y for y in still if abs(y) > 10.0]
    assert len(turned) <= 0.02 * len(still), turned
    facing = sorted(v for _, v in s["cv_facingAudience"])
    assert facing[len(facing) // 2] >= 0.85
    # the gesture rate: the presenter's (session 18, old: the body under the audience head,
    # 0/min written with 4 true gestures), or not measured. Session 19: the presenter's left
    # arm is under the overlay; the pose model guessed it (2 false gestures, 22-24 s read 2
    # over, the final rate right by luck). An arm not seen makes no gestures, and a rate that
    # cannot count it is not written: "not measured", and the log says which part is unseen.
    assert s["cv_gestures"] == []
    assert s["cv_gestures_source"] and {v for _, v in s["cv_gestures_source"]} == {0.0}
    assert "does not see one of the presenter's arms" in stderr


@needs_vision_env
@pytest.mark.slow
def test_an_arm_hidden_for_part_of_the_window_flags_the_rate_as_maybe_low(tmp_path: Path) -> None:
    # Session 20: an arm hidden in fewer than half a window's frames left the rate counting the
    # other hand there, and cv_gestures_source said 1 as for a window seen whole (on copies of
    # gestures_a/b with one arm hidden for 9 s, up to 4 gestures a minute low). Counting over
    # the seen part only was tried and read worse (see BodyGestureDetector.uncounted); now the
    # rate is written as counted and flagged: cv_gestures_source 3, and the log says so.
    # arm_hidden_part.mp4 = gestures_a.mp4's first 16 s, its image-right arm under a grey box
    # from 9 to 13 s:
    #   ffmpeg -i gestures_a.mp4 -t 16 -vf "drawbox=x=165:y=110:w=155:h=130:color=gray:\
    #     t=fill:enable='between(t,9,13)'" -c:v libx264 -crf 30 -pix_fmt yuv420p -an \
    #     arm_hidden_part.mp4
    stderr, s = run_module(
        MATERIAL / "arm_hidden_part.mp4", "--no-head", "--gesture-window", "12", out=tmp_path
    )
    source = dict(s["cv_gestures_source"])
    assert (
        [t for t, _ in s["cv_gestures"]] == sorted(source) == [10.0, 11.0, 12.0, 13.0, 14.0, 15.0]
    )
    assert all(source[t] == 3.0 for t in (12.0, 13.0, 14.0, 15.0)), source
    assert "may be low (cv_gestures_source 3)" in stderr
    assert stderr.count("may be low") == 1  # once for the stretch
    # the rendered presenters seen whole are not: test_the_stream_and_log_say_the_rate_comes...


@needs_vision_env
@pytest.mark.slow
def test_a_video_too_dark_to_see_the_arms_gives_no_gesture_rate_and_says_why(
    tmp_path: Path,
) -> None:
    # dark_a.mp4: gestures_a's first 20 s darkened as session 17's dark video (5 of 7 found,
    # 0/min written as a measurement at 10-13 s):
    #   ffmpeg -i gestures_a.mp4 -t 20 -vf "eq=brightness=-0.35:contrast=0.5" \
    #     -c:v libx264 -crf 28 -pix_fmt yuv420p -an dark_a.mp4
    stderr, s = run_module(MATERIAL / "dark_a.mp4", "--no-head", out=tmp_path)
    assert s["cv_gestures"] == []
    assert s["cv_gestures_source"] and {v for _, v in s["cv_gestures_source"]} == {0.0}
    assert "cannot be told from the background" in stderr
    assert stderr.count("gesture rate not measured from") == 1  # once for the stretch
