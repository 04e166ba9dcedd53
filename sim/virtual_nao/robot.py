"""The virtual NAO's robot: NAOqi's body names, the model behind the services (the PyBullet NAO
or :class:`KinematicNao`) and :class:`VirtualNao`, which owns the clock, the motion tasks and the
speech queue (see the package's docstring for the semantics and the real-time loop).
"""

from __future__ import annotations

import itertools
import json
import math
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any, Protocol, TypeGuard

import numpy as np
import qi

from prezence.errors import did_you_mean
from prezence.feedback.limits import (
    BODY_ORDER,
    CHAINS,
    JointLimit,
    JointLimits,
    load_limits,
)
from prezence.feedback.trajectory import Trajectory

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
