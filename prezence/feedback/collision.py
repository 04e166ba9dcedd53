"""Self-collision of planned gestures, measured with the URDF's own collision shapes in PyBullet.

Position limits say nothing about the robot's body: two keyframes can each be within every joint
range and still put one hand inside the other, or a forearm into the chest. A real NAO cannot
reach such a pose (its shell stops it, or its joints stall against each other), so the gesture
would not look as planned. :class:`SelfCollisionChecker` loads the project's URDF in a headless
PyBullet client and measures, for a pose or along a whole planned trajectory (sampled every
``SAMPLE_DT``), the smallest signed distance between any two links that are not **adjacent**:
two links are adjacent when one is the other's nearest ancestor that has a collision shape
(e.g. ``LForeArm`` and ``LBicep``, across the shapeless ``LElbow``); they touch at their joint
by construction. ``torso`` and ``LForeArm`` are not adjacent, so a forearm in the chest counts.

The shapes are the URDF's primitives (boxes, cylinders, spheres), a few millimetres larger or
smaller than NAO's shell in places; :data:`MIN_CLEARANCE_M` is the margin a gesture keeps.

PyBullet is an optional dependency (the ``sim`` extra): this module imports it only inside
:class:`SelfCollisionChecker`; :func:`pybullet_available` says whether it can.

Example:
    >>> from prezence.feedback.gestures import build_trajectory
    >>> from prezence.feedback.limits import load_limits
    >>> lim = load_limits()
    >>> with SelfCollisionChecker(limits=lim) as checker:  # doctest: +SKIP
    ...     c = checker.trajectory_clearance(build_trajectory("summary", speed_fraction=0.6,
    ...                                                        limits=lim))
    >>> c.distance_m >= MIN_CLEARANCE_M  # doctest: +SKIP
    True
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import json
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import TracebackType
from typing import Any

import numpy as np

from prezence.errors import BackendUnavailable, GestureCheckFailed, LimitViolation
from prezence.feedback.gestures import (
    DEFAULT_SPEED_FRACTION,
    GESTURES_FILE,
    GestureLibrary,
    build_trajectory,
    load_library,
)
from prezence.feedback.limits import JointLimits, load_limits
from prezence.feedback.trajectory import Trajectory

#: The least distance (m) two non-adjacent links of a planned gesture must keep.
MIN_CLEARANCE_M = 0.005
#: Time between the checked poses of a trajectory (s). The distance between two links is
#: smooth near its minimum, so sampling misses that minimum by well under a millimetre.
SAMPLE_DT = 0.01
#: Pairs further apart than this (m) are not measured (the whole robot fits well within it).
_SEARCH_M = 1.0
#: A first, cheaper search radius (m); the full one is used only when no pair is this close.
_NEAR_M = 0.05

log = logging.getLogger(__name__)


def pybullet_available() -> bool:
    """Whether PyBullet can be imported (without importing it)."""
    return importlib.util.find_spec("pybullet") is not None


@dataclass(frozen=True)
class Clearance:
    """The closest two non-adjacent links come, in a pose or along a motion.

    Attributes:
        distance_m: the smallest signed distance between their collision shapes (m); negative
            when the shapes overlap by that much.
        links: the two links (URDF link names, e.g. ``l_wrist``, ``r_wrist``).
        time_s: when along the trajectory (None for a single pose).
    """

    distance_m: float
    links: tuple[str, str]
    time_s: float | None = None

    @property
    def mm(self) -> float:
        """``distance_m`` in millimetres."""
        return 1000.0 * self.distance_m

    def describe(self) -> str:
        """E.g. ``"-18.5 mm between l_wrist and r_wrist at 1.60 s"``."""
        when = f" at {self.time_s:.2f} s" if self.time_s is not None else ""
        return f"{self.mm:.1f} mm between {self.links[0]} and {self.links[1]}{when}"


class SelfCollisionChecker:
    """A headless PyBullet client holding the NAO, for clearance queries (see the module doc).

    Joints a query does not name stay at the gesture library's neutral pose. Use it as a
    context manager, or call :meth:`close`.

    Args:
        limits: joint limits; their URDF (``limits.source``) is the one loaded.
        library: the gesture library whose neutral pose is the base pose (default built-in).

    Raises:
        BackendUnavailable: PyBullet is not installed (names the extra to install).
    """

    def __init__(
        self, *, limits: JointLimits | None = None, library: GestureLibrary | None = None
    ) -> None:
        try:
            import pybullet
        except ModuleNotFoundError as e:
            raise BackendUnavailable(
                'the self-collision check needs pybullet: pip install "prezence[sim]"'
            ) from e
        self._p: Any = pybullet
        self.limits = limits if limits is not None else load_limits()
        lib = library if library is not None else load_library(self.limits)
        self.neutral: dict[str, float] = dict(lib.neutral)
        p = self._p
        cid = int(p.connect(p.DIRECT))
        try:
            self._robot = p.loadURDF(
                str(self.limits.source), [0, 0, 0], useFixedBase=True, physicsClientId=cid
            )
        except Exception:
            p.disconnect(cid)
            raise
        self._cid: int | None = cid
        self._index: dict[str, int] = {}
        self.link_names: dict[int, str] = {}
        parent: dict[int, int] = {}
        for i in range(p.getNumJoints(self._robot, physicsClientId=cid)):
            info = p.getJointInfo(self._robot, i, physicsClientId=cid)
            self._index[info[1].decode()] = i
            self.link_names[i] = info[12].decode()
            parent[i] = int(info[16])
        shaped = {
            i
            for i in self.link_names
            if p.getCollisionShapeData(self._robot, i, physicsClientId=cid)
        }
        adjacent: set[tuple[int, int]] = set()
        for i in shaped:
            j = parent[i]
            while j != -1 and j not in shaped:
                j = parent[j]
            if j != -1:
                adjacent.add((min(i, j), max(i, j)))
        self._parent = parent
        self._pair_ids: tuple[tuple[int, int], ...] = tuple(
            (a, b)
            for a in sorted(shaped)
            for b in sorted(shaped)
            if a < b and (a, b) not in adjacent
        )
        #: The link pairs measured: every two links with shapes that are not adjacent.
        self.pairs: tuple[tuple[str, str], ...] = tuple(
            (self.link_names[a], self.link_names[b]) for a, b in self._pair_ids
        )
        self._pose: dict[str, float] = {}
        self._set(self.neutral)

    # -- life cycle ------------------------------------------------------------------------------
    def close(self) -> None:
        """Disconnect the PyBullet client (idempotent)."""
        if self._cid is not None:
            self._p.disconnect(self._cid)
            self._cid = None

    def __enter__(self) -> SelfCollisionChecker:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    # -- queries ---------------------------------------------------------------------------------
    def _client(self) -> int:
        if self._cid is None:
            raise RuntimeError("the self-collision checker is closed")
        return self._cid

    def _set(self, pose: Mapping[str, float]) -> None:
        p, cid = self._p, self._client()
        for name, value in pose.items():
            if self._pose.get(name) != value and name in self._index:
                p.resetJointState(self._robot, self._index[name], float(value), physicsClientId=cid)
                self._pose[name] = value

    def _closest(self, pairs: Sequence[tuple[int, int]]) -> tuple[float, tuple[str, str]]:
        """The least distance between the link pairs given (link indices) and its pair."""
        p, cid, robot = self._p, self._client(), self._robot
        best, where = math.inf, ("", "")
        for search in (_NEAR_M, _SEARCH_M):  # the near search is cheaper and nearly always hits
            for a, b in pairs:
                for c in p.getClosestPoints(robot, robot, search, a, b, physicsClientId=cid):
                    if c[8] < best:
                        best, where = float(c[8]), (self.link_names[a], self.link_names[b])
            if best < math.inf:
                break
        return best, where

    def _moving(self, joints: Sequence[str]) -> set[int]:
        """Links that move when ``joints`` do (their children, and those links' descendants)."""
        moved = {self._index[j] for j in joints if j in self._index}
        out: set[int] = set()
        for link in self.link_names:
            k = link
            while k != -1 and k not in moved:
                k = self._parent[k]
            if k != -1:
                out.add(link)
        return out

    def pose_clearance(self, pose: Mapping[str, float]) -> Clearance:
        """Clearance of one pose (radians; hands: opening fraction; other joints: neutral).

        Raises:
            UnknownName: a joint the limits do not know.
        """
        self.limits.require_known(pose)
        self._set({**self.neutral, **self.limits.couple(pose)})
        distance, links = self._closest(self._pair_ids)
        return Clearance(distance, links)

    def trajectory_clearance(
        self,
        traj: Trajectory,
        *,
        pose: Mapping[str, float] | None = None,
        dt: float = SAMPLE_DT,
    ) -> Clearance:
        """The least clearance along ``traj``, sampled every ``dt`` seconds and at its end.

        Args:
            traj: a planned trajectory.
            pose: values of joints ``traj`` does not move (default: neutral).
            dt: time between checked poses (s).
        """
        if not dt > 0:
            raise ValueError(f"dt must be > 0, got {dt!r}")
        self._set({**self.neutral, **self.limits.couple(dict(pose or {}))})
        moving = self._moving(traj.joints)
        changing = [(a, b) for a, b in self._pair_ids if a in moving or b in moving]
        fixed = [(a, b) for a, b in self._pair_ids if a not in moving and b not in moving]
        distance, links = self._closest(fixed)  # these keep their distance all along
        best = Clearance(distance, links, 0.0)
        times = np.append(np.arange(0.0, traj.duration, dt), traj.duration)
        for t in times:
            self._set(dict(zip(traj.joints, traj.sample(float(t)).tolist(), strict=True)))
            distance, links = self._closest(changing)
            if distance < best.distance_m:
                best = Clearance(distance, links, float(t))
        return best


def check_own_clearance(library: GestureLibrary, *, limits: JointLimits) -> None:
    """Raise :class:`LimitViolation` if a gesture of a library of one's own (at each
    parameter's smallest and largest value) brings two links of the robot closer than
    :data:`MIN_CLEARANCE_M` along its planned path.

    A talk checks it before it starts, as it checks the joint limits: a real NAO's shell (or
    its joints stalling against each other) would stop such a gesture, and the simulated NAO,
    which has no self-collision, would play it as if nothing were wrong. The path between
    keyframes does not depend on the speed, so one speed is checked (the time in the message
    is at :data:`~prezence.feedback.gestures.DEFAULT_SPEED_FRACTION`).

    Raises:
        LimitViolation: naming the file, the gesture's line, the two links and when.
        BackendUnavailable: PyBullet is not installed.
    """
    if library.own:
        _least_clearance(library, library.own, limits=limits)


def _least_clearance(
    library: GestureLibrary, names: Sequence[str], *, limits: JointLimits
) -> float:
    """The least clearance (m) of the gestures ``names`` of ``library`` (each parameter at its
    smallest and largest value), raising :class:`LimitViolation` at the first one under
    :data:`MIN_CLEARANCE_M`."""
    least = math.inf
    with SelfCollisionChecker(limits=limits, library=library) as checker:
        for name in names:
            g = library[name]
            for params in g.extreme_params():
                traj = build_trajectory(
                    name,
                    params=params,
                    speed_fraction=DEFAULT_SPEED_FRACTION,
                    limits=limits,
                    library=library,
                )
                c = checker.trajectory_clearance(traj)
                least = min(least, c.distance_m)
                if c.distance_m < MIN_CLEARANCE_M:
                    with_ = "".join(f" with {k} = {v}" for k, v in (params or {}).items())
                    check = (
                        f"prezence gestures check {g.path or 'FILE'}"
                        if name in library.own
                        else "prezence gestures check"  # a built-in gesture
                    )
                    raise LimitViolation(
                        f"{g.at()}gesture '{name}'{with_}: self-collision: {c.describe()} "
                        f"(< {1000 * MIN_CLEARANCE_M:.0f} mm clearance; a real NAO's shell "
                        f"would stop it): move its keyframes apart (`{check}` shows each "
                        "gesture's clearance)"
                    )
    return least


# ---------------------------------------------------------------------------------------------
# Gestures whose self-collision was not checked, and a robot whose shell would stop them
#: The shipped record of the built-in gestures' self-collision check: the SHA-256 of the
#: ``gestures.toml`` (as parsed: comments, layout and line endings aside) and of the URDF (its
#: line endings made LF) that ``tests/sim/test_self_collision.py`` checked (with PyBullet),
#: and the least clearance it measured. The test fails when either changes and the record
#: does not, so a record that matches names what was checked.
BUILTIN_RECORD = "gestures_self_collision.json"
#: How to have the self-collision of gestures checked where the talk runs.
_HOW = (
    'pip install "prezence[sim]" where the talk runs (it brings PyBullet; the talk then checks '
    "them)"
)
#: The option that plays unchecked gestures on a robot anyway.
ALLOW_UNCHECKED = "--allow-unchecked-collision"


def builtin_hashes(limits: JointLimits) -> dict[str, str]:
    """The hashes of the built-in ``gestures.toml`` and of ``limits``' URDF, as the shipped
    record (:data:`BUILTIN_RECORD`) writes them.

    ``gestures_sha256`` is over the parsed file (its TOML as canonical JSON), so a comment, a
    blank line or a CRLF checkout leaves it; ``urdf_sha256`` is over the URDF's bytes with
    CRLF made LF (on an LF checkout, the file's own SHA-256).
    """
    from importlib import resources
    from pathlib import Path

    text = resources.files("prezence.feedback").joinpath("data", GESTURES_FILE).read_text()
    return {
        "gestures_sha256": toml_digest(text),
        "urdf_sha256": hashlib.sha256(
            Path(limits.source).read_bytes().replace(b"\r\n", b"\n")
        ).hexdigest(),
    }


@functools.lru_cache(maxsize=8)  # a talk's start asks for the built-in file's three times
def toml_digest(text: str) -> str:
    """The SHA-256 of a TOML text as parsed (canonical JSON: sorted keys, no spaces): the
    same for the same values whatever its comments, layout or line endings.

    Example:
        >>> toml_digest("# a note\\na = 1  # one") == toml_digest("a=1")
        True
    """
    import tomllib

    canonical = json.dumps(
        tomllib.loads(text), sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str
    )
    return hashlib.sha256(canonical.encode()).hexdigest()


def builtin_record() -> dict[str, Any]:
    """The shipped record of the built-in gestures' self-collision check (see
    :data:`BUILTIN_RECORD`)."""
    from importlib import resources

    text = resources.files("prezence.feedback").joinpath("data", BUILTIN_RECORD).read_text()
    record: dict[str, Any] = json.loads(text)
    return record


#: The least clearance (m) of the built-in gestures checked here, by :func:`builtin_hashes`
#: (only versions that passed: a failing one is checked, and refused, again).
_BUILTIN_CHECKED: dict[tuple[str, ...], float] = {}


def _checked_key(hashes: Mapping[str, str], limits: JointLimits) -> tuple[str, ...]:
    """The key of :data:`_BUILTIN_CHECKED`: the files' hashes and the URDF's path."""
    return (*hashes.values(), str(limits.source))


def check_builtin_clearance(limits: JointLimits) -> bool:
    """Whether the self-collision of the built-in gestures is checked: True when the built-in
    ``gestures.toml`` and the URDF are the ones the shipped record names (the test suite
    checked them), or, when they are not, where PyBullet is installed, after checking every
    built-in gesture here as a library of one's own is checked (once per version of the files;
    a few seconds); False when they are not and PyBullet is not installed.

    Raises:
        LimitViolation: a built-in gesture, checked here, runs into the robot (its line).
    """
    hashes = builtin_hashes(limits)
    if {k: builtin_record().get(k) for k in hashes} == hashes:
        return True
    if not pybullet_available():
        return False
    key = _checked_key(hashes, limits)
    if key not in _BUILTIN_CHECKED:
        library = load_library(limits)
        least = _least_clearance(library, library.names, limits=limits)
        _BUILTIN_CHECKED[key] = least
        log.info(
            "the built-in %s (or the URDF) is not the one %s records: its self-collision "
            "was checked here (least clearance %.1f mm)",
            GESTURES_FILE,
            BUILTIN_RECORD,
            1000 * least,
        )
    return True


def builtin_edits(limits: JointLimits) -> dict[str, Any]:
    """What a session records when the built-in ``gestures.toml`` or ``limits``' URDF is not
    the file the shipped record (:data:`BUILTIN_RECORD`) names, e.g. edited in place by a
    gesture designer; ``{}`` when both are.

    Returns:
        ``file`` (the built-in ``gestures.toml``) and ``urdf``, absolute; their hashes as the
        record writes them (``gestures_sha256``, ``urdf_sha256``: :func:`builtin_hashes`);
        ``differs_from_record``, which of the two files is not the recorded one; and
        ``least_clearance_mm`` where their self-collision was checked here
        (:func:`check_builtin_clearance`; absent: not checked).
    """
    from importlib import resources
    from pathlib import Path

    hashes = builtin_hashes(limits)
    record = builtin_record()
    gestures = Path(str(resources.files("prezence.feedback").joinpath("data", GESTURES_FILE)))
    urdf = Path(limits.source).resolve()
    files = {"gestures_sha256": gestures.name, "urdf_sha256": urdf.name}
    differs = [name for key, name in files.items() if record.get(key) != hashes[key]]
    if not differs:
        return {}
    out: dict[str, Any] = {
        "file": str(gestures.resolve()),
        "urdf": str(urdf),
        **hashes,
        "differs_from_record": differs,
    }
    least = _BUILTIN_CHECKED.get(_checked_key(hashes, limits))
    if least is not None:
        out["least_clearance_mm"] = round(1000 * least, 1)
    return out


def unchecked_collision(library: GestureLibrary | None, *, limits: JointLimits) -> list[str]:
    """Why the self-collision of the gestures a talk with ``library`` plays (None: the built-in
    ones) was not checked here; empty when it was.

    The gestures of a library of one's own are checked when the talk loads them, if PyBullet
    is installed. The built-in ones count as checked when the built-in ``gestures.toml`` and
    the URDF are the files the shipped record names (the test suite checked them), and are
    checked here otherwise, if PyBullet is installed (:func:`check_builtin_clearance`).

    Raises:
        LimitViolation: a built-in gesture not the one the record names runs into the robot.
    """
    out: list[str] = []
    if not check_builtin_clearance(limits):
        out.append(
            f"the built-in {GESTURES_FILE} (or the URDF) is not the one whose self-collision "
            f"the test suite checked (its SHA-256 is not the one {BUILTIN_RECORD} records), "
            "and PyBullet is not installed here to check it"
        )
    if library is not None and library.own and not pybullet_available():
        out.append(
            f"{library.source}: the self-collision of its gestures was not checked: PyBullet "
            "is not installed here"
        )
    return out


def require_collision_checked(
    library: GestureLibrary | None, *, limits: JointLimits, backend: str, allow: bool = False
) -> list[str]:
    """Refuse to play gestures whose self-collision was not checked on a backend that moves a
    physical body (:attr:`~prezence.backends.base.Backend.physical`): a real NAO's shell, or its
    joints stalling against each other, would stop a self-colliding gesture (on the
    ``prezence[naoqi]`` install, which has no PyBullet, nothing else would say so).

    Args:
        library: the talk's library (None: the built-in one).
        limits: joint limits.
        backend: the backend's name, for the message.
        allow: play them anyway (:data:`ALLOW_UNCHECKED`): the reasons are returned, to be
            warned of and recorded.

    Returns:
        :func:`unchecked_collision`'s reasons (empty: every gesture checked).

    Raises:
        GestureCheckFailed: a reason, and not ``allow``; naming the file and how to check it.
    """
    reasons = unchecked_collision(library, limits=limits)
    if reasons and not allow:
        raise GestureCheckFailed(
            "\n".join(
                f"{r}; --backend {backend} moves a real robot, which plays only gestures checked "
                f"against its own body: {_HOW}, or give {ALLOW_UNCHECKED} "
                "to play them unchecked (recorded in session.json)"
                for r in reasons
            )
        )
    return reasons


__all__ = [
    "ALLOW_UNCHECKED",
    "BUILTIN_RECORD",
    "MIN_CLEARANCE_M",
    "SAMPLE_DT",
    "Clearance",
    "SelfCollisionChecker",
    "builtin_edits",
    "builtin_hashes",
    "builtin_record",
    "check_builtin_clearance",
    "check_own_clearance",
    "pybullet_available",
    "require_collision_checked",
    "toml_digest",
    "unchecked_collision",
]
