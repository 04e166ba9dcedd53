"""``prezence gestures check``: every gesture's timing and limit margins, as a table or JSON.

For each gesture (``time_left`` at its smallest and largest parameter) the report gives the
planned duration, the time-optimal minimum under the same speed and acceleration bounds, their
ratio, the highest planned joint speed as a share of that joint's URDF limit, and the smallest
distance to a position limit along the whole path (sampled every 5 ms, head anti-collision range
included) and, when PyBullet is installed, the least clearance between two non-adjacent links
of the robot along the path (:mod:`prezence.feedback.collision`, the URDF's collision shapes).
The exit status is non-zero when any gesture breaks a limit, comes closer to itself than
``MIN_CLEARANCE_M``, is slower than ``MAX_RATIO`` × its minimum, or takes more than
``MAX_DURATION_S``.

``prezence gestures check FILE`` checks the gestures of a library of one's own
(:func:`~prezence.feedback.gestures.load_library_file`) the same way; the built-in gestures it
leaves in place are the ones ``prezence gestures check`` checks.
"""

from __future__ import annotations

import functools
import json
import logging
import math
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

from prezence.errors import ConfigError, GestureCheckFailed, LimitViolation, PrezenceError
from prezence.feedback.collision import (
    ALLOW_UNCHECKED,
    MIN_CLEARANCE_M,
    SelfCollisionChecker,
    pybullet_available,
)
from prezence.feedback.gestures import (
    GestureLibrary,
    build_trajectory,
    library_notes,
    load_library,
    load_library_file,
    missing_gestures,
    time_optimal_minimum,
)
from prezence.feedback.limits import HANDS, JointLimits, load_limits
from prezence.feedback.trajectory import ACCEL_TIME_S, BLEND_FRACTION, RAMP_S, Trajectory

log = logging.getLogger(__name__)

#: The issue's bound: planned duration <= 1.10 × the time-optimal minimum.
MAX_RATIO = 1.10
#: The longest a gesture may take (s). While it plays the robot gives no other cue, a time
#: warning included; the built-in ones take at most 4.3 s at the default speed (6.8 s at 0.2).
MAX_DURATION_S = 10.0
SAMPLE_DT = 0.005
_TOL = 1e-9


def _cases(lib: GestureLibrary) -> list[tuple[str, str, dict[str, int] | None]]:
    """Each gesture to check (a library of one's own: those its file defines)."""
    out: list[tuple[str, str, dict[str, int] | None]] = []
    for name in lib.own or lib.names:
        for params in lib[name].extreme_params():
            label = name + "".join(f"[{k}={v}]" for k, v in (params or {}).items())
            out.append((label, name, params))
    return out


def _path_margin(
    traj: Trajectory, limits: JointLimits, neutral: dict[str, float]
) -> tuple[float, str, int]:
    """Smallest distance to a position limit over the sampled path (radians; hands excluded),
    the joint where it occurs, and how many samples were outside a limit."""
    n = max(2, int(math.ceil(traj.duration / SAMPLE_DT)) + 1)
    ts = np.linspace(0.0, traj.duration, n)
    qs = np.array([traj.sample(float(t)) for t in ts])
    idx = {j: i for i, j in enumerate(traj.joints)}
    best, where, outside = math.inf, "", 0
    for i, j in enumerate(traj.joints):
        if j in HANDS:
            continue
        if j == "HeadPitch":
            yaw = qs[:, idx["HeadYaw"]] if "HeadYaw" in idx else np.full(n, neutral["HeadYaw"])
            lo, hi = limits.head_pitch_ranges(yaw)  # head_pitch_range's values, all at once
        else:
            lo = np.full(n, limits.lower[j])
            hi = np.full(n, limits.upper[j])
        m = np.minimum(qs[:, i] - lo, hi - qs[:, i])
        outside += int(np.count_nonzero(m < -_TOL))
        if float(m.min()) < best:
            best, where = float(m.min()), j
    for j in HANDS & set(idx):
        col = qs[:, idx[j]]
        outside += int(
            np.count_nonzero((col < limits.lower[j] - _TOL) | (col > limits.upper[j] + _TOL))
        )
    return best, where, outside


def gesture_rows(
    speed_fraction: float,
    *,
    limits: JointLimits | None = None,
    collisions: bool | None = None,
    library: GestureLibrary | None = None,
) -> list[dict[str, Any]]:
    """One row of figures per gesture case (see the module docstring).

    Args:
        speed_fraction: fraction of the URDF velocity limits, in (0, 1].
        limits: joint limits (default: the project's URDF).
        collisions: measure self-clearance (needs PyBullet); None: when PyBullet is installed.
        library: the library (default: the built-in one); of one's own: the gestures its file
            defines.
    """
    limits = limits if limits is not None else load_limits()
    lib = library if library is not None else load_library(limits)
    if collisions is None:
        collisions = pybullet_available()
    with ExitStack() as stack:
        checker = (
            stack.enter_context(SelfCollisionChecker(limits=limits, library=lib))
            if collisions
            else None
        )
        return _rows(speed_fraction, limits, lib, checker)


def _rows(
    speed_fraction: float,
    limits: JointLimits,
    lib: GestureLibrary,
    checker: SelfCollisionChecker | None,
) -> list[dict[str, Any]]:
    return [
        _row(label, name, params, speed_fraction, limits, lib, checker)
        for label, name, params in _cases(lib)
    ]


def _row(
    label: str,
    name: str,
    params: dict[str, int] | None,
    speed_fraction: float,
    limits: JointLimits,
    lib: GestureLibrary,
    checker: SelfCollisionChecker | None,
) -> dict[str, Any]:
    """The row of one gesture case (see :func:`gesture_rows`)."""
    row: dict[str, Any] = {"gesture": label}
    try:
        traj = build_trajectory(
            name, params=params, speed_fraction=speed_fraction, limits=limits, library=lib
        )
    except (LimitViolation, ConfigError) as e:  # out of the limits, or never moves
        row.update(ok=False, error=str(e))
        return row
    t_min = time_optimal_minimum(traj, speed_fraction=speed_fraction, limits=limits)
    peaks = traj.peak_velocities()
    ratios = {j: float(v) / limits.velocity[j] for j, v in zip(traj.joints, peaks, strict=True)}
    worst = max(ratios, key=lambda j: ratios[j])
    margin, margin_joint, outside = _path_margin(traj, limits, dict(lib.neutral))
    problems: list[str] = []
    if ratios[worst] > speed_fraction * (1.0 + 1e-9):
        problems.append(
            f"{worst} planned at {ratios[worst]:.1%} of its limit > {speed_fraction:.0%}"
        )
    if outside:
        problems.append(f"{outside} path samples outside a position limit")
    ratio = traj.duration / t_min if t_min > 0 else math.inf
    if ratio > MAX_RATIO:
        problems.append(f"duration {ratio:.3f} × the time-optimal minimum > {MAX_RATIO}")
    if traj.duration > MAX_DURATION_S:
        problems.append(
            f"takes {traj.duration:.1f} s > {MAX_DURATION_S:g} s: while a gesture plays the "
            "robot gives no other cue, a time warning included (fewer holds or repeats)"
        )
    collided = False
    if checker is not None:
        clearance = checker.trajectory_clearance(traj)
        row.update(
            clearance_mm=round(clearance.mm, 1),
            clearance_links=list(clearance.links),
            clearance_at_s=clearance.time_s,
        )
        if clearance.distance_m < MIN_CLEARANCE_M:
            collided = True
            problems.append(
                f"self-collision: {clearance.describe()} "
                f"(< {1000 * MIN_CLEARANCE_M:.0f} mm clearance)"
            )
    row.update(
        ok=not problems,
        duration_s=round(traj.duration, 4),
        time_optimal_s=round(t_min, 4),
        ratio=round(ratio, 4),
        peak_velocity_pct=round(100.0 * ratios[worst], 2),
        peak_velocity_joint=worst,
        peak_velocity_pct_by_joint={j: round(100.0 * r, 2) for j, r in ratios.items()},
        margin_deg=round(math.degrees(margin), 2),
        margin_joint=margin_joint,
        keyframes=len(traj.times),
        joints=len(traj.joints),
    )
    if problems:
        # a self-collision row names the gesture's file:line, as a row out of a limit names
        # its keyframe's (and a talk's refusal of it, the same line); the others keep their
        # text, which the speed checks below read
        row["error"] = (lib[name].at() if collided else "") + "; ".join(problems)
    return row


def gesture_failure(
    name: str,
    params: dict[str, int] | None,
    *,
    speed_fraction: float,
    library: GestureLibrary | None = None,
    limits: JointLimits | None = None,
) -> str | None:
    """What fails ``gestures check`` in one gesture case that can be planned (its row's
    error: self-collision where PyBullet is, too long, too slow…), or None when it passes or
    cannot be planned at all (out of a position limit: planning it raises that error itself).

    ``gestures render`` says it (session 23: it drew a self-colliding gesture without a word).
    """
    limits = limits if limits is not None else load_limits()
    lib = library if library is not None else load_library(limits)
    with ExitStack() as stack:
        checker = (
            stack.enter_context(SelfCollisionChecker(limits=limits, library=lib))
            if pybullet_available()
            else None
        )
        row = _row(name, name, params, speed_fraction, limits, lib, checker)
    if row["ok"] or "duration_s" not in row:
        return None
    # the caller names the gesture's file:line itself (a self-collision row starts with it)
    return str(row["error"]).removeprefix(lib[name].at())


def check_gestures(
    speed_fraction: float,
    *,
    as_json: bool,
    collisions: bool | None = None,
    library: str | Path | None = None,
) -> tuple[str, int]:
    """The report for ``prezence gestures check [FILE]`` and its exit status.

    Args:
        speed_fraction: fraction of the URDF velocity limits, in (0, 1].
        as_json: JSON (one object with the settings and a row per gesture) instead of a table.
        collisions: check self-collision (needs PyBullet); None: when PyBullet is installed;
            False: not checked, and said so without blaming a missing PyBullet.
        library: a library file of one's own: its gestures are checked (None: the built-in
            library's).

    Returns:
        (text, status): status 0 when every gesture is within every limit, keeps
        ``MIN_CLEARANCE_M`` from itself (when checked), is within ``MAX_RATIO`` of its
        time-optimal minimum and takes at most ``MAX_DURATION_S``, 1 otherwise, 2 for a bad
        argument.

    Raises:
        ConfigError: ``library`` cannot be read or is not a valid library (``file:line:``).
    """
    if not 0.0 < speed_fraction <= 1.0:
        return f"error: --speed must be in (0, 1], got {speed_fraction}", 2
    skipped = "not checked (--no-collisions)" if collisions is False else ""
    if collisions is None:
        collisions = pybullet_available()
    try:
        limits = load_limits()
    except PrezenceError as e:
        return f"error: {e}", 2
    lib = load_library_file(library, limits=limits) if library is not None else None
    try:
        rows = gesture_rows(speed_fraction, limits=limits, collisions=collisions, library=lib)
    except PrezenceError as e:
        return f"error: {e}", 2
    notes = library_notes(lib) if lib is not None else []
    # a command of the table whose gesture is in neither library stops a talk at its cue
    missing = missing_gestures(lib)
    status = 0 if all(r["ok"] for r in rows) and not missing else 1
    settings = {
        "speed_fraction": speed_fraction,
        "profile": "trapezoidal velocity, S-curve blends, rest at every keyframe",
        "ramp_s": RAMP_S,
        "blend_fraction": BLEND_FRACTION,
        "accel_bound": f"fraction x URDF velocity / {ACCEL_TIME_S:.2f} s",
        "max_ratio": MAX_RATIO,
        "max_duration_s": MAX_DURATION_S,
        "self_collision": (
            f"URDF collision shapes, non-adjacent links, >= {1000 * MIN_CLEARANCE_M:.0f} mm"
            if collisions
            else skipped or 'not checked (needs pybullet: pip install "prezence[sim]")'
        ),
    }
    if lib is not None:
        settings["library"] = str(library)
    if as_json:
        doc: dict[str, Any] = {"settings": settings, "ok": status == 0, "gestures": rows}
        if missing:
            doc["missing_gestures"] = missing
        return json.dumps({**doc, "notes": notes} if lib else doc, indent=2), status
    of = f"gestures of {library}" if lib is not None else "gestures"
    lines = [
        f"{of} at {speed_fraction:.0%} of the URDF velocity limits; profile: trapezoid with "
        f"{RAMP_S:.2f} s ramps and {BLEND_FRACTION:.0%} blends, "
        f"acceleration bound v/{ACCEL_TIME_S:.2f} s",
        f"{'gesture':<22}{'planned':>9}{'minimum':>9}{'ratio':>7}  {'peak speed (of limit)':<27}"
        f"{'position margin':<24}" + (f"{'self clearance':<33}" if collisions else "") + "status",
    ]
    if not collisions:
        lines.insert(1, f"self-collision {settings['self_collision']}")
    for r in rows:
        if "duration_s" not in r:
            lines.append(
                f"{r['gesture']:<22}{'-':>9}{'-':>9}{'-':>7}  {'':<27}{'':<24}"
                + (f"{'':<33}" if collisions else "")
                + f"FAIL: {r['error']}"
            )
            continue
        peak = f"{r['peak_velocity_pct']:5.1f} % {r['peak_velocity_joint']}"
        margin = f"{r['margin_deg']:6.1f}° {r['margin_joint']}"
        clear = (
            f"{r['clearance_mm']:6.1f} mm {'-'.join(r['clearance_links'])}"
            if "clearance_mm" in r
            else ""
        )
        # without the clearance a row is not the whole check: no plain "ok" (a talk on a
        # robot refuses these gestures, prezence.feedback.collision.require_collision_checked)
        passed = "ok" if collisions else "ok but self-collision not checked"
        state = passed if r["ok"] else f"FAIL: {r['error']}"
        lines.append(
            f"{r['gesture']:<22}{r['duration_s']:>7.2f} s{r['time_optimal_s']:>7.2f} s"
            f"{r['ratio']:>7.3f}  "
            f"{peak:<27}{margin:<24}" + (f"{clear:<33}" if collisions else "") + state
        )
    measured = [r for r in rows if "ratio" in r]
    worst = max(measured, key=lambda r: r["ratio"]) if measured else None
    names = {str(r["gesture"]).partition("[")[0] for r in rows}
    gestures = "gesture" if len(names) == 1 else "gestures"
    summary = f"{sum(r['ok'] for r in rows)}/{len(rows)} timings ok ({len(names)} {gestures}"
    if lib is not None:
        summary += f" of {library}"
    summary += ", some at several parameter values)" if len(names) < len(rows) else ")"
    if worst is not None:
        summary += (
            f"; largest ratio {worst['ratio']:.3f} ({worst['gesture']}), bound {MAX_RATIO:.2f}"
        )
    cleared = [r for r in rows if "clearance_mm" in r]
    if cleared:
        closest = min(cleared, key=lambda r: r["clearance_mm"])
        summary += (
            f"; least self clearance {closest['clearance_mm']:.1f} mm ({closest['gesture']}), "
            f"bound {1000 * MIN_CLEARANCE_M:.0f} mm"
        )
    lines.append(summary)
    if not collisions and lib is not None:
        if pybullet_available():  # skipped here (--no-collisions); every talk checks them
            lines.append(
                f"self-collision of the gestures of {library} not checked here "
                "(--no-collisions): a talk checks them before it starts (PyBullet is installed)"
            )
        else:
            lines.append(
                f"self-collision of the gestures of {library} not checked: a talk on a real "
                f"robot (--backend naoqi) refuses them here unless given {ALLOW_UNCHECKED} "
                '(pip install "prezence[sim]" checks them)'
            )
    if lib is not None and len(lib.names) > len(lib.own):  # a whole library leaves none
        kept = len(lib.names) - len(lib.own)
        lines.append(
            f"the other {kept} gestures a talk with --gestures {library} plays are the built-in "
            "ones (prezence gestures check)"
        )
    lines += [f"FAIL: {m}" for m in missing]
    lines += [f"note: {n}" for n in notes]
    return "\n".join(lines), status


# ---------------------------------------------------------------------------------------------
# A talk's gestures: refused when they fail the check at the talk's speed
def lowest_passing_speed(
    name: str,
    params: dict[str, int] | None,
    *,
    library: GestureLibrary,
    limits: JointLimits,
) -> float | None:
    """The lowest speed fraction, in hundredths, at which one gesture case passes the check
    (self-collision aside: the path, and so the clearance, is the same at every speed), or
    None when it fails even at 1.

    A gesture's duration shrinks as the speed grows (its holds stay), so the speeds it passes
    at are those from some value up: found by bisection, first on the duration alone (no path
    to sample), then on the whole check where something else fails there.
    """

    def fits(hundredths: int) -> bool:  # within MAX_DURATION_S: cheap, no path sampled
        try:
            traj = build_trajectory(
                name, params=params, speed_fraction=hundredths / 100, limits=limits, library=library
            )
        except (LimitViolation, ConfigError):
            return False
        return traj.duration <= MAX_DURATION_S

    def ok(hundredths: int) -> bool:  # the whole check
        return bool(_row(name, name, params, hundredths / 100, limits, library, None)["ok"])

    def lowest(test: Callable[[int], bool], fails: int) -> int:  # test(100) holds
        passes = 100
        while passes - fails > 1:
            mid = (fails + passes) // 2
            if test(mid):
                passes = mid
            else:
                fails = mid
        return passes

    if not fits(100):
        return None
    first = lowest(fits, 0)  # 0 stands for "no speed": the range is (0, 1]
    if ok(first):
        return first / 100
    if not ok(100):
        return None
    return lowest(ok, first) / 100


@functools.lru_cache(maxsize=16)
def _builtin_failures(
    speed_fraction: float, urdf: str
) -> tuple[tuple[str, dict[str, int] | None, dict[str, Any]], ...]:
    """The built-in gesture cases that fail the check at ``speed_fraction`` (once per speed:
    every talk asks, and the built-in library is the same each time)."""
    limits = load_limits(urdf)
    lib = load_library(limits)
    rows = [(n, p, _row(lb, n, p, speed_fraction, limits, lib, None)) for lb, n, p in _cases(lib)]
    return tuple((n, p, r) for n, p, r in rows if not r["ok"])


@functools.lru_cache(maxsize=64)
def _builtin_lowest(name: str, params: tuple[tuple[str, int], ...], urdf: str) -> float | None:
    """:func:`lowest_passing_speed` of a built-in gesture case (a fact of the library: once)."""
    limits = load_limits(urdf)
    return lowest_passing_speed(
        name, dict(params) or None, library=load_library(limits), limits=limits
    )


def _with(params: dict[str, int] | None) -> str:
    return "".join(f" with {k} = {v}" for k, v in (params or {}).items())


def _of(params: dict[str, int] | None) -> str:
    return f" ({', '.join(f'{k} = {v}' for k, v in params.items())})" if params else ""


def _fix(
    name: str,
    params: dict[str, int] | None,
    speed_fraction: float,
    *,
    library: GestureLibrary,
    limits: JointLimits,
) -> str:
    """What to change so that a failing gesture case passes: a higher --speed, when one does."""
    lowest = lowest_passing_speed(name, params, library=library, limits=limits)
    if lowest is not None:
        return f"or give --speed {lowest:g} or more (the lowest at which it passes)"
    at_1 = _row(name, name, params, 1.0, limits, library, None)
    took = (
        f" (at --speed 1 it still takes {at_1['duration_s']:.1f} s)" if "duration_s" in at_1 else ""
    )
    return f"no --speed makes it pass{took}: change the gesture"


def check_talk_gestures(
    speed_fraction: float,
    *,
    library: GestureLibrary | None,
    limits: JointLimits | None = None,
) -> None:
    """Refuse a talk whose gestures fail ``prezence gestures check`` at its speed.

    A talk plays the gestures of ``library`` (of one's own: the file's, the built-in rest) at
    ``speed_fraction``. Each is checked as ``gestures check`` checks it at that speed, save
    self-collision (checked on load, :func:`~prezence.feedback.gestures.library_for_talk`,
    and the same at every speed): a gesture that takes more than :data:`MAX_DURATION_S` would
    keep the robot from any other cue, a time warning included, for that long. Every command
    that runs a talk calls it before the robot opens and before a session folder is written.

    Args:
        speed_fraction: the talk's ``--speed``, in (0, 1].
        library: a library of one's own (None: the built-in one).
        limits: joint limits (default: the project's URDF).

    Raises:
        ValueError: ``speed_fraction`` outside (0, 1].
        GestureCheckFailed: one line per failing gesture of one's own (``file:line: gesture
            'name' …``, what failed, the speed at which it would pass or that none would), and
            one for the built-in gestures that fail at this speed with the lowest speed at which
            every one of them passes.
    """
    if not 0.0 < speed_fraction <= 1.0:
        raise ValueError(f"speed_fraction must be in (0, 1], got {speed_fraction!r}")
    limits = limits if limits is not None else load_limits()
    own = library.own if library is not None else ()
    lines: list[str] = []
    if library is not None and own:
        from prezence.feedback.commands import load_commands

        # a gesture no command plays is never played in a talk (loading it says so)
        played = {c.gesture for c in load_commands().values()}
        for _label, name, params in _cases(library):
            if name not in played:
                continue
            row = _row(name, name, params, speed_fraction, limits, library, None)
            if row["ok"]:
                continue
            g = library[name]
            fix = _fix(name, params, speed_fraction, library=library, limits=limits)
            lines.append(
                f"{g.at()}gesture '{name}'{_with(params)} fails `prezence gestures check "
                f"{g.path or 'FILE'} --speed {speed_fraction:g}`: {row['error']}; {fix}"
            )
    builtin = [
        (n, p, r)
        for n, p, r in _builtin_failures(float(speed_fraction), str(limits.source))
        if n not in own
    ]
    if builtin:
        lines.append(_builtin_line(speed_fraction, builtin, limits=limits))
    if lines:
        raise GestureCheckFailed("\n".join(lines))


def _builtin_line(
    speed_fraction: float,
    failures: list[tuple[str, dict[str, int] | None, dict[str, Any]]],
    *,
    limits: JointLimits,
) -> str:
    """``--speed 0.05: 10 built-in gestures would take longer than 10 s (…); the lowest speed
    at which every built-in gesture passes is 0.11``."""
    slow = sorted(
        ((n, p, r) for n, p, r in failures if str(r["error"]).startswith("takes ")),
        key=lambda f: -float(f[2]["duration_s"]),
    )
    other = [(n, p, r) for n, p, r in failures if not str(r["error"]).startswith("takes ")]
    parts: list[str] = []
    if slow:
        names = {n for n, _, _ in slow}
        gestures = "gesture" if len(names) == 1 else "gestures"
        took = ", ".join(f"{n}{_of(p)} {r['duration_s']:.1f} s" for n, p, r in slow)
        parts.append(
            f"{len(names)} built-in {gestures} would take longer than {MAX_DURATION_S:g} s "
            f"({took}), and while a gesture plays the robot gives no other cue, a time warning "
            "included"
        )
    parts += [f"built-in gesture '{n}'{_with(p)}: {r['error']}" for n, p, r in other]
    speeds = [
        _builtin_lowest(n, tuple((p or {}).items()), str(limits.source)) for n, p, _ in failures
    ]
    if any(s is None for s in speeds):
        fix = "no --speed makes every built-in gesture pass"
    else:
        lowest = max(s for s in speeds if s is not None)
        while lowest < 1.0 and _builtin_failures(lowest, str(limits.source)):
            lowest = round(lowest + 0.01, 2)  # a case that passed below may fail here
        fix = f"the lowest speed at which every built-in gesture passes is {lowest:g}"
    return (
        f"--speed {speed_fraction:g}: " + "; ".join(parts) + f"; {fix} "
        f"(prezence gestures check --speed {speed_fraction:g} shows each)"
    )
