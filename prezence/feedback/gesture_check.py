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

import json
import logging
import math
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

from prezence.errors import ConfigError, LimitViolation, PrezenceError
from prezence.feedback.collision import MIN_CLEARANCE_M, SelfCollisionChecker, pybullet_available
from prezence.feedback.gestures import (
    GestureLibrary,
    build_trajectory,
    library_notes,
    load_library,
    load_library_file,
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
            ranges = np.array([limits.head_pitch_range(float(y)) for y in yaw])
            lo, hi = ranges[:, 0], ranges[:, 1]
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
    if checker is not None:
        clearance = checker.trajectory_clearance(traj)
        row.update(
            clearance_mm=round(clearance.mm, 1),
            clearance_links=list(clearance.links),
            clearance_at_s=clearance.time_s,
        )
        if clearance.distance_m < MIN_CLEARANCE_M:
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
        row["error"] = "; ".join(problems)
    return row


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
    status = 0 if all(r["ok"] for r in rows) else 1
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
        doc = {"settings": settings, "ok": status == 0, "gestures": rows}
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
        state = "ok" if r["ok"] else f"FAIL: {r['error']}"
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
    if lib is not None:
        kept = len(lib.names) - len(lib.own)
        lines.append(
            f"the other {kept} gestures a talk with --gestures {library} plays are the built-in "
            "ones (prezence gestures check)"
        )
    lines += [f"note: {n}" for n in notes]
    return "\n".join(lines), status
