"""The PyBullet NAO (CONTRACT STUB: the NAO-model work fills this in; keep these signatures).

Used by ``sim.backend.SimBackend`` (gestures in headless talks) and by ``sim.virtual_nao``
(the NAOqi look-alike server). Stepping is driven by the caller's clock: nothing free-runs.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from prezence.feedback.trajectory import Trajectory


class NaoSim:
    """A NAO in PyBullet with the URDF's joint limits, stepped by the caller.

    Args:
        urdf: path of the URDF; None uses the project's ``assets/nao_urdf/nao.urdf``.
        gui: open a PyBullet window instead of DIRECT (headless).
        timestep: physics step in seconds.
    """

    def __init__(self, *, urdf: Path | None = None, gui: bool = False, timestep: float = 1 / 240) -> None:
        raise NotImplementedError

    def open(self) -> None:
        """Connect to PyBullet and load the robot standing (fixed base)."""
        raise NotImplementedError

    def close(self) -> None:
        """Disconnect; safe to call twice."""
        raise NotImplementedError

    @property
    def time(self) -> float:
        """Simulated seconds since open()."""
        raise NotImplementedError

    @property
    def joint_names(self) -> tuple[str, ...]:
        raise NotImplementedError

    def set_targets(
        self, names: Sequence[str], positions: Sequence[float], speed_fraction: float | Sequence[float]
    ) -> None:
        """Velocity-capped position control (NAOqi setAngles semantics): each joint moves to its
        target no faster than fraction × its URDF velocity limit. Targets outside the position
        limits are clipped; NaN raises ValueError naming the joint."""
        raise NotImplementedError

    def follow(self, traj: Trajectory, *, start: float | None = None) -> None:
        """Track ``traj`` from sim time ``start`` (default: now), replacing targets of its joints."""
        raise NotImplementedError

    def following(self) -> bool:
        """True while a trajectory given to follow() has not reached its end."""
        raise NotImplementedError

    def step_to(self, t: float) -> None:
        """Advance the physics to sim time ``t`` (recording joint states)."""
        raise NotImplementedError

    def positions(self, names: Sequence[str] | None = None) -> list[float]:
        """Measured joint positions (all joints in joint_names order when names is None)."""
        raise NotImplementedError
