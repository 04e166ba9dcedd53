"""A tiny input module for launcher tests: writes speech_speed at 10 Hz in real time.

    python pace_module.py --out SESSION --t0 EPOCH --wpm 260 [--crash-after 8 --marker FILE]

With ``--crash-after N`` it exits with status 3 after N lines, once (the marker file remembers),
so a supervisor that restarts it sees a crash and then a healthy module.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from prezence.streams.writer import StreamWriter


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--t0", type=float, required=True)
    ap.add_argument("--wpm", type=float, default=160.0)
    ap.add_argument("--crash-after", type=int, default=0)
    ap.add_argument("--marker", type=Path)
    args = ap.parse_args()
    crash = args.crash_after > 0 and args.marker is not None and not args.marker.exists()
    with StreamWriter(args.out / "streams" / "speech_speed.txt") as w:
        n = 0
        while True:
            w.write(max(0.0, time.time() - args.t0), args.wpm)
            n += 1
            if crash and n >= args.crash_after:
                args.marker.write_text("crashed once\n")
                return 3
            time.sleep(0.1)


if __name__ == "__main__":
    sys.exit(main())
