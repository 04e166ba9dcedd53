"""The PyBullet NAO: the project's URDF with its joint limits, stepped by the caller.

Used by ``sim.backend.SimBackend`` (gestures in headless talks) and by ``sim.virtual_nao``
(the NAOqi look-alike server). Stepping is driven by the caller's clock: nothing free-runs.

How it is simulated, and why:

* **Fixed base, standing.** The torso is welded to the world at standing height (legs straight,
  soles on the floor). A coaching NAO stands still and only moves its head and arms, so a
  floating base would add contacts and balance control for nothing.
* **Motors.** Every joint is under ``POSITION_CONTROL`` from ``open()`` on; this replaces
  PyBullet's default velocity motors (which hold 0 rad/s with a large force). Every command
  passes ``maxVelocity = fraction × URDF velocity`` (PyBullet ignores the URDF's ``velocity``
  and treats ``maxVelocity=0`` as *no cap*, so a fraction of 0 is refused) and
  ``force = URDF effort``.
* **Trajectories** (:meth:`NaoSim.follow`) are tracked by sampling ``Trajectory.sample`` and
  ``Trajectory.velocity`` at the end of each physics step (position target plus velocity feed-
  forward), still under the velocity cap.
* **One owner per joint.** Several trajectories may run at once (NAOqi's ``angleInterpolation``
  gives each joint its own time list, and two calls on different joints overlap). Each joint
  follows the last command given to it: a new trajectory or ``set_targets`` takes its joints
  over, and the other joints keep following the trajectories they had. A trajectory that loses
  a joint goes on with the rest and ends with ``ok=False``; one that loses them all ends at once.
* **Coupled joints.** A HipYawPitch target goes to both hip joints (PyBullet ignores
  ``<mimic>``); HeadPitch targets are clipped to the HeadYaw-dependent anti-collision range.
* **No self-collision** by default: the shapes are visual stand-ins and neighbouring links
  overlap in deep poses, where contacts would fight the joint limits. ``self_collision=True``
  loads with ``URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS``.
* **Frozen joints** (``frozen``, off by default; the sim backend freezes the legs). A frozen
  joint is loaded as a fixed joint at a given angle (its URDF origin turned by that angle about
  its axis), so the solver no longer carries it. On a fixed base the legs only hang; freezing
  them cuts each physics step from about 0.21 to 0.08 ms (26 to 14 joints, 50 solver
  iterations) without changing the arms' motion. Commanding a frozen joint is refused.
* **Idle skipping.** When no trajectory runs and every joint has come to rest at its target,
  :meth:`step_to` jumps the clock without stepping: a fixed-base robot holding still does
  nothing, so skipped steps would only burn CPU. A 10-minute talk then costs only the seconds
  the robot actually moves.
* **Recording.** Each step reads every joint's position and velocity: per joint the peak speed
  as a share of the URDF limit, and the count of samples beyond a position limit
  (``POSITION_TOL`` rad) or a velocity limit (``VELOCITY_TOL`` × limit).
"""

from __future__ import annotations

import logging
import math
import os
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pybullet as p

from prezence.feedback.limits import JointLimits, load_limits, require_finite
from prezence.feedback.trajectory import Trajectory

log = logging.getLogger(__name__)

#: Torso height above the floor with straight legs: HipOffsetZ + thigh + tibia + FootHeight.
STANDING_HEIGHT_M = 0.085 + 0.100 + 0.1029 + 0.04519
#: Share of the position error the motor removes per step (PyBullet's default is 0.1, which lags
#: by about ten steps; with the trajectory's velocity as feed-forward a stiffer gain is stable).
POSITION_GAIN = 0.5
#: Gain of plain position targets (set_targets, holds): PyBullet's default. Without velocity
#: feed-forward a stiff gain drives a joint into its end stop hard enough to pass it by ~0.01 rad.
HOLD_GAIN = 0.1
#: Slack before a sample counts as a position-limit violation (rad; hands: fraction).
POSITION_TOL = 0.005
#: Slack before a sample counts as a velocity-limit violation (share of the URDF limit).
VELOCITY_TOL = 0.02
#: A trajectory has arrived when every joint is this close to its final value (rad) …
ARRIVAL_TOL = 0.005
#: … and slower than this (rad/s).
REST_SPEED = 0.05
#: A finished trajectory that has not arrived this long after its planned end is given up.
SETTLE_TIMEOUT_S = 1.0


def frozen_urdf(path: Path, angles: Mapping[str, float]) -> str:
    """The URDF at ``path`` as text, with the named joints made fixed at the given angles.

    A revolute joint at angle q places its child at ``origin · rotation(axis, q)``; the fixed
    joint gets that product as its origin, so every link sits exactly where the movable model
    puts it at q. Relative mesh paths are made absolute, since the text is loaded from
    elsewhere. Raises ValueError for a name that is not a revolute or continuous joint.
    """
    tree = ET.parse(path)
    root = tree.getroot()
    left = dict(angles)
    for joint in root.iter("joint"):
        name = joint.get("name")
        if name not in left:
            continue
        if joint.get("type") not in ("revolute", "continuous"):
            raise ValueError(f"{path}: joint {name} is {joint.get('type')!r}, cannot be frozen")
        q = left.pop(name)
        origin = joint.find("origin")
        if origin is None:
            origin = ET.SubElement(joint, "origin")
        rpy = [float(x) for x in origin.get("rpy", "0 0 0").split()]
        ax = joint.find("axis")
        axis = np.array(
            [float(x) for x in (ax.get("xyz", "1 0 0") if ax is not None else "1 0 0").split()]
        )
        axis = axis / np.linalg.norm(axis)
        turn = p.getQuaternionFromAxisAngle(axis.tolist(), q)
        _, quat = p.multiplyTransforms([0, 0, 0], p.getQuaternionFromEuler(rpy), [0, 0, 0], turn)
        origin.set("rpy", " ".join(repr(float(x)) for x in p.getEulerFromQuaternion(quat)))
        joint.set("type", "fixed")
        for child in ("axis", "limit", "mimic", "dynamics", "safety_controller"):
            for el in joint.findall(child):
                joint.remove(el)
    if left:
        raise ValueError(f"{path}: no joint named {', '.join(sorted(left))}")
    base = Path(path).resolve().parent
    for mesh in root.iter("mesh"):
        fn = mesh.get("filename", "")
        if fn and "://" not in fn and not os.path.isabs(fn):
            mesh.set("filename", str(base / fn))
    return ET.tostring(root, encoding="unicode")


class _Live(NamedTuple):
    """A running trajectory's joints that it still drives, as each physics step uses them
    (derived from ``Tracking.active``; rebuilt when a joint is taken over)."""

    motors: list[tuple[int, str, int, float, float]]  # column, name, index, velocity cap, force
    cols: np.ndarray  # their columns in NaoSim.joint_names order
    final: np.ndarray  # their final values
    every: bool  # still all of the trajectory's joints


@dataclass
class Tracking:
    """How the robot followed one trajectory (filled in step by step).

    Attributes:
        traj: the trajectory.
        start: sim time it started.
        peak_speed: per joint of the trajectory, highest measured speed (rad/s).
        violations: samples beyond a position or velocity limit during it.
        arrived_at: first sim time from which every joint stayed within ``ARRIVAL_TOL`` of the
            final pose (None until the motion has settled).
        finished_at: sim time the motion was declared over (arrived and at rest, timed out, or
            every joint taken over by another command).
        ok: False if it timed out before settling or another command took any of its joints.
        fraction: the velocity cap of its commands, as a fraction of the URDF limits.
        cols: per joint of the trajectory, its column in :attr:`NaoSim.joint_names` order.
        active: per joint of the trajectory, False once another command has taken it over (its
            speed, violations and arrival then no longer count here).
    """

    traj: Trajectory
    start: float
    indices: tuple[int, ...]
    final: np.ndarray
    peak_speed: np.ndarray
    violations: int = 0
    arrived_at: float | None = None
    finished_at: float | None = None
    ok: bool = True
    fraction: float = 1.0
    cols: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int), repr=False)
    active: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool), repr=False)
    _inside_since: float | None = field(default=None, repr=False)
    # what each step needs about the joints it still drives (NaoSim._live_of); None: rebuild
    _live: _Live | None = field(default=None, repr=False)

    @property
    def done(self) -> bool:
        return self.finished_at is not None

    @property
    def measured_s(self) -> float | None:
        """Start to arrival, in seconds (None while running)."""
        end = self.arrived_at if self.arrived_at is not None else self.finished_at
        return None if end is None else end - self.start


class NaoSim:
    """A NAO in PyBullet with the URDF's joint limits, stepped by the caller.

    Args:
        urdf: path of the URDF; None uses the project's ``assets/nao_urdf/nao.urdf``.
        gui: open a PyBullet window instead of DIRECT (headless).
        timestep: physics step in seconds.
        self_collision: load with self-collision (parents excluded); off by default.
        skip_idle: jump the clock without stepping while the robot is at rest.
        frozen: joints loaded rigid, each at the given angle (rad; within its limits). They
            are not simulated, recorded or commandable; the other joints move as before.
    """

    def __init__(
        self,
        *,
        urdf: Path | None = None,
        gui: bool = False,
        timestep: float = 1 / 240,
        self_collision: bool = False,
        skip_idle: bool = True,
        solver_iterations: int = 50,
        position_gain: float = POSITION_GAIN,
        frozen: Mapping[str, float] | None = None,
    ) -> None:
        if not timestep > 0:
            raise ValueError(f"timestep must be > 0, got {timestep!r}")
        self.urdf = Path(urdf) if urdf is not None else None
        self.gui = gui
        self.timestep = float(timestep)
        self.self_collision = self_collision
        self.skip_idle = skip_idle
        self.solver_iterations = int(solver_iterations)
        self.position_gain = float(position_gain)
        self.frozen: dict[str, float] = {n: float(q) for n, q in (frozen or {}).items()}
        self._cid: int | None = None
        self._robot = -1
        self._t = 0.0
        self._steps = 0
        self._names: tuple[str, ...] = ()
        self._index: dict[str, int] = {}
        self._limits: JointLimits | None = None
        self._targets: dict[str, float] = {}
        self._track: Tracking | None = None  # the last one given to follow()
        self._tracks: list[Tracking] = []  # running, in the order follow() got them
        self._owner: dict[str, Tracking] = {}  # joint -> the running trajectory that drives it
        self._all_idx: list[int] = []
        self._lo = self._hi = self._vcap = np.zeros(0)
        self._peak = np.zeros(0)
        self._violations = 0
        self._pos_violations = 0
        self._vel_violations = 0

    # -- lifecycle ----------------------------------------------------------------------------
    def open(self) -> None:
        """Connect to PyBullet and load the robot standing (fixed base)."""
        if self._cid is not None:
            return
        from prezence.feedback.gestures import load_library
        from prezence.resources import urdf_path

        path = self.urdf if self.urdf is not None else urdf_path()
        self._limits = load_limits(path)
        if self.frozen:
            self._limits.require_known(self.frozen)
            require_finite(self.frozen)
            self._limits.check(self.frozen, where="frozen joints")
        cid = p.connect(p.GUI if self.gui else p.DIRECT)
        if cid < 0:
            raise RuntimeError("cannot connect to PyBullet")
        self._cid = cid
        p.setTimeStep(self.timestep, physicsClientId=cid)
        p.setGravity(0, 0, -9.81, physicsClientId=cid)
        p.setPhysicsEngineParameter(numSolverIterations=self.solver_iterations, physicsClientId=cid)
        flags = p.URDF_USE_INERTIA_FROM_FILE
        if self.self_collision:
            flags |= p.URDF_USE_SELF_COLLISION | p.URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS
        tmp = None
        if self.frozen:
            fd, tmp = tempfile.mkstemp(suffix=".urdf", prefix="nao-frozen-")
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(frozen_urdf(path, self.frozen))
        try:
            self._robot = p.loadURDF(
                tmp or str(path),
                [0.0, 0.0, STANDING_HEIGHT_M],
                useFixedBase=True,
                flags=flags,
                physicsClientId=cid,
            )
        finally:
            if tmp is not None:
                os.unlink(tmp)
        index: dict[str, int] = {}
        for i in range(p.getNumJoints(self._robot, physicsClientId=cid)):
            info = p.getJointInfo(self._robot, i, physicsClientId=cid)
            if info[2] == p.JOINT_REVOLUTE:
                index[info[1].decode()] = i
        self._names = tuple(n for n in self._limits.names if n in index)
        self._index = index
        self._peak = np.zeros(len(self._names))
        lim = self._limits
        self._all_idx = [index[n] for n in self._names]
        self._lo = np.array([lim.lower[n] for n in self._names]) - POSITION_TOL
        self._hi = np.array([lim.upper[n] for n in self._names]) + POSITION_TOL
        self._vcap = np.array([lim.velocity[n] for n in self._names]) * (1.0 + VELOCITY_TOL)
        neutral = {n: q for n, q in dict(load_library(self._limits).neutral).items() if n in index}
        for name in self._names:
            p.resetJointState(
                self._robot, index[name], neutral.get(name, 0.0), 0.0, physicsClientId=cid
            )
        self._targets = {}
        self._track, self._tracks, self._owner = None, [], {}
        self._command(neutral, 1.0)
        self._t = 0.0
        self._steps = 0

    def close(self) -> None:
        """Disconnect; safe to call twice."""
        if self._cid is not None:
            p.disconnect(physicsClientId=self._cid)
            self._cid = None

    def __enter__(self) -> NaoSim:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- state --------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Simulated seconds since open()."""
        return self._t

    @property
    def steps(self) -> int:
        """Physics steps taken since open() (idle jumps take none)."""
        return self._steps

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._names

    @property
    def client(self) -> int:
        """The PyBullet physics client id (for rendering)."""
        return self._require()

    @property
    def robot(self) -> int:
        """The robot's PyBullet body id."""
        self._require()
        return self._robot

    @property
    def limits(self) -> JointLimits:
        if self._limits is None:
            raise RuntimeError("NaoSim is not open")
        return self._limits

    @property
    def tracking(self) -> Tracking | None:
        """The record of the last trajectory given to follow()."""
        return self._track

    @property
    def trackings(self) -> tuple[Tracking, ...]:
        """The records of the trajectories still running, oldest first."""
        return tuple(self._tracks)

    def _require(self) -> int:
        if self._cid is None:
            raise RuntimeError("NaoSim is not open")
        return self._cid

    def positions(self, names: Sequence[str] | None = None) -> list[float]:
        """Measured joint positions (all joints in joint_names order when names is None)."""
        return [s[0] for s in self._states(names)]

    def velocities(self, names: Sequence[str] | None = None) -> list[float]:
        """Measured joint velocities (rad/s)."""
        return [s[1] for s in self._states(names)]

    def _states(self, names: Sequence[str] | None) -> list[tuple[float, float]]:
        cid = self._require()
        idx = self._all_idx if names is None else [self._joint_index(n) for n in names]
        if not idx:  # PyBullet answers None to an empty list
            return []
        return [(s[0], s[1]) for s in p.getJointStates(self._robot, idx, physicsClientId=cid)]

    def _joint_index(self, name: str) -> int:
        if name not in self._index:
            self.limits.require_known([name])
            if name in self.frozen:
                raise ValueError(
                    f"{name} is held rigid in this simulation (frozen at "
                    f"{self.frozen[name]:g} rad); open the NaoSim without freezing it to move it"
                )
            raise ValueError(f"{name} is not a movable joint of this robot")
        return self._index[name]

    def peak_velocity_ratio(self) -> dict[str, float]:
        """Per joint, the highest measured speed since open() / its URDF velocity limit."""
        lim = self.limits
        return {n: float(v) / lim.velocity[n] for n, v in zip(self._names, self._peak, strict=True)}

    def stats(self) -> dict[str, float | int]:
        """Whole-run figures: steps, violations (position, velocity) and the peak speed ratio."""
        ratios = self.peak_velocity_ratio()
        return {
            "sim_time_s": self._t,
            "steps": self._steps,
            "violations": self._violations,
            "position_violations": self._pos_violations,
            "velocity_violations": self._vel_violations,
            "peak_velocity_ratio": max(ratios.values()) if ratios else 0.0,
        }

    # -- commands -----------------------------------------------------------------------------
    def set_targets(
        self,
        names: Sequence[str],
        positions: Sequence[float],
        speed_fraction: float | Sequence[float],
    ) -> None:
        """Velocity-capped position control (NAOqi setAngles semantics): each joint moves to its
        target no faster than fraction × its URDF velocity limit. Targets outside the position
        limits are clipped; NaN raises ValueError naming the joint."""
        self._require()
        names = list(names)
        values = [float(v) for v in positions]
        if len(names) != len(values):
            raise ValueError(f"{len(names)} joint names for {len(values)} positions")
        fractions = (
            [float(speed_fraction)] * len(names)
            if isinstance(speed_fraction, int | float)
            else [float(f) for f in speed_fraction]
        )
        if len(fractions) != len(names):
            raise ValueError(f"{len(names)} joint names for {len(fractions)} speed fractions")
        targets = dict(zip(names, values, strict=True))
        require_finite(targets)
        self.limits.require_known(targets)
        for n, f in zip(names, fractions, strict=True):
            # maxVelocity=0 would mean "no cap" to PyBullet: refuse it instead.
            if not 0.0 < f <= 1.0:
                raise ValueError(f"{n}: speed fraction must be in (0, 1], got {f!r}")
        frac = dict(zip(names, fractions, strict=True))
        clipped = self.limits.clip(
            targets, pose=dict(zip(self._names, self.positions(), strict=True))
        )
        for hip in ("LHipYawPitch", "RHipYawPitch"):
            if hip in clipped and hip not in frac:
                frac[hip] = frac.get("LHipYawPitch", frac.get("RHipYawPitch", 1.0))
        for name in clipped:
            self._joint_index(name)  # a frozen joint is refused before anything moves
        self._take_over(clipped)
        for name, value in clipped.items():
            self._command({name: value}, frac[name])

    def _command(self, targets: dict[str, float], fraction: float) -> None:
        """Send plain position targets at PyBullet's default gain (setAngles-like approach).
        Trajectory tracking sends its own, with velocity feed-forward and the stiffer
        ``position_gain`` (:meth:`_apply_tracks`)."""
        cid = self._require()
        lim = self.limits
        for name, q in targets.items():
            self._targets[name] = q
            p.setJointMotorControl2(
                self._robot,
                self._index[name],
                p.POSITION_CONTROL,
                targetPosition=q,
                targetVelocity=0.0,
                maxVelocity=fraction * lim.velocity[name],
                positionGain=HOLD_GAIN,
                velocityGain=1.0,
                force=lim.effort[name],
                physicsClientId=cid,
            )

    def follow(
        self, traj: Trajectory, *, start: float | None = None, speed_fraction: float = 1.0
    ) -> Tracking:
        """Track ``traj`` from sim time ``start`` (default: now), taking its joints over.

        Its joints stop following any trajectory they followed; the other joints go on with
        theirs (see the module docstring).

        Args:
            traj: the trajectory (its joints must be URDF joints).
            start: sim time of its t = 0 (default: now).
            speed_fraction: the velocity cap passed with every command, as a fraction of the URDF
                limit; the backend passes the fraction the trajectory was planned at.

        Returns:
            its record, filled in as the robot follows it (also :attr:`tracking` until the
            next call).
        """
        self._require()
        if not 0.0 < speed_fraction <= 1.0:
            raise ValueError(f"speed fraction must be in (0, 1], got {speed_fraction!r}")
        self.limits.require_known(traj.joints)
        for j in traj.joints:
            self._joint_index(j)
        self._take_over(traj.joints)
        t0 = self._t if start is None else float(start)
        tr = Tracking(
            traj=traj,
            start=t0,
            indices=tuple(self._index[j] for j in traj.joints),
            final=np.asarray(traj.sample(traj.duration), dtype=float),
            peak_speed=np.zeros(len(traj.joints)),
            fraction=float(speed_fraction),
            cols=np.array([self._names.index(j) for j in traj.joints], dtype=int),
            active=np.ones(len(traj.joints), dtype=bool),
        )
        self._track = tr
        self._tracks.append(tr)
        for j in traj.joints:
            self._owner[j] = tr
        return tr

    def following(self) -> bool:
        """True while a trajectory given to follow() has not reached its end."""
        return bool(self._tracks)

    def _take_over(self, joints: Iterable[str]) -> None:
        """Detach ``joints`` from the trajectories driving them; a trajectory left with no
        joint ends at once. Either way it ends with ``ok=False``."""
        for j in joints:
            tr = self._owner.pop(j, None)
            if tr is None:
                continue
            tr.active[tr.traj.joints.index(j)] = False
            tr._live = None
            tr.ok = False
            if not tr.active.any():
                self._finish_track(tr, ok=False)

    # -- stepping -----------------------------------------------------------------------------
    def step_to(self, t: float) -> None:
        """Advance the physics to sim time ``t`` (recording joint states)."""
        cid = self._require()
        if not math.isfinite(t):
            raise ValueError(f"step_to needs a finite time, got {t!r}")
        dt = self.timestep
        eps = 1e-9
        while self._t + dt <= t + eps:
            if self.skip_idle and not self.following() and self._at_rest():
                self._t = t
                return
            self._apply_tracks(self._t + dt)
            p.stepSimulation(physicsClientId=cid)
            self._steps += 1
            self._t += dt
            self._record()

    def _apply_tracks(self, t_next: float) -> None:
        cid = self._cid
        robot = self._robot
        targets = self._targets
        gain = self.position_gain
        control = p.setJointMotorControl2
        mode = p.POSITION_CONTROL
        for tr in self._tracks:
            tau = t_next - tr.start
            if tau < 0.0:
                continue
            q, v = tr.traj.state(tau)
            qs, vs = q.tolist(), v.tolist()
            for k, name, index, cap, force in self._live_of(tr).motors:
                targets[name] = qs[k]
                control(
                    robot,
                    index,
                    mode,
                    targetPosition=qs[k],
                    targetVelocity=vs[k],
                    maxVelocity=cap,
                    positionGain=gain,
                    velocityGain=1.0,
                    force=force,
                    physicsClientId=cid,
                )

    def _live_of(self, tr: Tracking) -> _Live:
        """``tr``'s :class:`_Live`, built once per change of the joints it drives."""
        if tr._live is None:
            lim = self.limits
            motors = [
                (k, j, self._index[j], tr.fraction * lim.velocity[j], lim.effort[j])
                for k, (j, a) in enumerate(zip(tr.traj.joints, tr.active, strict=True))
                if a
            ]
            every = bool(tr.active.all())
            tr._live = _Live(motors, tr.cols[tr.active], tr.final[tr.active], every)
        return tr._live

    def _record(self) -> None:
        cid = self._require()
        states = p.getJointStates(self._robot, self._all_idx, physicsClientId=cid)
        q, v = np.array([s[:2] for s in states]).T
        v = np.abs(v)
        np.maximum(self._peak, v, out=self._peak)
        pos_bad = (q < self._lo) | (q > self._hi)
        vel_bad = v > self._vcap
        if pos_bad.any() or vel_bad.any():
            n_pos, n_vel = int(np.count_nonzero(pos_bad)), int(np.count_nonzero(vel_bad))
            self._pos_violations += n_pos
            self._vel_violations += n_vel
            self._violations += n_pos + n_vel
        for tr in list(self._tracks):
            self._record_track(tr, q, v, pos_bad | vel_bad)

    def _record_track(self, tr: Tracking, q: np.ndarray, v: np.ndarray, bad: np.ndarray) -> None:
        """Update one running trajectory's record from this step's states (all joints)."""
        _, col, final, every = self._live_of(tr)
        speed = v[tr.cols] if every else np.where(tr.active, v[tr.cols], 0.0)
        np.maximum(tr.peak_speed, speed, out=tr.peak_speed)
        tr.violations += int(np.count_nonzero(bad[col]))
        inside = bool(np.all(np.abs(q[col] - final) <= ARRIVAL_TOL))
        if not inside:
            tr._inside_since = None
        elif tr._inside_since is None:
            tr._inside_since = self._t
        end = tr.start + tr.traj.duration
        if self._t >= end - 1e-9:
            if inside and bool(np.all(v[col] <= REST_SPEED)):
                tr.arrived_at = tr._inside_since
                self._finish_track(tr, ok=tr.ok)
            elif self._t >= end + SETTLE_TIMEOUT_S:
                log.warning(
                    "%s: not settled %.1f s after its planned end", tr.traj.name, SETTLE_TIMEOUT_S
                )
                self._finish_track(tr, ok=False)

    def _finish_track(self, tr: Tracking, *, ok: bool) -> None:
        """Declare ``tr`` over; the joints it still drives hold its final pose."""
        if tr.done:
            return
        tr.finished_at = self._t
        tr.ok = ok
        self._tracks.remove(tr)
        held = {}
        for j, a, x in zip(tr.traj.joints, tr.active, tr.final, strict=True):
            if a:
                held[j] = float(x)
                del self._owner[j]
        # hold the final pose with a plain capped position target
        if held:
            self._command(held, tr.fraction)

    def _at_rest(self) -> bool:
        states = self._states(None)
        for name, (q, v) in zip(self._names, states, strict=True):
            if abs(v) > 1e-3:
                return False
            target = self._targets.get(name)
            if target is not None and abs(q - target) > ARRIVAL_TOL:
                return False
        return True
