"""The anchors inside Prezence against the peers' reference replay, on the shared workload.

    python bench/bench_anchors.py [--n 200000] [--duration 4] [--tick 0.5] [--peers ../shared/peers]

Writes the peers' throughput workload (``mkload.py``) into a temporary folder, replays it through
``peers/replay.py --policy pz16|pt|rhema`` (the reference, run as its own process) and through
Prezence's processor with the same anchor (``pz16``, ``presentation_trainer``, ``rhema``), the same
decision tick and a robot that is busy for the same fixed time per cue; prints the cue counts and
their ratio, and the wall time of both. Prezence reads the folder's streams and ``rules.conf``
with its own readers (seed line format, the room's ANGLE = -15).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from prezence.peers import load_folder, reference_cues, replay_fixed_busy

#: Prezence's name for each peers' policy name.
PAIRS = {"pz16": "pz16", "pt": "presentation_trainer", "rhema": "rhema"}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=200_000, help="samples in the workload")
    ap.add_argument("--duration", type=float, default=4.0, help="seconds the robot is busy per cue")
    ap.add_argument("--tick", type=float, default=0.5, help="decision period, s")
    ap.add_argument(
        "--peers",
        type=Path,
        default=Path(__file__).resolve().parents[1].parent / "shared" / "peers",
    )
    a = ap.parse_args()
    if not (a.peers / "replay.py").is_file():
        print(f"no peers folder at {a.peers}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "load"
        subprocess.run(
            [sys.executable, str(a.peers / "mkload.py"), str(folder), str(a.n)],
            check=True,
            capture_output=True,
        )
        cfg, samples = load_folder(folder)
        print(f"workload: {len(samples)} samples, {samples[-1].t:.0f} s, cue {a.duration:g} s")
        print("| policy | peers' replay.py cues | Prezence cues | ratio | peers s | Prezence s |")
        print("|---|---:|---:|---:|---:|---:|")
        for peer, ours in PAIRS.items():
            t0 = time.perf_counter()
            ref = len(reference_cues(a.peers, folder, peer, duration=a.duration, tick=a.tick))
            t1 = time.perf_counter()
            got = len(replay_fixed_busy(cfg, samples, ours, duration=a.duration, tick=a.tick))
            t2 = time.perf_counter()
            print(f"| {ours} | {ref} | {got} | {got / ref:.3f} | {t1 - t0:.2f} | {t2 - t1:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
