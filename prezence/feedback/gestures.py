"""The gesture library (data in ``data/gestures.toml``) and its timing against the joint limits.

A gesture is a list of keyframes in degrees (hands: opening fraction 0..1) that starts from and
returns to a neutral standing pose. Its timing is computed, never written down: each segment
between keyframes takes the time its slowest joint needs at ``speed_fraction × URDF velocity``
under the profile of :mod:`prezence.feedback.trajectory` (a trapezoidal velocity profile with
short blends and an acceleration bound of ``v / ACCEL_TIME_S``), plus the holds the data asks
for. :func:`time_optimal_minimum` is the fastest any rest-to-rest motion through the same
keyframes could be under the same speed and acceleration bounds (bang-coast-bang per segment,
same holds); the planned duration stays within 5.4 % of it by construction.

TOML form (see the file's header for all keys)::

    [gestures.slow_down]
    description = "Both palms pat the air downwards twice: slow down."
    mirror = true        # left-arm values are mirrored onto the right arm unless given
    [[gestures.slow_down.keyframes]]
    pose = { LShoulderPitch = 35, LWristYaw = 70, LHand = 1.0 }
    hold = 0.2
    [[gestures.slow_down.keyframes]]
    repeat = 2           # or the name of a parameter, e.g. "minutes"
    sequence = [ { pose = { LShoulderPitch = 60 } }, { pose = { LShoulderPitch = 35 } } ]

A library of one's own (:func:`load_library_file`; ``prezence gestures check FILE``, ``--gestures
FILE`` on the talk commands) has the same form without ``[neutral]``: its gestures replace the
built-in ones of the same name, the others stay (docs/gestures.md). Every error names the file,
the line (best effort) and the key path; a key a table does not hold is refused by name.
"""

from __future__ import annotations

import functools
import hashlib
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from prezence.errors import ConfigError, LimitViolation, UnknownName, did_you_mean, unknown_message
from prezence.feedback.limits import (
    HANDS,
    HIP_YAW_PITCH,
    LEGS,
    JointLimits,
    load_limits,
    require_finite,
)
from prezence.feedback.trajectory import (
    Trajectory,
    min_segment_duration,
    profile_time,
    segment_duration,
)
from prezence.tomlio import KeyLines, loads_toml, parse_keypath, read_text

log = logging.getLogger(__name__)

GESTURES_FILE = "gestures.toml"
#: NAOqi-like default ``fractionMaxSpeed`` for feedback gestures.
DEFAULT_SPEED_FRACTION = 0.6
#: Moves smaller than this (rad; hands: fraction) are no move at all.
MIN_MOVE = 1e-9
#: Spacing of the poses :func:`check_path` checks along a planned path (s).
PATH_CHECK_DT = 0.01
#: The longest hold a keyframe may ask for (s); the built-in gestures hold at most 0.8 s. A cue
#: keeps the robot from any other cue while it plays, and `hold = 1e9` asked the check for
#: 745 GiB of samples.
MAX_HOLD_S = 5.0
#: The most times a sequence may repeat (a literal count, or a parameter's largest value).
MAX_REPEAT = 10
#: Mirror rule left → right arm: pitch and hand keep their value, roll and yaw change sign.
_MIRROR_SIGN = {
    "ShoulderPitch": 1.0,
    "ShoulderRoll": -1.0,
    "ElbowYaw": -1.0,
    "ElbowRoll": -1.0,
    "WristYaw": -1.0,
    "Hand": 1.0,
}


@dataclass(frozen=True)
class Keyframe:
    """A (partial) pose to reach, in radians (hands: fraction), then hold for ``hold`` seconds.

    ``where`` is its place in the data file, e.g. ``keyframes[1].sequence[0]``; ``line`` its
    line there (best effort; None: not known).
    """

    pose: Mapping[str, float]
    hold: float
    where: str
    line: int | None = None


@dataclass(frozen=True)
class Step:
    """A keyframe, or a sequence of keyframes repeated ``repeat`` times (an int or a param)."""

    keyframes: tuple[Keyframe, ...]
    repeat: int | str = 1


@dataclass(frozen=True)
class Param:
    """A gesture parameter: an integer clamped to [low, high]."""

    name: str
    default: int
    low: int
    high: int


@dataclass(frozen=True)
class Gesture:
    """One gesture of the library.

    ``path`` and ``line`` say where it is written (None: built in code, not read from a file):
    a keyframe out of the limits is reported at its ``file:line``.
    """

    name: str
    description: str
    steps: tuple[Step, ...]
    params: Mapping[str, Param] = field(default_factory=dict)
    path: str | None = None
    line: int | None = None

    def at(self, line: int | None = None) -> str:
        """``file:line: `` of the gesture (or of its keyframe at ``line``), or ``""``.

        Example:
            >>> Gesture("wave", "", (), path="my.toml", line=3).at(5)
            'my.toml:5: '
        """
        if self.path is None:
            return ""
        n = line if line is not None else self.line
        return f"{self.path}:{n}: " if n is not None else f"{self.path}: "

    def resolve_params(self, params: Mapping[str, Any] | None) -> dict[str, int]:
        """Parameter values with defaults filled in and clamped to their ranges.

        Keys the gesture does not declare are ignored (a cue's parameters also feed its phrase).

        Raises:
            TypeError: a value that is not a whole number.
        """
        given = dict(params or {})
        out: dict[str, int] = {}
        for name, p in self.params.items():
            v = given.get(name, p.default)
            if isinstance(v, bool) or not isinstance(v, int | float) or not float(v).is_integer():
                raise TypeError(
                    f"gesture '{self.name}': parameter {name} must be a whole number, got {v!r}"
                )
            out[name] = min(max(int(v), p.low), p.high)
        return out

    def extreme_params(self) -> list[dict[str, int] | None]:
        """The parameter values a check plays: each parameter at its smallest and largest
        value (None: a gesture without parameters, played once)."""
        if not self.params:
            return [None]
        return [{p.name: v} for p in self.params.values() for v in sorted({p.low, p.high})]

    def keyframes(self, params: Mapping[str, Any] | None = None) -> list[Keyframe]:
        """The keyframes in order, repeats expanded (without the final return to neutral)."""
        values = self.resolve_params(params)
        out: list[Keyframe] = []
        for step in self.steps:
            n = values[step.repeat] if isinstance(step.repeat, str) else step.repeat
            for _ in range(n):
                out.extend(step.keyframes)
        return out


@dataclass(frozen=True)
class GestureLibrary:
    """The neutral pose (radians) and every gesture by name.

    A library of one's own (:func:`load_library_file`) is the built-in library with the
    gestures its file defines put in by name: ``source`` is that file, ``text`` what was read
    from it, ``own`` the names it defines. The built-in library has ``source`` None.
    """

    neutral: Mapping[str, float]
    gestures: Mapping[str, Gesture]
    source: str | None = None
    text: str = ""
    own: tuple[str, ...] = ()

    def __getitem__(self, name: str) -> Gesture:
        try:
            return self.gestures[name]
        except KeyError:
            raise UnknownName("gesture", name, self.gestures) from None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(self.gestures)

    def record(self) -> dict[str, Any]:
        """What a session records of a library of one's own: the file (absolute), the SHA-256
        of the text that was read, the gestures it defines and those left built in."""
        return {
            "file": str(Path(self.source).resolve()) if self.source else None,
            "sha256": hashlib.sha256(self.text.encode("utf-8")).hexdigest(),
            "defines": list(self.own),
            "built_in": [n for n in self.names if n not in self.own],
        }


# ---------------------------------------------------------------------------------------------
# Parsing
#: The keys each table of a library file may hold (anything else is refused, by name).
_TOP_KEYS = ("format", "neutral", "gestures")
_GESTURE_KEYS = ("description", "mirror", "params", "keyframes")
_KEYFRAME_KEYS = ("pose", "hold", "mirror")
_SEQUENCE_KEYS = ("sequence", "repeat", "mirror")
_PARAM_KEYS = ("default", "min", "max")


def _kind(value: Any) -> str:
    return {dict: "a table", list: "an array", str: "a string", bool: "a boolean"}.get(
        type(value), type(value).__name__
    )


class _Doc:
    """One library file being read: each error names the file, the line (found by a scan of
    the text, :func:`~prezence.tomlio.locate`: tomllib keeps no positions) and the key path."""

    def __init__(self, path: str, text: str) -> None:
        self.path = path
        self.text = text
        self._lines: KeyLines | None = None

    def line(self, key: str) -> int | None:
        if not (self.text and key):
            return None
        if self._lines is None:  # one scan of the text for all the keys asked about
            self._lines = KeyLines(self.text)
        return self._lines.line(parse_keypath(key))

    def error(self, message: str, key: str = "") -> ConfigError:
        return ConfigError(message, path=self.path, line=self.line(key), key=key or None)

    def table(self, raw: Any, key: str, what: str = "a table") -> Mapping[str, Any]:
        if not isinstance(raw, Mapping):
            raise self.error(f"expected {what}, got {_kind(raw)}", key)
        return raw

    def only(self, raw: Mapping[str, Any], allowed: Sequence[str], key: str) -> None:
        for k in raw:
            if k not in allowed:
                raise self.error(
                    unknown_message("key", str(k), allowed), f"{key}.{k}" if key else str(k)
                )

    def flag(self, raw: Mapping[str, Any], name: str, default: bool, key: str) -> bool:
        v = raw.get(name, default)
        if not isinstance(v, bool):
            raise self.error(f"expected true or false, got {v!r}", f"{key}.{name}")
        return v


def _to_rad(joint: str, value: Any, doc: _Doc, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise doc.error(f"expected a number, got {value!r}", key)
    v = float(value)
    if not math.isfinite(v):
        raise doc.error(f"{joint} target is {v!r}; joint targets must be finite", key)
    return v if joint in HANDS else math.radians(v)


def _mirror(pose: dict[str, float]) -> dict[str, float]:
    out = dict(pose)
    for name, v in pose.items():
        if name.startswith("L") and name[1:] in _MIRROR_SIGN:
            out.setdefault("R" + name[1:], v * _MIRROR_SIGN[name[1:]])
    return out


def _parse_pose(
    raw: Any, *, known: set[str], mirror: bool, doc: _Doc, key: str, legs: bool = False
) -> dict[str, float]:
    """A pose table in radians (hands: fraction); leg joints only where ``legs`` (the neutral
    standing pose gives them, a gesture may not move them)."""
    table = doc.table(raw, key, "a table of joint = value")
    pose: dict[str, float] = {}
    for joint, value in table.items():
        if joint not in known:
            # a gesture may not move a leg: hinting one (HeadRoll → RHipRoll) led to a refusal
            hint = known if legs else known - LEGS
            raise doc.error(str(UnknownName("joint", joint, hint)), f"{key}.{joint}")
        if joint in LEGS and not legs:
            raise doc.error(
                f"{joint} is a leg joint: gestures move the head, arms and hands only "
                "(the NAO coaches standing, and a standing robot that moves a leg can fall)",
                f"{key}.{joint}",
            )
        pose[joint] = _to_rad(joint, value, doc, f"{key}.{joint}")
    if mirror and not legs:
        right = [j for j in pose if j[0] == "R" and j[1:] in _MIRROR_SIGN]
        if right and not any(j[0] == "L" and j[1:] in _MIRROR_SIGN for j in pose):
            # session 23's gesture designer: a one-armed gesture played without a word
            raise doc.error(
                f"mirror = true copies the left arm's values onto the right arm, and this pose "
                f"gives right-arm values only ({', '.join(right)}), so the left arm would not "
                "move: write them as the left arm's (they are mirrored), or set mirror = false",
                key,
            )
    return _mirror(pose) if mirror else pose


def _parse_keyframe(
    raw: Any, *, known: set[str], mirror: bool, doc: _Doc, key: str, where: str
) -> Keyframe:
    entry = doc.table(raw, key)
    doc.only(entry, _KEYFRAME_KEYS, key)
    hold = entry.get("hold", 0.0)
    if isinstance(hold, bool) or not isinstance(hold, int | float) or not 0 <= hold <= MAX_HOLD_S:
        raise doc.error(f"hold must be seconds in [0, {MAX_HOLD_S:g}], got {hold!r}", f"{key}.hold")
    m = doc.flag(entry, "mirror", mirror, key)
    pose = _parse_pose(entry.get("pose", {}), known=known, mirror=m, doc=doc, key=f"{key}.pose")
    return Keyframe(MappingProxyType(pose), float(hold), where, doc.line(key))


def _parse_param(name: str, raw: Any, doc: _Doc, key: str) -> Param:
    spec = doc.table(raw, key, "a table { default, min, max }")
    doc.only(spec, _PARAM_KEYS, key)
    values: dict[str, int] = {}
    for k in _PARAM_KEYS:
        v = spec.get(k)
        if isinstance(v, bool) or not isinstance(v, int):
            raise doc.error("a parameter needs integer default, min and max", key)
        values[k] = v
    p = Param(name, values["default"], values["min"], values["max"])
    if not 1 <= p.low <= p.default <= p.high <= MAX_REPEAT:
        # a parameter is a repeat count: it plays a sequence that many times
        raise doc.error(
            f"a parameter needs 1 <= min <= default <= max <= {MAX_REPEAT}, "
            f"got min {p.low}, default {p.default}, max {p.high}",
            key,
        )
    return p


def _parse_gesture(name: str, raw: Any, *, known: set[str], doc: _Doc) -> Gesture:
    base = f"gestures.{name}"
    table = doc.table(raw, base)
    doc.only(table, _GESTURE_KEYS, base)
    mirror = doc.flag(table, "mirror", False, base)
    description = table.get("description", "")
    if not isinstance(description, str):
        raise doc.error(f"expected a string, got {_kind(description)}", f"{base}.description")
    raw_params = doc.table(table.get("params", {}), f"{base}.params")
    params = {
        str(p): _parse_param(str(p), spec, doc, f"{base}.params.{p}")
        for p, spec in raw_params.items()
    }
    steps: list[Step] = []
    raw_steps = table.get("keyframes")
    if not isinstance(raw_steps, list) or not raw_steps:
        raise doc.error("a gesture needs a non-empty keyframes list", base)
    for i, entry in enumerate(raw_steps):
        key = f"{base}.keyframes[{i}]"
        where = f"keyframes[{i}]"
        if isinstance(entry, Mapping) and "sequence" in entry:
            doc.only(entry, _SEQUENCE_KEYS, key)
            repeat = entry.get("repeat", 1)
            if isinstance(repeat, str):
                if repeat not in params:
                    raise doc.error(f"repeat names unknown parameter {repeat!r}", f"{key}.repeat")
            elif (
                isinstance(repeat, bool)
                or not isinstance(repeat, int)
                or not 1 <= repeat <= MAX_REPEAT
            ):
                raise doc.error(
                    f"repeat must be an integer in [1, {MAX_REPEAT}] or a parameter name",
                    f"{key}.repeat",
                )
            m = doc.flag(entry, "mirror", mirror, key)
            seq = entry["sequence"]
            if not isinstance(seq, list) or not seq:
                raise doc.error(
                    "a sequence is a non-empty array of keyframes { pose = {…}, hold = s }",
                    f"{key}.sequence",
                )
            frames = tuple(
                _parse_keyframe(
                    sub,
                    known=known,
                    mirror=m,
                    doc=doc,
                    key=f"{key}.sequence[{j}]",
                    where=f"{where}.sequence[{j}]",
                )
                for j, sub in enumerate(seq)
            )
            steps.append(Step(frames, repeat))
        else:
            kf = _parse_keyframe(entry, known=known, mirror=mirror, doc=doc, key=key, where=where)
            steps.append(Step((kf,)))
    return Gesture(
        name,
        description,
        tuple(steps),
        MappingProxyType(params),
        path=doc.path,
        line=doc.line(base),
    )


def _read(
    text: str, *, limits: JointLimits, path: str, own: bool
) -> tuple[_Doc, Mapping[str, Any], dict[str, Gesture]]:
    """The document, its top-level table and its gestures (format and keys checked)."""
    doc = _Doc(path, text)
    top = loads_toml(text, path=path)
    fmt = top.get("format")
    if fmt != 1 or isinstance(fmt, bool):
        if "format" in top:
            raise doc.error(f"expected format = 1, found {fmt!r}", "format")
        raise ConfigError(
            "expected format = 1, found none (a gesture library's first line is format = 1)",
            path=path,
            line=1,
        )
    if own and "neutral" in top:
        raise doc.error(
            "a library of your own gives gestures only: the neutral pose is the robot's "
            "standing pose, the built-in one, which every backend moves to at the start and "
            "every gesture returns to (remove [neutral])",
            "neutral",
        )
    doc.only(top, _TOP_KEYS, "")
    known = set(limits.names)
    raw = doc.table(top.get("gestures", {}), "gestures", "a table of [gestures.NAME] tables")
    gestures = {
        str(name): _parse_gesture(str(name), g, known=known, doc=doc) for name, g in raw.items()
    }
    return doc, top, gestures


def parse_library(text: str, *, limits: JointLimits, path: str = GESTURES_FILE) -> GestureLibrary:
    """Parse a whole gesture library (the built-in one's form) from TOML text (joint names
    checked against ``limits``).

    Raises:
        ConfigError: TOML syntax (with line and column) or a bad key (with its line, best
            effort, and key path).
    """
    doc, top, gestures = _read(text, limits=limits, path=path, own=False)
    known = set(limits.names)
    neutral = _parse_pose(
        top.get("neutral", {}), known=known, mirror=True, doc=doc, key="neutral", legs=True
    )
    neutral = limits.couple(neutral)
    missing = [n for n in limits.names if n not in neutral]
    if missing:
        raise doc.error(f"the neutral pose lacks {', '.join(missing)}", "neutral")
    limits.check(neutral, where=f"{path}: neutral")
    return GestureLibrary(MappingProxyType(neutral), MappingProxyType(gestures))


def parse_own_library(
    text: str, *, limits: JointLimits, path: str, base: GestureLibrary
) -> GestureLibrary:
    """A library of one's own from TOML text: ``base`` (the built-in library) with the
    gestures ``text`` defines put in by name (one of the same name is replaced, a new name
    added). The text gives ``format = 1`` and ``[gestures.NAME]`` tables only: the neutral pose
    stays ``base``'s.

    Raises:
        ConfigError: as :func:`parse_library`; also a ``[neutral]`` table, or no gesture.
    """
    doc, _, gestures = _read(text, limits=limits, path=path, own=True)
    if not gestures:
        raise doc.error(
            "defines no gesture: give a [gestures.NAME] table for each gesture to replace "
            "(prezence --list gestures names the built-in ones)"
        )
    merged = {**base.gestures, **gestures}
    return GestureLibrary(
        base.neutral, MappingProxyType(merged), source=path, text=text, own=tuple(gestures)
    )


@functools.cache
def _builtin(source: str) -> GestureLibrary:
    from prezence.feedback.limits import load_limits

    text = resources.files("prezence.feedback").joinpath("data", GESTURES_FILE).read_text()
    return parse_library(text, limits=load_limits(source or None))


def load_library(limits: JointLimits | None = None) -> GestureLibrary:
    """The built-in gesture library (parsed once per URDF)."""
    return _builtin(str(limits.source) if limits is not None else "")


def load_library_file(path: str | Path, *, limits: JointLimits | None = None) -> GestureLibrary:
    """A gesture library of one's own: the built-in library with the gestures of the TOML file
    at ``path`` in place of those of the same name (see :func:`parse_own_library`).

    Raises:
        ConfigError: the file cannot be read, or is not a valid library (``file:line:``).
    """
    from prezence.feedback.limits import load_limits

    limits = limits if limits is not None else load_limits()
    text = read_text(path)
    return parse_own_library(text, limits=limits, path=str(path), base=load_library(limits))


def unplayed(library: GestureLibrary) -> list[str]:
    """A note per gesture of a library of one's own that no command plays (a talk never
    uses it: a new name, or a misspelt one)."""
    from prezence.feedback.commands import load_commands

    played = sorted({c.gesture for c in load_commands().values()})
    out = []
    for name in library.own:
        if name not in played:
            g = library[name]
            out.append(
                f"{g.at()}gestures.{name}: no command plays '{name}'{did_you_mean(name, played)} "
                "(a talk plays only the gestures of the command table: prezence --list gestures)"
            )
    return out


def unset_params(library: GestureLibrary) -> list[str]:
    """A note per parameter of a gesture of one's own that no cue sets: the commands that play
    the gesture give their cues other parameters (``time_left``'s cues give ``minutes``), so a
    ``mins`` would play at its default in every cue."""
    from prezence.feedback.commands import load_commands

    given: dict[str, set[str]] = {}
    for c in load_commands().values():
        given.setdefault(c.gesture, set()).update(c.params)
    out = []
    for name in library.own:
        if name not in given:
            continue  # unplayed() says so
        g = library[name]
        for p in g.params.values():
            if p.name not in given[name]:
                out.append(
                    f"{g.at()}gestures.{name}.params.{p.name}: no cue sets '{p.name}', so every "
                    f"cue plays it at its default {p.default}"
                    + (
                        f"{did_you_mean(p.name, sorted(given[name]))} (the cues that play "
                        f"'{name}' give {', '.join(sorted(given[name]))})"
                        if given[name]
                        else f" (the cues that play '{name}' give no parameter)"
                    )
                )
    return out


#: A gesture whose every angle is within ± this (degrees, as written) was most likely written in
#: radians: 2.09 rad is the widest NAO joint's limit, and a move of 2° is not seen from the room.
RADIANS_LIKE_DEG = 2.1


def radians_like(library: GestureLibrary, *, limits: JointLimits | None = None) -> list[str]:
    """A note per gesture of one's own whose angles look like radians: all of them
    (``RShoulderPitch = 1.2``: the file is read in degrees, so the arm would move 1.2°, not
    69°), or every value of a joint beside larger angles (a nod ``HeadPitch = 0.4`` beside
    ``HeadYaw = 3``), where each value read as radians is within the joint's limits (``limits``,
    default the project's URDF): ``LShoulderRoll = -2`` beside degrees is no radian (-115° is
    past its limit), and the built-in ``gesture_less`` writes it."""
    out = []
    for name in library.own:
        g = library[name]
        written = [
            (j, math.degrees(v), kf.line)
            for kf in g.keyframes({p.name: p.low for p in g.params.values()})
            for j, v in kf.pose.items()
            if j not in HANDS
        ]
        if written and max(abs(a) for _, a, _ in written) <= RADIANS_LIKE_DEG:
            joint, big, _ = max(written, key=lambda w: abs(w[1]))
            out.append(
                f"{g.at()}gestures.{name}: every angle is within ±{RADIANS_LIKE_DEG:g}; angles "
                f"are degrees, so {joint} = {big:g} is {big:g}°, not {math.degrees(big):.0f}° "
                "(radians? multiply by 57.3)"
            )
            continue
        note = _radians_beside_degrees(g, written, limits if limits is not None else load_limits())
        if note:
            out.append(note)
    return out


def _radians_beside_degrees(
    g: Gesture, written: list[tuple[str, float, int | None]], limits: JointLimits
) -> str | None:
    """The note for joints of ``g`` written in radians beside angles in degrees (see
    :func:`radians_like`), or None. ``written``: (joint, value as written, its line)."""
    by_joint: dict[str, list[float]] = {}
    for j, a, _ in written:
        by_joint.setdefault(j, []).append(a)
    small = [
        j
        for j, values in by_joint.items()
        if max(abs(a) for a in values) <= RADIANS_LIKE_DEG
        and any(values)  # 0 is 0 in either unit
        and all(limits[j].lower <= a <= limits[j].upper for a in values)  # read as radians
    ]
    if not small:
        return None
    joint, big, line = max((w for w in written if w[0] in small), key=lambda w: abs(w[1]))
    other, beside, _ = max((w for w in written if w[0] not in small), key=lambda w: abs(w[1]))
    every = " and ".join(small)
    return (
        f"{g.at(line)}gestures.{g.name}: every {every} is within ±{RADIANS_LIKE_DEG:g} where "
        f"{other} = {beside:g} is not; angles are degrees, so {joint} = {big:g} is {big:g}°, "
        f"not {math.degrees(big):.0f}° (radians? multiply by 57.3)"
    )


def library_notes(library: GestureLibrary) -> list[str]:
    """What ``gestures check`` notes and a talk warns of in a library of one's own: gestures
    no command plays (:func:`unplayed`), parameters no cue sets (:func:`unset_params`) and
    angles that look like radians (:func:`radians_like`)."""
    return unplayed(library) + unset_params(library) + radians_like(library)


def check_plannable(library: GestureLibrary, *, limits: JointLimits) -> None:
    """Raise if a gesture of a library of one's own cannot be planned within the joint limits
    (every keyframe and the path between them, at each parameter's smallest and largest value).

    Raises:
        LimitViolation: naming the file, line, gesture, keyframe and joint.
        ConfigError: a gesture that never moves.
    """
    for name in library.own:
        check_keyframes(name, limits=limits, library=library)


#: The built-in gestures pass ``gestures check`` at this ``--speed`` and at every one above it
#: (a test checks it at the bound, below it and across the range). A talk with no library of its
#: own at such a speed is not checked again: the answer is fixed by the shipped data, and the
#: check cost every process 0.15-0.2 s (its imports, and the paths sampled), a third of a demo.
BUILTIN_PASS_FROM_SPEED = 0.11


@functools.cache
def builtin_gesture_names() -> frozenset[str]:
    """The names of the built-in gestures: the data file's ``[gestures.NAME]`` tables, read
    without planning them (a talk on the built-in library needs no more)."""
    text = resources.files("prezence.feedback").joinpath("data", GESTURES_FILE).read_text()
    return frozenset(loads_toml(text, path=GESTURES_FILE).get("gestures", {}))


def missing_gestures(
    library: GestureLibrary | None, commands: Mapping[str, Sequence[str]] | None = None
) -> list[str]:
    """One line per command whose gesture ``library`` (None: the built-in one) lacks: each of
    ``commands`` (command → what gives it: a talk's, from
    :meth:`~prezence.config.model.Config.talk_commands`), or, with None, every command of the
    command table. Each names the command and its ``commands.toml:line``, the missing gesture
    with a "did you mean", and what gives the command (a rules line)."""
    from prezence.feedback.commands import load_commands

    table = load_commands()
    given = commands if commands is not None else {name: () for name in table}
    names = set(library.names) if library is not None else set(builtin_gesture_names())
    own = library.source if library is not None and library.own else ""
    out = []
    for name, wheres in given.items():
        command = table.get(name)
        if command is None or command.gesture in names:
            continue  # an unknown command is the config loader's error, with its line
        hint = did_you_mean(command.gesture, sorted(names)).removeprefix("; ")
        out.append(
            f"{command.where}: command '{name}' plays gesture '{command.gesture}', which is not "
            f"in the built-in gestures{f' nor in {own}' if own else ''}"
            + (f" ({hint})" if hint else "")
            + (f"; {', '.join(wheres)} gives {name}" if wheres else "")
            + f": define [gestures.{command.gesture}] in a --gestures file (or in the built-in "
            "gestures.toml), or give the command a gesture that exists"
        )
    return out


def check_command_gestures(
    library: GestureLibrary | None, commands: Mapping[str, Sequence[str]]
) -> None:
    """Refuse a talk that would give a command whose gesture ``library`` lacks (see
    :func:`missing_gestures`): it would stop at the first such cue, its summary and report
    unwritten.

    Raises:
        GestureCheckFailed: one line per such command.
    """
    from prezence.feedback.gesture_check import GestureCheckFailed

    lines = missing_gestures(library, commands)
    if lines:
        raise GestureCheckFailed("\n".join(lines))


def library_for_talk(
    path: str | Path | None,
    *,
    speed_fraction: float,
    commands: Mapping[str, Sequence[str]] | None = None,
) -> GestureLibrary | None:
    """The library a talk with ``--gestures path`` plays (None: the built-in one), checked
    before the talk starts: the file's gestures planned within the limits and, with PyBullet,
    clear of the robot's own body, a warning for each note ``gestures check`` gives (a gesture
    no command plays…), every command the talk can give (``commands``, from
    :meth:`~prezence.config.model.Config.talk_commands`: its rules', and the coach's own:
    praise, time warnings, the summary; None: not checked) having its gesture in the library
    (:func:`check_command_gestures`), and
    every gesture the talk plays passing ``gestures check`` at ``speed_fraction``
    (:func:`~prezence.feedback.gesture_check.check_talk_gestures`: none takes so long that
    the robot could give no other cue). The file is read and checked once per version and
    speed (the command's start and its talk both ask). The built-in gestures, when the
    built-in ``gestures.toml`` or the URDF is not the one the shipped record names, are checked
    for self-collision here too where PyBullet is
    (:func:`~prezence.feedback.collision.check_builtin_clearance`, once per version).

    Raises:
        ConfigError, LimitViolation: the file cannot be read or played (``file:line:``); a
            built-in gesture changed since the record runs into the robot.
        GestureCheckFailed: a command the talk can give has no gesture in the library, or a
            gesture the talk would play fails the check at this speed.
    """
    from prezence.feedback.collision import check_builtin_clearance
    from prezence.feedback.limits import load_limits

    check_builtin_clearance(load_limits())  # an edited built-in gestures.toml, as one's own
    if path is None and commands is not None:
        check_command_gestures(None, commands)
    if path is None and BUILTIN_PASS_FROM_SPEED <= speed_fraction <= 1.0:
        return None  # the built-in gestures at a speed they pass at (see the constant)
    from prezence.feedback.gesture_check import check_talk_gestures

    if path is None:
        check_talk_gestures(speed_fraction, library=None)
        return None
    p = Path(path)
    try:
        st = p.stat()
    except OSError:
        load_library_file(p)  # raises, naming the file
        raise
    version = (str(p), str(p.resolve()), st.st_mtime_ns, st.st_size)
    library = _for_talk(*version)
    if commands is not None:
        check_command_gestures(library, commands)
    if (version, speed_fraction) not in _CHECKED:
        check_talk_gestures(speed_fraction, library=library)  # raises: not remembered
        _CHECKED.add((version, speed_fraction))
    return library


#: The library versions and speeds :func:`library_for_talk` has found passing the check.
_CHECKED: set[tuple[tuple[str, str, int, int], float]] = set()


@functools.lru_cache(maxsize=8)
def _for_talk(path: str, resolved: str, mtime_ns: int, size: int) -> GestureLibrary:
    from prezence.feedback.limits import load_limits

    limits = load_limits()
    library = load_library_file(path, limits=limits)
    check_plannable(library, limits=limits)
    from prezence.feedback.collision import check_own_clearance, pybullet_available

    if pybullet_available():
        check_own_clearance(library, limits=limits)
    elif library.own:
        log.warning(
            "%s: self-collision not checked: PyBullet is not installed here (pip install "
            '"prezence[sim]", or run `prezence gestures check %s` where it is)',
            path,
            path,
        )
    for note in library_notes(library):
        log.warning("%s", note)
    return library


# ---------------------------------------------------------------------------------------------
# Timing
def _check_fraction(speed_fraction: float) -> float:
    f = float(speed_fraction)
    if not 0.0 < f <= 1.0:
        raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")
    return f


def _ordered_joints(limits: JointLimits, used: set[str]) -> tuple[str, ...]:
    if used & set(HIP_YAW_PITCH):
        used = used | set(HIP_YAW_PITCH)
    return tuple(n for n in limits.names if n in used)


def build_trajectory(
    name: str,
    *,
    params: Mapping[str, Any] | None = None,
    speed_fraction: float,
    limits: JointLimits,
    start_pose: Mapping[str, float] | None = None,
    library: GestureLibrary | None = None,
) -> Trajectory:
    """Plan gesture ``name``: from ``start_pose`` through its keyframes back to neutral.

    Args:
        name: a gesture of the library (``slow_down``, ``time_left``…).
        params: gesture parameters, e.g. ``{"minutes": 3}`` for ``time_left`` (undeclared keys
            are ignored).
        speed_fraction: fraction of each joint's URDF velocity limit, in (0, 1].
        limits: joint limits (from :func:`prezence.feedback.limits.load_limits`).
        start_pose: where the robot is now (radians / hand fraction; missing joints: neutral).
        library: a gesture library; default the built-in one.

    Returns:
        The trajectory; ``duration`` is known before it is played.

    Raises:
        UnknownName: no such gesture.
        LimitViolation: a keyframe (or the start pose) is outside a position limit; the message
            names the gesture, the keyframe (``keyframes[i]``) and the joint. Or the path
            between keyframes leaves one (the head anti-collision range): the message names the
            gesture, the time, the keyframe it heads to and the joint (:func:`check_path`).
        ValueError: ``speed_fraction`` outside (0, 1], or a NaN in ``start_pose`` (naming the
            joint).
    """
    f = _check_fraction(speed_fraction)
    lib = library if library is not None else load_library(limits)
    gesture = lib[name]
    frames = gesture.keyframes(params)
    joints = _ordered_joints(limits, {j for kf in frames for j in kf.pose})
    if not joints:
        raise ConfigError(
            f"gesture '{name}' moves no joint",
            path=gesture.path or GESTURES_FILE,
            line=gesture.line,
            key=f"gestures.{name}",
        )

    current = dict(lib.neutral)
    if start_pose:
        sp = {k: float(v) for k, v in start_pose.items()}
        require_finite(sp, where=f"gesture '{name}' start pose")
        sp = limits.couple(sp)
        limits.check(sp, pose=current, where=f"gesture '{name}' start pose")
        current.update(sp)
    start = tuple(current[j] for j in joints)
    still = {j: v for j, v in current.items() if j not in joints}  # what the path leaves alone

    speeds = [f * limits.velocity[j] for j in joints]
    times: list[float] = []
    positions: list[tuple[float, ...]] = []
    heading: list[str] = []  # per keyframe time, the keyframe it arrives at
    t = 0.0
    prev = start
    targets = [(kf.pose, kf.hold, kf.where, kf.line) for kf in frames]
    targets.append((lib.neutral, 0.0, "return to neutral", None))
    for pose, hold, where, line in targets:
        goal = limits.snap(limits.couple(dict(pose)), pose=current)
        current.update(goal)
        limits.check(current, where=f"{gesture.at(line)}gesture '{name}' {where}", pose=current)
        q = tuple(current[j] for j in joints)
        if max(abs(b - a) for a, b in zip(prev, q, strict=True)) <= MIN_MOVE:
            q = prev  # nothing to move (a segment this short would not even advance the clock)
        u = max(abs(b - a) / v for a, b, v in zip(prev, q, speeds, strict=True))
        dur = segment_duration(u)
        if dur > 0.0:
            t += dur
            times.append(t)
            positions.append(q)
            heading.append(where)
        if hold > 0.0:
            t += hold
            times.append(t)
            positions.append(q)
            heading.append(f"the hold at {where}")
        prev = q
    if not times:
        raise ConfigError(
            f"gesture '{name}' never moves from its start pose",
            path=gesture.path or GESTURES_FILE,
            line=gesture.line,
            key=f"gestures.{name}",
        )
    traj = Trajectory(
        name=name, joints=joints, times=tuple(times), positions=tuple(positions), start=start
    )
    try:
        check_path(traj, limits=limits, pose=still, labels=heading)
    except LimitViolation as e:
        if gesture.path is None:
            raise
        raise LimitViolation(f"{gesture.at()}{e}") from None
    return traj


def path_check_times(
    traj: Trajectory, *, limits: JointLimits, pose: Mapping[str, float] | None = None
) -> np.ndarray:
    """The times at which :func:`check_path` checks ``traj``'s pose, sorted.

    Every ``PATH_CHECK_DT`` seconds, every keyframe, and, on each segment, the moments of
    :meth:`~prezence.feedback.limits.JointLimits.critical_fractions` (where ``|HeadYaw|``
    crosses a point of the head table), which make the check exact, not just sampled.
    """
    still = dict(pose or {})
    knots_t = (0.0, *traj.times)
    knots_q = (traj.start, *traj.positions)
    found = set(np.arange(0.0, traj.duration, PATH_CHECK_DT).tolist()) | set(knots_t)
    for k in range(len(traj.times)):
        a, b = knots_q[k], knots_q[k + 1]
        if a == b:
            continue
        fractions = limits.critical_fractions(
            {**still, **dict(zip(traj.joints, a, strict=True))},
            {**still, **dict(zip(traj.joints, b, strict=True))},
        )
        span = knots_t[k + 1] - knots_t[k]
        found.update(knots_t[k] + profile_time(s, span) for s in fractions[1:-1])
    return np.array(sorted(found))


def check_path(
    traj: Trajectory,
    *,
    limits: JointLimits,
    pose: Mapping[str, float] | None = None,
    labels: Sequence[str] | None = None,
) -> None:
    """Raise :class:`LimitViolation` if ``traj`` leaves a position limit anywhere on its path.

    Keyframes within the limits do not make a path within them: the head anti-collision range
    (HeadPitch limits that depend on HeadYaw) is not convex, so the straight move between two
    allowed head poses can cross it. The poses at :func:`path_check_times` are checked.

    Args:
        traj: a planned trajectory.
        limits: joint limits.
        pose: the values of the joints ``traj`` does not move (e.g. ``HeadYaw``).
        labels: per keyframe time of ``traj``, what it arrives at (``keyframes[2]``), for the
            message.

    Raises:
        LimitViolation: naming the gesture, the time, the keyframe the robot is heading to and
            the joint.
    """
    times = path_check_times(traj, limits=limits, pose=pose)
    samples = np.array([traj.sample(float(t)) for t in times])
    hit = limits.worst_violation(traj.joints, samples, pose=pose)
    if hit is None:
        return
    i, problems = hit
    t = float(times[i])
    k = min(int(np.searchsorted(traj.times, t - 1e-12)), len(traj.times) - 1)
    toward = labels[k] if labels is not None and k < len(labels) else f"keyframe {k}"
    raise LimitViolation(
        f"gesture '{traj.name}' at {t:.3f} s, on the way to {toward}: {problems[0]}; the "
        "keyframes are within the limits but the straight path between them is not (add a "
        "keyframe in between or move the head in two steps)"
    )


def segment_ratios(traj: Trajectory, *, speed_fraction: float, limits: JointLimits) -> list[float]:
    """Per segment, ``u = max_j |Δq_j| / (fraction × v_j)`` (0 for a hold)."""
    f = _check_fraction(speed_fraction)
    speeds = [f * limits.velocity[j] for j in traj.joints]
    knots = [traj.start, *traj.positions]
    return [
        max(abs(b - a) / v for a, b, v in zip(p, q, speeds, strict=True))
        for p, q in zip(knots, knots[1:], strict=False)
    ]


def time_optimal_minimum(traj: Trajectory, *, speed_fraction: float, limits: JointLimits) -> float:
    """The shortest time any motion through the same keyframes could take.

    Rest to rest at every keyframe (as planned), each segment bang-coast-bang for its slowest
    joint with speed ``fraction × URDF velocity`` and acceleration ``speed / ACCEL_TIME_S``, plus
    the same holds (a hold is part of what the gesture says).
    """
    total = 0.0
    prev_t = 0.0
    for t, u in zip(
        traj.times, segment_ratios(traj, speed_fraction=speed_fraction, limits=limits), strict=True
    ):
        total += min_segment_duration(u) if u > 0.0 else t - prev_t
        prev_t = t
    return total


def check_keyframes(
    name: str, *, limits: JointLimits, library: GestureLibrary | None = None
) -> None:
    """Raise :class:`LimitViolation` if any keyframe of ``name`` (all parameter values) is out
    of limits."""
    lib = library if library is not None else load_library(limits)
    for params in lib[name].extreme_params():
        build_trajectory(name, params=params, speed_fraction=1.0, limits=limits, library=lib)


__all__ = [
    "DEFAULT_SPEED_FRACTION",
    "Gesture",
    "GestureLibrary",
    "Keyframe",
    "LimitViolation",
    "build_trajectory",
    "builtin_gesture_names",
    "check_command_gestures",
    "check_path",
    "check_plannable",
    "library_for_talk",
    "library_notes",
    "load_library",
    "load_library_file",
    "missing_gestures",
    "parse_library",
    "parse_own_library",
    "radians_like",
    "unplayed",
    "unset_params",
    "segment_ratios",
    "time_optimal_minimum",
]
