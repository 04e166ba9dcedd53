"""Memory and time of a 3-hour talk: replay (the coach over every sample) and the report.

    python bench/bench_long_talk.py [--hours 3] [--no-plots]

Writes a session folder as a 3-hour live talk would leave it (speech metrics every second,
eye contact at 10 Hz, gestures every second: the modules' own rates), then, each in a fresh
process, replays it (the processor decides every 0.5 s over all of it) and writes its report.
Prints the peak resident memory (ru_maxrss) and the wall time of each, and the folder's size.
A live talk runs the same processor and tailer; its memory is bounded by the same state.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = """
import resource, sys, time, logging
logging.disable(logging.WARNING)
sys.path.insert(0, {root!r})
t = time.perf_counter()
if {what!r} == "replay":
    from prezence.replay import replay
    from prezence.talk import RunOptions
    replay({src!r}, out={out!r}, options=RunOptions.default(report=False))
else:
    from prezence.report.build import write_report
    import prezence.report.plots as plots
    if {no_plots!r}:
        plots.available = lambda: False
    write_report({src!r})
print(time.perf_counter() - t, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)
"""


def make_session(root: Path, hours: float, seed: int = 0) -> Path:
    rng = random.Random(seed)
    s = root / "long"
    (s / "streams").mkdir(parents=True)
    (s / "config.toml").write_text((ROOT / "prezence/config/defaults/default.toml").read_text())
    talk_s = hours * 3600.0
    rates = {
        "speech_speed": (1.0, 160, 25),
        "speech_volume": (1.0, 66, 4),
        "speech_accuracy": (1.0, 0.8, 0.1),
        "cv_headGaze": (0.1, -5, 8),
        "cv_gestures": (1.0, 7, 3),
    }
    for metric, (dt, mu, sd) in rates.items():
        n = int(talk_s / dt)
        with open(s / "streams" / f"{metric}.txt", "w") as f:
            f.writelines(f"{i * dt:.2f} {rng.gauss(mu, sd):.3f}\n" for i in range(n))
    meta = {"format": 1, "kind": "live", "t0_epoch": time.time() - talk_s, "talk_s": talk_s}
    (s / "session.json").write_text(json.dumps(meta))
    (s / "config.toml").write_text(
        (s / "config.toml").read_text().replace("allocated_s = 600.0", f"allocated_s = {talk_s}")
    )
    return s


def du(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=3.0)
    ap.add_argument("--no-plots", action="store_true")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="prezence-long-") as tmp:
        s = make_session(Path(tmp), args.hours)
        print(f"{args.hours:g} h talk: streams {du(s / 'streams') / 1e6:.1f} MB")
        for what in ("replay", "report"):
            src = str(s) if what == "report" else str(s)
            out = str(Path(tmp) / "replayed")
            code = CHILD.format(root=str(ROOT), what=what, src=src, out=out, no_plots=args.no_plots)
            p = subprocess.run(
                [sys.executable, "-c", code], capture_output=True, text=True, env=dict(os.environ)
            )
            if p.returncode != 0:
                print(p.stderr[-3000:], file=sys.stderr)
                return 1
            wall, rss_kb = p.stdout.split()[-2:]
            print(f"{what:<7} wall {float(wall):7.1f} s   peak RSS {int(rss_kb) / 1024:7.0f} MB")
        print(f"replayed session folder: {du(Path(out)) / 1e6:.1f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
