"""``prezence gestures check``: every gesture's timing and limit margins, as a table or JSON.

For each gesture (``time_left`` at its smallest and largest parameter) the report gives the
planned duration, the time-optimal minimum under the same speed and acceleration bounds, their
ratio, the highest planned joint speed as a share of that joint's URDF limit, and the smallest
distance to a position limit along the whole path (sampled every 5 ms, head anti-collision range
included). The exit status is non-zero when any gesture breaks a limit or is slower than
``MAX_RATIO`` × its minimum.
"""

from __future__ import annotations

import json
import logging
import math
from typing import Any

import numpy as np

from prezence.errors import LimitViolation, PrezenceError
from prezence.feedback.gestures import (
    GestureLibrary,
    build_trajectory,
    load_library,
    time_optimal_minimum,
)
from prezence.feedback.limits import HANDS, JointLimits, load_limits
from prezence.feedback.trajectory import ACCEL_TIME_S, BLEND_FRACTION, RAMP_S, Trajectory

log = logging.getLogger(__name__)

#: The issue's bound: planned duration <= 1.10 × the time-optimal minimum.
MAX_RATIO = 1.10
SAMPLE_DT = 0.005
_TOL = 1e-9


def _cases(lib: GestureLibrary) -> list[tuple[str, str, dict[str, int] | None]]:
    out: list[tuple[str, str, dict[str, int] | None]] = []
    for name in lib.names:
        g = lib[name]
        if not g.params:
            out.append((name, name, None))
            continue
        for pname, p in g.params.items():
            for v in sorted({p.low, p.high}):
                out.append((f"{name}[{pname}={v}]", name, {pname: v}))
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
    speed_fraction: float, *, limits: JointLimits | None = None
) -> list[dict[str, Any]]:
    """One row of figures per gesture case (see the module docstring)."""
    limits = limits if limits is not None else load_limits()
    lib = load_library(limits)
    rows: list[dict[str, Any]] = []
    for label, name, params in _cases(lib):
        row: dict[str, Any] = {"gesture": label}
        try:
            traj = build_trajectory(
                name, params=params, speed_fraction=speed_fraction, limits=limits
            )
        except LimitViolation as e:
            row.update(ok=False, error=str(e))
            rows.append(row)
            continue
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
        rows.append(row)
    return rows


def check_gestures(speed_fraction: float, *, as_json: bool) -> tuple[str, int]:
    """The report for ``prezence gestures check`` and its exit status.

    Args:
        speed_fraction: fraction of the URDF velocity limits, in (0, 1].
        as_json: JSON (one object with the settings and a row per gesture) instead of a table.

    Returns:
        (text, status): status 0 when every gesture is within every limit and within
        ``MAX_RATIO`` of its time-optimal minimum, 1 otherwise, 2 for a bad argument.
    """
    if not 0.0 < speed_fraction <= 1.0:
        return f"error: --speed must be in (0, 1], got {speed_fraction}", 2
    try:
        rows = gesture_rows(speed_fraction)
    except PrezenceError as e:
        return f"error: {e}", 2
    status = 0 if all(r["ok"] for r in rows) else 1
    settings = {
        "speed_fraction": speed_fraction,
        "profile": "trapezoidal velocity, S-curve blends, rest at every keyframe",
        "ramp_s": RAMP_S,
        "blend_fraction": BLEND_FRACTION,
        "accel_bound": f"fraction x URDF velocity / {ACCEL_TIME_S:.2f} s",
        "max_ratio": MAX_RATIO,
    }
    if as_json:
        return json.dumps(
            {"settings": settings, "ok": status == 0, "gestures": rows}, indent=2
        ), status
    lines = [
        f"gestures at {speed_fraction:.0%} of the URDF velocity limits; profile: trapezoid with "
        f"{RAMP_S:.2f} s ramps and {BLEND_FRACTION:.0%} blends, "
        f"acceleration bound v/{ACCEL_TIME_S:.2f} s",
        f"{'gesture':<22}{'planned':>9}{'minimum':>9}{'ratio':>7}  {'peak speed (of limit)':<27}"
        f"{'position margin':<24}status",
    ]
    for r in rows:
        if "duration_s" not in r:
            lines.append(
                f"{r['gesture']:<22}{'-':>9}{'-':>9}{'-':>7}  {'':<27}{'':<24}FAIL: {r['error']}"
            )
            continue
        peak = f"{r['peak_velocity_pct']:5.1f} % {r['peak_velocity_joint']}"
        margin = f"{r['margin_deg']:6.1f}° {r['margin_joint']}"
        state = "ok" if r["ok"] else f"FAIL: {r['error']}"
        lines.append(
            f"{r['gesture']:<22}{r['duration_s']:>7.2f} s{r['time_optimal_s']:>7.2f} s"
            f"{r['ratio']:>7.3f}  "
            f"{peak:<27}{margin:<24}{state}"
        )
    measured = [r for r in rows if "ratio" in r]
    worst = max(measured, key=lambda r: r["ratio"]) if measured else None
    summary = f"{sum(r['ok'] for r in rows)}/{len(rows)} gestures ok"
    if worst is not None:
        summary += (
            f"; largest ratio {worst['ratio']:.3f} ({worst['gesture']}), bound {MAX_RATIO:.2f}"
        )
    lines.append(summary)
    return "\n".join(lines), status
