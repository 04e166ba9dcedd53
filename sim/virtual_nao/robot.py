"""The virtual NAO: a simulated robot that speaks the NAOqi protocol (``qi``) on loopback.

A client (``NaoqiBackend``, or any script written for a real NAO) connects with
``qi.Session().connect("tcp://127.0.0.1:PORT")`` and uses ``session.service("ALMotion")`` and
friends exactly as on the robot. Behind the services is the PyBullet NAO (:class:`sim.nao.NaoSim`)
or, with ``model="kinematic"``, :class:`KinematicNao` (velocity-capped integration, no physics).

Semantics follow NAOqi's documentation (``reference/naoqi_api.md``):

- *Blocking* calls (``angleInterpolation*``, ``goToPosture``, ``say``, ``fadeRGB``…) block the
  caller, not the service: the method returns a ``qi.Future`` from a ``qi.Promise`` that the
  simulation clock completes, so ``getAngles``/``setAngles`` still answer during a gesture.
  Services stay single-threaded (qi's default), so a burst of ``setAngles`` applies in order.
- ``setAngles`` retargets; speed is ``fractionMaxSpeed × the joint's velocity limit``; targets
  are clipped to the position limits; chain names (``Head``, ``LArm``, ``Body``…) expand; names,
  angles and times may be scalars or lists.
- ``angleInterpolation`` keyframes get the same clipping as ``setAngles`` targets (joint ranges,
  the head anti-collision table at the HeadYaw planned for that key time, one hip motor). Keys too
  close together for a joint's velocity limit are spread out, never followed late: the motion is
  slowed down to the limit, the call returns when it is done, and one warning per call names the
  joint, the speed asked and the limit (:func:`plan_keyframes`).
- A blocking motion on joints that a running one holds waits until that one ends or is killed
  (NAOqi's motion tasks and resources); ``say`` sentences queue behind each other.
- Bad input raises; the client sees NAOqi's kind of error, a ``RuntimeError`` with a text.
- Commands to joints whose stiffness is 0 are accepted and ignored, as on the robot. The virtual
  NAO starts awake (stiffness 1).
- ``ALTextToSpeech.say`` logs each phrase at INFO on the ``sim.virtual_nao.speech`` logger (no
  audio is produced), and the speech log records its start and end.

Time: a server must run in real time, because its clients do. So, unlike everything else in
Prezence (where the caller's clock drives the physics), ONE loop thread steps the model to the
wall clock at ``rate_hz`` and completes the promises whose time has come. It is the only
free-running loop in the project, on purpose. ``VirtualNao.start(realtime=False)`` leaves the
clock to the caller (:meth:`VirtualNao.tick`), for tests.

Run it with ``python -m sim.virtual_nao --port 0`` (prints ``listening on tcp://127.0.0.1:PORT``)
or ``prezence sim serve``.
"""

from __future__ import annotations

import argparse
import itertools
import json
import logging
import math
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType, TracebackType
from typing import IO, Any, Protocol, TypeGuard

import numpy as np
import qi

from prezence.backends.base import estimate_speech_s
from prezence.errors import did_you_mean
from prezence.feedback.limits import (
    BODY_ORDER,
    CHAINS,
    HIP_YAW_PITCH,
    JointLimit,
    JointLimits,
    load_limits,
)
from prezence.feedback.trajectory import RAMP_S, Trajectory, profile_peaks

log = logging.getLogger("sim.virtual_nao")  # the package's logger, as before the split
#: Logger of the phrases said (INFO, one line per ``say``): enable it to watch the robot talk.
SPEECH_LOGGER = "sim.virtual_nao.speech"
say_log = logging.getLogger(SPEECH_LOGGER)

# -- joints, chains, limits ----------------------------------------------------------------------

BODY: tuple[str, ...] = tuple(n for c in BODY_ORDER for n in CHAINS[c])
GROUPS: dict[str, tuple[str, ...]] = {
    **CHAINS,
    "Arms": CHAINS["LArm"] + CHAINS["RArm"],
    "Legs": CHAINS["LLeg"] + CHAINS["RLeg"],
    "Body": BODY,
    "Joints": BODY,
    "Actuators": BODY,
    "JointActuators": BODY,
    "BodyJoints": BODY,
    "BodyActuators": BODY,
    "Chains": BODY_ORDER,
}


def body_specs(limits: JointLimits) -> dict[str, JointLimit]:
    """The limits of NAOqi's body joints, in ``getBodyNames("Body")`` order."""
    return {n: limits[n] for n in BODY}


#: Postures for ``ALRobotPosture``: rounded values in the spirit of NAOqi's (arms down and
#: slightly bent; legs straight since the simulated NAO stands on a fixed base). Approximate:
#: they are not NAOqi's joint values.
_ARMS_DOWN = {
    "HeadYaw": 0.0,
    "HeadPitch": 0.0,
    "LShoulderPitch": 1.4,
    "LShoulderRoll": 0.3,
    "LElbowYaw": -1.2,
    "LElbowRoll": -0.5,
    "LWristYaw": 0.0,
    "LHand": 0.25,
    "RShoulderPitch": 1.4,
    "RShoulderRoll": -0.3,
    "RElbowYaw": 1.2,
    "RElbowRoll": 0.5,
    "RWristYaw": 0.0,
    "RHand": 0.25,
}
POSTURES: dict[str, dict[str, float]] = {
    "StandInit": {**_ARMS_DOWN},
    "Stand": {**_ARMS_DOWN},
    "StandZero": {n: 0.0 for n in BODY},
    "Crouch": {**_ARMS_DOWN, "LShoulderPitch": 0.9, "RShoulderPitch": 0.9},
}

#: LED groups NAOqi documents for NAO, plus the eye segments.
LED_GROUPS = frozenset(
    {
        "AllLeds",
        "FaceLeds",
        "LeftFaceLeds",
        "RightFaceLeds",
        "ChestLeds",
        "EarLeds",
        "LeftEarLeds",
        "RightEarLeds",
        "FeetLeds",
        "LeftFootLeds",
        "RightFootLeds",
        "BrainLeds",
    }
    | {f"FaceLed{i}" for i in range(8)}
)
LED_COLORS = {
    "white": 0xFFFFFF,
    "red": 0xFF0000,
    "green": 0x00FF00,
    "blue": 0x0000FF,
    "yellow": 0xFFFF00,
    "magenta": 0xFF00FF,
    "cyan": 0x00FFFF,
}
_TTS_TAG = re.compile(r"\\[a-zA-Z]+=?[^\\]*\\")


# -- the model behind the services -----------------------------------------------------------------


class Model(Protocol):
    """What the virtual NAO needs from a robot model (the ``sim.nao.NaoSim`` contract)."""

    @property
    def time(self) -> float: ...

    @property
    def joint_names(self) -> tuple[str, ...]: ...

    def open(self) -> None: ...

    def close(self) -> None: ...

    def set_targets(
        self,
        names: Sequence[str],
        positions: Sequence[float],
        speed_fraction: float | Sequence[float],
    ) -> None: ...

    def follow(self, traj: Trajectory, *, start: float | None = None) -> object: ...

    def following(self) -> bool: ...

    def step_to(self, t: float) -> None: ...

    def positions(self, names: Sequence[str] | None = None) -> list[float]: ...


class KinematicNao:
    """A NAO without physics: each joint moves toward its setpoint no faster than its limit.

    Same methods as :class:`sim.nao.NaoSim`. ``set_targets`` caps speed at fraction × the joint's
    velocity limit; ``follow`` tracks the trajectory's sample, capped at the full limit.

    Args:
        specs: joint limits by name.
        timestep: integration step in seconds.
    """

    def __init__(self, specs: dict[str, JointLimit], *, timestep: float = 0.005) -> None:
        if not timestep > 0:
            raise ValueError(f"timestep must be > 0, got {timestep!r}")
        self._specs = specs
        self._names = tuple(specs)
        self._index = {n: i for i, n in enumerate(self._names)}
        self._lo = np.array([s.lower for s in specs.values()])
        self._hi = np.array([s.upper for s in specs.values()])
        self._vmax = np.array([s.velocity for s in specs.values()])
        self._q = np.clip(np.zeros(len(self._names)), self._lo, self._hi)
        self._target = self._q.copy()
        self._speed = self._vmax.copy()
        self._trajs: dict[int, tuple[Trajectory, float, list[int]]] = {}
        self._owner: dict[int, int] = {}  # joint index -> key in _trajs
        self._keys = itertools.count()
        self._t = 0.0
        self._dt = timestep

    def open(self) -> None:
        """Nothing to load."""

    def close(self) -> None:
        """Nothing to release."""

    @property
    def time(self) -> float:
        return self._t

    @property
    def joint_names(self) -> tuple[str, ...]:
        return self._names

    def _idx(self, names: Sequence[str]) -> list[int]:
        try:
            return [self._index[n] for n in names]
        except KeyError as e:
            raise ValueError(f"unknown joint {e.args[0]!r}") from None

    def set_targets(
        self,
        names: Sequence[str],
        positions: Sequence[float],
        speed_fraction: float | Sequence[float],
    ) -> None:
        """Retarget joints (velocity-capped at fraction × limit, clipped to the range)."""
        idx = self._idx(names)
        pos = np.asarray(positions, dtype=float)
        for n, p in zip(names, pos, strict=True):
            if math.isnan(p):
                raise ValueError(f"NaN target for {n}")
        frac = np.broadcast_to(np.asarray(speed_fraction, dtype=float), pos.shape)
        for i, p, f in zip(idx, pos, frac, strict=True):
            self._release(i)
            self._target[i] = min(max(p, self._lo[i]), self._hi[i])
            self._speed[i] = self._vmax[i] * min(max(f, 0.0), 1.0)

    def _release(self, i: int) -> None:
        key = self._owner.pop(i, None)
        if key is not None and not any(k == key for k in self._owner.values()):
            self._trajs.pop(key, None)

    def follow(self, traj: Trajectory, *, start: float | None = None) -> None:
        """Track ``traj`` from ``start`` (default: now), replacing the targets of its joints."""
        idx = self._idx(traj.joints)
        for i in idx:
            self._release(i)
        key = next(self._keys)
        self._trajs[key] = (traj, self._t if start is None else start, idx)
        for i in idx:
            self._owner[i] = key
            self._speed[i] = self._vmax[i]

    def following(self) -> bool:
        return any(self._t < t0 + tr.duration for tr, t0, _ in self._trajs.values())

    def step_to(self, t: float) -> None:
        while self._t < t - 1e-12:
            dt = min(self._dt, t - self._t)
            self._t += dt
            for key, (tr, t0, idx) in self._trajs.items():
                q = np.clip(tr.sample(self._t - t0), self._lo[idx], self._hi[idx])
                for k, i in enumerate(idx):
                    if self._owner.get(i) == key:
                        self._target[i] = q[k]
            step = np.clip(self._target - self._q, -self._speed * dt, self._speed * dt)
            self._q = self._q + step

    def positions(self, names: Sequence[str] | None = None) -> list[float]:
        if names is None:
            return [float(x) for x in self._q]
        return [float(self._q[i]) for i in self._idx(names)]


def make_model(kind: str, specs: dict[str, JointLimit], *, gui: bool = False) -> Model:
    """``"pybullet"`` (the PyBullet NAO, :class:`sim.nao.NaoSim`) or ``"kinematic"``."""
    if kind == "kinematic":
        return KinematicNao(specs)
    if kind == "pybullet":
        from sim.nao import NaoSim

        return NaoSim(gui=gui)
    raise ValueError(f"unknown model {kind!r}; use 'pybullet' or 'kinematic'")


# -- argument shapes ---------------------------------------------------------------------------


def _is_seq(x: object) -> TypeGuard[list[Any] | tuple[Any, ...]]:
    return isinstance(x, list | tuple)


def _num(x: object, what: str) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float):
        raise TypeError(f"{what} must be a number, got {x!r}")
    v = float(x)
    if math.isnan(v):
        raise ValueError(f"{what} is NaN")
    return v


@dataclass
class _Task:
    """A blocking call in progress (or waiting for its resources)."""

    id: int
    name: str
    resources: frozenset[str]
    promise: Any  # qi.Promise
    begin: Callable[[float], float]  # starts it at sim time t; returns its duration
    finish: Callable[[bool], None] | None = None
    value: Any = None
    started_at: float | None = None
    ends_at: float = math.inf
    #: when set, the task ends once this returns True (checked from ``settle_from``, the
    #: duration ``begin`` returned) or ``grace_s`` later at the latest
    arrived: Callable[[], bool] | None = None
    grace_s: float = 0.0
    settle_from: float = math.inf
    info: dict[str, Any] = field(default_factory=dict)


class VirtualNao:
    """The simulated robot behind the services: model, clock, motion tasks, speech queue.

    Args:
        model: ``"pybullet"`` or ``"kinematic"`` (see :func:`make_model`), or a model object.
        gui: show the PyBullet window.
        speech_log: JSONL file that records every utterance and motion (start and end, sim time
            ``t`` and the host's monotonic clock ``mono``), or None.
        rate_hz: loop rate of the real-time stepping thread.
        limits: joint limits; None reads the project's URDF.
    """

    def __init__(
        self,
        *,
        model: str | Model = "pybullet",
        gui: bool = False,
        speech_log: Path | str | None = None,
        rate_hz: float = 100.0,
        limits: JointLimits | None = None,
    ) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz!r}")
        self.limits = limits if limits is not None else load_limits()
        self.specs = body_specs(self.limits)
        self.model: Model = (
            make_model(model, self.specs, gui=gui) if isinstance(model, str) else model
        )
        self.rate_hz = rate_hz
        self.speech_log = Path(speech_log) if speech_log is not None else None
        self.lock = threading.Lock()
        self.stiffness = {n: 1.0 for n in self.specs}
        self.commanded: dict[str, float] = {}
        self.breath: dict[str, bool] = {}
        self.idle_posture: dict[str, bool] = {}
        self.memory: dict[str, Any] = {}
        self.leds: dict[str, int] = {g: 0xFFFFFF for g in LED_GROUPS}
        self.posture = "Stand"
        self.tts_params: dict[str, float] = {"speed": 100.0, "pitchShift": 0.0, "volume": 1.0}
        self.language = "English"
        self._tasks: list[_Task] = []
        self._ids = itertools.count(1)
        self._log_file: IO[str] | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._t0 = 0.0
        self._sim0 = 0.0

    # -- lifecycle ---------------------------------------------------------------------------
    def start(self, *, realtime: bool = True) -> None:
        """Open the model and start the real-time loop thread.

        Args:
            realtime: False starts no thread: the caller drives the clock with :meth:`tick`
                (deterministic tests).
        """
        if self.speech_log is not None:
            self._log_file = open(self.speech_log, "a", encoding="utf-8", buffering=1)  # noqa: SIM115
        try:
            self.model.open()
        except BaseException:
            if self._log_file is not None:
                self._log_file.close()
                self._log_file = None
            raise
        self.commanded = dict(zip(self.specs, self.model.positions(list(self.specs)), strict=True))
        self._t0 = time.monotonic()
        self._sim0 = self.model.time
        if realtime:
            self._thread = threading.Thread(
                target=self._loop, name="virtual-nao-clock", daemon=True
            )
            self._thread.start()

    def stop(self) -> None:
        """Stop the loop, fail pending calls, close the model and the log; safe to call twice."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
        with self.lock:
            tasks, self._tasks = self._tasks, []
        for task in tasks:
            if not task.promise.future().isFinished():
                task.promise.setError("virtual NAO shut down")
        self.model.close()
        if self._log_file is not None:
            self._log_file.close()
            self._log_file = None

    def _loop(self) -> None:
        period = 1.0 / self.rate_hz
        next_tick = time.monotonic()
        while not self._stop.is_set():
            self.tick(self._sim0 + time.monotonic() - self._t0)
            next_tick += period
            delay = next_tick - time.monotonic()
            if delay < -period:  # fell behind (slow host): do not try to catch up in a burst
                next_tick = time.monotonic()
            self._stop.wait(max(0.0, delay))

    def tick(self, t: float) -> None:
        """Step the model to sim time ``t``; end the calls whose time has come; start the next."""
        with self.lock:
            if t > self.model.time:
                self.model.step_to(t)
            done = self._reap_locked(self.model.time)
        self._settle(done)

    # -- tasks (call with the lock held unless said otherwise) -------------------------------
    @property
    def now(self) -> float:
        return self.model.time

    def submit(
        self,
        name: str,
        resources: frozenset[str],
        begin: Callable[[float], float],
        *,
        value: Any = None,
        finish: Callable[[bool], None] | None = None,
        info: dict[str, Any] | None = None,
        arrived: Callable[[], bool] | None = None,
        grace_s: float = 0.0,
    ) -> Any:
        """Queue a blocking call; returns the ``qi.Future`` the client waits on (lock NOT held)."""
        holder: list[_Task] = []
        promise = qi.Promise(lambda p: self._cancel(holder[0].id) if holder else None)
        with self.lock:
            task = _Task(
                next(self._ids),
                name,
                resources,
                promise,
                begin,
                finish,
                value,
                info=info or {},
                arrived=arrived,
                grace_s=grace_s,
            )
            holder.append(task)
            self._tasks.append(task)
            self._start_ready_locked(self.model.time)
            done = self._reap_locked(self.model.time)
        self._settle(done)
        return promise.future()

    def _start_ready_locked(self, now: float) -> None:
        held: set[str] = set()
        for task in self._tasks:
            if task.started_at is None and not (task.resources & held):
                task.started_at = now
                task.settle_from = now + max(0.0, task.begin(now))
                task.ends_at = task.settle_from + (task.grace_s if task.arrived else 0.0)
                self.record("start", task)
            held |= task.resources

    def _reap_locked(self, now: float) -> list[tuple[_Task, str]]:
        done = [
            (t, "value")
            for t in self._tasks
            if t.started_at is not None
            and (
                t.ends_at <= now or (t.arrived is not None and t.settle_from <= now and t.arrived())
            )
        ]
        if done:
            ended = {id(t) for t, _ in done}
            self._tasks = [t for t in self._tasks if id(t) not in ended]
            for task, _ in done:
                if task.finish is not None:
                    task.finish(True)
                self.record("end", task, ok=True)
            self._start_ready_locked(now)
        return done

    def kill_locked(
        self, resources: frozenset[str] | None, *, how: str = "value"
    ) -> list[tuple[_Task, str]]:
        """End the tasks using any of ``resources`` (every motion task when None)."""
        if resources is None:
            return self._end_locked(
                [t for t in self._tasks if t.resources and "tts" not in t.resources], how
            )
        return self._end_locked([t for t in self._tasks if t.resources & resources], how)

    def _end_locked(self, killed: list[_Task], how: str) -> list[tuple[_Task, str]]:
        """Remove ``killed`` from the task list; their joints hold where they are."""
        if not killed:
            return []
        gone = {id(t) for t in killed}
        self._tasks = [t for t in self._tasks if id(t) not in gone]
        joints = sorted(
            {r for t in killed if t.started_at is not None for r in t.resources if r in self.specs}
        )
        if joints:
            self.model.set_targets(joints, self.model.positions(joints), 1.0)
        for task in killed:
            if task.finish is not None and task.started_at is not None:
                task.finish(False)
            self.record("end", task, ok=False, how="canceled" if how == "cancel" else "killed")
        self._start_ready_locked(self.model.time)
        return [(t, how) for t in killed]

    def busy_locked(self, resources: frozenset[str]) -> bool:
        """True while a task (running or waiting) holds any of ``resources``."""
        return any(t.resources & resources for t in self._tasks)

    def motion_tasks_locked(self) -> list[list[Any]]:
        return [[t.name, t.id] for t in self._tasks if t.resources and "tts" not in t.resources]

    def _cancel(self, task_id: int) -> None:
        """A client cancelled its call: end that task only."""
        with self.lock:
            done = self._end_locked([t for t in self._tasks if t.id == task_id], "cancel")
        self._settle(done)

    @staticmethod
    def _settle(done: list[tuple[_Task, str]]) -> None:
        """Complete promises outside the lock (their continuations may call back into us)."""
        for task, how in done:
            if task.promise.future().isFinished():
                continue
            if how == "cancel":
                task.promise.setCanceled()
            else:
                task.promise.setValue(task.value)

    def settle(self, done: list[tuple[_Task, str]]) -> None:
        """Public alias of the promise completion step for the services."""
        self._settle(done)

    def record(self, event: str, task: _Task, **extra: Any) -> None:
        """Write one JSONL line (lock held)."""
        if self._log_file is None:
            return
        rec = {
            "event": event,
            "call": task.name,
            "id": task.id,
            "t": round(self.model.time, 6),
            "mono": time.monotonic(),
            **task.info,
            **extra,
        }
        self._log_file.write(json.dumps(rec) + "\n")

    # -- joints ----------------------------------------------------------------------------
    def expand(self, names: object, method: str) -> list[str]:
        """Joint, chain or group name(s) to joint names; raises for unknown names."""
        if isinstance(names, str):
            items = [names]
        elif _is_seq(names) and all(isinstance(n, str) for n in names):
            items = list(names)
        else:
            raise TypeError(f"ALMotion.{method}: names must be a string or a list of strings")
        out: list[str] = []
        for n in items:
            if n in self.specs:
                out.append(n)
            elif n in GROUPS and n != "Chains":
                out.extend(GROUPS[n])
            else:
                known = list(self.specs) + list(GROUPS)
                raise ValueError(
                    f"ALMotion.{method}: unknown joint or chain '{n}'" + did_you_mean(n, known)
                )
        return out

    def stiff(self, names: Sequence[str]) -> list[int]:
        """Indices of the joints that are powered (commands to the others are ignored)."""
        return [i for i, n in enumerate(names) if self.stiffness[n] > 0.0]


def _per_joint(values: object, n: int, what: str, method: str) -> list[list[float]]:
    """NAOqi's shapes for angle/time lists → one list per joint.

    A scalar (one joint), a flat list (one value per joint; for a single joint, its keyframes),
    or a list of lists. A flat list of length k with n > 1 joints and k != n is rejected.
    """
    if not _is_seq(values):
        if n != 1:
            raise ValueError(f"ALMotion.{method}: one {what} for {n} joints")
        return [[_num(values, what)]]
    seq = list(values)
    if n == 1 and all(not _is_seq(v) for v in seq):
        return [[_num(v, what) for v in seq]]
    if len(seq) != n:
        raise ValueError(f"ALMotion.{method}: {len(seq)} {what} lists for {n} joints")
    return [[_num(x, what) for x in v] if _is_seq(v) else [_num(v, what)] for v in seq]


#: A segment counts as too fast when its peak speed exceeds the joint's limit by this share.
SPEED_TOL = 1e-6


@dataclass(frozen=True)
class KeyframePlan:
    """What ``angleInterpolation`` plays once NAO's rules are applied (:func:`plan_keyframes`).

    Attributes:
        joints: the joints moved: the call's, plus the other HipYawPitch when one was given.
        angles: per joint, absolute angles after clipping.
        times: per joint, key times in seconds from the start (spread out where too fast).
        asked_s: the last key time asked.
        duration_s: the last key time played (``asked_s`` unless the motion was slowed down).
        capped: the segment furthest over its joint's velocity limit, as (joint, speed asked,
            limit) in rad/s (hands: fraction/s); None when every segment is within its limit.
    """

    joints: tuple[str, ...]
    angles: tuple[tuple[float, ...], ...]
    times: tuple[tuple[float, ...], ...]
    asked_s: float
    duration_s: float
    capped: tuple[str, float, float] | None = None


def min_segment_time(distance: float, velocity: float) -> float:
    """The shortest segment that moves ``distance`` with a peak speed of at most ``velocity``.

    Segments follow :mod:`prezence.feedback.trajectory`'s profile, whose peak over a segment of
    duration ``T`` is ``|distance| / (T − min(RAMP_S, T/2))``.

    Example:
        >>> round(min_segment_time(2.0, 8.0), 3)  # 0.25 s at full speed, plus one ramp
        0.45
    """
    u = abs(distance) / velocity
    return 2.0 * u if u < RAMP_S else u + RAMP_S


def plan_keyframes(
    limits: JointLimits,
    joints: Sequence[str],
    angles: Sequence[Sequence[float]],
    times: Sequence[Sequence[float]],
    pose: dict[str, float],
) -> KeyframePlan:
    """NAO's rules applied to ``angleInterpolation`` keyframes, as ``setAngles`` applies them.

    * **One hip motor**: a HipYawPitch's keys go to both hips (LHipYawPitch wins when both are
      given, as on NAO).
    * **Limits**: every key is clipped with :meth:`JointLimits.clip` (``setAngles``' function);
      a HeadPitch key against the anti-collision range at the HeadYaw planned for its time (the
      call's HeadYaw keyframes, or the current HeadYaw when the call leaves it alone).
    * **Velocity limits**: a segment whose peak speed would exceed its joint's limit is not
      followed late: the stretch of the call's timeline under it is slowed down until it fits,
      i.e. each key time after it moves later and every joint keeps its keys in step with the
      others'. ``capped`` names the worst segment so the caller can warn.

    Args:
        limits: the joint limits.
        joints: joint names.
        angles: per joint, absolute angles, one per key time.
        times: per joint, strictly increasing key times (seconds from the start, > 0).
        pose: every body joint's angle now (each joint's first segment starts there).
    """
    keys = {j: (list(a), list(t)) for j, a, t in zip(joints, angles, times, strict=True)}
    left, right = HIP_YAW_PITCH
    if left in keys:
        keys[right] = keys[left]
    elif right in keys:
        keys[left] = keys[right]
    for j, (a, t) in keys.items():
        if j != "HeadPitch":
            keys[j] = ([limits.clip({j: x}, pose=pose)[j] for x in a], t)
    if "HeadPitch" in keys:
        a, t = keys["HeadPitch"]
        yaw = [pose["HeadYaw"]] * len(t)
        if "HeadYaw" in keys:
            ya, yt = keys["HeadYaw"]
            traj = Trajectory(
                "HeadYaw", ("HeadYaw",), tuple(yt), tuple((x,) for x in ya), (pose["HeadYaw"],)
            )
            yaw = [float(traj.sample(tk)[0]) for tk in t]
        keys["HeadPitch"] = (
            [
                limits.clip({"HeadPitch": x}, pose={**pose, "HeadYaw": y})["HeadPitch"]
                for x, y in zip(a, yaw, strict=True)
            ],
            t,
        )
    # velocity limits: slow down the stretches of the timeline under too fast segments
    grid = sorted({0.0, *(x for _, t in keys.values() for x in t)})
    slot = {x: i for i, x in enumerate(grid)}
    factor = [1.0] * (len(grid) - 1)
    capped: tuple[str, float, float] | None = None
    for j, (a, t) in keys.items():
        limit = limits.velocity[j]
        q0, t0 = pose[j], 0.0
        for q, tk in zip(a, t, strict=True):
            asked = abs(q - q0) * profile_peaks(tk - t0)[0]
            if asked > limit * (1.0 + SPEED_TOL):
                f = min_segment_time(q - q0, limit) / (tk - t0)
                for i in range(slot[t0], slot[tk]):
                    factor[i] = max(factor[i], f)
                if capped is None or asked / limit > capped[1] / capped[2]:
                    capped = (j, asked, limit)
            q0, t0 = q, tk
    played = [0.0]
    for i, f in enumerate(factor):
        played.append(played[-1] + (grid[i + 1] - grid[i]) * f)
    when = dict(zip(grid, played, strict=True))
    return KeyframePlan(
        joints=tuple(keys),
        angles=tuple(tuple(a) for a, _ in keys.values()),
        times=tuple(tuple(when[x] for x in t) for _, t in keys.values()),
        asked_s=grid[-1],
        duration_s=played[-1],
        capped=capped,
    )


class ALMotion:
    """ALMotion on the virtual NAO (joint control, stiffness, motion tasks)."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    # -- reactive ----------------------------------------------------------------------------
    def setAngles(self, names: object, angles: object, fractionMaxSpeed: object) -> None:
        """Non-blocking: retarget joints at fractionMaxSpeed × their velocity limit."""
        self._set("setAngles", names, angles, fractionMaxSpeed, relative=False)

    def changeAngles(self, names: object, changes: object, fractionMaxSpeed: object) -> None:
        """Non-blocking: like setAngles, relative to the current angles."""
        self._set("changeAngles", names, changes, fractionMaxSpeed, relative=True)

    @qi.nobind
    def _set(
        self, method: str, names: object, angles: object, frac: object, *, relative: bool
    ) -> None:
        r = self._r
        joints = r.expand(names, method)
        values = (
            [_num(a, "angle") for a in angles]
            if _is_seq(angles)
            else [_num(angles, "angle")] * (1 if len(joints) == 1 else 0)
        )
        if len(values) != len(joints):
            raise ValueError(f"ALMotion.{method}: {len(values)} angles for {len(joints)} joints")
        fracs = [_num(f, "fractionMaxSpeed") for f in frac] if _is_seq(frac) else None
        if fracs is not None and len(fracs) != len(joints):
            raise ValueError(f"ALMotion.{method}: {len(fracs)} speeds for {len(joints)} joints")
        speeds = fracs or [_num(frac, "fractionMaxSpeed")] * len(joints)
        if any(not f > 0.0 for f in speeds):
            raise ValueError(f"ALMotion.{method}: fractionMaxSpeed must be > 0")
        speeds = [min(f, 1.0) for f in speeds]
        with r.lock:
            pose = dict(zip(BODY, r.model.positions(list(BODY)), strict=True))
            if relative:
                values = [v + pose[j] for v, j in zip(values, joints, strict=True)]
            wanted = {j: v for j, v in zip(joints, values, strict=True) if r.stiffness[j] > 0.0}
            if not wanted:
                return
            speed_of = dict(zip(joints, speeds, strict=True))
            # NAOqi clips to the ranges, applies head anti-collision and the one-motor hip rule
            clipped = r.limits.clip(wanted, pose=pose)
            names_k = list(clipped)
            r.model.set_targets(
                names_k,
                [clipped[n] for n in names_k],
                [speed_of.get(n, max(speeds)) for n in names_k],
            )
            r.commanded.update(clipped)

    # -- animation (blocking) ------------------------------------------------------------------
    def angleInterpolation(
        self,
        names: object,
        angleLists: object,
        timeLists: object,
        isAbsolute: object,
    ) -> Any:
        """Blocking: follow timed keyframes (seconds from the call's start).

        Keyframes are clipped like ``setAngles`` targets and slowed down where too fast for a
        joint's velocity limit (:func:`plan_keyframes`); the call returns at the last key time
        played, with one warning when it had to slow down.
        """
        r = self._r
        joints = r.expand(names, "angleInterpolation")
        angles = _per_joint(angleLists, len(joints), "angle", "angleInterpolation")
        times = _per_joint(timeLists, len(joints), "time", "angleInterpolation")
        for j, a, t in zip(joints, angles, times, strict=True):
            if len(a) != len(t):
                raise ValueError(
                    f"ALMotion.angleInterpolation: {j}: {len(a)} angles, {len(t)} times"
                )
            if not t or any(not b > a_ for a_, b in zip([0.0, *t], t, strict=False)):
                raise ValueError(
                    f"ALMotion.angleInterpolation: {j}: times must increase from > 0, got {t}"
                )
        absolute = bool(isAbsolute)
        info: dict[str, Any] = {"joints": joints}

        def begin(now: float) -> float:
            pose = dict(zip(BODY, r.model.positions(list(BODY)), strict=True))
            stiff = [k for k, j in enumerate(joints) if r.stiffness[j] > 0.0]
            if not stiff:
                return max(t[-1] for t in times)
            plan = plan_keyframes(
                r.limits,
                [joints[k] for k in stiff],
                [[a + (0.0 if absolute else pose[joints[k]]) for a in angles[k]] for k in stiff],
                [times[k] for k in stiff],
                pose,
            )
            if plan.capped is not None:
                joint, asked, limit = plan.capped
                log.warning(
                    "ALMotion.angleInterpolation: %s asked for %.3g rad/s, over its limit of "
                    "%.3g rad/s; slowed down to the limit: %.2f s instead of %.2f s",
                    joint,
                    asked,
                    limit,
                    plan.duration_s,
                    plan.asked_s,
                )
                info.update(asked_s=plan.asked_s, capped=joint, asked_speed=round(asked, 6))
            info["planned_s"] = round(plan.duration_s, 6)
            groups: dict[tuple[float, ...], list[int]] = {}
            for k, j in enumerate(plan.joints):
                if r.stiffness[j] > 0.0:
                    groups.setdefault(plan.times[k], []).append(k)
            for ts, ks in groups.items():
                names_g = tuple(plan.joints[k] for k in ks)
                pos = tuple(tuple(plan.angles[k][i] for k in ks) for i in range(len(ts)))
                traj = Trajectory(
                    "angleInterpolation", names_g, ts, pos, tuple(pose[n] for n in names_g)
                )
                r.model.follow(traj, start=now)
                r.commanded.update(zip(names_g, pos[-1], strict=True))
            return plan.duration_s

        return r.submit("angleInterpolation", frozenset(joints), begin, info=info)

    def angleInterpolationWithSpeed(
        self,
        names: object,
        targetAngles: object,
        maxSpeedFraction: object,
    ) -> Any:
        """Blocking: move to one target per joint at maxSpeedFraction × the velocity limits."""
        r = self._r
        joints = r.expand(names, "angleInterpolationWithSpeed")
        targets = [
            v[0]
            for v in _per_joint(targetAngles, len(joints), "angle", "angleInterpolationWithSpeed")
        ]
        frac = _num(maxSpeedFraction, "maxSpeedFraction")
        if not frac > 0:
            raise ValueError("ALMotion.angleInterpolationWithSpeed: maxSpeedFraction must be > 0")
        return self._move_to("angleInterpolationWithSpeed", joints, targets, min(frac, 1.0))

    @qi.nobind
    def _move_to(
        self, call: str, joints: list[str], targets: list[float], frac: float, value: Any = None
    ) -> Any:
        """A blocking move to targets that returns when the joints have arrived (NAOqi's
        ``angleInterpolationWithSpeed``): no earlier than the speed-capped estimate, and as
        soon as the joints are within 0.01 rad of the goal or have stopped moving."""
        r = self._r
        state: dict[str, Any] = {}

        def begin(now: float) -> float:
            keep = [i for i, j in enumerate(joints) if r.stiffness[j] > 0.0]
            if not keep:
                return 0.0
            pose = dict(zip(BODY, r.model.positions(list(BODY)), strict=True))
            # NAOqi clips to the ranges, applies head anti-collision and the one-motor hip rule
            clipped = r.limits.clip({joints[i]: targets[i] for i in keep}, pose=pose)
            names_k = [n for n in clipped if r.stiffness[n] > 0.0]
            goal = [clipped[n] for n in names_k]
            cur = [pose[n] for n in names_k]
            r.model.set_targets(names_k, goal, frac)
            r.commanded.update(zip(names_k, goal, strict=True))
            estimate = max(
                abs(g - q) / (frac * r.specs[n].velocity)
                for n, g, q in zip(names_k, goal, cur, strict=True)
            )
            state.update(names=names_k, goal=np.asarray(goal), last=np.asarray(cur))
            return estimate

        def arrived() -> bool:
            if not state:
                return True
            q = np.asarray(r.model.positions(state["names"]))
            still = float(np.max(np.abs(q - state["last"]))) < 1e-4
            state["last"] = q
            return still or float(np.max(np.abs(q - state["goal"]))) < 0.01

        return r.submit(
            call,
            frozenset(joints),
            begin,
            value=value,
            info={"joints": joints},
            arrived=arrived,
            grace_s=2.0,  # the physics may lag the estimate; never hang for ever
        )

    def openHand(self, handName: str) -> Any:
        """Blocking: open ``LHand`` or ``RHand``."""
        return self._hand("openHand", handName, 1.0)

    def closeHand(self, handName: str) -> Any:
        """Blocking: close ``LHand`` or ``RHand``."""
        return self._hand("closeHand", handName, 0.0)

    @qi.nobind
    def _hand(self, call: str, hand: object, value: float) -> Any:
        if hand not in ("LHand", "RHand"):
            raise ValueError(f"ALMotion.{call}: expected 'LHand' or 'RHand', got {hand!r}")
        return self._move_to(call, [str(hand)], [value], 0.5)

    # -- reading -------------------------------------------------------------------------------
    @qi.bind(qi.List(qi.Float), (qi.Dynamic, qi.Bool), "getAngles")
    def getAngles(self, names: object, useSensors: bool) -> list[float]:
        """Measured angles (useSensors) or the last commanded ones; float32 like the robot."""
        r = self._r
        joints = r.expand(names, "getAngles")
        with r.lock:
            if useSensors:
                return r.model.positions(joints)
            return [r.commanded.get(j, 0.0) for j in joints]

    @qi.bind(qi.List(qi.List(qi.Float)), (qi.String,), "getLimits")
    def getLimits(self, name: str) -> list[list[float]]:
        """``[[min, max, maxVelocity, maxTorque], …]``, one inner list per joint."""
        r = self._r
        return [
            [s.lower, s.upper, s.velocity, s.effort]
            for s in (r.specs[j] for j in r.expand(name, "getLimits"))
        ]

    def getBodyNames(self, name: str) -> list[str]:
        """Joint names of a joint, chain or group (``"Chains"`` lists the chains)."""
        if name == "Chains":
            return list(GROUPS["Chains"])
        return self._r.expand(name, "getBodyNames")

    def getJointNames(self, name: str) -> list[str]:
        """Deprecated alias of getBodyNames."""
        return self.getBodyNames(name)

    def getMotionCycleTime(self) -> int:
        """ALMotion's cycle, in ms (NAOqi: 20)."""
        return 20

    # -- stiffness and life cycle ------------------------------------------------------------------
    def setStiffnesses(self, names: object, stiffnesses: object) -> None:
        """Set stiffness 0..1 (a scalar for all, or one per joint)."""
        r = self._r
        joints = r.expand(names, "setStiffnesses")
        values = (
            [_num(s, "stiffness") for s in stiffnesses]
            if _is_seq(stiffnesses)
            else [_num(stiffnesses, "stiffness")] * len(joints)
        )
        if len(values) != len(joints):
            raise ValueError(
                f"ALMotion.setStiffnesses: {len(values)} values for {len(joints)} joints"
            )
        with r.lock:
            for j, v in zip(joints, values, strict=True):
                r.stiffness[j] = min(max(v, 0.0), 1.0)

    def stiffnessInterpolation(
        self, names: object, stiffnessLists: object, timeLists: object
    ) -> Any:
        """Blocking: reach the last stiffness of each list after its last time (stepwise here)."""
        r = self._r
        joints = r.expand(names, "stiffnessInterpolation")
        values = _per_joint(stiffnessLists, len(joints), "stiffness", "stiffnessInterpolation")
        times = _per_joint(timeLists, len(joints), "time", "stiffnessInterpolation")

        def begin(now: float) -> float:
            for j, v in zip(joints, values, strict=True):
                r.stiffness[j] = min(max(v[-1], 0.0), 1.0)
            return max(t[-1] for t in times)

        return r.submit("stiffnessInterpolation", frozenset(), begin)

    def getStiffnesses(self, names: object) -> list[float]:
        r = self._r
        joints = r.expand(names, "getStiffnesses")
        with r.lock:
            return [r.stiffness[j] for j in joints]

    def wakeUp(self) -> None:
        """Motors on (the simulated NAO already stands)."""
        with self._r.lock:
            for j in self._r.stiffness:
                self._r.stiffness[j] = 1.0

    @qi.bind(qi.Dynamic, (), "rest")
    def rest0(self) -> None:
        """Kill the motion tasks and switch every motor off."""
        self._rest("Body")

    @qi.bind(qi.Dynamic, (qi.String,), "rest")
    def rest1(self, chain: str) -> None:
        """Switch one chain's motors off."""
        self._rest(chain)

    @qi.nobind
    def _rest(self, chain: str) -> None:
        r = self._r
        joints = r.expand(chain, "rest")
        with r.lock:
            done = r.kill_locked(frozenset(joints))
            for j in joints:
                r.stiffness[j] = 0.0
        r.settle(done)

    def robotIsWakeUp(self) -> bool:
        with self._r.lock:
            return any(v > 0.0 for v in self._r.stiffness.values())

    # -- tasks ---------------------------------------------------------------------------------
    def killAll(self) -> None:
        """Kill every motion task (their blocking calls return)."""
        r = self._r
        with r.lock:
            done = r.kill_locked(None)
        r.settle(done)

    def killTasksUsingResources(self, resourceNames: object) -> None:
        """Kill the motion tasks that hold any of these joints."""
        r = self._r
        joints = frozenset(r.expand(resourceNames, "killTasksUsingResources"))
        with r.lock:
            done = r.kill_locked(joints)
        r.settle(done)

    def areResourcesAvailable(self, resourceNames: object) -> bool:
        r = self._r
        joints = frozenset(r.expand(resourceNames, "areResourcesAvailable"))
        with r.lock:
            return not r.busy_locked(joints)

    def getTaskList(self) -> list[list[Any]]:
        """``[[name, id], …]`` for the motion tasks running or waiting."""
        r = self._r
        with r.lock:
            return r.motion_tasks_locked()

    # -- idle animations (no-ops here, remembered for the getters) -----------------------------
    def setBreathEnabled(self, chainName: str, isEnabled: bool) -> None:
        self._r.expand(chainName, "setBreathEnabled")
        self._r.breath[chainName] = bool(isEnabled)

    def getBreathEnabled(self, chainName: str) -> bool:
        return self._r.breath.get(chainName, False)

    def setIdlePostureEnabled(self, chainName: str, isEnabled: bool) -> None:
        self._r.expand(chainName, "setIdlePostureEnabled")
        self._r.idle_posture[chainName] = bool(isEnabled)

    def getIdlePostureEnabled(self, chainName: str) -> bool:
        return self._r.idle_posture.get(chainName, False)


class ALTextToSpeech:
    """ALTextToSpeech on the virtual NAO: ``say`` takes as long as the planner's estimate."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    @qi.bind(qi.Dynamic, (qi.String,), "say")
    def say1(self, text: str) -> Any:
        """Blocking: say ``text`` (queued after the sentence being spoken)."""
        return self._say(text, self._r.language)

    @qi.bind(qi.Dynamic, (qi.String, qi.String), "say")
    def say2(self, text: str, language: str) -> Any:
        """Blocking: say ``text`` in ``language``."""
        return self._say(text, language)

    @qi.nobind
    def _say(self, text: object, language: str) -> Any:
        if not isinstance(text, str):
            raise TypeError(f"ALTextToSpeech.say: text must be a string, got {text!r}")
        r = self._r
        plain = _TTS_TAG.sub(" ", text)
        duration = estimate_speech_s(plain) * 100.0 / max(r.tts_params["speed"], 1.0)
        say_log.info("say (%s, %.1f s): %s", language, duration, " ".join(plain.split()))

        def begin(now: float) -> float:
            r.memory["ALTextToSpeech/TextStarted"] = 1
            r.memory["ALTextToSpeech/CurrentSentence"] = text
            return duration

        def finish(ok: bool) -> None:
            r.memory["ALTextToSpeech/TextStarted"] = 0
            r.memory["ALTextToSpeech/TextDone" if ok else "ALTextToSpeech/TextInterrupted"] = 1

        return r.submit(
            "say",
            frozenset({"tts"}),
            begin,
            finish=finish,
            info={"text": text, "language": language, "planned_s": round(duration, 6)},
        )

    def stopAll(self) -> None:
        """Stop the sentence being said and drop the queued ones."""
        r = self._r
        with r.lock:
            done = r.kill_locked(frozenset({"tts"}))
        r.settle(done)

    def setVolume(self, volume: object) -> None:
        """0.0 … 1.0."""
        v = _num(volume, "volume")
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"ALTextToSpeech.setVolume: volume must be in 0..1, got {v}")
        self._r.tts_params["volume"] = v

    def getVolume(self) -> float:
        """0 … 100, as NAOqi describes it."""
        return self._r.tts_params["volume"] * 100.0

    def setParameter(self, parameter: str, value: object) -> None:
        """``speed`` (percent; 50–400 accepted here), ``pitchShift``, ``doubleVoice``…"""
        v = _num(value, parameter)
        if parameter == "speed" and not 50.0 <= v <= 400.0:
            raise ValueError(f"ALTextToSpeech.setParameter: speed must be in 50..400, got {v}")
        self._r.tts_params[str(parameter)] = v

    def getParameter(self, parameter: str) -> float:
        try:
            return self._r.tts_params[parameter]
        except KeyError:
            raise ValueError(
                f"ALTextToSpeech.getParameter: unknown parameter '{parameter}'"
            ) from None

    def resetSpeed(self) -> None:
        self._r.tts_params["speed"] = 100.0

    def setLanguage(self, language: str) -> None:
        if language not in self.getAvailableLanguages():
            raise ValueError(f"ALTextToSpeech.setLanguage: language '{language}' is not installed")
        self._r.language = language

    def getLanguage(self) -> str:
        return self._r.language

    def getAvailableLanguages(self) -> list[str]:
        return ["English", "French", "German", "Spanish", "Italian", "Japanese", "Chinese"]


class ALLeds:
    """ALLeds on the virtual NAO: remembers each group's colour; fades take their duration."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    def fadeRGB(self, *args: Any) -> Any:
        """Blocking fade.

        Forms: ``(name, 0xRRGGBB, secs)``, ``(name, colorName, secs)``, ``(name, r, g, b, secs)``.
        """
        if len(args) == 3:
            name, color, duration = args
            if isinstance(color, str):
                if color not in LED_COLORS:
                    raise ValueError(
                        f"ALLeds.fadeRGB: unknown colour '{color}'"
                        + did_you_mean(color, LED_COLORS)
                    )
                rgb = LED_COLORS[color]
            else:
                rgb = int(_num(color, "rgb"))
        elif len(args) == 5:
            name, red, green, blue, duration = args
            ch = [min(max(_num(c, "channel"), 0.0), 1.0) for c in (red, green, blue)]
            rgb = (round(ch[0] * 255) << 16) | (round(ch[1] * 255) << 8) | round(ch[2] * 255)
        else:
            raise TypeError(f"ALLeds.fadeRGB: expected 3 or 5 arguments, got {len(args)}")
        self._check(name)
        secs = _num(duration, "duration")
        r = self._r

        def begin(now: float) -> float:
            r.leds[name] = rgb & 0xFFFFFF
            return max(secs, 0.0)

        return r.submit("fadeRGB", frozenset(), begin, info={"group": name, "rgb": rgb})

    @qi.nobind
    def _check(self, name: object) -> None:
        if name not in LED_GROUPS:
            raise ValueError(
                f"ALLeds: unknown LED group {name!r}" + did_you_mean(str(name), LED_GROUPS)
            )

    def getColor(self, name: str) -> int:
        """The group's colour as 0x00RRGGBB (virtual NAO only: a test hook)."""
        self._check(name)
        return self._r.leds[name]

    def reset(self, name: str) -> None:
        self._check(name)
        self._r.leds[name] = 0xFFFFFF

    def listGroups(self) -> list[str]:
        return sorted(LED_GROUPS)


class ALRobotPosture:
    """ALRobotPosture on the virtual NAO (approximate postures, see :data:`POSTURES`)."""

    def __init__(self, robot: VirtualNao, motion: ALMotion) -> None:
        self._r = robot
        self._motion = motion

    def goToPosture(self, postureName: str, maxSpeedFraction: object) -> Any:
        """Blocking: move every joint of the posture; returns True when reached."""
        pose = self._pose(postureName)
        frac = _num(maxSpeedFraction, "maxSpeedFraction")
        if not frac > 0:
            raise ValueError("ALRobotPosture.goToPosture: maxSpeedFraction must be > 0")
        self._r.posture = postureName
        return self._motion._move_to(
            "goToPosture", list(pose), list(pose.values()), min(frac, 1.0), True
        )

    def applyPosture(self, postureName: str, maxSpeedFraction: object) -> Any:
        return self.goToPosture(postureName, maxSpeedFraction)

    @qi.nobind
    def _pose(self, name: object) -> dict[str, float]:
        if name not in POSTURES:
            raise ValueError(
                f"ALRobotPosture: unknown posture {name!r}" + did_you_mean(str(name), POSTURES)
            )
        return POSTURES[str(name)]

    def getPostureList(self) -> list[str]:
        return list(POSTURES)

    def getPosture(self) -> str:
        return self._r.posture


class ALMemory:
    """A minimal ALMemory: a key-value store (the TTS writes its events here)."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    def getData(self, key: str) -> Any:
        try:
            return self._r.memory[key]
        except KeyError:
            raise KeyError(f"ALMemory.getData: data not found: '{key}'") from None

    def insertData(self, key: str, value: Any) -> None:
        self._r.memory[str(key)] = value

    def getListData(self, keys: list[str]) -> list[Any]:
        return [self._r.memory.get(k) for k in keys]

    def getDataList(self, filter: str) -> list[str]:
        return sorted(k for k in self._r.memory if filter in k)

    def raiseEvent(self, name: str, value: Any) -> None:
        self._r.memory[str(name)] = value


# -- serving -------------------------------------------------------------------------------------


class VirtualNaoServer:
    """A running virtual NAO: a standalone qi session with the services registered.

    Attributes:
        url: where clients connect (``tcp://127.0.0.1:PORT``; the real port when 0 was asked).
        robot: the simulated robot behind the services.
    """

    def __init__(self, session: Any, robot: VirtualNao, url: str) -> None:
        self.session = session
        self.robot = robot
        self.url = url
        self._closed = False

    def close(self) -> None:
        """Disconnect the clients, stop the clock and the model; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self.session.close()
        self.robot.stop()

    def __enter__(self) -> VirtualNaoServer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def serve(
    host: str = "127.0.0.1",
    port: int = 9559,
    gui: bool = False,
    *,
    speech_log: Path | str | None = None,
    model: str = "pybullet",
    rate_hz: float = 100.0,
) -> VirtualNaoServer:
    """Start a virtual NAO listening on ``tcp://host:port`` (port 0 picks a free one).

    Args:
        host: address to listen on.
        port: TCP port; 0 picks a free one (see the returned server's ``url``).
        gui: show the PyBullet window (``model="pybullet"`` only).
        speech_log: JSONL file that records every phrase said and every motion (start and
            end), appended to; None records nothing. The phrases are logged at INFO on
            :data:`SPEECH_LOGGER` either way.
        model: ``"pybullet"`` (the PyBullet NAO) or ``"kinematic"`` (no physics).
        rate_hz: rate of the real-time clock loop.

    Raises:
        ValueError: an unknown model or a port out of range.
        RuntimeError: the port is taken (libqi's "Address already in use").
    """
    if not 0 <= port <= 65535:
        raise ValueError(f"port must be in 0..65535, got {port}")
    robot = VirtualNao(model=model, gui=gui, speech_log=speech_log, rate_hz=rate_hz)
    robot.start()
    session = qi.Session()
    try:
        session.listenStandalone(f"tcp://{host}:{port}")
        motion = ALMotion(robot)
        session.registerService("ALMotion", motion)
        session.registerService("ALTextToSpeech", ALTextToSpeech(robot))
        session.registerService("ALLeds", ALLeds(robot))
        session.registerService("ALRobotPosture", ALRobotPosture(robot, motion))
        session.registerService("ALMemory", ALMemory(robot))
    except RuntimeError:
        session.close()
        robot.stop()
        raise
    url = next((e for e in session.endpoints() if e.startswith("tcp://")), session.endpoints()[0])
    log.info("virtual NAO listening on %s (model %s)", url, model)
    return VirtualNaoServer(session, robot, url)


def spawn(*args: str, timeout_s: float = 60.0) -> tuple[subprocess.Popen[str], str]:
    """Start ``python -m sim.virtual_nao ARGS`` in another process; return it and its URL.

    Use ``--port 0`` to let the OS pick a free port. Stop it with ``proc.terminate()``.

    Raises:
        RuntimeError: it did not print its ``listening on`` line within ``timeout_s``.
    """
    proc = subprocess.Popen(
        [sys.executable, "-m", "sim.virtual_nao", *args],
        cwd=Path(__file__).resolve().parents[2],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    lines: queue.Queue[str] = queue.Queue()
    out = proc.stdout
    assert out is not None  # noqa: S101 - stdout=PIPE

    def pump() -> None:
        for x in out:
            lines.put(x)

    threading.Thread(target=pump, daemon=True).start()
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            line = lines.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            break
        if line.startswith("listening on "):
            return proc, line.split()[-1]
    proc.kill()
    proc.wait()
    raise RuntimeError("the virtual NAO did not start")


def stop_spawned(proc: subprocess.Popen[str], *, kill: bool = False) -> None:
    """Stop a virtual NAO started with :func:`spawn` (SIGTERM, or SIGKILL: a robot lost)."""
    if proc.poll() is None:
        proc.kill() if kill else proc.terminate()
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    if proc.stdout is not None:
        proc.stdout.close()


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="python -m sim.virtual_nao", description="Serve a virtual NAO over the NAOqi protocol."
    )
    p.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    p.add_argument("--port", type=int, default=9559, help="0 picks a free port (default 9559)")
    p.add_argument("--gui", action="store_true", help="show the PyBullet window")
    p.add_argument("--model", choices=("pybullet", "kinematic"), default="pybullet")
    p.add_argument("--speech-log", type=Path, help="JSONL record of speech and motions")
    p.add_argument("--rate", type=float, default=100.0, help="clock loop rate in Hz")
    p.add_argument("-v", "--verbose", action="store_true", help="show libqi's and our info logs")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Serve until SIGTERM or Ctrl-C; prints ``listening on URL`` first (flushed).

    The phrases said are logged on stderr (``SPEECH_LOGGER`` at INFO) unless the root logger is
    quieter than WARNING.
    """
    args = build_parser().parse_args(argv)
    # libqi logs to stdout; keep stdout for the "listening on" line unless asked
    qi.logging.setLevel(qi.logging.INFO if args.verbose else qi.logging.ERROR)
    if not logging.getLogger().handlers:
        logging.basicConfig(
            level=logging.INFO if args.verbose else logging.WARNING,
            format="%(levelname)s %(name)s: %(message)s",
            stream=sys.stderr,
        )
    if logging.getLogger().getEffectiveLevel() <= logging.WARNING:
        # the robot has no voice here: show what it says unless logging was made quieter
        logging.getLogger(SPEECH_LOGGER).setLevel(logging.INFO)
    stop = threading.Event()

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGTERM, signal.SIGINT)}
    try:
        server = serve(
            args.host,
            args.port,
            args.gui,
            speech_log=args.speech_log,
            model=args.model,
            rate_hz=args.rate,
        )
    except (RuntimeError, OSError) as e:  # port taken; speech log not writable
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        print(f"listening on {server.url}", flush=True)
        while not stop.wait(0.5):
            pass
    finally:
        server.close()
        for s, h in previous.items():
            signal.signal(s, h)
    return 0


if __name__ == "__main__":
    sys.exit(main())
