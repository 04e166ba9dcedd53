"""Speech module cost and accuracy on the shipped test audio and the corpus: prints figures only.

Four parts (``--part``, all by default):

``files``
    For each file of tests/modules/material: CPU seconds per audio minute (``time.process_time``,
    one core) of the whole analysis (endpointer, pocketsphinx, syllables, volume, LUFS, windows),
    the real-time factor (CPU s per audio s; the module's target is <= 0.25), recognised words
    and wpm against the manifest's truth, and the whole-file clarity. The decoder's one-off
    start-up cost is measured separately. ``--defaults`` runs pocketsphinx with its own default
    search settings instead of the module's, for comparison.
``windows``
    The speech_speed stream, window by window, on ~2 minute talks at 130 / 175 / 225 wpm made
    from the shipped rate files: ``talk`` = the text's sentences in a seeded random order per
    round (:func:`make_test_audio.long_talk`), ``loop`` = the file repeated (whose period a
    window can line up with). For each: p10 / p50 / p90 of window wpm / truth, the share of
    windows within +-10 % of the truth and, at 175 wpm, inside the default rule's 140-180 band;
    ``before`` = a plain 10 s window (the module's old default), ``after`` = the defaults.
``clarity``
    The speech_accuracy stream on the clean talks and on the 175 wpm talk with seeded white noise
    at SNR 20 / 10 / 0 dB (as tools/make_test_audio.py makes snr_*.flac): percentiles and the
    share of windows under candidate thresholds of the rule ``speech_accuracy min X``.

``corpus``
    The corpus of ``tools/make_speech_corpus.py`` (voices x rates x conditions, with truth; built
    into ``--corpus``, default /tmp/speech_corpus): per file, the error of the median
    speech_speed, the share of full 30 s windows within +-10 / +-12 %, the share of windows whose
    speed came from the recogniser (speech_speed_source), the articulation error, the median
    speech_accuracy and the CPU per audio second; then per split (dev / held-out voices) the
    worst and mean median error, and the clarity ROC AUC of clean against degraded windows with
    the clean / degraded shares under candidate thresholds. A window of a file whose manifest
    entry has ``segments`` (every file of a current build: the synthetic voices' word times,
    the real readers' utterances or lines) is held against the true rate of the talk it covers.
    Clarity is given per split, for speech_accuracy (what the coach cues on) and for
    speech_confidence (the recogniser's confidence alone, without the clean-signal credit).
    ``--perturb N`` runs each clean and pauses file again with N
    seeds of +-1 LSB noise and prints how far the figures move (the recogniser's decisions can
    flip on inaudible differences).

Usage::

    python bench/bench_speech.py [--part files|windows|clarity|corpus ...] [--defaults]
        [--repeat 1] [--corpus DIR] [--conditions clean ...] [--only NAME ...] [--jobs 2]
        [--perturb 3]
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import cast

import numpy as np

from prezence.modules import speech
from prezence.modules.audio_io import read_file
from prezence.samples import Sample

Stream = Callable[[str, str, str], list[tuple[float, float]]]

ROOT = Path(__file__).resolve().parent.parent
MATERIAL = ROOT / "tests" / "modules" / "material"
RATES = (130, 175, 225)
SNRS = (20, 10, 0)
#: The default rule's band (prezence/config/defaults/default.toml).
BAND = (140.0, 180.0)
THRESHOLDS = (0.8, 0.7, 0.65, 0.6, 0.55)
#: ``before``: the module's old default, a plain 10 s window (pauses counted in full).
SETTINGS: dict[str, speech.SpeechOptions] = {
    "before": speech.SpeechOptions(window_s=10.0, word_window_s=10.0, max_pause_s=10.0),
    "after": speech.SpeechOptions(),
}


def tool(name: str) -> ModuleType:
    """``tools/<name>.py`` as a module, loaded once: make_test_audio (:func:`long_talk`,
    :func:`with_noise`), make_speech_corpus (the truth of a window: :func:`window_wpm`)."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, ROOT / "tools" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod


def part_files(args: argparse.Namespace) -> None:
    """CPU cost and whole-file figures per shipped file."""
    manifest = json.loads((MATERIAL / "manifest.json").read_text())["files"]
    opts = speech.SpeechOptions()
    whole = speech.SpeechOptions(window_s=600.0, word_window_s=600.0)

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


def talks(mta: ModuleType) -> dict[str, tuple[np.ndarray, float]]:
    """The ~2 minute talks: ``talk_175``, ``loop_175``…: samples and true wpm."""
    out: dict[str, tuple[np.ndarray, float]] = {}
    for rate in RATES:
        x = read_file(MATERIAL / f"rate_{rate}.flac")
        y, words = mta.long_talk(x, min_s=120.0)
        out[f"talk_{rate}"] = (y, words / (len(y) / 16000) * 60.0)
        loop = np.tile(x, math.ceil(120.0 * 16000 / len(x)))
        n_words = mta.count_words(mta.TEXT) * (len(loop) // len(x))
        out[f"loop_{rate}"] = (loop, n_words / (len(loop) / 16000) * 60.0)
    return out


def ratios(values: list[float], truth: float) -> str:
    r = np.asarray(values) / truth
    p10, p50, p90 = np.percentile(r, [10, 50, 90])
    within = np.mean(np.abs(r - 1.0) <= 0.1) * 100
    return f"{len(r):>4}{p10:>7.3f}{p50:>7.3f}{p90:>7.3f}{within:>7.0f}%"


def part_windows(truths: dict[str, float], cached: Stream) -> None:
    """Per-window speech_speed against the truth, before and after."""
    print(
        "speech_speed per window / truth (shuffled-sentence talk and plain loop, ~2 min each); "
        "'from 30 s': windows ending at t >= 30 s"
    )
    print(
        f"{'talk':<10}{'truth':>7}{'setting':>8}{'n':>5}{'p10':>7}{'p50':>7}{'p90':>7}"
        f"{'±10%':>8}{'in 140-180':>12}{'from 30 s: ±10%':>17}{'in band':>9}"
    )
    for name, truth in truths.items():
        for setting in SETTINGS:
            got = cached(name, setting, speech.SPEECH_SPEED)
            vals = [v for _, v in got]
            late = [v for t, v in got if t >= 30.0]
            band = np.mean([BAND[0] <= v <= BAND[1] for v in vals]) * 100
            late_band = np.mean([BAND[0] <= v <= BAND[1] for v in late]) * 100
            late_within = np.mean([abs(v / truth - 1) <= 0.1 for v in late]) * 100
            band_s = f"{band:>11.0f}%" if abs(truth - 175) < 1 else f"{'-':>12}"
            late_s = f"{late_band:>8.0f}%" if abs(truth - 175) < 1 else f"{'-':>9}"
            print(
                f"{name:<10}{truth:>7.1f}{setting:>8}{ratios(vals, truth)}{band_s}"
                f"{late_within:>16.0f}%{late_s}"
            )


def part_clarity(cached: Stream) -> None:
    """speech_accuracy distributions, clean against noisy."""
    print("speech_accuracy per window (talks of ~2 min; noise: white, SNR against active speech)")
    heads = "".join(f"{f'<{x:g}':>7}" for x in THRESHOLDS)
    print(
        f"{'talk':<14}{'setting':>8}{'n':>5}{'min':>7}{'p5':>7}{'p10':>7}{'p50':>7}{'p90':>7}"
        f"{'max':>7}{heads}"
    )
    names = [f"talk_{r}" for r in RATES] + [f"talk_175_snr{s}" for s in SNRS]
    for name in names:
        for setting in SETTINGS:
            a = np.array([v for _, v in cached(name, setting, speech.SPEECH_ACCURACY)])
            pct = "".join(f"{v:>7.3f}" for v in np.percentile(a, [0, 5, 10, 50, 90]))
            under = "".join(f"{np.mean(a < x) * 100:>6.0f}%" for x in THRESHOLDS)
            print(f"{name:<14}{setting:>8}{len(a):>5}{pct}{a.max():>7.3f}{under}")


def _analyse_file(path: str, seed: int | None = None) -> dict[str, object]:
    """One corpus file through the module with its defaults: streams and CPU. With ``seed``,
    the file with seeded noise of at most one least significant bit added (-90 dBFS, far
    below hearing: the kind of difference a dither, a resampler or another codec makes)."""
    x = read_file(Path(path))
    if seed is not None:
        noise = np.random.default_rng(seed).integers(-1, 2, len(x))
        x = np.clip(x.astype(np.int32) + noise, -32768, 32767).astype(np.int16)
    blocks = [x[i : i + 1600] for i in range(0, len(x), 1600)]
    t = time.process_time()
    an = speech.SpeechAnalyser(speech.SpeechOptions())
    an.window_log = []
    samples = [s for b in blocks for s in an.feed(b)] + an.finish()
    cpu = time.process_time() - t
    streams: dict[str, list[tuple[float, float]]] = {}
    for smp in samples:
        streams.setdefault(smp.metric, []).append((smp.t, smp.value))
    return {"streams": streams, "cpu": cpu, "dur": len(x) / 16000, "log": an.window_log}


def roc_auc(pos: list[float], neg: list[float]) -> float:
    """Probability that a random ``pos`` scores higher than a random ``neg`` (ties half)."""
    p, n = np.asarray(pos)[:, None], np.asarray(neg)[None, :]
    return float(np.mean((p > n) + 0.5 * (p == n)))


def _analyse_seeded(job: tuple[str, int | None]) -> dict[str, object]:
    return _analyse_file(*job)


def speed_figures(m: dict[str, object], r: dict[str, object]) -> tuple[float, float, float]:
    """Error of the median speech_speed (%), and the share of full 30 s windows within 10 and
    12 % (%): each window against the true rate of the talk it covers when the manifest knows
    where the words are (``segments``: a real reader's pace varies), else the file's rate."""
    truth = float(m["true_wpm"])  # type: ignore[arg-type]
    st = cast(dict[str, list[tuple[float, float]]], r["streams"])
    sp = st.get(speech.SPEECH_SPEED, [])
    vals = np.array([v for _, v in sp])
    full = np.array([v for t, v in sp if t >= speech.WORD_WINDOW_S - 1e-6])
    med = (np.median(vals) / truth - 1) * 100 if len(vals) else float("nan")
    segs = m.get("segments")
    wtruth = np.full(len(full), truth)
    if segs:
        log = cast(list[dict[str, float]], r["log"])
        span = {round(w["t"], 3): (w["from"], w["until"]) for w in log}
        ts = [t for t, _ in sp if t >= speech.WORD_WINDOW_S - 1e-6]
        wpm = tool("make_speech_corpus").window_wpm
        wtruth = np.array([wpm(segs, *span[round(t, 3)], speech.MAX_PAUSE_S) for t in ts])
    w10 = np.mean(np.abs(full / wtruth - 1) <= 0.10) * 100 if len(full) else float("nan")
    w12 = np.mean(np.abs(full / wtruth - 1) <= 0.12) * 100 if len(full) else float("nan")
    return float(med), float(w10), float(w12)


def part_corpus(args: argparse.Namespace) -> None:
    """The corpus of tools/make_speech_corpus.py: voice x rate x condition."""
    cdir = Path(args.corpus)
    manifest: dict[str, dict[str, object]] = json.loads((cdir / "manifest.json").read_text())
    names = sorted(manifest)
    if args.only:
        names = [n for n in names if any(o in n for o in args.only)]
    if args.conditions:
        names = [n for n in names if manifest[n]["condition"] in args.conditions]
    paths = [str(cdir / str(manifest[n]["file"])) for n in names]
    if args.jobs > 1:
        from multiprocessing import Pool

        with Pool(args.jobs) as pool:
            res = pool.map(_analyse_file, paths)
    else:
        res = [_analyse_file(p) for p in paths]
    if args.save:
        Path(args.save).write_text(json.dumps(dict(zip(names, res, strict=True))))
    print(
        "speech_speed against the truth per corpus file (module defaults); med = error of the "
        "median reading; ±10/±12 = share of full 30 s windows (t >= 30 s) within that of the "
        "true rate of the talk the window covers (files with segments, marked *: word times "
        "of the synthetic voices, sentences or lines of the real readers) or of the file's "
        "rate (the rest); src = "
        "share of windows from the recogniser (rest: syllables); art = articulation median error "
        "(truth from an energy VAD); clar = median speech_accuracy (0-1)"
    )
    print(
        f"{'file':<30}{'split':>8}{'F0':>5}{'truth':>7}{'med':>7}{'±10':>6}{'±12':>6}{'src':>6}"
        f"{'art':>7}{'clar':>6}{'RTF':>7}"
    )
    clean_scores: list[float] = []
    bad_scores: list[float] = []
    # (split, real speaker?, degraded?) -> (speech_accuracy, speech_confidence) per window
    by_group: dict[tuple[str, bool, bool], tuple[list[float], list[float]]] = {}
    per_split: dict[str, list[tuple[float, float]]] = {}
    untimed: dict[str, list[str]] = {}  # clean files with no speech_speed at all, per split
    tot_cpu = tot_dur = 0.0
    for name, r in zip(names, res, strict=True):
        m = manifest[name]
        st = r["streams"]
        assert isinstance(st, dict)
        truth = float(m["true_wpm"])  # type: ignore[arg-type]
        vals = [v for _, v in st.get(speech.SPEECH_SPEED, [])]
        segs = m.get("segments")
        med, w10, w12 = speed_figures(m, r)
        src = [v for _, v in st.get(speech.SPEECH_SPEED_SOURCE, [])]
        asr = np.mean([v == speech.SOURCE_RECOGNISER for v in src]) * 100 if src else float("nan")
        art = [v for _, v in st.get(speech.SPEECH_ARTICULATION, [])]
        ta = m.get("true_articulation")
        art_err = (np.median(art) / float(ta) - 1) * 100 if art and ta else float("nan")  # type: ignore[arg-type]
        acc = [v for _, v in st.get(speech.SPEECH_ACCURACY, [])]
        clar = float(np.median(acc)) if acc else float("nan")
        cond = str(m["condition"])
        conf = [v for _, v in st.get(speech.SPEECH_CONFIDENCE, [])]
        if cond in ("clean", "pauses", "snr10", "snr5", "reverb", "lowpass"):
            g = by_group.setdefault(
                (str(m["split"]), name.startswith("real_"), cond not in ("clean", "pauses")),
                ([], []),
            )
            g[0].extend(acc)
            g[1].extend(conf)
        if cond in ("clean", "pauses"):
            clean_scores += acc
            if cond == "clean" and len(vals):
                per_split.setdefault(str(m["split"]), []).append((med, w12))
            elif cond == "clean":
                untimed.setdefault(str(m["split"]), []).append(name)
        elif cond in ("snr10", "snr5", "reverb", "lowpass"):
            bad_scores += acc
        rtf = float(r["cpu"]) / float(r["dur"])  # type: ignore[arg-type]
        tot_cpu += float(r["cpu"])  # type: ignore[arg-type]
        tot_dur += float(r["dur"])  # type: ignore[arg-type]
        print(
            f"{name + ('*' if segs else ''):<30}{str(m['split']):>8}{m['f0_hz']!s:>5}"
            f"{truth:>7.1f}{med:>+7.1f}{w10:>6.0f}"
            f"{w12:>6.0f}{asr:>6.0f}{art_err:>+7.1f}{clar:>6.2f}{rtf:>7.3f}"
        )
    for split in sorted(set(per_split) | set(untimed)):
        rows = per_split.get(split, [])
        meds = np.array([a for a, _ in rows])
        windowed = [w for _, w in rows if not np.isnan(w)]
        never = untimed.get(split, [])
        print(
            f"{split}: {len(rows)} clean files, |median error| max "
            f"{np.max(np.abs(meds)) if len(meds) else float('nan'):.1f} %, "
            f"mean {np.mean(np.abs(meds)) if len(meds) else float('nan'):.1f} %; "
            f"files with >= 90 % of windows within ±12 %: "
            f"{sum(1 for w in windowed if w >= 90)}/{len(windowed)}"
            f" ({len(rows) - len(windowed)} too short for a full window)"
            + (f"; not in these figures, never timed: {', '.join(never)}" if never else "")
        )
    if clean_scores and bad_scores:
        auc = roc_auc(clean_scores, bad_scores)
        print(
            f"clarity (speech_accuracy per window): clean/pauses n={len(clean_scores)}, degraded "
            f"(SNR 10/5, reverb, low-pass) n={len(bad_scores)}, ROC AUC {auc:.3f}"
        )
        best = max(
            np.unique(np.round(np.concatenate([clean_scores, bad_scores]), 2)),
            key=lambda th: (
                np.mean(np.asarray(clean_scores) >= th) + np.mean(np.asarray(bad_scores) < th)
            ),
        )
        for th in sorted({float(best), 0.3, 0.35, 0.4, 0.45, 0.5, 0.6}):
            c = np.mean(np.asarray(clean_scores) < th) * 100
            b = np.mean(np.asarray(bad_scores) < th) * 100
            print(f"  threshold {th:.2f}: clean windows under it {c:.1f} %, degraded {b:.1f} %")
        for k, metric in enumerate(("speech_accuracy", "speech_confidence")):
            for split in ("dev", "heldout"):
                parts = []
                for real in (False, True):
                    v = by_group.get((split, real, False), ([], []))[k]
                    if v:
                        kind = "real" if real else "synthetic"
                        parts.append(f"clean {kind} {np.mean(np.asarray(v) < 0.5) * 100:.1f} %")
                bad = by_group.get((split, False, True), ([], []))[k]
                clean = [
                    x
                    for real in (False, True)
                    for x in by_group.get((split, real, False), ([], []))[k]
                ]
                if bad and clean:
                    print(
                        f"  {metric} {split}: AUC {roc_auc(clean, bad):.3f}; under 0.5: degraded "
                        f"{np.mean(np.asarray(bad) < 0.5) * 100:.1f} %, " + ", ".join(parts)
                    )
    print(
        f"CPU: {tot_cpu:.1f} s for {tot_dur:.1f} s of audio = {tot_cpu / tot_dur:.3f} CPU s per "
        "audio s (one core per file)"
    )
    if args.perturb:
        perturbed(args, manifest, names, paths, res)


def perturbed(
    args: argparse.Namespace,
    manifest: dict[str, dict[str, object]],
    names: list[str],
    paths: list[str],
    res: list[dict[str, object]],
) -> None:
    """How much the figures move when the input changes by one least significant bit."""
    keep = [k for k, n in enumerate(names) if manifest[n]["condition"] in ("clean", "pauses")]
    jobs = [(paths[k], seed) for k in keep for seed in range(1, args.perturb + 1)]
    if args.jobs > 1:
        from multiprocessing import Pool

        with Pool(args.jobs) as pool:
            more = pool.map(_analyse_seeded, jobs)
    else:
        more = [_analyse_seeded(j) for j in jobs]
    print(
        f"\nthe same clean and pauses files with +-1 LSB of seeded noise added ({args.perturb} "
        "seeds): the figures as built, then their range over the built file and the seeds"
    )
    print(f"{'file':<30}{'med':>7}{'range':>16}{'±12':>6}{'range':>12}")
    spread_med: list[float] = []
    worst_w12: list[tuple[float, str]] = []
    for i, k in enumerate(keep):
        name = names[k]
        figs = [speed_figures(manifest[name], res[k])]
        figs += [speed_figures(manifest[name], r) for r in more[i * args.perturb :][: args.perturb]]
        meds = [f[0] for f in figs]
        w12s = [f[2] for f in figs]
        spread_med.append(max(meds) - min(meds))
        worst_w12.append((min(w12s), name))
        print(
            f"{name:<30}{meds[0]:>+7.1f}{min(meds):>+8.1f}..{max(meds):>+5.1f}"
            f"{w12s[0]:>7.0f}{min(w12s):>7.0f}..{max(w12s):>3.0f}"
        )
    print(
        f"median error moved by {np.median(spread_med):.1f} points (median over files), at "
        f"most {max(spread_med):.1f}; files whose worst case has < 90 % of windows within ±12 %: "
        + (", ".join(n for w, n in sorted(worst_w12) if w < 90) or "none")
    )


def main(argv: list[str] | None = None) -> int:
    """Print the figures of the chosen parts."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--part",
        nargs="+",
        choices=("files", "windows", "clarity", "corpus"),
        default=None,
        help="(all)",
    )
    ap.add_argument("--defaults", action="store_true", help="pocketsphinx's default search")
    ap.add_argument("--repeat", type=int, default=1, help="runs per file (the best is kept)")
    ap.add_argument(
        "--corpus", default="/tmp/speech_corpus", help="tools/make_speech_corpus.py --out"
    )
    ap.add_argument("--only", nargs="*", help="corpus files whose name contains one of these")
    ap.add_argument("--conditions", nargs="*", help="corpus conditions to run (default: all)")
    ap.add_argument("--jobs", type=int, default=1, help="corpus files analysed in parallel")
    ap.add_argument("--save", default=None, help="write the corpus streams to this JSON file")
    ap.add_argument(
        "--perturb",
        type=int,
        default=0,
        metavar="N",
        help="also run each clean and pauses file with N seeds of +-1 LSB noise and print how "
        "far the figures move",
    )
    args = ap.parse_args(argv)
    parts = args.part or ["files", "windows", "clarity"]
    if args.defaults:
        speech.DECODER_CONFIG = {}
    mta = tool("make_test_audio")
    made = talks(mta) if "windows" in parts or "clarity" in parts else {}
    audio = {k: v for k, (v, _) in made.items()}
    results: dict[tuple[str, str], list[Sample]] = {}

    def samples_of(name: str) -> np.ndarray:
        if name not in audio:  # talk_175_snr10: talk_175 with seeded noise
            base, snr = name.split("_snr")
            noisy = mta.with_noise(audio[base], float(snr), np.random.default_rng(int(snr)))
            audio[name] = np.clip(np.round(noisy), -32768, 32767).astype(np.int16)
        return audio[name]

    def cached(name: str, setting: str, metric: str) -> list[tuple[float, float]]:
        key = (name, setting)
        if key not in results:
            x = samples_of(name)
            blocks = [x[i : i + 1600] for i in range(0, len(x), 1600)]
            results[key], _ = speech.analyse(blocks, SETTINGS[setting], loudness=False)
        return [(s.t, s.value) for s in results[key] if s.metric == metric]

    for part in parts:
        if part == "files":
            part_files(args)
        elif part == "corpus":
            part_corpus(args)
        elif part == "windows":
            part_windows({k: truth for k, (_, truth) in made.items()}, cached)
        else:
            part_clarity(cached)
        print()
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
