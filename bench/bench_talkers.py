"""Other people talking behind the presenter (issue 11): build a small corpus and measure it.

A main voice reads the corpus text (``tools/make_speech_corpus.py``'s :data:`TEXTS`) at 130,
150 and 175 wpm (``sox tempo``); other voices read other texts (our own words, below) or are
the real readers shipped in ``tests/modules/material/corpus`` (LibriVox, the Sonnet), and are
mixed under it at 15, 20, 25 and 30 dB below the main voice's active speech power (the sum of
all talkers; 1 or 3 talkers). Truth: the main voice's words / its duration.

Split: the DEV main voices and talkers were used to choose the method and its threshold; the
HELD-OUT ones (other voices, other talkers, the real readers) only measured.

Needs Debian ``espeak-ng``, ``flite`` and ``sox`` (``apt-get install -y espeak-ng flite sox``).

Usage::

    python bench/bench_talkers.py --build /tmp/talkers
    python bench/bench_talkers.py --run /tmp/talkers [--split dev|heldout] [--save out.json]
        [--other-voices]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from prezence.metrics import Untimed  # noqa: E402
from prezence.modules import speech  # noqa: E402
from prezence.modules.audio_io import read_file  # noqa: E402

SHIPPED = ROOT / "tests" / "modules" / "material" / "corpus"

#: What the background talkers say (our own words; not the main text).
TALKER_TEXTS = (
    "Did you see the train times for tomorrow? I think the early one leaves at seven, "
    "but the second one is cheaper and it stops in the old town. We could take the bus "
    "back in the evening if the weather stays dry, and have dinner near the river.",
    "The kitchen on the third floor is closed again, so people are queueing downstairs. "
    "Someone left a box of oranges by the printer. If you want coffee, the machine in the "
    "lobby still works, although it only takes coins and it makes a terrible noise.",
    "My brother moved to a small village last spring. He grows tomatoes and beans, and he "
    "says the neighbours are friendly, although the internet is slow and the shop closes at "
    "noon on Saturdays. He wants us to visit in August when the festival is on.",
)
#: name -> (engine, voice). Main voices read TEXTS; talkers read TALKER_TEXTS.
MAIN = {
    "dev": {"espeak_m": ("espeak", "en-us"), "flite_awb": ("flite", "awb")},
    "heldout": {"flite_rms": ("flite", "rms"), "flite_kal16": ("flite", "kal16")},
}
TALKERS = {
    "dev": {
        "espeak_f": ("espeak", "en-us+f3"),
        "flite_slt": ("flite", "slt"),
        "espeak_rp": ("espeak", "en-gb-x-rp"),
    },
    # the real readers (shipped), and a voice none of the dev files has
    "heldout": {
        "real_librivox": ("file", "librivox.flac"),
        "real_sonnet": ("file", "sonnet.flac"),
        "espeak_nyc": ("espeak", "en-us-nyc"),
    },
}
RATES = (130.0, 150.0, 175.0)
LEVELS = (15.0, 20.0, 25.0, 30.0)


def tool() -> ModuleType:
    spec = importlib.util.spec_from_file_location("mkc", ROOT / "tools" / "make_speech_corpus.py")
    assert spec and spec.loader
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def build(out: Path) -> None:
    mk = tool()
    out.mkdir(parents=True, exist_ok=True)
    manifest: dict[str, dict[str, object]] = {}
    text = " ".join(mk.TEXTS)
    words = mk.count_words(text)
    with tempfile.TemporaryDirectory() as td:
        tmp = Path(td)
        for split in ("dev", "heldout"):
            talk: dict[str, np.ndarray] = {}
            for k, (eng, v) in enumerate(TALKERS[split].items()):
                engine, voice = v
                if engine == "file":
                    x = mk.read(SHIPPED / voice)
                else:
                    x = mk.synth(engine, voice, TALKER_TEXTS[k % len(TALKER_TEXTS)], tmp / "o", tmp)
                talk[eng] = x / np.sqrt(mk.active_power(x))  # unit active power
            names = list(talk)
            for mv, (engine, voice) in MAIN[split].items():
                base = mk.synth(engine, voice, text, tmp / "o", tmp)
                natural = words / (len(base) / mk.RATE) * 60
                for rate in RATES:
                    x = mk.tempo(base, rate / natural, tmp)
                    truth = words / (len(x) / mk.RATE) * 60
                    p = mk.active_power(x)
                    n = len(x)
                    mixes: list[tuple[str, list[str], float | None]] = [("clean", [], None)]
                    for lv in LEVELS:
                        mixes.append((f"3t{lv:.0f}", names, lv))
                    mixes.append(("1t20", names[:1], 20.0))
                    mixes.append(("1t15", names[1:2], 15.0))
                    for cond, who, level in mixes:
                        y = x.copy()
                        if who and level is not None:
                            bg = np.zeros(n)
                            for j, name in enumerate(who):
                                s = talk[name]
                                # each talker starts somewhere else in its text, looped
                                off = (j * 7919 + int(rate)) % len(s)
                                s = np.roll(s, -off)
                                reps = int(np.ceil(n / len(s)))
                                bg += np.tile(s, reps)[:n]
                            bg *= np.sqrt(p / mk.active_power(bg)) * 10 ** (-level / 20)
                            y = x + bg
                        name = f"{mv}_{rate:.0f}_{cond}"
                        mk.write(out / f"{name}.flac", y)
                        manifest[name] = {
                            "split": split,
                            "main": mv,
                            "talkers": who,
                            "level_db": level,
                            "condition": cond,
                            "true_wpm": round(truth, 2),
                            "file": f"{name}.flac",
                        }
                        print(name, round(truth, 1), flush=True)
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1))


def analyse(path: Path, other_voices: bool = False) -> dict[str, Any]:
    x = read_file(path)
    t = time.process_time()
    an = speech.SpeechAnalyser(speech.SpeechOptions(other_voices=other_voices))
    an.window_log = []
    samples = [s for i in range(0, len(x), 1600) for s in an.feed(x[i : i + 1600])]
    samples += an.finish()
    cpu = time.process_time() - t
    sp = [(s.t, s.value) for s in samples if s.metric == speech.SPEECH_SPEED]
    why_t = [(s.t, int(s.value)) for s in samples if s.metric == speech.SPEECH_UNTIMED_REASON]
    why = [c for _, c in why_t]
    return {
        "speed": sp,
        "why": why,
        "why_t": why_t,
        "cpu": cpu,
        "dur": len(x) / 16000,
        "log": an.window_log,
    }


def run(
    cdir: Path, split: str | None, only: str | None, save: str | None, other_voices: bool = False
) -> None:
    """Each file's pace against the truth: the median and 90th percentile of its full 30 s
    windows (t >= 30 s; -: none written), windows with a pace, windows said to have other
    voices near (code 11), and the reason codes."""
    manifest = json.loads((cdir / "manifest.json").read_text())
    names = [
        n
        for n in sorted(manifest)
        if (split is None or manifest[n]["split"] == split) and (only is None or only in n)
    ]
    res = {}
    # per level ("clean", "15-25 dB", "30 dB"): full windows, those timed, those more than 10 %
    # off the truth, those said to have other voices near
    groups: dict[str, list[int]] = {}
    print(f"{'file':<28}{'truth':>7}{'med':>7}{'p90':>7}{'timed':>7}{'other':>7}  codes")
    cpu = dur = 0.0
    other = int(getattr(Untimed, "OTHER_VOICES", 11))
    for n in names:
        m = manifest[n]
        r = analyse(cdir / m["file"], other_voices)
        res[n] = r
        cpu += r["cpu"]
        dur += r["dur"]
        speed: list[tuple[float, float]] = r["speed"]
        why: list[int] = r["why"]
        full = np.array([v for t, v in speed if t >= speech.WORD_WINDOW_S - 1e-6])
        truth = float(m["true_wpm"])
        med = (np.median(full) / truth - 1) * 100 if len(full) else float("nan")
        p90 = (np.percentile(full, 90) / truth - 1) * 100 if len(full) else float("nan")
        codes = {c: why.count(c) for c in sorted(set(why))}
        level = m["level_db"]
        g = groups.setdefault(
            "clean" if level is None else "15-25 dB" if level <= 25 else "30 dB", [0, 0, 0, 0]
        )
        g[0] += sum(1 for w in r["log"] if w["t"] >= speech.WORD_WINDOW_S - 1e-6)
        g[1] += len(full)
        g[2] += int(np.sum(np.abs(full / truth - 1) > 0.10))
        g[3] += sum(1 for t, c in r["why_t"] if c == other and t >= speech.WORD_WINDOW_S - 1e-6)
        print(
            f"{n:<28}{truth:>7.1f}{med:>+7.1f}{p90:>+7.1f}{len(speed):>7}"
            f"{codes.get(other, 0):>7}  {codes}",
            flush=True,
        )
    for g_name, (n_w, n_t, n_off, n_other) in sorted(groups.items()):
        print(
            f"{g_name}: {n_w} full windows, {n_t} timed, {n_off} of them more than 10 % off, "
            f"{n_other} said 'other voices'"
        )
    print(f"CPU per audio second: {cpu / max(dur, 1e-9):.3f}")
    if save:
        Path(save).write_text(json.dumps(res))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", type=Path)
    ap.add_argument("--run", type=Path)
    ap.add_argument("--split", choices=("dev", "heldout"))
    ap.add_argument("--only")
    ap.add_argument("--save")
    ap.add_argument(
        "--other-voices",
        action="store_true",
        help="with the speech module's other-voices rule (off by default, as in the module)",
    )
    a = ap.parse_args()
    if a.build:
        build(a.build)
    if a.run:
        run(a.run, a.split, a.only, a.save, a.other_voices)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
