"""Make the speech module's test audio: tests/modules/material/*.flac and manifest.json.

Needs Debian's ``festival festvox-us-slt-hts sox`` (``apt-get install -y festival
festvox-us-slt-hts sox``) and numpy. Offline. The voice is festival's HTS voice ``slt``: natural
enough that pocketsphinx recognises it (espeak-ng's formant voice is a poor recogniser test).

What it writes (16 kHz mono 16-bit FLAC), with the truth in ``manifest.json``:

- ``rate_130``, ``rate_175``, ``rate_225``: the text at about 130 / 175 / 225 wpm by
  ``sox tempo -s`` (tempo keeps the pitch). True wpm = words / file duration × 60.
- ``gain_0``, ``gain_m6``, ``gain_m12``: the first ~8 s of ``rate_175`` scaled by 0 / −6 / −12 dB,
  for the volume test.
- ``snr_20``, ``snr_10``, ``snr_0``: the first ~14 s of ``rate_175`` plus seeded white noise at
  that SNR against the power of the active speech, for the clarity test.
- ``phone_225``: ``rate_225`` as a telephone line carries it (:func:`phone_copy`: 8 kHz, band-pass
  300-3400 Hz, played back at 16 kHz), for the narrowband test; the truth is ``rate_225``'s.
  Alone, from the shipped file: ``python tools/make_test_audio.py --phone-only``.

:func:`long_talk` builds a ~2 minute talk from a shipped ``rate_*`` file at test time (nothing is
written): its sentences, cut at their pauses, in a seeded random order per round. The speech
module's per-window test and bench use it; unlike the file looped, it has no period that a
window length could line up with.

Usage::

    python tools/make_test_audio.py [--out tests/modules/material]
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

#: The talk. Our own words; the word count is the truth for speech speed.
TEXT = (
    "Good morning, everyone, and thank you for coming. "
    "Today I want to talk about how small habits shape the way we work. "
    "Over the next few minutes, I will share three simple ideas that helped our team "
    "finish projects on time. "
    "Let me begin with the first idea. "
    "First, plan the week on Monday. Second, keep meetings short. "
    "Third, review what went well every Friday afternoon."
)
#: Excerpts of rate_175 (cut at the quietest 100 ms near these times) for the gain and noise files.
GAIN_EXCERPT_S = 8.0
NOISE_EXCERPT_S = 14.0
RATE = 16000
#: Target rates in wpm; the tempo factor is target / the voice's own rate.
TARGET_WPM = {"rate_130": 130.0, "rate_175": 175.0, "rate_225": 225.0}
GAINS_DB = {"gain_0": 0.0, "gain_m6": -6.0, "gain_m12": -12.0}
SNRS_DB = {"snr_20": 20.0, "snr_10": 10.0, "snr_0": 0.0}
NOISE_SEED = 20261101
#: The telephone copy: name -> the rate file it is made from.
PHONE = {"phone_225": "rate_225"}


def count_words(text: str) -> int:
    """Words as a listener counts them: whitespace-separated tokens with a letter in them."""
    return sum(1 for tok in text.split() if any(c.isalpha() for c in tok))


def _run(cmd: list[str]) -> None:
    subprocess.run(cmd, check=True, capture_output=True)


def _read(path: Path) -> np.ndarray:
    raw = subprocess.run(
        [
            "sox",
            str(path),
            "-t",
            "raw",
            "-e",
            "signed",
            "-b",
            "16",
            "-c",
            "1",
            "-r",
            str(RATE),
            "-",
        ],
        check=True,
        capture_output=True,
    ).stdout
    return np.frombuffer(raw, dtype="<i2").astype(np.float64)


def _write(path: Path, x: np.ndarray) -> None:
    pcm = np.clip(np.round(x), -32768, 32767).astype("<i2").tobytes()
    subprocess.run(
        ["sox", "-t", "raw", "-e", "signed", "-b", "16", "-c", "1", "-r", str(RATE), "-"]
        + ["-C", "8", str(path)],
        input=pcm,
        check=True,
        capture_output=True,
    )


def active_power(x: np.ndarray) -> float:
    """Mean power of 30 ms frames within 30 dB of the loudest 5 % (speech, not pauses)."""
    n = len(x) // 480
    frames = np.asarray(x[: n * 480], dtype=np.float64).reshape(n, 480)
    p = np.mean(frames**2, axis=1) + 1e-12
    db = 10 * np.log10(p)
    return float(np.mean(p[db >= np.percentile(db, 95) - 30.0]))


def with_noise(
    x: np.ndarray, snr_db: float, rng: np.random.Generator, power: float | None = None
) -> np.ndarray:
    """``x`` (as float) plus white noise ``snr_db`` below ``power`` (default: its active power)."""
    p = active_power(x) if power is None else power
    noise = rng.standard_normal(len(x)) * np.sqrt(p / 10 ** (snr_db / 10.0))
    return np.asarray(x, dtype=np.float64) + noise


def _duration(path: Path) -> float:
    return len(_read(path)) / RATE


def _cut_at_pause(x: np.ndarray, near_s: float) -> np.ndarray:
    """Cut ``x`` at the quietest 100 ms within 1.5 s of ``near_s`` (so no word is cut)."""
    step = RATE // 100
    lo, hi = int((near_s - 1.5) * RATE), int((near_s + 1.5) * RATE)
    starts = range(lo, hi - 10 * step, step)
    energy = [float(np.sum(x[i : i + 10 * step] ** 2)) for i in starts]
    best = starts[int(np.argmin(energy))] + 5 * step
    return x[:best]


def phone_copy(src: Path, dst: Path) -> None:
    """``src`` as a telephone line carries it: resampled to 8 kHz, band-passed to 300-3400 Hz
    and played back at 16 kHz (nothing above 4 kHz), without dither (the same bytes each run)::

        sox -D SRC -r 8000 -t wav - sinc 300-3400 | sox -D -t wav - -r 16000 -C 8 DST
    """
    narrow = subprocess.run(
        ["sox", "-D", str(src), "-r", "8000", "-t", "wav", "-", "sinc", "300-3400"],
        check=True,
        capture_output=True,
    ).stdout
    subprocess.run(
        ["sox", "-D", "-t", "wav", "-", "-r", str(RATE), "-C", "8", str(dst)],
        input=narrow,
        check=True,
        capture_output=True,
    )


def make_phone(out: Path, manifest: dict[str, dict[str, object]]) -> None:
    """Write the telephone copies of :data:`PHONE` from the rate files in ``out``; add them to
    ``manifest`` (the rate files' entries must be in it)."""
    for name, source in PHONE.items():
        path = out / f"{name}.flac"
        phone_copy(out / f"{source}.flac", path)
        info = manifest[f"{source}.flac"]
        manifest[path.name] = {
            "kind": "phone",
            "source": f"{source}.flac",
            "band_hz": [300, 3400],
            "words": info["words"],
            "duration_s": round(_duration(path), 4),
            "true_wpm": info["true_wpm"],
        }


def make(out: Path) -> dict[str, dict[str, object]]:
    """Write every file into ``out`` and return the manifest."""
    for tool in ("text2wave", "sox"):
        if shutil.which(tool) is None:
            sys.exit(f"error: {tool} not found: apt-get install -y festival festvox-us-slt-hts sox")
    out.mkdir(parents=True, exist_ok=True)
    words = count_words(TEXT)
    manifest: dict[str, dict[str, object]] = {}
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        (tmp / "talk.txt").write_text(TEXT + "\n")
        _run(
            ["text2wave", "-eval", "(voice_cmu_us_slt_arctic_hts)"]
            + [str(tmp / "talk.txt"), "-o", str(tmp / "talk.wav")]
        )
        natural_wpm = words / (len(_read(tmp / "talk.wav")) / RATE) * 60.0
        for name, target in TARGET_WPM.items():
            tempo = round(target / natural_wpm, 4)
            path = out / f"{name}.flac"
            _run(
                ["sox", str(tmp / "talk.wav"), "-r", str(RATE), "-c", "1", "-b", "16"]
                + ["-C", "8", str(path), "tempo", "-s", str(tempo)]
            )
            dur = _duration(path)
            manifest[path.name] = {
                "kind": "rate",
                "tempo": tempo,
                "words": words,
                "duration_s": round(dur, 4),
                "true_wpm": round(words / dur * 60.0, 2),
            }
        make_phone(out, manifest)
        base = _read(out / "rate_175.flac")
        excerpt = _cut_at_pause(base, GAIN_EXCERPT_S)
        for name, gain in GAINS_DB.items():
            path = out / f"{name}.flac"
            _write(path, excerpt * 10 ** (gain / 20.0))
            manifest[path.name] = {"kind": "gain", "gain_db": gain, "source": "rate_175.flac"}
        rng = np.random.default_rng(NOISE_SEED)
        clean = _cut_at_pause(base, NOISE_EXCERPT_S)
        p_speech = active_power(clean)
        for name, snr in SNRS_DB.items():
            path = out / f"{name}.flac"
            mixed = with_noise(clean, snr, rng, p_speech)
            peak = np.max(np.abs(mixed))
            if peak > 32767:
                raise SystemExit(f"error: {name} would clip (peak {peak:.0f}); lower the level")
            _write(path, mixed)
            manifest[path.name] = {
                "kind": "noise",
                "snr_db": snr,
                "source": "rate_175.flac",
                "duration_s": round(len(clean) / RATE, 4),
            }
    (out / "manifest.json").write_text(
        json.dumps({"text": TEXT, "files": manifest}, indent=2, sort_keys=True) + "\n"
    )
    return manifest


def sentences(text: str = TEXT) -> list[str]:
    """The text's sentences, in order (split after ``.``, ``!`` or ``?``)."""
    return [s for s in re.split(r"(?<=[.!?])\s+", text.strip()) if s]


def sentence_cuts(x: np.ndarray, n: int, sample_rate: int = RATE) -> list[int]:
    """Sample indices cutting ``x`` into ``n`` sentences: the middles of its n - 1 longest pauses.

    A pause is a run of 10 ms frames more than 40 dB below the loudest 5 %; festival leaves its
    longest pauses at sentence ends (checked on the shipped rate files: the six longest pauses
    inside each are 0.22-0.49 s and fall at the sentence ends; the next is 0.2 s at most).

    Raises:
        ValueError: ``x`` has fewer than ``n - 1`` pauses inside it.
    """
    f = sample_rate // 100
    m = len(x) // f
    frames = np.asarray(x[: m * f], dtype=np.float64).reshape(m, f)
    db = 10.0 * np.log10(np.mean(frames**2, axis=1) + 1e-3)
    quiet = db < np.percentile(db, 95) - 40.0
    runs: list[tuple[int, int]] = []  # (length, middle frame), inside the file only
    i = 0
    while i < m:
        if not quiet[i]:
            i += 1
            continue
        j = i
        while j < m and quiet[j]:
            j += 1
        if i > 0 and j < m:
            runs.append((j - i, (i + j) // 2))
        i = j
    if len(runs) < n - 1:
        raise ValueError(f"found {len(runs)} pauses, need {n - 1}")
    longest = sorted(runs, reverse=True)[: n - 1]
    return sorted(mid * f for _, mid in longest)


def long_talk(
    x: np.ndarray, *, min_s: float = 120.0, seed: int = 1, text: str = TEXT
) -> tuple[np.ndarray, int]:
    """A talk of whole rounds of ``x``'s sentences, each round in a new seeded random order.

    Args:
        x: a ``rate_*`` file's samples (the whole text, once).
        min_s: rounds are added until the talk is at least this long.
        seed: the order's random seed.
        text: the text ``x`` reads.

    Returns:
        The samples (same dtype as ``x``) and the number of words in them. Every round holds
        every sentence with its own pauses once, so the true rate is the file's: words / length.
    """
    parts = sentences(text)
    cuts = [0, *sentence_cuts(x, len(parts)), len(x)]
    pieces = [x[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    rng = np.random.default_rng(seed)
    out: list[np.ndarray] = []
    total = rounds = 0
    while total < min_s * RATE:
        for k in rng.permutation(len(pieces)):
            out.append(pieces[k])
            total += len(pieces[k])
        rounds += 1
    return np.concatenate(out), rounds * count_words(text)


def main(argv: list[str] | None = None) -> int:
    """Command line: ``python tools/make_test_audio.py [--out DIR] [--phone-only]``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("tests/modules/material"))
    ap.add_argument(
        "--phone-only",
        action="store_true",
        help="only (re)make the telephone copies from the rate files already in --out",
    )
    args = ap.parse_args(argv)
    if args.phone_only:
        path = args.out / "manifest.json"
        doc = json.loads(path.read_text())
        make_phone(args.out, doc["files"])
        path.write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n")
        manifest = doc["files"]
    else:
        manifest = make(args.out)
    total = sum(p.stat().st_size for p in args.out.glob("*.flac"))
    for name, info in sorted(manifest.items()):
        print(name, {k: v for k, v in info.items() if k != "source"})
    print(f"total {total / 1e6:.2f} MB in {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
