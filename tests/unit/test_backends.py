"""Backend interface: the contract on the fake backend, the registry's names and errors."""

from __future__ import annotations

import logging

import pytest

from prezence.backends.check import CHECK_TRAJECTORY, check_backend
from prezence.backends.fake import FakeBackend
from prezence.backends.registry import make_backend
from prezence.errors import UnknownName


def test_fake_backend_passes_the_contract() -> None:
    times = check_backend(FakeBackend())
    assert times["gesture_s"] == pytest.approx(CHECK_TRAJECTORY.duration, abs=0.021)


def test_fake_backend_slower_robot_takes_longer() -> None:
    times = check_backend(FakeBackend(time_scale=2.0))
    assert times["gesture_s"] == pytest.approx(2 * CHECK_TRAJECTORY.duration, abs=0.021)


def test_unknown_backend_suggests_a_name() -> None:
    with pytest.raises(UnknownName, match="did you mean 'fake'"):
        make_backend("fak")


def test_play_before_open_is_an_error() -> None:
    with pytest.raises(RuntimeError, match="not open"):
        FakeBackend().play(CHECK_TRAJECTORY, now=0.0)


def test_backend_records_match_their_classes() -> None:
    """The registry's records say what the classes say (real time, physical body, name)."""
    import importlib

    from prezence.backends.registry import BACKENDS

    checked = 0
    for name, rec in BACKENDS.items():
        module, _, attr = rec.entry_point.partition(":")
        try:
            cls = getattr(importlib.import_module(module), attr)
        except ModuleNotFoundError:
            continue  # its extra is not installed here
        assert (cls.name, cls.realtime, cls.physical) == (name, rec.realtime, rec.physical)
        checked += 1
    assert checked >= 2  # fake and NAOqi import with no extra


class _DoneFuture:
    """A finished qi future that failed with ``error`` (what a dropped session gives)."""

    def __init__(self, error: str) -> None:
        self._error = error

    def isFinished(self) -> bool:  # noqa: N802 - qi's spelling
        return True

    def isCanceled(self) -> bool:  # noqa: N802
        return False

    def hasError(self) -> bool:  # noqa: N802
        return True

    def error(self) -> str:
        return self._error

    def cancel(self) -> None:
        pass


class _Session:
    def close(self, _async: bool = False) -> _DoneFuture:
        return _DoneFuture("")


def test_naoqi_link_lost_while_two_motions_run_fails_both_once() -> None:
    """The gesture's and the phrase's futures both end with "Session closed" before the link's
    own lost flag is seen (CI hit this order): the first failure drops the link and fails the
    other motion; polling must not handle that motion a second time."""
    import threading

    from prezence.backends.base import Motion, MotionKind
    from prezence.backends.naoqi import NaoqiBackend, _Call, _Link

    backend = NaoqiBackend(url="tcp://127.0.0.1:9", reconnect_initial_s=60.0, reconnect_max_s=60.0)
    link = _Link(
        session=_Session(),
        motion=None,
        tts=None,
        leds=None,
        joints=(),
        velocity={},
        lost=threading.Event(),
        reason=[],
    )
    backend._link = link
    backend._opened = True
    backend._next_ping = float("inf")  # keep the heartbeat out of the way
    gesture = Motion(kind=MotionKind.GESTURE, name="slow", started_at=0.0, planned_s=1.0)
    phrase = Motion(kind=MotionKind.SPEECH, name="Slow down.", started_at=0.0, planned_s=1.0)
    for m in (gesture, phrase):
        backend._calls.append(_Call(m, _DoneFuture("Session closed"), 0.0, 1e12, (), [0.1]))
    backend._advance(0.2)
    assert not backend._calls
    assert gesture.done and not gesture.ok
    assert phrase.done and not phrase.ok and "robot lost" in phrase.info["error"]
    stats = backend.stats()
    assert stats["failed"] == 2 and stats["disconnects"] == 1


def test_a_fast_move_to_neutral_on_a_real_robot_is_warned_of_as_a_fast_speed_is(
    caplog: pytest.LogCaptureFixture,
) -> None:
    # Session 23's gesture designer: --robot-option neutral_speed_fraction=1.0 was taken without
    # the over-0.7 warning --speed gets (the URDF's velocities are no-load values).
    from prezence.backends.naoqi import NaoqiBackend

    with caplog.at_level(logging.WARNING, logger="prezence.backends.naoqi"):
        NaoqiBackend(url="tcp://127.0.0.1:9", neutral_speed_fraction=0.5)
        assert not caplog.records
        NaoqiBackend(url="tcp://127.0.0.1:9", neutral_speed_fraction=1.0)
    assert "use 0.7 or less on a real robot" in caplog.records[0].getMessage()
