"""Other people talking behind the presenter (issue 11).

Session 24's tester: a 150 wpm voice with three talkers 20 dB under it read 187 wpm ("slow
down"), trusted and unwarned: the recogniser counted the talkers' words in the presenter's
pauses. The module now leaves out words both far under the presenter's level and at another
pitch than the presenter's and, where such words are many (other voices near the presenter's),
writes no pace but the reason ``Untimed.OTHER_VOICES``, which the report says in words. Level
alone (session 25) also took real speakers' own quiet words (J. F. Kennedy read -9.1 %): a real
reader alone must read as it did without the rule. The rule is asked for (``--other-voices``),
off by default: a lone presenter's quieter, lower sentence endings are taken for other voices
too (session 26's review: a narrow-pitched voice trailing off went untimed in 70 of 112 windows).
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from prezence.metrics import UNTIMED_WORDS, Untimed
from prezence.report.speech import untimed_sentence, untimed_words

MATERIAL = Path(__file__).parent / "material"
RATE = 16000


def active_power(x: np.ndarray) -> float:
    """Mean square of the 30 ms frames within 30 dB of the loudest 5 % (the speech)."""
    n = len(x) // 480
    p = np.mean(x[: n * 480].reshape(n, 480) ** 2, axis=1) + 1e-9
    db = 10 * np.log10(p)
    return float(np.mean(p[db >= np.percentile(db, 95) - 30.0]))


def streams(x: np.ndarray, *, other_voices: bool = True) -> dict[str, list[tuple[float, float]]]:
    from prezence.modules.speech import SpeechOptions, analyse

    pcm = np.clip(np.round(x), -32768, 32767).astype(np.int16)
    samples, _ = analyse(
        [pcm[i : i + 1600] for i in range(0, len(pcm), 1600)],
        SpeechOptions(other_voices=other_voices),
        loudness=False,
    )
    out: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for s in samples:
        out[s.metric].append((s.t, s.value))
    return out


def test_two_readers_talking_20_db_under_a_talk_do_not_make_its_pace_read_high() -> None:
    pytest.importorskip("pocketsphinx", reason='needs pocketsphinx: pip install "prezence[speech]"')
    pytest.importorskip("av", reason='needs PyAV: pip install "prezence[speech]"')
    from prezence.modules.audio_io import read_file

    talk = read_file(MATERIAL / "rate_130.flac").astype(np.float64)
    main = np.concatenate([talk, talk])  # 61 s at 130 wpm: full 30 s word windows
    others = np.zeros(len(main))
    for name in ("librivox.flac", "sonnet.flac"):  # two real readers, other texts, looped
        y = read_file(MATERIAL / "corpus" / name).astype(np.float64)
        others += np.tile(y / np.sqrt(active_power(y)), len(main) // len(y) + 1)[: len(main)]
    others *= np.sqrt(active_power(main) / active_power(others)) * 10 ** (-20 / 20)
    clean = [v for _, v in streams(main)["speech_speed"]]
    got = streams(main + others)
    # before: 153-171 wpm against 130-152 without the talkers, in every window (a "slow down"
    # for a 130 wpm talk); now the pace is either what the talk alone read, or not written
    paced = dict(got["speech_speed"])
    assert clean and max(paced.values(), default=0.0) <= 1.02 * max(clean)
    why = dict(got["speech_untimed_reason"])
    said = [t for t, v in why.items() if v == Untimed.OTHER_VOICES]
    # once the word window is full the module says why it wrote no pace: other voices
    assert said and all(t in said for t in why if t >= 30.0)
    assert not set(paced) & set(said)
    # not asked for (the default), the talkers' words are counted as before
    default = dict(streams(main + others, other_voices=False)["speech_speed"])
    assert max(default.values()) > 1.02 * max(clean)


def test_the_other_voices_rule_is_asked_for_on_the_command_line() -> None:
    from prezence.modules.speech import SpeechOptions, build_parser

    assert SpeechOptions().other_voices is False
    args = build_parser().parse_args(["--audio", "t.wav", "--out", "o", "--other-voices"])
    assert args.other_voices is True
    assert build_parser().parse_args(["--audio", "t.wav", "--out", "o"]).other_voices is False


@pytest.mark.parametrize("name", ["librivox", "sonnet"])
def test_a_real_reader_alone_reads_as_without_the_other_voices_rule_to_a_word(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("pocketsphinx", reason='needs pocketsphinx: pip install "prezence[speech]"')
    pytest.importorskip("av", reason='needs PyAV: pip install "prezence[speech]"')
    from prezence.modules import speech
    from prezence.modules.audio_io import read_file

    x = read_file(MATERIAL / "corpus" / f"{name}.flac").astype(np.float64)
    x = np.concatenate([x, x])  # full 30 s word windows
    got = streams(x)
    # a real reader's quiet words lie 12-18 dB under the loud ones (session 25's level rule
    # dropped two of LibriVox's 71, read 155 wpm as 150, and called the telephone pair "other
    # voices"): at the reader's own pitch they are the reader's and count. LibriVox reads as
    # without the rule; the Sonnet's reader loses one word in some windows (130.7 -> 130.4
    # wpm at the median, truth 125.8): a word of 65 in a 30 s window is 1.5 %
    monkeypatch.setattr(speech, "OTHER_VOICE_GAP_DB", math.inf)
    without = dict(streams(x)["speech_speed"])
    paced = dict(got["speech_speed"])
    assert paced and set(paced) == set(without)
    assert all(abs(paced[t] / without[t] - 1) <= 0.02 for t in paced)
    assert Untimed.OTHER_VOICES not in {v for _, v in got["speech_untimed_reason"]}


def test_the_report_says_other_voices_were_near_in_words() -> None:
    # code 11 read "reason 11" before: the presenter must be told what stopped the measuring
    assert UNTIMED_WORDS[Untimed.OTHER_VOICES] == "other voices near yours"
    m = {
        "label": "pace",
        "in_range_s": 30.0,
        "out_of_range_s": 0.0,
        "check": "inRange",
        "samples": 30,
        "untimed": [{"code": int(Untimed.OTHER_VOICES), "s": 80.0}, {"code": 3, "s": 10.0}],
    }
    assert (
        untimed_words(m)
        == "other voices near yours for 1:20, too little speech yet to time for 0:10"
    )
    sentence = untimed_sentence({"talk_s": 120.0, "metrics": {"speech_speed": m}})
    assert sentence == "Other people were talking near you."
