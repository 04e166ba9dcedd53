"""NAO joint limits, read once from the URDF (the single source of truth), plus the rules a URDF
cannot express.

Position, velocity and effort limits come from ``<limit>`` in the URDF (read with yourdfpy); no
limit value is written in code. Three real-robot rules are handled here (``nao_facts.md`` §7):

* **One hip motor.** ``LHipYawPitch`` and ``RHipYawPitch`` are one motor. :meth:`JointLimits.couple`
  gives a target for one to both (``LHipYawPitch`` wins a conflict, as on NAO);
  :meth:`JointLimits.check` rejects two different values.
* **Head anti-collision.** The ``HeadPitch`` range depends on ``HeadYaw`` (the shell hits the
  shoulders). :data:`HEAD_PITCH_TABLE` is Aldebaran's table (H25 joints page, identical for
  V3.2…V5); between its points we interpolate linearly, which is our choice, not documented
  behaviour. The result is intersected with the URDF range.
* **Hands.** ``LHand``/``RHand`` are an opening fraction, 0 closed … 1 open (the URDF's 0..1
  "revolute" limits encode exactly that), never radians: messages show them as fractions.

Example:
    >>> lim = load_limits()
    >>> lim.expand("Head")
    ('HeadYaw', 'HeadPitch')
    >>> lim.couple({"LHipYawPitch": -0.2})["RHipYawPitch"]
    -0.2
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import logging
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np

from prezence.errors import ConfigError, LimitViolation, UnknownName

log = logging.getLogger(__name__)

#: NAOqi chain names and their joints, in ``getBodyNames`` order (naoqi_api.md §1).
CHAINS: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {
        "Head": ("HeadYaw", "HeadPitch"),
        "LArm": (
            "LShoulderPitch",
            "LShoulderRoll",
            "LElbowYaw",
            "LElbowRoll",
            "LWristYaw",
            "LHand",
        ),
        "LLeg": (
            "LHipYawPitch",
            "LHipRoll",
            "LHipPitch",
            "LKneePitch",
            "LAnklePitch",
            "LAnkleRoll",
        ),
        "RLeg": (
            "RHipYawPitch",
            "RHipRoll",
            "RHipPitch",
            "RKneePitch",
            "RAnklePitch",
            "RAnkleRoll",
        ),
        "RArm": (
            "RShoulderPitch",
            "RShoulderRoll",
            "RElbowYaw",
            "RElbowRoll",
            "RWristYaw",
            "RHand",
        ),
    }
)
#: ``Body`` is Head + LArm + LLeg + RLeg + RArm (26 names), as NAOqi orders it.
BODY_ORDER = ("Head", "LArm", "LLeg", "RLeg", "RArm")
HANDS = frozenset({"LHand", "RHand"})
#: The leg joints. The NAO coaches standing: no gesture may move one (a standing robot that
#: bends a knee or a hip can fall), and the sim backend holds them rigid.
LEGS = frozenset(CHAINS["LLeg"] + CHAINS["RLeg"])
HIP_YAW_PITCH = ("LHipYawPitch", "RHipYawPitch")
#: How far past a URDF limit a keyframe may be written and still be taken as meaning the limit
#: (:meth:`JointLimits.snap`): 0.001° in radians (a hand's opening: 1.7e-5). The URDF rounds the
#: NAO's documented whole-degree limits by up to 2e-5°.
DOCUMENTED_TOL = math.radians(0.001)

#: Head anti-collision (|HeadYaw| rad → HeadPitch min, max rad), symmetric in yaw. Aldebaran
#: "H25 – Joints" head table, as transcribed in nao_facts.md §7.2.
HEAD_PITCH_TABLE: tuple[tuple[float, float, float], ...] = (
    (0.0, -0.671951, 0.515047),
    (0.486074, -0.671951, 0.422021),
    (0.756077, -0.548033, 0.370010),
    (0.903033, -0.479965, 0.330041),
    (1.089958, -0.430049, 0.300022),
    (1.526988, -0.330041, 0.200015),
    (2.086017, -0.449073, 0.330041),
)


@dataclass(frozen=True)
class JointLimit:
    """One joint's URDF limits (radians, rad/s, N·m; hands: opening fraction and fraction/s)."""

    name: str
    lower: float
    upper: float
    velocity: float
    effort: float


def fmt_value(name: str, value: float, digits: int | None = None) -> str:
    """A joint value for people: degrees for angles, the fraction for hands.

    ``digits`` decimals (default 1 for degrees, 2 for hands).

    Example:
        >>> fmt_value("HeadYaw", math.pi / 2), fmt_value("LHand", 0.5)
        ('90.0°', '0.50 (opening)')
    """
    if name in HANDS:
        return f"{value:.{2 if digits is None else digits}f} (opening)"
    return f"{math.degrees(value):.{1 if digits is None else digits}f}°"


def _fmt_apart(name: str, value: float, bounds: tuple[float, float]) -> tuple[str, str, str]:
    """``value`` and its range with as many decimals as it takes for the value to read outside:
    the NAO's documented -18° for LShoulderRoll is -17.99998° in the URDF, and "-18.0° is
    outside [-18.0°, 76.0°]" tells the reader nothing."""
    lo, hi = bounds
    near = lo if abs(value - lo) <= abs(value - hi) else hi
    base = 2 if name in HANDS else 1
    digits = base
    while digits < base + 6 and fmt_value(name, value, digits) == fmt_value(name, near, digits):
        digits += 1
    return (
        fmt_value(name, value, digits),
        fmt_value(name, lo, digits),
        fmt_value(name, hi, digits),
    )


def require_finite(targets: Mapping[str, float], *, where: str = "") -> None:
    """Raise ``ValueError`` naming the first joint whose target is NaN or infinite."""
    for name, v in targets.items():
        if not math.isfinite(float(v)):
            prefix = f"{where}: " if where else ""
            raise ValueError(f"{prefix}{name} target is {v!r}; joint targets must be finite")


class JointLimits:
    """The limits of every actuated joint, with NAOqi chain names and the coupled-joint rules.

    Build it with :func:`load_limits` (cached) rather than directly.

    Attributes:
        source: the URDF the limits were read from.
        lower, upper, velocity, effort: read-only maps joint name → value.
    """

    def __init__(self, joints: Iterable[JointLimit], *, source: Path) -> None:
        by_name = {j.name: j for j in joints}
        body = [n for chain in BODY_ORDER for n in CHAINS[chain]]
        missing = [n for n in body if n not in by_name]
        if missing:
            raise ConfigError(f"URDF lacks NAO joints: {', '.join(missing)}", path=source)
        # Body order first (NAOqi's), then anything else the URDF adds.
        order = body + sorted(n for n in by_name if n not in set(body))
        self._joints: Mapping[str, JointLimit] = MappingProxyType({n: by_name[n] for n in order})
        self.source = source
        self.lower: Mapping[str, float] = MappingProxyType(
            {n: j.lower for n, j in self._joints.items()}
        )
        self.upper: Mapping[str, float] = MappingProxyType(
            {n: j.upper for n, j in self._joints.items()}
        )
        self.velocity: Mapping[str, float] = MappingProxyType(
            {n: j.velocity for n, j in self._joints.items()}
        )
        self.effort: Mapping[str, float] = MappingProxyType(
            {n: j.effort for n, j in self._joints.items()}
        )

    # -- lookup ------------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """All joint names, in NAOqi ``Body`` order."""
        return tuple(self._joints)

    @property
    def chains(self) -> Mapping[str, tuple[str, ...]]:
        """Chain name → joint names (``Head``, ``LArm``, ``RArm``, ``LLeg``, ``RLeg``, ``Body``)."""
        out = dict(CHAINS)
        out["Body"] = tuple(n for c in BODY_ORDER for n in CHAINS[c])
        return MappingProxyType(out)

    def __getitem__(self, name: str) -> JointLimit:
        try:
            return self._joints[name]
        except KeyError:
            raise UnknownName("joint", name, self._joints) from None

    def __contains__(self, name: object) -> bool:
        return name in self._joints

    def require_known(self, names: Iterable[str]) -> None:
        """Raise :class:`~prezence.errors.UnknownName` for the first name that is no joint."""
        for name in names:
            if name not in self._joints:
                raise UnknownName("joint", name, self._joints)

    def expand(self, name: str) -> tuple[str, ...]:
        """A joint, chain or ``Body`` name → the joint names it stands for.

        Raises:
            UnknownName: neither a joint nor a chain (with a did-you-mean).
        """
        if name in self._joints:
            return (name,)
        chains = self.chains
        if name in chains:
            return chains[name]
        raise UnknownName("joint or chain", name, [*self._joints, *chains])

    # -- coupled rules -----------------------------------------------------------------------
    def head_pitch_range(self, yaw: float) -> tuple[float, float]:
        """HeadPitch (min, max) allowed at this HeadYaw: the anti-collision table ∩ the URDF."""
        lo, hi = self.head_pitch_ranges(np.asarray([float(yaw)]))
        return float(lo[0]), float(hi[0])

    def head_pitch_ranges(self, yaw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`head_pitch_range` for an array of HeadYaw values: (mins, maxes)."""
        table = np.asarray(HEAD_PITCH_TABLE)
        a = np.abs(np.asarray(yaw, dtype=float))
        urdf = self["HeadPitch"]
        lo = np.maximum(np.interp(a, table[:, 0], table[:, 1]), urdf.lower)
        hi = np.minimum(np.interp(a, table[:, 0], table[:, 2]), urdf.upper)
        return lo, hi

    def critical_fractions(
        self, start: Mapping[str, float], end: Mapping[str, float]
    ) -> tuple[float, ...]:
        """Where the straight move ``start`` → ``end`` can come closest to a position limit.

        Along ``q(s) = start + s · (end − start)``, ``0 <= s <= 1``, every margin to a URDF
        bound is linear in ``s``, and the head anti-collision range is piecewise linear in
        ``|HeadYaw|`` with its corners at the table's yaw points. So each margin is smallest at
        ``s = 0``, ``s = 1`` or an ``s`` where ``|HeadYaw|`` crosses a table point: checking the
        poses at the returned fractions checks the whole move exactly. A joint missing from
        ``end`` keeps its ``start`` value.

        Example:
            >>> load_limits().critical_fractions({"HeadYaw": 0.0}, {"HeadYaw": 1.0})
            (0.0, 0.486074, 0.756077, 0.903033, 1.0)
        """
        out = {0.0, 1.0}
        y0 = start.get("HeadYaw")
        y1 = end.get("HeadYaw", y0)
        if y0 is not None and y1 is not None and y1 != y0:
            for point in (row[0] for row in HEAD_PITCH_TABLE):
                for yaw in (point, -point):
                    s = (yaw - y0) / (y1 - y0)
                    if 0.0 < s < 1.0:
                        out.add(s)
        return tuple(sorted(out))

    def range(self, name: str, pose: Mapping[str, float] | None = None) -> tuple[float, float]:
        """The allowed (min, max) of ``name``; HeadPitch uses ``pose['HeadYaw']`` when given."""
        j = self[name]
        if name == "HeadPitch" and pose is not None and "HeadYaw" in pose:
            return self.head_pitch_range(pose["HeadYaw"])
        return j.lower, j.upper

    def couple(self, targets: Mapping[str, float]) -> dict[str, float]:
        """Targets with the one-motor hip rule applied: a HipYawPitch target goes to both sides
        (LHipYawPitch wins when both are given and differ, as on NAO)."""
        out = dict(targets)
        left, right = HIP_YAW_PITCH
        if left in out:
            out[right] = out[left]
        elif right in out:
            out[left] = out[right]
        return out

    # -- clip and check ----------------------------------------------------------------------
    def clip(
        self, targets: Mapping[str, float], *, pose: Mapping[str, float] | None = None
    ) -> dict[str, float]:
        """Targets moved inside every limit (hip coupling and head table applied).

        Args:
            targets: joint name → value.
            pose: the robot's other joint values, for HeadYaw when only HeadPitch is targeted.

        Raises:
            ValueError: a NaN or infinite target (naming the joint).
            UnknownName: an unknown joint.
        """
        require_finite(targets)
        out = self.couple(targets)
        self.require_known(out)
        context = {**(pose or {}), **out}
        for name in list(out):
            if name == "HeadPitch":
                continue
            lo, hi = self.range(name)
            out[name] = min(max(float(out[name]), lo), hi)
        if "HeadPitch" in out:
            context["HeadYaw"] = out.get("HeadYaw", context.get("HeadYaw", 0.0))
            lo, hi = self.range("HeadPitch", context)
            out["HeadPitch"] = min(max(float(out["HeadPitch"]), lo), hi)
        return out

    def snap(
        self, targets: Mapping[str, float], *, pose: Mapping[str, float] | None = None
    ) -> dict[str, float]:
        """Targets within :data:`DOCUMENTED_TOL` past a limit, moved onto it.

        The NAO's documentation gives its limits in whole degrees (LShoulderRoll -18° .. 76°);
        the URDF's radians round them a hair inside (-17.99998°). A keyframe written with the
        documented value is meant to reach the limit, not to break it: it is moved onto the
        URDF's value (at most 0.001°, far below the joint encoders' resolution). A value further
        out is left as written, for :meth:`check` to refuse.
        """
        out = dict(targets)
        context = {**(pose or {}), **out}
        for name, value in out.items():
            if name not in self._joints:
                continue
            lo, hi = self.range(name, context)
            if lo - DOCUMENTED_TOL <= value < lo:
                out[name] = lo
            elif hi < value <= hi + DOCUMENTED_TOL:
                out[name] = hi
        return out

    def violations(
        self,
        targets: Mapping[str, float],
        *,
        pose: Mapping[str, float] | None = None,
        tol: float = 1e-9,
    ) -> list[str]:
        """Every broken position rule, one message per joint (empty when all are fine)."""
        require_finite(targets)
        problems: list[str] = []
        context = {**(pose or {}), **targets}
        left, right = HIP_YAW_PITCH
        if left in targets and right in targets and abs(targets[left] - targets[right]) > tol:
            problems.append(
                f"{right} = {fmt_value(right, targets[right])} differs from {left} = "
                f"{fmt_value(left, targets[left])}; they are one motor, give one value"
            )
        for name, value in targets.items():
            lo, hi = self.range(name, context)
            if not lo - tol <= value <= hi + tol:
                why = " (head anti-collision range at this HeadYaw)" if name == "HeadPitch" else ""
                v_s, lo_s, hi_s = _fmt_apart(name, value, (lo, hi))
                problems.append(f"{name} = {v_s} is outside [{lo_s}, {hi_s}]{why}")
        return problems

    def worst_violation(
        self,
        names: Sequence[str],
        samples: np.ndarray,
        *,
        pose: Mapping[str, float] | None = None,
        tol: float = 1e-9,
    ) -> tuple[int, list[str]] | None:
        """The pose, of many checked at once, that breaks a position rule by the most.

        Args:
            names: the joints, one per column of ``samples``.
            samples: poses, one per row (radians; hands: opening fraction).
            pose: the values of joints not in ``names`` (e.g. ``HeadYaw`` for the head range).
            tol: slack in the joint's unit.

        Returns:
            None when every row is within every rule, else the index of the row that is
            furthest outside one and :meth:`violations`'s messages for it.

        Raises:
            ValueError: a NaN or infinite value (naming the joint).
            UnknownName: an unknown joint.
        """
        q = np.asarray(samples, dtype=float).reshape(-1, len(names))
        col = {n: i for i, n in enumerate(names)}
        self.require_known(col)
        for name, i in col.items():
            if not np.isfinite(q[:, i]).all():
                require_finite({name: float(q[~np.isfinite(q[:, i]), i][0])})
        excess = np.zeros(len(q))
        for name, i in col.items():
            if name == "HeadPitch":
                yaw = q[:, col["HeadYaw"]] if "HeadYaw" in col else None
                if yaw is None and pose is not None and "HeadYaw" in pose:
                    yaw = np.full(len(q), float(pose["HeadYaw"]))
                if yaw is not None:
                    lo, hi = self.head_pitch_ranges(yaw)
                else:
                    lo, hi = (np.full(len(q), v) for v in self.range(name))
            else:
                lo, hi = (np.full(len(q), v) for v in self.range(name))
            excess = np.maximum(excess, np.maximum(lo - q[:, i], q[:, i] - hi))
        left, right = HIP_YAW_PITCH
        if left in col and right in col:
            excess = np.maximum(excess, np.abs(q[:, col[left]] - q[:, col[right]]))
        if not (excess > tol).any():
            return None
        i = int(np.argmax(excess))
        row = {n: float(q[i, k]) for n, k in col.items()}
        return i, self.violations(row, pose=pose, tol=tol)

    def check(
        self,
        targets: Mapping[str, float],
        *,
        pose: Mapping[str, float] | None = None,
        where: str = "",
        tol: float = 1e-9,
    ) -> None:
        """Raise :class:`~prezence.errors.LimitViolation` naming the first joint out of limits.

        Args:
            targets: joint name → value (radians; hands: opening fraction).
            pose: the robot's other joint values (for the HeadYaw-dependent HeadPitch range).
            where: prefix for the message, e.g. ``"gesture 'louder' keyframes[2]"``.
            tol: slack in the joint's unit.

        Raises:
            LimitViolation: a value is outside its range, or the two hip joints disagree.
            ValueError: a NaN or infinite target (naming the joint).
            UnknownName: an unknown joint name.
        """
        self.require_known(targets)
        problems = self.violations(targets, pose=pose, tol=tol)
        if problems:
            prefix = f"{where}: " if where else ""
            raise LimitViolation(prefix + problems[0])


def _read_urdf(path: Path) -> list[JointLimit]:
    import yourdfpy  # a core dependency; imported here to keep `import prezence` light

    try:
        urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_scene_graph=False)
    except Exception as e:  # yourdfpy raises assorted lxml/ValueError types on a bad file
        raise ConfigError(f"cannot read URDF: {e}", path=path) from e
    out: list[JointLimit] = []
    for name, joint in urdf.joint_map.items():
        if joint.type not in ("revolute", "prismatic"):
            continue
        lim = joint.limit
        if lim is None or lim.lower is None or lim.upper is None or lim.velocity is None:
            raise ConfigError(f"joint {name} has no complete <limit>", path=path)
        out.append(
            JointLimit(
                name=name,
                lower=float(lim.lower),
                upper=float(lim.upper),
                velocity=float(lim.velocity),
                effort=float(lim.effort or 0.0),
            )
        )
    return out


#: Where the limits read from a URDF are kept (``$PREZENCE_CACHE``, else
#: ``$XDG_CACHE_HOME/prezence``, else ``~/.cache/prezence``): importing yourdfpy (trimesh,
#: scipy) costs far more than a whole headless talk, and the limits of a file never change.
LIMITS_CACHE_FORMAT = 1


def _cache_dir() -> Path:
    env = os.environ.get("PREZENCE_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "prezence"


def _cached_joints(path: Path) -> list[JointLimit]:
    """The URDF's joint limits, from the cache when this exact file (by content) was read."""
    data = path.read_bytes()
    digest = hashlib.sha256(data).hexdigest()[:32]
    cache = _cache_dir() / f"urdf-limits-{LIMITS_CACHE_FORMAT}-{digest}.json"
    try:
        rows = json.loads(cache.read_text(encoding="utf-8"))
        return [JointLimit(**row) for row in rows]
    except (OSError, ValueError, TypeError):
        pass  # no cache yet, or a damaged one: read the URDF
    joints = _read_urdf(path)
    try:
        cache.parent.mkdir(parents=True, exist_ok=True)
        tmp = cache.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(json.dumps([dataclasses.asdict(j) for j in joints]), encoding="utf-8")
        tmp.replace(cache)
    except OSError as e:  # a read-only home: read the URDF every time
        log.debug("joint limits not cached: %s", e)
    return joints


@functools.cache
def _load(path: str) -> JointLimits:
    log.debug("reading joint limits from %s", path)
    return JointLimits(_cached_joints(Path(path)), source=Path(path))


def load_limits(urdf: Path | str | None = None) -> JointLimits:
    """The joint limits of ``urdf`` (default: the project's NAO), read once and cached."""
    if urdf is None:
        from prezence.resources import urdf_path

        urdf = urdf_path()
    return _load(str(Path(urdf).resolve()))
