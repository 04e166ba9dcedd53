"""Screenshot ``prezence up``'s live view at a given terminal width, as a person sees it.

Usage::

    python tools/screenshot_live_view.py -o live_80.png --width 80 [--seconds 30] -- UP_ARGS...

Runs ``prezence up UP_ARGS`` in a detached ``tmux`` window of that width, captures the pane
with its colours after ``--seconds``, renders it with rich (SVG) and Chromium (PNG). Needs tmux,
rich and Chromium; the talk runs in real time.
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.text import Text


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-o", "--out", type=Path, required=True, help="the PNG to write")
    p.add_argument("--width", type=int, default=80, help="terminal columns (default 80)")
    p.add_argument("--height", type=int, default=24, help="terminal rows (default 24)")
    p.add_argument("--seconds", type=float, default=30.0, help="capture after this long")
    p.add_argument("up_args", nargs=argparse.REMAINDER, help="-- then prezence up's options")
    args = p.parse_args(argv)
    up_args = [a for a in args.up_args if a != "--"]
    cmd = shlex.join([sys.executable, "-m", "prezence", "up", *up_args]) + "; sleep 3600"
    sock = f"prezence-shot-{args.width}"
    subprocess.run(
        ["tmux", "-L", sock, "new-session", "-d", "-s", "v", "-x", str(args.width),
         "-y", str(args.height), cmd],
        check=True,
    )  # fmt: skip
    try:
        time.sleep(args.seconds)
        ansi = subprocess.run(
            ["tmux", "-L", sock, "capture-pane", "-e", "-p", "-t", "v"],
            check=True, capture_output=True, text=True,
        ).stdout  # fmt: skip
    finally:
        subprocess.run(["tmux", "-L", sock, "kill-server"], check=False)
    with open("/dev/null", "w") as devnull:
        con = Console(record=True, width=args.width, file=devnull, force_terminal=True)
        for line in ansi.splitlines():
            con.print(Text.from_ansi(line), no_wrap=True, overflow="crop")
    svg = args.out.with_suffix(".svg")
    con.save_svg(str(svg), title=f"prezence up: {args.width} columns")
    subprocess.run(
        ["chromium", "--headless", "--no-sandbox", "--disable-gpu", f"--screenshot={args.out}",
         f"--window-size={int(args.width * 9.6) + 60},{args.height * 22 + 120}",
         svg.resolve().as_uri()],
        check=True, capture_output=True,
    )  # fmt: skip
    print(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
