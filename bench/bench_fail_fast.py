"""Time from ``prezence up`` to a clear error, for inputs that cannot be used.

    python bench/bench_fail_fast.py [--repeat 3]

Cases: a missing audio file, a closed robot port (nothing listens), a silent robot port (a
socket that accepts but never speaks NAOqi; needs ``qi``), and a module that exits with its
bad-input status (2) once started. Prints the median wall time of the whole command (Python's
start-up included) and the error line. Loopback only.
"""

from __future__ import annotations

import argparse
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def run(args: list[str]) -> tuple[float, int, str]:
    t = time.perf_counter()
    p = subprocess.run(
        [sys.executable, "-m", "prezence", *args], capture_output=True, text=True, env=ENV
    )
    err = next((ln for ln in p.stderr.splitlines() if ln.startswith("error:")), p.stderr[-200:])
    return time.perf_counter() - t, p.returncode, err


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="prezence-ff-") as tmp:
        bad = Path(tmp) / "bad.py"
        bad.write_text(
            "import sys\nprint('error: talk.wav: the audio is damaged', file=sys.stderr)\n"
            "sys.exit(2)\n"
        )
        with socket.socket() as free:
            free.bind(("127.0.0.1", 0))
            closed_port = free.getsockname()[1]
        silent = socket.socket()
        silent.bind(("127.0.0.1", 0))
        silent.listen(8)
        silent_port = silent.getsockname()[1]
        cases = {
            "missing audio file": ["up", "--audio", f"{tmp}/nothere.wav"],
            "closed robot port": ["up", "--module", "x=true", "--backend", "naoqi",
                                  "--robot", f"tcp://127.0.0.1:{closed_port}"],
            "silent robot port": ["up", "--module", "x=true", "--backend", "naoqi",
                                  "--robot", f"tcp://127.0.0.1:{silent_port}"],
            "module: bad input": ["up", "-q", "--module", f"bad={sys.executable} {bad}"],
        }  # fmt: skip
        print(f"{'case':<20} {'median s':>8} {'exit':>4}  error")
        for name, cmd in cases.items():
            out = []
            for i in range(args.repeat):
                out.append(run([*cmd, "--out", f"{tmp}/{name.replace(' ', '_')}{i}"]))
            med = statistics.median(o[0] for o in out)
            print(f"{name:<20} {med:8.2f} {out[-1][1]:>4}  {out[-1][2][:110]}")
        silent.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
