"""A module gone wrong, for the counting tests: writes speech_speed at 10 Hz in real time,
with a garbage line, a line stamped 5 s ahead and one stamped 1e5 s ahead every few lines.

    python junk_module.py --out SESSION --t0 EPOCH
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--t0", type=float, required=True)
    args = ap.parse_args()
    path = args.out / "streams" / "speech_speed.txt"
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("a", encoding="utf-8") as f:
        n = 0
        while True:
            t = max(0.0, time.time() - args.t0)
            f.write(f"{t:.3f} 160\n")
            if n % 3 == 0:
                f.write("hello world\n")
            if n % 4 == 0:
                f.write(f"{t + 5.0:.3f} 230\n")
            if n % 5 == 0:
                f.write(f"{t + 1e5:.3f} 231\n")
            f.flush()
            n += 1
            time.sleep(0.1)


if __name__ == "__main__":
    sys.exit(main())
