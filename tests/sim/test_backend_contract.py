"""The backend contract (prezence.backends.check) on every backend: fake, the PyBullet NAO,
and NAOqi against the virtual NAO over loopback. The clock follows the backend's declared
``realtime``: simulated time for those that move only when told, the wall clock for NAOqi."""

from __future__ import annotations

import importlib.util
from collections.abc import Iterator

import pytest

from prezence.backends.base import Backend
from prezence.backends.check import CHECK_TRAJECTORY, check_backend
from prezence.backends.registry import make_backend
from prezence.clock import ManualClock, MonotonicClock

HAVE_PYBULLET = importlib.util.find_spec("pybullet") is not None
HAVE_QI = importlib.util.find_spec("qi") is not None


@pytest.fixture
def naoqi_url() -> Iterator[str]:
    from sim.virtual_nao import spawn, stop_spawned

    proc, url = spawn("--port", "0", "--model", "kinematic")
    try:
        yield url
    finally:
        stop_spawned(proc)


def _backend(name: str, request: pytest.FixtureRequest) -> Backend:
    if name == "naoqi":
        return make_backend("naoqi", url=request.getfixturevalue("naoqi_url"))
    return make_backend(name)


@pytest.mark.parametrize(
    "name",
    [
        "fake",
        pytest.param(
            "sim",
            marks=pytest.mark.skipif(not HAVE_PYBULLET, reason="the sim extra is not installed"),
        ),
        pytest.param(
            "naoqi",
            marks=pytest.mark.skipif(
                not (HAVE_QI and HAVE_PYBULLET), reason="qi or the virtual NAO is not installed"
            ),
        ),
    ],
)
def test_every_backend_keeps_the_contract(name: str, request: pytest.FixtureRequest) -> None:
    backend = _backend(name, request)
    clock = MonotonicClock() if backend.realtime else ManualClock()
    times = check_backend(backend, clock=clock)
    assert times["gesture_s"] > 0 and times["speech_s"] > 0
    if not backend.realtime:  # on simulated time the gesture takes its planned time
        assert times["gesture_s"] == pytest.approx(CHECK_TRAJECTORY.duration, abs=0.25)
