"""The ``sim`` backend: gestures performed by the PyBullet NAO, speech timed by its plan.

The run's clock drives the physics: :meth:`SimBackend.advance` steps the robot to ``now``
(nothing free-runs). A gesture's motion ends when the robot has tracked its trajectory to the
end and come to rest; :attr:`Motion.info` then holds what the simulated robot did:

* ``planned_s``: the trajectory's duration;
* ``measured_s``: from the start to the moment every joint stayed within 0.005 rad of the final
  pose;
* ``peak_velocity_ratio``: the highest measured joint speed / that joint's URDF velocity limit;
* ``violations``: samples beyond a position limit (+0.005 rad) or a velocity limit (+2 %).

Speech has no audio here: it lasts its planned duration.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from prezence.backends.base import Backend, Motion, MotionKind
from prezence.errors import BackendUnavailable, LimitViolation
from prezence.feedback.limits import CHAINS
from prezence.feedback.trajectory import Trajectory

log = logging.getLogger(__name__)

#: Physics step of talks. 1/100 s tracks the gestures' planned timing within 1.7 % and their
#: velocity caps within 0.1 % (bench/bench_gestures.py), at less than half the cost of 1/240 s.
SIM_TIMESTEP = 0.01
#: Joints the sim backend holds rigid at 0 rad (the legs straight, as the fixed base stands):
#: no coach gesture moves them, and on a fixed base they only hang, so simulating them is 60 %
#: of each physics step (0.21 -> 0.08 ms) for nothing. A trajectory that drives one is refused
#: with a ValueError naming it; ``SimBackend(frozen=())`` simulates every joint.
LEGS: tuple[str, ...] = CHAINS["LLeg"] + CHAINS["RLeg"]


class SimBackend(Backend):
    """A simulated NAO (PyBullet), headless unless ``gui``.

    Args:
        gui: open a PyBullet window (one per process).
        speed_fraction: velocity cap for gestures, as a fraction of the URDF limits; None caps
            each gesture at the fraction it was planned at. A trajectory planned faster than the
            cap is refused with :class:`~prezence.errors.LimitViolation`.
        urdf: the robot model; None uses the project's NAO.
        timestep: physics step in seconds.
        frozen: joints held rigid at 0 rad (default :data:`LEGS`); ``()`` simulates them all.
    """

    name = "sim"

    def __init__(
        self,
        *,
        gui: bool = False,
        speed_fraction: float | None = None,
        urdf: Path | None = None,
        timestep: float = SIM_TIMESTEP,
        frozen: Iterable[str] = LEGS,
    ) -> None:
        super().__init__()
        if speed_fraction is not None and not 0.0 < float(speed_fraction) <= 1.0:
            raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")
        if not timestep > 0:
            raise ValueError(f"timestep must be > 0, got {timestep!r}")
        self.gui = gui
        self.speed_fraction = float(speed_fraction) if speed_fraction is not None else None
        self.urdf = Path(urdf) if urdf is not None else None
        self.timestep = float(timestep)
        self.frozen = tuple(frozen)
        self._sim: Any = None
        self._gesture: Motion | None = None
        self._gestures = 0

    # -- lifecycle ----------------------------------------------------------------------------
    def _open(self) -> None:
        try:
            from sim.nao import NaoSim
        except ModuleNotFoundError as e:
            raise BackendUnavailable(
                f'the sim backend needs {e.name}: pip install "prezence[sim]"'
            ) from e
        if self.urdf is not None and not self.urdf.is_file():
            raise BackendUnavailable(f"robot model not found: {self.urdf}")
        sim = NaoSim(
            urdf=self.urdf,
            gui=self.gui,
            timestep=self.timestep,
            frozen=dict.fromkeys(self.frozen, 0.0),
        )
        sim.open()
        self._sim = sim

    def _close(self) -> None:
        if self._sim is not None:
            self._sim.close()
            self._sim = None

    @property
    def sim(self) -> Any:
        """The :class:`sim.nao.NaoSim` (after open())."""
        if self._sim is None:
            raise RuntimeError("sim backend is not open")
        return self._sim

    # -- hooks --------------------------------------------------------------------------------
    def _cap_for(self, traj: Trajectory) -> float:
        limits = self.sim.limits
        limits.require_known(traj.joints)
        for k, pose in enumerate(traj.positions):
            limits.check(
                dict(zip(traj.joints, pose, strict=True)),
                where=f"trajectory '{traj.name}' keyframe {k}",
            )
        peaks = traj.peak_velocities()
        planned = max(
            (float(v) / limits.velocity[j] for j, v in zip(traj.joints, peaks, strict=True)),
            default=0.0,
        )
        cap = self.speed_fraction if self.speed_fraction is not None else min(1.0, planned)
        if planned > cap * (1.0 + 1e-6):
            worst = max(
                zip(traj.joints, peaks, strict=True), key=lambda jv: jv[1] / limits.velocity[jv[0]]
            )[0]
            raise LimitViolation(
                f"trajectory '{traj.name}' needs {planned:.1%} of {worst}'s velocity limit; "
                f"this backend caps gestures at {cap:.1%}"
            )
        return cap if cap > 0.0 else 1.0

    def _start_gesture(self, traj: Trajectory, motion: Motion) -> None:
        if self._gesture is not None and not self._gesture.done:
            raise RuntimeError(f"{self.name} backend is busy with gesture '{self._gesture.name}'")
        cap = self._cap_for(traj)
        sim = self.sim
        if sim.time < motion.started_at:
            sim.step_to(motion.started_at)
        sim.follow(traj, start=motion.started_at, speed_fraction=cap)
        self._gesture = motion
        self._gestures += 1

    def _start_speech(self, text: str, motion: Motion) -> None:
        log.debug("say (%.2f s): %s", motion.planned_s, text)

    def _advance(self, now: float) -> None:
        sim = self.sim
        if now > sim.time:
            sim.step_to(now)
        for m in self._running:
            if m.done:
                continue
            if m.kind is MotionKind.SPEECH:
                end = m.started_at + m.planned_s
                if now >= end:
                    m.finish(end, measured_s=m.planned_s)
            elif m is self._gesture:
                tr = sim.tracking
                if tr is not None and tr.done:
                    limits = sim.limits
                    ratio = max(
                        (
                            float(v) / limits.velocity[j]
                            for j, v in zip(tr.traj.joints, tr.peak_speed, strict=True)
                        ),
                        default=0.0,
                    )
                    m.finish(
                        tr.finished_at,
                        ok=tr.ok,
                        measured_s=tr.measured_s,
                        planned_s=tr.traj.duration,
                        peak_velocity_ratio=ratio,
                        violations=tr.violations,
                    )

    def stats(self) -> dict[str, Any]:
        """``joint_limit_violations`` (samples beyond a limit, whole run), ``gestures`` played,
        and the physics figures."""
        out: dict[str, Any] = {"joint_limit_violations": 0, "gestures": self._gestures}
        if self._sim is not None:
            s = self._sim.stats()
            out.update(
                joint_limit_violations=int(s["violations"]),
                peak_velocity_ratio=float(s["peak_velocity_ratio"]),
                sim_steps=int(s["steps"]),
                sim_time_s=float(s["sim_time_s"]),
            )
        return out
