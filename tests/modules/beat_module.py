"""A tiny input module for hang-detection tests.

    python beat_module.py --out SESSION --t0 EPOCH --metric cv_gestures [--rate 10]
    python beat_module.py --out SESSION --t0 EPOCH --heartbeat-only
    python beat_module.py --out SESSION --t0 EPOCH --silent

It writes ``--metric`` at ``--rate`` Hz in real time; with ``--heartbeat-only`` it writes no
sample but touches the heartbeat file the launcher names in ``$PREZENCE_HEARTBEAT`` every 0.2 s
(a speech module in a long pause); with ``--silent`` it does nothing at all until killed (a hung
module).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from prezence.streams.writer import StreamWriter


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--t0", type=float, required=True)
    ap.add_argument("--metric", default="speech_speed")
    ap.add_argument("--value", type=float, default=160.0)
    ap.add_argument("--rate", type=float, default=10.0)
    ap.add_argument("--heartbeat-only", action="store_true")
    ap.add_argument("--silent", action="store_true")
    args = ap.parse_args()
    if args.silent:
        while True:
            time.sleep(1.0)
    if args.heartbeat_only:
        beat = Path(os.environ["PREZENCE_HEARTBEAT"])
        while True:
            beat.touch()
            time.sleep(0.2)
    with StreamWriter(args.out / "streams" / f"{args.metric}.txt") as w:
        while True:
            w.write(max(0.0, time.time() - args.t0), args.value)
            time.sleep(1.0 / args.rate)


if __name__ == "__main__":
    sys.exit(main())
