"""Speech module cost and accuracy on the shipped test audio: prints figures, asserts nothing.

For each file of tests/modules/material: CPU seconds per audio minute (``time.process_time``,
one core) of the whole analysis (endpointer, pocketsphinx, syllables, volume, LUFS, windows),
the real-time factor (CPU s per audio s; the module's target is <= 0.25), recognised words and
wpm against the manifest's truth, and the whole-file clarity. The decoder's one-off start-up
cost is measured separately. ``--defaults`` runs pocketsphinx with its own default search
settings instead of the module's, for comparison.

Usage::

    python bench/bench_speech.py [--defaults] [--repeat 1]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from prezence.modules import speech
from prezence.modules.audio_io import read_file

MATERIAL = Path(__file__).resolve().parent.parent / "tests" / "modules" / "material"


def main(argv: list[str] | None = None) -> int:
    """Print one line per file and a total."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--defaults", action="store_true", help="pocketsphinx's default search")
    ap.add_argument("--repeat", type=int, default=1, help="runs per file (the best is kept)")
    args = ap.parse_args(argv)
    if args.defaults:
        speech.DECODER_CONFIG = {}
    manifest = json.loads((MATERIAL / "manifest.json").read_text())["files"]
    opts = speech.SpeechOptions()
    whole = speech.SpeechOptions(window_s=600.0)

    t = time.process_time()
    speech.SpeechAnalyser(opts)  # imports scipy/pyloudnorm and loads the model once
    first = time.process_time() - t
    t = time.process_time()
    speech.SpeechAnalyser(opts)
    init = time.process_time() - t
    print(f"decoder start-up: {init:.2f} CPU s (first in a process, with imports: {first:.2f})")
    print(f"decoder config: {speech.DECODER_CONFIG or 'pocketsphinx defaults'}")
    print(
        f"{'file':<16}{'audio s':>8}{'CPU s/min':>10}{'RTF':>7}{'words':>7}"
        f"{'wpm':>8}{'true':>8}{'err %':>7}{'clarity':>8}"
    )
    tot_audio = tot_cpu = 0.0
    for name in sorted(manifest):
        x = read_file(MATERIAL / name)
        dur = len(x) / 16000
        blocks = [x[i : i + 1600] for i in range(0, len(x), 1600)]
        best = float("inf")
        for _ in range(max(1, args.repeat)):
            an = speech.SpeechAnalyser(opts)
            t = time.process_time()
            for b in blocks:
                an.feed(b)
            an.finish()
            best = min(best, time.process_time() - t)
        samples, totals = speech.analyse(blocks, whole, loudness=False)
        clarity = next((s.value for s in samples if s.metric == speech.SPEECH_CLARITY), 0.0)
        truth = manifest[name].get("true_wpm")
        err = f"{(totals.wpm / truth - 1) * 100:+.1f}" if truth else "-"
        print(
            f"{name:<16}{dur:>8.1f}{best / dur * 60:>10.2f}{best / dur:>7.3f}{totals.words:>7}"
            f"{totals.wpm:>8.1f}{truth or '-':>8}{err:>7}{clarity:>8.1f}"
        )
        tot_audio += dur
        tot_cpu += best
    print(
        f"total: {tot_audio:.1f} s of audio in {tot_cpu:.2f} CPU s = "
        f"{tot_cpu / tot_audio * 60:.2f} CPU s per audio minute, RTF {tot_cpu / tot_audio:.3f} "
        f"(headroom on one core: {tot_audio / tot_cpu:.1f}x real time)"
    )
    load = Path("/proc/loadavg")
    if load.exists():
        print(
            f"load average while measured: {load.read_text().split()[0]} (CPU time inflates "
            "on a busy machine)"
        )
    print(f"numpy {np.__version__}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
