"""Backend interface: the contract on the fake backend, the registry's names and errors."""

from __future__ import annotations

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
    """The registry's records say what the classes say (real time, name)."""
    import importlib

    from prezence.backends.registry import BACKENDS

    checked = 0
    for name, rec in BACKENDS.items():
        module, _, attr = rec.entry_point.partition(":")
        try:
            cls = getattr(importlib.import_module(module), attr)
        except ModuleNotFoundError:
            continue  # its extra is not installed here
        assert (cls.name, cls.realtime) == (name, rec.realtime)
        checked += 1
    assert checked >= 2  # fake and NAOqi import with no extra
