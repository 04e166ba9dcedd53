"""The pace advice a speaker gets, voice by voice: ``prezence rehearse`` on 5-minute talks.

    python bench/bench_advice.py [--corpus /tmp/speech_corpus] [--minutes 5] [--jobs 2]
        [--only NAME ...] [--extra FILE:WORDS ...]

The speech-speed table (``bench_speech.py --part corpus``) says how far the module's readings
are from the truth; this says what the coach then tells the speaker, which is what a user
feels. Issue 11's case: a 5-minute talk by festival's ``kal`` at a true 157 wpm, inside the
default band of 140-180 wpm the whole time, got 7 ``speedUp`` cues.

For every clean file of the corpus (``tools/make_speech_corpus.py``: each voice at 110, 160 and
210 wpm, and the real reading), the file is played back to back until the talk lasts at least
``--minutes`` (its true rate is the file's), written as a WAV and given to ``prezence rehearse``
(the speech module as its own process, the default rules and weighted policy, fake robot). The
table counts the cues about ``speech_speed``: *right* when the true rate is outside the band and
the cue asks for the way back (``speedUp`` below 140, ``slowDown`` above 180), *wrong* when the
true rate is inside the band, or the cue points the wrong way; and the ``articulate`` cues
(``speech_accuracy`` under the default 0.5), every one of them wrong on this clean speech.
``--extra FILE:WORDS`` adds recordings of your own (the truth is WORDS over the file's length).

Prints figures only; asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import wave
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from prezence.modules.audio_io import SAMPLE_RATE, read_file
from prezence.session import read_jsonl
from prezence.streams.tail import read_stream


class Row(NamedTuple):
    """One talk's figures."""

    name: str
    split: str
    true_wpm: float
    secs: float
    commands: list[str]  # the speech_speed cues' commands, in order
    first_t: float
    median: float  # of the speech_speed readings
    recogniser: float  # share of windows whose speed came from the recogniser
    unclear: int  # articulate cues


BAND = (140.0, 180.0)  # the default rule: speech_speed inRange 140 180


def looped(src: Path, dst: Path, minutes: float) -> float:
    """Write ``src`` played back to back for at least ``minutes`` to ``dst``; its seconds."""
    pcm = read_file(src)
    n = max(1, math.ceil(minutes * 60.0 * SAMPLE_RATE / len(pcm)))
    out = np.tile(pcm, n)
    with wave.open(str(dst), "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(SAMPLE_RATE)
        w.writeframes(out.astype("<i2").tobytes())
    return len(out) / SAMPLE_RATE


def rehearse(wav: Path, out: Path) -> tuple[list[dict[str, Any]], int, list[float], list[float]]:
    """Run ``prezence rehearse`` on ``wav``: the speech_speed cues, the number of
    speech_accuracy cues, the speed readings and their sources."""
    cmd = [sys.executable, "-m", "prezence", "rehearse", str(wav), "--out", str(out)]
    cmd += ["--no-report", "-q"]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode not in (0, 3):
        raise SystemExit(f"{' '.join(cmd)} failed ({p.returncode}):\n{p.stderr[-2000:]}")
    cues = read_jsonl(out / "cues.jsonl")
    pace = [c for c in cues if c.get("metric") == "speech_speed"]
    unclear = sum(c.get("metric") == "speech_accuracy" for c in cues)
    streams = out / "streams"
    speeds, _ = read_stream(streams / "speech_speed.txt", "speech_speed")
    sources, _ = read_stream(streams / "speech_speed_source.txt", "speech_speed_source")
    return pace, unclear, [s.value for s in speeds], [s.value for s in sources]


def judge(true_wpm: float, command: str) -> str:
    lo, hi = BAND
    if true_wpm < lo:
        return "right" if command == "speedUp" else "wrong"
    if true_wpm > hi:
        return "right" if command == "slowDown" else "wrong"
    return "wrong"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--corpus", type=Path, default=Path("/tmp/speech_corpus"))
    ap.add_argument("--minutes", type=float, default=5.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--only", nargs="*", help="corpus files whose name contains one of these")
    ap.add_argument("--extra", nargs="*", default=[], help="FILE:WORDS recordings of your own")
    args = ap.parse_args()

    todo: list[tuple[str, Path, float, str]] = []  # name, file, true wpm, split
    manifest = args.corpus / "manifest.json"
    if manifest.exists():
        entries = json.loads(manifest.read_text(encoding="utf-8"))
        for name, e in sorted(entries.items()):
            if e.get("condition") != "clean":
                continue
            if args.only and not any(o in name for o in args.only):
                continue
            todo.append((name, args.corpus / e["file"], float(e["true_wpm"]), e["split"]))
    elif not args.extra:
        raise SystemExit(
            f"{manifest}: not found; build the corpus with tools/make_speech_corpus.py "
            "or give --extra FILE:WORDS"
        )
    for spec in args.extra:
        path_s, _, words_s = spec.rpartition(":")
        path = Path(path_s)
        secs = len(read_file(path)) / SAMPLE_RATE
        todo.append((path.stem, path, float(words_s) * 60.0 / secs, "extra"))

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)

        def one(item: tuple[str, Path, float, str]) -> Row:
            name, src, true_wpm, split = item
            wav = d / f"{name}.wav"
            secs = looped(src, wav, args.minutes)
            cues, unclear, speeds, sources = rehearse(wav, d / name)
            wav.unlink()
            return Row(
                name,
                split,
                true_wpm,
                secs,
                [str(c["command"]) for c in cues],
                float(cues[0]["t"]) if cues else math.nan,
                statistics.median(speeds) if speeds else math.nan,
                sum(1 for s in sources if s == 1.0) / len(sources) if sources else math.nan,
                unclear,
            )

        jobs = max(1, min(args.jobs, os.cpu_count() or 1))
        with ThreadPoolExecutor(jobs) as pool:
            rows = list(pool.map(one, todo))

    print(f"default band {BAND[0]:.0f}-{BAND[1]:.0f} wpm; talks of >= {args.minutes:g} min")
    print(
        f"{'talk':<22} {'split':<8} {'true':>6} {'min':>5} {'median read':>11} "
        f"{'recogniser':>10} {'right':>5} {'wrong':>5} {'articulate':>10}  first pace cue, commands"
    )
    in_band = wrong_in_band = right_out = out_talks = silent_out = wrong_way = unclear = 0
    for r in rows:
        verdicts = [judge(r.true_wpm, c) for c in r.commands]
        right = verdicts.count("right")
        wrong = verdicts.count("wrong")
        unclear += r.unclear
        if BAND[0] <= r.true_wpm <= BAND[1]:
            in_band += 1
            wrong_in_band += wrong
        else:
            out_talks += 1
            right_out += right
            silent_out += right == 0
            wrong_way += wrong
        shown = " ".join(r.commands) if r.commands else "-"
        first_s = f"{r.first_t:6.1f} s" if r.commands else "      -"
        print(
            f"{r.name:<22} {r.split:<8} {r.true_wpm:6.1f} {r.secs / 60:5.1f} {r.median:11.1f} "
            f"{r.recogniser:10.0%} {right:5d} {wrong:5d} {r.unclear:10d}  {first_s} {shown}"
        )
    print(
        f"talks inside the band: {in_band}, pace cues on them {wrong_in_band}; "
        f"talks outside: {out_talks}, right cues {right_out}, wrong-way cues {wrong_way}, "
        f"talks without a right cue {silent_out}; articulate cues on clean speech {unclear} "
        f"(in {sum(r.unclear > 0 for r in rows)} of {len(rows)} talks)"
    )


if __name__ == "__main__":
    main()
