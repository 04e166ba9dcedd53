"""The sim backend performs every gesture within the joint limits, on its planned time."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

pytest.importorskip("pybullet")

from prezence.backends.base import Motion  # noqa: E402
from prezence.backends.registry import make_backend  # noqa: E402
from prezence.errors import LimitViolation  # noqa: E402
from prezence.feedback.gestures import build_trajectory, load_library  # noqa: E402
from prezence.feedback.limits import load_limits  # noqa: E402
from sim.backend import SimBackend  # noqa: E402

LIMITS = load_limits()
FRACTION = 0.6
#: measured/planned duration may differ by this share (arrival within 0.005 rad, 0.01 s steps)
DURATION_TOL = 0.03
#: measured joint speeds may pass the cap by this share
CAP_TOL = 0.02
CASES = [(n, {"minutes": 4} if n == "time_left" else {}) for n in load_library(LIMITS).names]


@pytest.fixture(scope="module")
def performed() -> Iterator[tuple[SimBackend, dict[str, Motion]]]:
    """Every gesture played once, one after another, on one simulated robot."""
    backend = make_backend("sim", speed_fraction=FRACTION)
    assert isinstance(backend, SimBackend)
    motions: dict[str, Motion] = {}
    with backend:
        t = 1.0
        for name, params in CASES:
            traj = build_trajectory(name, params=params, speed_fraction=FRACTION, limits=LIMITS)
            backend.advance(t)
            motions[name] = backend.play(traj, now=t)
            backend.say("Keep going.", now=t)
            while backend.busy:
                t += 0.25
                backend.advance(t)
            t += 5.0
        yield backend, motions


@pytest.mark.parametrize("name", [n for n, _ in CASES])
def test_gesture_runs_within_limits_on_time(
    performed: tuple[SimBackend, dict[str, Motion]], name: str
) -> None:
    m = performed[1][name]
    assert m.done and m.ok
    assert m.info["violations"] == 0
    assert m.info["peak_velocity_ratio"] <= FRACTION * (1 + CAP_TOL)
    assert m.info["measured_s"] == pytest.approx(m.info["planned_s"], rel=DURATION_TOL)
    assert m.info["planned_s"] == m.planned_s
    assert m.finished_at is not None and m.finished_at >= m.started_at + m.planned_s


def test_stats_count_gestures_and_no_violations(
    performed: tuple[SimBackend, dict[str, Motion]],
) -> None:
    stats = performed[0].stats()
    assert stats["gestures"] == len(CASES)
    assert stats["joint_limit_violations"] == 0


def test_a_gesture_planned_faster_than_the_cap_is_refused() -> None:
    fast = build_trajectory("encourage", speed_fraction=0.9, limits=LIMITS)
    with (
        SimBackend(speed_fraction=0.5) as backend,
        pytest.raises(LimitViolation, match="caps gestures at 50"),
    ):
        backend.play(fast, now=0.0)


def test_a_second_gesture_while_busy_is_refused() -> None:
    traj = build_trajectory("summary", speed_fraction=FRACTION, limits=LIMITS)
    with SimBackend() as backend:
        backend.play(traj, now=0.0)
        backend.advance(0.5)
        with pytest.raises(RuntimeError, match="busy"):
            backend.play(traj, now=0.5)


def test_speech_lasts_its_planned_time() -> None:
    with SimBackend() as backend:
        m = backend.say("That's the end of your talk.", now=2.0)
        backend.advance(2.0 + m.planned_s - 0.05)
        assert not m.done
        backend.advance(2.0 + m.planned_s + 0.05)
        assert m.finished_at == pytest.approx(2.0 + m.planned_s)


def test_bad_speed_fraction_is_refused() -> None:
    with pytest.raises(ValueError, match="speed_fraction"):
        SimBackend(speed_fraction=0.0)


def test_close_twice_is_harmless() -> None:
    backend = SimBackend()
    backend.open()
    backend.close()
    backend.close()
    assert backend.stats()["joint_limit_violations"] == 0
