"""Gesture timing and simulation speed: figures, never assertions.

Prints, per gesture, the planned duration against its time-optimal minimum (same speed and
acceleration bounds), then plays the whole library on the sim backend as a 10-minute talk would
(one gesture every ``--gap`` seconds, idle in between) and reports the real-time factor
(simulated seconds / wall seconds, one core) and the tracking figures per physics timestep.

    python bench/bench_gestures.py [--speed 0.6] [--gap 50] [--timesteps 0.004167 0.008333 0.01]
"""

from __future__ import annotations

import argparse
import os
import time

from prezence.feedback.gestures import build_trajectory, load_library, time_optimal_minimum
from prezence.feedback.limits import load_limits


def timing_table(speed: float) -> None:
    limits = load_limits()
    lib = load_library(limits)
    print(f"gesture timing at {speed:.0%} of the URDF velocity limits")
    print(f"{'gesture':<22}{'planned s':>10}{'minimum s':>11}{'ratio':>8}")
    worst = 0.0
    for name in lib.names:
        for params in [{"minutes": 1}, {"minutes": 5}] if lib[name].params else [None]:
            traj = build_trajectory(name, params=params, speed_fraction=speed, limits=limits)
            t_min = time_optimal_minimum(traj, speed_fraction=speed, limits=limits)
            label = name if params is None else f"{name}[{params['minutes']}]"
            ratio = traj.duration / t_min
            worst = max(worst, ratio)
            print(f"{label:<22}{traj.duration:>10.3f}{t_min:>11.3f}{ratio:>8.3f}")
    print(f"largest planned/minimum ratio: {worst:.3f}\n")


def play_library(speed: float, gap: float, timestep: float, talk_s: float) -> dict[str, float]:
    from sim.backend import SimBackend

    limits = load_limits()
    lib = load_library(limits)
    names = list(lib.names)
    trajs = [
        build_trajectory(
            n, params={"minutes": 3} if lib[n].params else None, speed_fraction=speed, limits=limits
        )
        for n in names
    ]
    wall0 = time.perf_counter()
    backend = SimBackend(speed_fraction=speed, timestep=timestep)
    err, worst_ratio, played = 0.0, 0.0, 0
    with backend:
        t = 0.0
        k = 0
        while t + gap <= talk_s:
            t += gap
            backend.advance(t)
            m = backend.play(trajs[k % len(trajs)], now=t)
            while backend.busy:
                t += 0.1  # the runner's tick
                backend.advance(t)
            err = max(err, abs(m.info["measured_s"] / m.info["planned_s"] - 1.0))
            worst_ratio = max(worst_ratio, m.info["peak_velocity_ratio"] / speed)
            played += 1
            k += 1
        backend.advance(talk_s)
        stats = backend.stats()
    wall = time.perf_counter() - wall0
    return {
        "timestep": timestep,
        "gestures": played,
        "sim_s": talk_s,
        "wall_s": wall,
        "rtf": talk_s / wall,
        "steps": stats["sim_steps"],
        "duration_err": err,
        "peak_over_cap": worst_ratio,
        "violations": stats["joint_limit_violations"],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--speed", type=float, default=0.6)
    ap.add_argument("--gap", type=float, default=50.0, help="seconds between gestures")
    ap.add_argument("--talk", type=float, default=600.0, help="talk length in seconds")
    ap.add_argument("--timesteps", type=float, nargs="+", default=[1 / 240, 1 / 120, 1 / 100])
    args = ap.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    timing_table(args.speed)
    print(f"sim backend: a {args.talk:.0f} s talk, one gesture every {args.gap:.0f} s, one core")
    print(
        f"{'timestep':>10}{'gestures':>9}{'steps':>7}{'wall s':>8}{'x real time':>12}"
        f"{'|meas/plan-1|':>14}{'peak/cap':>9}{'violations':>11}"
    )
    for dt in args.timesteps:
        r = play_library(args.speed, args.gap, dt, args.talk)
        print(
            f"{r['timestep']:>10.5f}{r['gestures']:>9}{r['steps']:>7}{r['wall_s']:>8.2f}{r['rtf']:>12.0f}"
            f"{r['duration_err']:>14.2%}{r['peak_over_cap']:>9.4f}{r['violations']:>11}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
