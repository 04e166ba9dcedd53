"""How a cue or the post-talk summary is told when the robot was lost, or only its gesture
failed (session 22: 'robot did NOT say its summary' for a phrase the robot said in full)."""

from __future__ import annotations

from prezence.cli import post_talk_line, robot_shortfall
from prezence.summary import cut_short, outcome_unknown

LOST = {
    "ok": False,
    "dropped": False,
    "gesture_ok": False,
    "gesture_error": "robot lost: no heartbeat answer within 2 s",
    "gesture_outcome": "unknown",
    "speech_ok": False,
    "speech_error": "robot lost: no heartbeat answer within 2 s",
    "speech_outcome": "unknown",
}
GESTURE_TIMEOUT = {
    "ok": False,
    "dropped": False,
    "gesture_ok": False,
    "gesture_error": "no end within 3.7 s",
    "speech_ok": True,
}


def test_a_cue_running_when_the_robot_was_lost_is_of_unknown_outcome_not_cut_short() -> None:
    assert cut_short(LOST) is None
    assert outcome_unknown(LOST) == (
        "robot lost during the cue (robot lost: no heartbeat answer within 2 s)"
    )


def test_a_gesture_timeout_does_not_say_the_phrase_was_not_said() -> None:
    assert cut_short(GESTURE_TIMEOUT) == "no end within 3.7 s (the phrase was said)"
    assert outcome_unknown(GESTURE_TIMEOUT) is None


def test_the_post_talk_summary_said_with_its_gesture_killed_is_shown_as_said() -> None:
    post = {"phrase": "You used 40 seconds.", **GESTURE_TIMEOUT}
    line = post_talk_line(post)
    assert line.startswith('robot: "You used 40 seconds."') and "NOT" not in line
    assert "its gesture was cut short: no end within 3.7 s" in line
    shortfall = robot_shortfall({"counts": {}, "post_talk": post})
    assert shortfall is not None and "not said" not in shortfall
    assert "the post-talk summary's gesture cut short" in shortfall


def test_the_post_talk_summary_when_the_robot_was_lost_is_of_unknown_outcome() -> None:
    post = {"phrase": "You used 40 seconds.", **LOST}
    line = post_talk_line(post)
    assert "outcome unknown" in line and "NOT" not in line
    shortfall = robot_shortfall({"counts": {}, "post_talk": post})
    assert shortfall is not None and "unknown outcome" in shortfall
