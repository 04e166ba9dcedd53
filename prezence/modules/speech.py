"""Speech input module: speed, articulation rate, volume and clarity, from a file or the microphone.

Run it as its own process::

    python -m prezence.modules.speech --audio talk.flac --out SESSION
    python -m prezence.modules.speech --audio mic --out SESSION --t0 1767225600.0 \\
        [--window 10] [--word-window 30] [--max-pause 2] [--hop 1] [--calibration-db 90]
        [--realtime]

Every ``--hop`` seconds it appends one line to each stream, ``SESSION/streams/<metric>.txt``, with
``t`` = the end of the window in seconds since the talk began (media time for a file; for the
microphone, wall time minus ``--t0``). The levels are measured over the last ``--window``
seconds; the word-based metrics over the last ``--word-window`` seconds of *talk*, where a pause
counts at most ``--max-pause`` seconds (so a long pause neither reads as slow speech nor empties
the window); early in the talk, over all the talk so far (at least ``--window`` seconds of it):

===================== ========================================================================
metric                 value
===================== ========================================================================
speech_speed           words per minute of talk (recognised words / talk time in the word
                       window), or the calibrated syllable estimate where the recogniser is not
                       trusted; not written where neither can be (see the rule below)
speech_speed_syllables the ASR-free estimate: syllable nuclei / :data:`NUCLEI_PER_WORD` / min
speech_speed_source    where the speech_speed and speech_articulation of the same ``t`` came
                       from: 1 = recogniser words, 2 = syllable nuclei, 0 = neither could be
                       trusted (and those two streams have no line at that ``t``)
speech_untimed_reason  why a window has no speech_speed, or one from the syllable count: a
                       code of :class:`prezence.metrics.Untimed` (1 a pause, 2 no voice, 3 too
                       little talk yet, 4 after a long pause, 5 noise or music next to the
                       words, 6 clipped, 7 too noisy, 8 narrowband, 9 recogniser unsure, 10 not
                       English); no line where the recogniser's count was used
speech_snr             the word window's estimated SNR, dB (loud p90 over quiet p10 30 ms
                       frames, :meth:`SpeechAnalyser._snr_db`): what speed and clarity were
                       measured in. The coach reads it to say the room is noisy when it cues
                       clarity there (:data:`prezence.metrics.NOISY_SNR_DB`), the report to say
                       how much of a low clarity fell in noise; no rule judges it
speech_articulation    words per *speaking* minute (the same words / the time the recognised
                       words cover; with syllables: / voice-activity time)
speech_volume          active-speech level in estimated dB SPL: RMS dBFS of the speech frames
                       plus ``--calibration-db`` (see "Calibrating the volume")
speech_loudness        integrated loudness of the window, LUFS (ITU-R BS.1770, pyloudnorm),
                       relative to full scale, uncalibrated; only when pyloudnorm is installed
speech_accuracy        clarity 0..1: the recogniser's confidence over the word window (the
                       summed word posteriors over the number of words spoken, the larger of
                       the recognised and the syllable count), plus
                       :data:`CLEAN_SIGNAL_CREDIT` where the signal is clean (see "Clarity");
                       capped at 1
speech_confidence      that recogniser confidence alone, without the credit
speech_clarity         speech_accuracy as a 0-100 score: 0.2 -> 0, 0.8 -> 100, clipped
speech_activity        the fraction of the last ``--window`` seconds with voice activity, 0..1
                       (0 where no voice is heard in it); written every hop, in silence and
                       noise too: the module's heartbeat
===================== ========================================================================

A window whose last ``--window`` seconds hold less than :data:`MIN_SPEECH_S` of voice activity
writes only speech_activity: silence is not slow, quiet or unclear speech (the other streams go
quiet), and speech_volume would only measure the room's noise. So does a window whose voice
activity is noise, music or a whisper, not a voice: under :data:`MIN_VOICED_SHARE` of its frames
voiced (periodic with a pitch of 70-400 Hz, :func:`aperiodicity`); it writes speech_activity 0 and
the log says "no voice heard". speech_activity goes on, so a silent presenter is not mistaken for a
hung module; and while the module reads audio it touches the launcher's heartbeat file,
``$PREZENCE_HEARTBEAT``, about once a second (:class:`prezence.modules.common.Heartbeat`).

How it works (measured figures: ``shared/reference/input_modules.md``, ``bench/bench_speech.py``):

* pocketsphinx's webrtc voice-activity ``Endpointer`` cuts the audio into utterances, and each
  utterance is decoded **once** (cost does not grow with window/hop); its words keep their times.
  An utterance longer than :data:`MAX_UTTERANCE_S` - :data:`CUT_SEARCH_S` is cut at its next
  quiet frame (a gap between words), and at :data:`MAX_UTTERANCE_S` at the latest; one whose
  last :data:`MIN_UNDECODED_SYLLABLES` or more syllable nuclei lie after its last recognised
  word (pocketsphinx's search can end mid-word, with no hypothesis or only the words before)
  is decoded again with 0.3 s of quiet after it, and the reading with more words kept.
* **Rate normalisation**: each utterance is decoded when it ends, at a frame rate scaled with
  the speaker's recent syllable rate (:meth:`SpeechAnalyser._set_frame_rate`; 65-140 frames/s
  around pocketsphinx's 100). At a fixed 100 frames/s the recogniser has a preferred speaking
  rate: on a voice it recognises poorly (espeak-ng) it inserted 16-19 % words at 110 wpm and
  dropped 14-15 % at 210 wpm (mostly substitutions with short inserted or merged words, the
  count drifting toward the decoder's own rhythm). Scaled, speech reaches the model at about
  :data:`REFERENCE_SYLLABLE_RATE` syllables per second whatever the speaker's rate; voices it
  recognises well read the same at any frame rate from 85 to 115.
* Lines are written every ``--hop`` (:data:`CADENCE_S`) as the audio arrives, evenly, whatever
  the block size (file input and ``--realtime`` give the same lines). The levels cover the
  audio up to ``t``; the word-based metrics cover the word window ending where every word is
  decoded, up to about :data:`MAX_UTTERANCE_S` before ``t`` in unbroken speech.
* A word counts in a window by the fraction of it that lies inside.
* Why a 30 s word window: over 10 s the count follows the local rate of the sentences in it,
  which on the test voice at a steady 175 wpm spans 0.91-1.10 x the talk's rate (p10-p90; the
  one paragraph looped: 0.85-1.16); over 30 s of talk 0.98-1.04, and 0.92-1.06 at 130-225 wpm
  (``bench/bench_speech.py --part windows``).
* Syllable nuclei (De Jong & Wempe style: 300-3000 Hz band intensity peaks, >= 2 dB prominent,
  >= 70 ms apart, within 25 dB of the loudest, voiced by a window-corrected autocorrelation so
  that low voices count as voiced) are found per utterance with numpy/scipy.
* **Which count speech_speed uses** (speech_speed_source), per window: the recogniser's when its
  mean word posterior is at least :data:`MIN_RELIABLE_POSTERIOR`, its words cover at least
  :data:`MIN_WORD_COVERAGE` of the voice-activity time and the window's estimated SNR (loud over
  quiet 30 ms frames) is at least :data:`MIN_RECOGNISER_SNR_DB`; otherwise the syllable count,
  divided by this speaker's nuclei per word as learnt in the windows where the recogniser was
  trusted (the prior :data:`NUCLEI_PER_WORD` before :data:`MIN_CALIBRATION_SYLLABLES`), when
  the estimated SNR is at least :data:`MIN_SYLLABLE_SNR_DB`; otherwise none: speech_speed and
  speech_articulation are not written there and the log says why (once per change of source).
  Neither is trusted where more than :data:`MAX_CLIPPED_SHARE` of the window's speech samples
  are clipped (at :data:`CLIPPED_LEVEL` of full scale or above): a recording driven past its
  range loses words and syllable peaks alike, and read up to a third slow. Nor where an
  utterance of noise without a voice (1 s or more, under :data:`MIN_VOICED_SHARE` voiced) lies
  in or within ``max_utterance_s`` of the word window: such an utterance is a pause, but the
  ones joining it to the speech hold noise counted as talk time. Nor is the recogniser trusted
  where the audio is narrowband (a telephone line, an 8 kHz recording: nothing above 4 kHz,
  :data:`NARROWBAND_EDGE_DB`): its wideband model misses or makes up words there with
  confident posteriors (a telephone conversation read 25 % slow); the syllable count is used
  where the SNR allows, and the log says why.
* Volume: RMS of the 30 ms frames inside voice activity and within 30 dB of the window's
  95th-percentile speech frame, so pauses do not dilute it and it follows a gain change exactly.
* **Clarity** (speech_accuracy). The recogniser's confidence falls where the speech is hard to
  hear (noise, reverberation, a muffled voice) and where the speaker mumbles, but also where the
  words are rare: its language model doubts Shakespeare as it doubts mumbling (clean real
  readers scored 0.43-0.50 on the corpus against the cue threshold 0.5). An acoustic,
  vocabulary-free confidence cannot be had from pocketsphinx (it scores every frame against
  that frame's best-fitting state, so the absolute fit is gone; a phone-loop decode scored
  worse than the present value, AUC 0.66-0.90). So the signal's own state counts as evidence:
  where it is clean, the window's SNR estimate at least :data:`CLEAN_SIGNAL_SNR_DB` and its
  speech frames' 1.5-4 kHz energy at most :data:`CLEAN_SIGNAL_BAND_DB` below their 0.1-1 kHz
  energy (a muffled voice loses its high band), the confidence gets
  :data:`CLEAN_SIGNAL_CREDIT`. Mumbling into a clean microphone is still cued when the
  recogniser doubts it more than rare words make it (confidence under 0.4). speech_confidence
  keeps the confidence alone.

Calibrating the volume (once per microphone, gain setting and distance):
    1. Put a phone sound-level meter app (A-weighted, "slow") where the listeners' ears would be,
       or next to the laptop microphone for the "at the laptop" level the rules use.
    2. Speak (or play pink noise / a recorded talk from a speaker at your mouth's place) at a
       steady, normal presenting level for 20-30 s while this module runs with
       ``--calibration-db 0``: speech_volume then shows the raw dBFS (e.g. -31).
    3. Read the meter's average (e.g. 62 dB SPL). ``--calibration-db`` = meter - dBFS
       (62 - (-31) = 93). Use that value from then on; change it if the input gain changes.
    Without calibration the default :data:`DEFAULT_CALIBRATION_DB` (90) is a rough guess for a
    laptop microphone at arm's length, and the module says so in its log.

Exit status: 0 done; 2 bad input (missing, empty or wrong-format file, no microphone) with
``error: FILE: …`` on stderr, or bad arguments; 3 a file that breaks off before its end (a
truncated recording), with ``warning: FILE: …`` on stderr once everything read has been
analysed and written.
"""

from __future__ import annotations

import argparse
import logging
import math
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

from prezence.errors import BackendUnavailable, PrezenceError
from prezence.metrics import (  # the stream names and source codes the report reads too
    SOURCE_NONE,
    SOURCE_RECOGNISER,
    SOURCE_SYLLABLES,
    SPEECH_ARTICULATION,
    SPEECH_SPEED_SOURCE,
    UNTIMED_METRIC,
    WORD_WINDOW_REASONS,
    Untimed,
)
from prezence.modules.audio_io import SAMPLE_RATE, AudioSource, FileSource, MicSource
from prezence.modules.common import (
    Heartbeat,
    InputCutShort,
    ModuleInputError,
    StreamSet,
    add_common_arguments,
    report_error,
    resume_offset,
    setup_logging,
)
from prezence.samples import SPEECH_ACCURACY, SPEECH_SPEED, SPEECH_VOLUME, Sample

log = logging.getLogger(__name__)

SPEECH_ACTIVITY = "speech_activity"
SPEECH_CLARITY = "speech_clarity"
SPEECH_CONFIDENCE = "speech_confidence"
SPEECH_LOUDNESS = "speech_loudness"
SPEECH_SPEED_SYLLABLES = "speech_speed_syllables"
#: The word window's estimated SNR (dB), written with the word-based metrics.
SPEECH_SNR = "speech_snr"
#: Why a window has no speech_speed, or one from the syllable count: a code of
#: :class:`prezence.metrics.Untimed` (the log says it in words; the report reads this).
SPEECH_UNTIMED_REASON = UNTIMED_METRIC
#: Every metric this module may write, in the order it writes them.
METRICS = (
    SPEECH_SPEED,
    SPEECH_SPEED_SYLLABLES,
    SPEECH_SPEED_SOURCE,
    SPEECH_UNTIMED_REASON,
    # before speech_accuracy: a reader that sees a window's clarity sees its SNR too
    SPEECH_SNR,
    SPEECH_ARTICULATION,
    SPEECH_VOLUME,
    SPEECH_LOUDNESS,
    SPEECH_ACCURACY,
    SPEECH_CONFIDENCE,
    SPEECH_CLARITY,
    SPEECH_ACTIVITY,
)

#: The metrics that count words or judge them against English: a recogniser with a US-English
#: model and English's syllables per word. For a talk in another language (``--language``) they
#: are not written (session 23: German at a true 151 wpm read 212, Spanish at 154 read 263,
#: each with two confident "slow down" cues); the level, loudness, SNR and voice activity are.
LANGUAGE_METRICS = frozenset(
    {
        SPEECH_SPEED,
        SPEECH_SPEED_SYLLABLES,
        SPEECH_SPEED_SOURCE,
        SPEECH_ARTICULATION,
        SPEECH_ACCURACY,
        SPEECH_CONFIDENCE,
        SPEECH_CLARITY,
    }
)


def is_english(language: str) -> bool:
    """Whether a language tag (``en``, ``en-GB``, ``en_US``, ``English``) names English.

    Example:
        >>> [is_english(x) for x in ("en", "EN-gb", "en_US", "english", "de", "es-MX", "eng")]
        [True, True, True, True, False, False, True]
    """
    tag = language.strip().lower().replace("_", "-")
    return tag.split("-")[0] in {"en", "eng", "english"}


def language_why(language: str) -> str:
    """Why the word-based metrics are not written for a talk in ``language``."""
    return (
        f"the talk is in '{language}' (--language): pace and clarity are measured for English "
        "talks only (the recogniser knows US English, and words are counted from English's "
        "syllables per word); volume is measured in any language"
    )


#: Seconds between two lines of every speech stream while voice is in the level window (the
#: default ``--hop``): the lines come out evenly as the audio arrives, for a file and live alike.
#: speech_activity keeps this cadence in silence too; the others pause while the last
#: ``--window`` seconds hold under :data:`MIN_SPEECH_S` of voice. A coach's staleness limit
#: should follow from this (plus the hop of any ``--hop`` override).
CADENCE_S = 1.0
#: The shortest ``--hop``: ten lines a second already outpace the coach's 0.5 s decision
#: period; a hop of 0.1 ms wrote 10,000 lines per second of audio at 2.9 CPU s per audio s.
MIN_HOP_S = 0.1
#: dBFS -> dB SPL offset used when the user has not calibrated (a rough laptop-mic guess).
DEFAULT_CALIBRATION_DB = 90.0
#: English averages about 1.4-1.5 syllables per word (the reference measured 1.34 on one text).
#: speech_accuracy counts a word as missed only where the syllable count at this rate exceeds
#: the recognised words: the detector finds fewer nuclei than syllables (next constant), so
#: this is a conservative count of the words spoken, and clear speech is not read unclear.
SYLLABLES_PER_WORD = 1.45
#: Syllable nuclei the detector finds per word: the prior that turns nuclei into words for
#: speech_speed_syllables and the syllable fallback, until this speaker's own ratio is learnt.
#: The median over the 18 clean dev files of the corpus (tools/make_speech_corpus.py; range
#: 1.16-1.55); on the held-out clean files the median is 1.26 too (range 1.12-1.58; the six
#: real speakers 1.12-1.58, median 1.19). The detector merges some syllables, so dividing by
#: the English average of 1.45 read 13 % low on the dev files, and 9-23 % low on five of the
#: six real speakers (the sixth, recorded phone prompts, 9 % high).
NUCLEI_PER_WORD = 1.26
#: The level window needs this much voice activity for anything but speech_activity.
MIN_SPEECH_S = 1.0
#: The word-based metrics need at least this much talk, even at the end of an input (a rate
#: from a second of audio is a guess, not a measurement).
MIN_WORD_TALK_S = 3.0
#: Seconds of talk the word-based metrics (speed, articulation, clarity) count over.
WORD_WINDOW_S = 30.0
#: A pause counts as at most this many seconds of talk in the word window.
MAX_PAUSE_S = 2.0
#: The word window looks back at most this many word windows of input time.
MAX_LOOKBACK = 3.0
#: Other people talking behind the presenter (issue 11): the recogniser gives their words in
#: the presenter's pauses, and they made the pace read high (150 wpm with three talkers 20 dB
#: under read 187). A recognised word is someone else's, and not counted, when it is both
#: quiet -- its loudest 30 ms frame more than this many dB under the speaker's level, the 95th
#: percentile of the word window's frames of voice activity -- and at another pitch (below).
#: Level alone (session 25) also took a real speaker's own quiet words: J. F. Kennedy read
#: -9.1 % and the Harvard sentences -8.6 %, and it was reverted.
OTHER_VOICE_GAP_DB = 12.0
#: ... and its median pitch (over its voiced frames) lies more than this many semitones
#: outside the presenter's: the 5th to 95th percentile of the pitch of the word window's loud
#: voiced frames (within :data:`OTHER_VOICE_LOUD_DB` of the speaker's level), which are the
#: presenter's. A quiet word of the presenter's own is at the presenter's pitch. Chosen on the
#: dev files of bench/bench_talkers.py (12 of them: espeak-ng en-us and flite awb at 150 wpm,
#: espeak-ng at 130 under one talker; each rule replayed on the words recorded once; talkers
#: 15-25 dB under, windows more than 10 % off: 218 of 276 before, 24 of the 50 still timed
#: with 0.5 or 1 semitone, 31 of 57 with 2: flite slt under awb, 5 semitones apart, went
#: unflagged); no dev clean window flagged. Held out (measured once):
#: 539 of 780 windows more than 10 % off before, 289 of the 484 still timed after (296 said
#: other voices); a talker at the presenter's own pitch is not told apart.
OTHER_VOICE_PITCH_ST = 1.0
OTHER_VOICE_LOUD_DB = 10.0
#: Fewer loud voiced frames than this in the word window: no pitch range, no word left out.
MIN_PITCH_FRAMES = 20
#: A word left out up to this many dB under the speaker's level is another voice near the
#: presenter's; fainter ones are only left out.
OTHER_VOICE_FLOOR_DB = 26.0
#: This many such words in the word window: other voices near the presenter's, and the pace is
#: not written (Untimed.OTHER_VOICES): with their words left out, the count still holds words
#: the recogniser made of the talkers over the presenter's own speech.
MIN_OTHER_VOICE_WORDS = 2
#: An utterance is cut here even without a pause (bounds the live lag).
MAX_UTTERANCE_S = 10.0
#: Normalised autocorrelation (window-corrected) a syllable nucleus needs to count as voiced.
VOICING_THRESHOLD = 0.45
#: A long utterance may be cut this many seconds before MAX_UTTERANCE_S, at a quiet frame.
CUT_SEARCH_S = 3.0
#: Below this mean word posterior the recogniser's word count is not trusted.
MIN_RELIABLE_POSTERIOR = 0.4
#: The recogniser's words must cover at least this share of the voice-activity time (clean
#: speech of every corpus voice: 0.79-0.94; a stretch the recogniser gave up on: about 0.6).
MIN_WORD_COVERAGE = 0.7
#: Syllables (summed over trusted windows) needed before the per-speaker syllables-per-word
#: ratio replaces the prior.
MIN_CALIBRATION_SYLLABLES = 300.0
#: The recogniser's count is used only where the estimated SNR is at least this (dB). The
#: estimate reads 8-10 dB for white noise at a true SNR of 5 dB, 13-14 at 10 dB, 22-24 at 20 dB
#: and >= 28 on clean speech (corpus); at a true 10 dB the recogniser misses about 16 % of words.
MIN_RECOGNISER_SNR_DB = 15.0
#: The syllable count is used only where the estimated SNR is at least this (dB).
MIN_SYLLABLE_SNR_DB = 20.0
#: Rate normalisation of the recogniser (:meth:`SpeechAnalyser._set_frame_rate`): the
#: decoder's frame rate is 100 x (syllable rate / this) ** FRAME_RATE_EXPONENT, in frames per
#: second, rounded to FRAME_RATE_STEP and kept within FRAME_RATE_RANGE. The syllable rate is
#: nuclei per second of utterance over the last RATE_HISTORY_S (at least MIN_RATE_HISTORY_S,
#: else 100 frames/s); over less than RATE_FULL_TRUST_S of utterances the exponent is scaled
#: down in proportion (a rate from a few seconds of speech is a rough guess).
REFERENCE_SYLLABLE_RATE = 3.5
FRAME_RATE_EXPONENT = 1.0
FRAME_RATE_STEP = 5.0
FRAME_RATE_RANGE = (65.0, 140.0)
RATE_HISTORY_S = 20.0
MIN_RATE_HISTORY_S = 3.0
RATE_FULL_TRUST_S = 10.0
#: An utterance is decoded again (with quiet after it) when at least this many syllable nuclei
#: follow its last recognised word (pocketsphinx's search ended early).
MIN_UNDECODED_SYLLABLES = 3
#: A window's signal is clean (speech_accuracy's credit) when its estimated SNR is at least
#: this (dB; dev corpus windows: degraded at most 14.5, clean at least 30.5; the estimate
#: under-reads unbroken speech, so a value nearer the degraded side) ...
CLEAN_SIGNAL_SNR_DB = 20.0
#: ... and the energy of its speech frames in 1.5-4 kHz is at most this far below that in
#: 0.1-1 kHz (dB; dev: low-passed -37.5 or lower, clean -23 or higher: the middle of the gap).
CLEAN_SIGNAL_BAND_DB = -30.0
#: What a clean signal adds to the recogniser's confidence: the least that lifts 99 % of the
#: dev corpus's clean windows to the cue threshold 0.5 (their 1st percentile: 0.395).
CLEAN_SIGNAL_CREDIT = 0.1
#: A sample at or above this share of full scale counts as clipped (a recorder driven past its
#: range flattens the waveform there). Not 1.0: a lossy codec (a phone's AAC, an MP3) puts the
#: flattened tops of a clipped recording at 0.9-0.95 of full scale with ripple; speech made
#: as loud as it can be without clipping (peaks normalised to -0.1 dBFS) has 0.003 % of its
#: samples this high, the same speech driven 12 dB past full scale 16-18 % (WAV, AAC, MP3).
CLIPPED_LEVEL = 0.9
#: Where more than this share of a word window's speech samples is clipped, neither count is
#: trusted: speech_speed and speech_articulation are not written (the log says why). Measured
#: on a 161.6 wpm flite reading driven past full scale (``sox gain``): +8 dB, 4.2 % of samples
#: clipped, read -6 %; +12 dB, 18.5 %, read -16 % with the recogniser trusted; +20 dB, 42 %,
#: read -32 % (the coach said "pick up the pace"); +16 dB saved as AAC or MP3 read -13 and
#: -17 %. Not a retuned threshold: a new condition, set between the first two of those.
MAX_CLIPPED_SHARE = 0.05
#: Narrowband (telephone) input: audio sampled at 8 kHz, or cut to the telephone band, and
#: played at 16 kHz has next to nothing above 4 kHz, and the recogniser, whose model was
#: trained on wideband speech, misses or invents words there with confident posteriors. Per
#: 30 ms frame, :func:`edge_db` is the energy above the telephone band
#: (:data:`NARROWBAND_ABOVE_HZ`) over that inside it (:data:`NARROWBAND_REFERENCE_HZ`); a
#: word window whose loud frames' median (the frames within 30 dB of the 95th percentile, as
#: for the volume) is at most :data:`NARROWBAND_EDGE_DB` and whose 1.5-4 kHz band is kept
#: (:data:`CLEAN_SIGNAL_BAND_DB`: a muffled voice, low-passed, loses that too and is left to
#: the rule as before) is narrowband: the recogniser's count is not trusted there, and the
#: syllable count is used where the SNR allows, else nothing. Measured (session 23) on the
#: corpus and on copies of its clean files at 8 kHz (``sox -r 8000``, with and without
#: ``sinc 300-3400``, back to 16 kHz), per 30 s window: wideband files (every voice and
#: condition but low-pass) -29.0 dB (J. F. Kennedy's old recording) or more, the dev voices'
#: -27.2 or more; the narrowband copies of the dev voices -57.9 or less; the threshold is the
#: middle of that dev gap. Held out: the real telephone pair -52.8, the held-out voices' copies
#: -57.1 or less; every window of the 46 copies is narrowband, and their 1.5-4 kHz band reads
#: -23.1 dB or more (low-passed files: -38.5 or less, so they are not).
NARROWBAND_EDGE_DB = -42.0
#: Above the telephone band (Hz): where 8 kHz audio has nothing and wideband speech has its
#: fricatives.
NARROWBAND_ABOVE_HZ = (4000.0, 7000.0)
#: Inside the telephone band (Hz): the reference the band above is held against.
NARROWBAND_REFERENCE_HZ = (1000.0, 3400.0)
#: A 30 ms frame is *voiced* (periodic, as a voice is and noise is not) where the YIN
#: aperiodicity (de Cheveigne & Kawahara 2002: the cumulative-mean-normalised difference
#: function's minimum) over it and the frame before it is under this, for a pitch of
#: :data:`VOICED_F0_RANGE`. Measured with 60 ms: white, pink and brown noise, a 400 Hz
#: low-passed fan, mains hum over noise and plucked chords: no frame under 0.3 (1 % under 0.4);
#: clean speech 51-78 % of its loud frames, at SNR 10 dB 55 %, at 0 dB 4 %.
VOICED_APERIODICITY = 0.3
#: Pitch range (Hz) the voicing test looks in: low male voices to high female ones.
VOICED_F0_RANGE = (70.0, 400.0)
#: A level window whose voice-activity frames are less than this share voiced holds no voice
#: the module can hear: the webrtc voice-activity detector fires on steady noise (a fan, a
#: hiss), and the recogniser makes up a few words there with high posteriors, so noise alone
#: read 65.8 "dB SPL" and clarity 0.61-1.0. Such a window writes speech_activity 0 and nothing
#: else, as silence does. Measured per 10 s window: the noises above 0.000 in every window;
#: speech 0.41-0.70 clean (the shipped voices), 0.52 or more at SNR 10 dB, 0.018-0.054 at SNR
#: 0 dB (white noise): the limit keeps a voice buried in noise (its clarity falls instead).
#: A steady tone or buzz with a pitch in :data:`VOICED_F0_RANGE` is not voiced either
#: (:data:`STEADY_PITCH_S`).
MIN_VOICED_SHARE = 0.01
#: Voiced frames whose pitch stays within :data:`STEADY_PITCH_TOL` of one value for this many
#: seconds or more are a steady tone or hum (a projector's or a fridge's 100/120 Hz buzz), not
#: a voice, and are counted unvoiced. Before, 30 s of a 100 Hz hum alone read speech_volume
#: 62 and speech_accuracy 0.73, and a 120 Hz buzz over noise clarity 0 (an `articulate` cue
#: on a buzz). A voice's pitch moves: the longest such run in the 67 files of the speech corpus
#: (every voice, rate and condition) is 22 frames (0.66 s, festival ked at 110 wpm, a diphone
#: voice); in its real recordings (held out) 14 (0.42 s); a hum's or a tone's, the whole file.
#: A slow glide (a siren, 100-300 Hz over 20 s) is not caught (its runs: 17 frames).
STEADY_PITCH_S = 1.0
#: Relative change of the pitch period that still continues a steady run.
STEADY_PITCH_TOL = 0.02
#: A buzz barely over noise breaks those runs: its period reads jitter past 2 % and, at 150 Hz
#: and up, twice or three times the period (YIN takes a multiple when noise fills the dip), and
#: at 0-3 dB over the noise up to nine tenths of its frames are not voiced. So a second
#: run is followed, of frames with an aperiodicity under :data:`STEADY_BUZZ_APERIODICITY`
#: whose period is within :data:`STEADY_BUZZ_TOL` of (a multiple of) the run's running mean
#: and whose level is within :data:`STEADY_BUZZ_DB` of the run's mean level, through up to
#: :data:`STEADY_BUZZ_GAP` frames in a row that are not; once it lasts this many seconds its
#: frames are a buzz too. The level keeps voices out: a diphone voice holds one pitch within
#: 1 % over several words (festival, with reverb), but its level moves 10-20 dB between them;
#: a buzz in steady noise holds its level within 1-2 dB. Measured on seeded buzzes (tuned on:
#: hum, square, triangle at 100/150/240 Hz and one spinning up 90-130 Hz, pink and white noise
#: 0-12 dB under them) 49 of 79 were heard as a voice (536 of 869 windows wrote
#: speech_volume), with this run 3 (12 windows); held out (120/180/200 Hz, hum, saw, sine, one
#: spinning up 120-160 Hz, other seeds, 1.5-9 dB) 39 of 59 (400 of 679 windows), then 6 (13).
#: A voice's longest such run in the 67-file corpus is 26 frames (0.78 s, flite awb with
#: reverb), in its real recordings 16 (0.48 s); no stream of the corpus changed. The first run
#: is kept: it alone catches a clean hum whose level beats (+-50 % amplitude: +-9.5 dB).
STEADY_BUZZ_S = 1.5
#: Relative distance from the run's mean period (or a multiple of it, up to four) that continues
#: a buzz run.
STEADY_BUZZ_TOL = 0.03
#: Weight of each frame's period in a buzz run's (exponential) mean: it follows a drifting hum
#: (a fan spinning up) within about ten frames.
STEADY_BUZZ_FOLLOW = 0.1
#: Level (dB) from the run's mean that continues a buzz run.
STEADY_BUZZ_DB = 4.0
#: Aperiodicity under which a frame can continue a buzz run (it need not be voiced).
STEADY_BUZZ_APERIODICITY = 0.6
#: Frames in a row that may break a buzz run without ending it.
STEADY_BUZZ_GAP = 2
#: speech_accuracy -> speech_clarity anchors: (accuracy, score).
CLARITY_ANCHORS = ((0.2, 0.0), (0.8, 100.0))
#: Warn when a live input is this many seconds behind.
BEHIND_WARN_S = 2.0

#: pocketsphinx settings. The second (flat-lexicon) pass is off and active HMMs and word exits
#: per frame are capped; the beams are pocketsphinx's own. On the corpus of
#: tools/make_speech_corpus.py this keeps the word count within a few % of the truth (132-139
#: of 136 words where the defaults find 141-145) at about half the defaults' CPU on clean speech
#: and a fifth on noisy speech. The tighter beams used before (1e-44 / 1e-44 / 1e-26) lost 6-8 %
#: of the words on several voices, so speed read low (bench/bench_speech.py --part corpus).
DECODER_CONFIG: dict[str, Any] = {
    "fwdflat": False,
    "maxhmmpf": 2500,
    "maxwpf": 10,
}
_ORDER = {m: i for i, m in enumerate(METRICS)}
_FRAME = 480  # 30 ms at 16 kHz: the endpointer's frame
_FRAME_S = _FRAME / SAMPLE_RATE
#: words known up to this far into a stretch of speech are none of its own (the endpointer's
#: utterance may open a little after the stretch)
_NEW_STRETCH_S = 0.5
_BAND_TAPER = np.hanning(_FRAME)
_BAND_FREQS = np.fft.rfftfreq(512, 1.0 / SAMPLE_RATE)


def _in_band(band: tuple[float, float]) -> np.ndarray:
    """Which bins of a 512-point spectrum at 16 kHz lie in ``band`` (Hz, its top excluded)."""
    lo, hi = band
    freqs = _BAND_FREQS
    return (freqs >= lo) & (freqs < hi)


_BAND_LOW = _in_band((100.0, 1000.0))
_BAND_HIGH = _in_band((1500.0, 4000.0))
_BAND_ABOVE_PHONE = _in_band(NARROWBAND_ABOVE_HZ)
_BAND_PHONE = _in_band(NARROWBAND_REFERENCE_HZ)


_VOICED_LAGS = (
    int(SAMPLE_RATE / VOICED_F0_RANGE[1]),
    int(math.ceil(SAMPLE_RATE / VOICED_F0_RANGE[0])),
)
_VOICED_TAU = np.arange(1, _VOICED_LAGS[1] + 1, dtype=np.float64)


def aperiodicity(x: np.ndarray) -> float:
    """YIN aperiodicity of ``x`` (samples in int16 units, at least two periods of the lowest
    pitch long): the minimum, over the lags of :data:`VOICED_F0_RANGE`, of the cumulative
    mean normalised difference function. Near 0 for a periodic signal, about 1 for noise of
    any colour (low-passed noise's difference grows smoothly with the lag and never dips);
    1.0 for a signal without energy.
    """
    return voicing(x)[0]


def voicing(x: np.ndarray) -> tuple[float, float]:
    """:func:`aperiodicity` of ``x`` and its pitch period in samples (0.0 without energy).

    The period is YIN's: the first lag whose normalised difference is under 0.1, walked down
    to its dip (so a periodic signal's double period, as deep a dip, is not taken), or the
    deepest lag when none is; refined between samples by a parabola through the dip.

    Example:
        >>> t = np.arange(960) / SAMPLE_RATE
        >>> ap, period = voicing(8000 * np.sin(2 * np.pi * 200.0 * t))
        >>> ap < 0.01, round(SAMPLE_RATE / period, 1)
        (True, 200.0)
    """
    tmin, tmax = _VOICED_LAGS
    x = np.asarray(x, dtype=np.float64)
    x = x - x.mean()
    w = len(x) - tmax
    if w <= tmax:
        raise ValueError(f"aperiodicity needs more than {2 * tmax} samples, got {len(x)}")
    cum = np.concatenate(([0.0], np.cumsum(x * x)))
    if cum[-1] < len(x):  # under one LSB of RMS: digital silence has no pitch
        return 1.0, 0.0
    # d(tau) = sum_j (x_j - x_{j+tau})^2 over j < w, for tau = 1 .. tmax
    r = np.correlate(x[1 : w + tmax], x[:w], mode="valid")
    d = cum[w] + (cum[w + 1 : w + tmax + 1] - cum[1 : tmax + 1]) - 2.0 * r
    total = np.cumsum(d)
    if total[-1] <= 0.0:
        return 1.0, 0.0
    dn = d * _VOICED_TAU / np.maximum(total, 1e-12)
    seg = dn[tmin - 1 :]
    below = np.flatnonzero(seg < 0.1)
    if len(below):
        i = int(below[0])
        while i + 1 < len(seg) and seg[i + 1] < seg[i]:
            i += 1
    else:
        i = int(np.argmin(seg))
    period = float(i + tmin)
    if 0 < i < len(seg) - 1:
        a, b, c = float(seg[i - 1]), float(seg[i]), float(seg[i + 1])
        if a - 2.0 * b + c > 0.0:
            period += 0.5 * (a - c) / (a - 2.0 * b + c)
    return float(seg.min()), period


def band_energies(frame: np.ndarray) -> tuple[float, float]:
    """Energy of a 30 ms frame in 0.1-1 kHz and in 1.5-4 kHz (Hann window, 512-point FFT)."""
    low, high, _ = _frame_spectrum(frame)
    return low, high


def _frame_spectrum(frame: np.ndarray) -> tuple[float, float, float]:
    """:func:`band_energies` of a 30 ms frame, and its :func:`narrowband edge <edge_db>`."""
    x = np.zeros(_FRAME)
    n = min(len(frame), _FRAME)
    x[:n] = frame[:n]
    p = np.abs(np.fft.rfft(x * _BAND_TAPER, 512)) ** 2
    return float(p[_BAND_LOW].sum()), float(p[_BAND_HIGH].sum()), edge_db(p)


def edge_db(power: np.ndarray) -> float:
    """dB of a 512-point power spectrum's energy in :data:`NARROWBAND_ABOVE_HZ` (above the
    telephone band) over that in :data:`NARROWBAND_REFERENCE_HZ` (inside it).

    Example:
        >>> p = np.ones(257)
        >>> round(edge_db(p), 1)  # a flat spectrum: 96 bins above, 77 inside
        1.0
    """
    above = float(power[_BAND_ABOVE_PHONE].sum())
    inside = float(power[_BAND_PHONE].sum())
    return 10.0 * math.log10((above + 1e-3) / (inside + 1e-3))


@dataclass(frozen=True)
class SpeechOptions:
    """What the speech analysis measures, and how.

    Attributes:
        window_s: length of the level window (volume, loudness, voice activity), seconds; the
            word-based metrics also need this much talk before their first value.
        hop_s: time between two measurements, seconds.
        calibration_db: dB added to dBFS to estimate dB SPL (see the module doc).
        syllables_per_word: syllables per word for speech_accuracy's count of words spoken.
        nuclei_per_word: the prior turning syllable nuclei into words for the speed.
        min_speech_s: voice activity the level window needs for anything but speech_activity.
        max_utterance_s: longest utterance decoded in one piece.
        word_window_s: seconds of talk the word-based metrics count over.
        max_pause_s: a pause counts as at most this many seconds of talk.
        other_voices: leave out words at another level and pitch than the presenter's as
            other people's (:data:`OTHER_VOICE_GAP_DB`); off unless asked (``--other-voices``):
            a lone presenter's quieter, lower sentence endings are taken for them too.
    """

    window_s: float = 10.0
    hop_s: float = CADENCE_S
    calibration_db: float = DEFAULT_CALIBRATION_DB
    syllables_per_word: float = SYLLABLES_PER_WORD
    nuclei_per_word: float = NUCLEI_PER_WORD
    min_speech_s: float = MIN_SPEECH_S
    max_utterance_s: float = MAX_UTTERANCE_S
    word_window_s: float = WORD_WINDOW_S
    max_pause_s: float = MAX_PAUSE_S
    other_voices: bool = False

    def __post_init__(self) -> None:
        for name in (
            "window_s",
            "word_window_s",
            "hop_s",
            "syllables_per_word",
            "nuclei_per_word",
            "max_utterance_s",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if self.hop_s < MIN_HOP_S:
            raise ValueError(f"hop_s must be at least {MIN_HOP_S} s, got {self.hop_s!r}")
        if self.hop_s > self.window_s:
            raise ValueError(f"hop_s ({self.hop_s}) must not exceed window_s ({self.window_s})")
        for name in ("min_speech_s", "max_pause_s"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be >= 0, got {v!r}")
        if not math.isfinite(self.calibration_db):
            raise ValueError(f"calibration_db must be finite, got {self.calibration_db!r}")


@dataclass(frozen=True)
class Word:
    """A recognised word: start and end in seconds of input time, posterior in [0, 1]."""

    start: float
    end: float
    text: str
    prob: float
    #: level of its loudest 30 ms frame, dB (10 log10 of the mean square, int16 scale)
    peak_db: float = 0.0
    #: median pitch of its voiced frames, semitones above 100 Hz (NaN: none voiced)
    pitch_st: float = math.nan


@dataclass(frozen=True)
class SpeechTotals:
    """Whole-input figures (for the bench, tests and the end-of-run log line)."""

    duration_s: float
    speech_s: float
    words: int
    syllables: int
    mean_posterior: float

    @property
    def wpm(self) -> float:
        """Recognised words per minute of input."""
        return self.words / self.duration_s * 60.0 if self.duration_s > 0 else 0.0


def clarity_score(accuracy: float) -> float:
    """Map speech_accuracy (0..1) to the 0-100 clarity score by :data:`CLARITY_ANCHORS`.

    Example:
        >>> clarity_score(0.8), round(clarity_score(0.5), 6), clarity_score(0.1)
        (100.0, 50.0, 0.0)
    """
    (a0, s0), (a1, s1) = CLARITY_ANCHORS
    x = (accuracy - a0) / (a1 - a0)
    return float(s0 + (s1 - s0) * min(1.0, max(0.0, x)))


def syllable_nuclei(pcm: np.ndarray, sample_rate: int = SAMPLE_RATE) -> np.ndarray:
    """Times (s from the start of ``pcm``) of syllable nuclei: voiced band-intensity peaks.

    Args:
        pcm: mono audio (int16 or float).
        sample_rate: its rate in Hz.

    Returns:
        Sorted peak times in seconds (empty for audio shorter than 0.1 s).
    """
    from scipy.signal import butter, find_peaks, sosfiltfilt

    x = np.asarray(pcm, dtype=np.float64)
    win, hop = int(0.032 * sample_rate), int(0.010 * sample_rate)
    if len(x) < max(win + 2 * hop, int(0.1 * sample_rate)):
        return np.zeros(0)
    sos = butter(4, [300.0, 3000.0], btype="bandpass", fs=sample_rate, output="sos")
    band = sosfiltfilt(sos, x)
    n = 1 + (len(x) - win) // hop
    idx = np.arange(win)[None, :] + hop * np.arange(n)[:, None]
    w = np.hanning(win)
    power = np.mean((band[idx] * w) ** 2, axis=1) + 1e-9
    db = 10.0 * np.log10(power)
    db = np.convolve(db, np.ones(3) / 3.0, mode="same")
    peaks, _ = find_peaks(db, height=np.percentile(db, 99) - 25.0, prominence=2.0, distance=7)
    if len(peaks) == 0:
        return np.zeros(0)
    # Voicing: normalised autocorrelation peak above 0.45 for a pitch of 80-400 Hz.
    frames = x[idx[peaks]] * w
    frames -= frames.mean(axis=1, keepdims=True)
    spec = np.fft.rfft(frames, n=2 * win, axis=1)
    ac = np.fft.irfft(np.abs(spec) ** 2, axis=1)[:, :win]
    # Divide by the window's own autocorrelation (Boersma 1993): a windowed periodic signal's
    # autocorrelation at lag L is damped by the window's, so without this a 100 Hz voice (lag
    # 10 ms of a 32 ms window) scored about 0.6 of a 200 Hz one and lost its syllables.
    wac = np.fft.irfft(np.abs(np.fft.rfft(w, n=2 * win)) ** 2)[:win]
    lo, hi = sample_rate // 400, sample_rate // 80
    norm = ac[:, lo : hi + 1] / (ac[:, :1] + 1e-9) / (wac[lo : hi + 1] / wac[0])
    voiced = np.max(norm, axis=1) > VOICING_THRESHOLD
    times: np.ndarray = (peaks[voiced] * hop + win / 2) / sample_rate
    return times


def _overlap(a0: float, a1: float, b0: float, b1: float) -> float:
    return max(0.0, min(a1, b1) - max(a0, b0))


def _is_word(w: str) -> bool:
    """A recognised word, not silence, a filler or a sentence mark."""
    return w not in ("<s>", "</s>", "<sil>") and not w.startswith(("[", "++", "<"))


def _seg_end(seg: Any, frate: float) -> float:
    """End of a pocketsphinx segment, seconds from the utterance start."""
    return float(seg.end_frame + 1) / frate


def _make_decoder() -> Any:
    try:
        from pocketsphinx import Decoder
    except ImportError as e:
        raise BackendUnavailable(
            'the speech module needs pocketsphinx: pip install "prezence[speech]"'
        ) from e
    return Decoder(samprate=SAMPLE_RATE, loglevel="FATAL", **DECODER_CONFIG)


def _make_endpointer() -> Any:
    from pocketsphinx import Endpointer

    ep = Endpointer(window=0.3, ratio=0.9, sample_rate=SAMPLE_RATE, frame_length=_FRAME_S)
    if ep.frame_bytes != 2 * _FRAME:  # pragma: no cover - a pocketsphinx change
        raise RuntimeError(f"pocketsphinx endpointer frame is {ep.frame_bytes} bytes, not 960")
    return ep


def _loudness_meter() -> Any:
    try:
        import pyloudnorm
    except ImportError:
        log.info("pyloudnorm is not installed: speech_loudness (LUFS) is not written")
        return None
    return pyloudnorm.Meter(SAMPLE_RATE)


class SpeechAnalyser:
    """Incremental speech measurements: feed 16 kHz mono int16 audio, get :class:`Sample` s.

    Each utterance is decoded once; windows are counted from the kept word and syllable times.

    Args:
        options: window, hop, calibration and priors.
        loudness: also measure LUFS when pyloudnorm is installed.

    Raises:
        BackendUnavailable: pocketsphinx is not installed.
    """

    def __init__(self, options: SpeechOptions, *, loudness: bool = True) -> None:
        self.options = options
        self._dec = _make_decoder()
        self._ep = _make_endpointer()
        self._meter = _loudness_meter() if loudness else None
        self._pending = np.zeros(0, np.int16)
        self._n_frames = 0  # 30 ms frames given to the endpointer
        self._n_samples = 0  # samples fed
        self._frame_ms: list[float] = []  # mean square per frame, for the volume
        self._frame_bands: list[tuple[float, float]] = []  # band_energies per frame (clarity)
        self._frame_edge: list[float] = []  # edge_db per frame (narrowband input)
        self._frame_clipped: list[float] = []  # share of clipped samples per frame
        #: (t_out, share) of every word window too clipped to count (:data:`MAX_CLIPPED_SHARE`)
        self.clipped_windows: list[tuple[float, float]] = []
        self._frame_voiced: list[bool] = []  # the frame (with the one before) is periodic
        self._frame_st: list[float] = []  # its pitch, semitones above 100 Hz (NaN: no pitch)
        self._frame_steady: list[bool] = []  # periodic, but in a steady run (a hum, a tone)
        self._steady_period: float | None = None  # the current run's first period, samples
        self._steady_from = 0  # the current run's first frame
        self._steady_marked = 0  # frames before this one are marked already
        # The buzz run (STEADY_BUZZ_S): its fundamental period (a running mean), the sum of its
        # frames' levels (dB), their count, its first frame, frames missed in a row, frames
        # marked already.
        self._buzz_period: float | None = None
        self._buzz_db = 0.0
        self._buzz_n = 0
        self._buzz_from = 0
        self._buzz_gap = 0
        self._buzz_marked = 0
        self._prev_frame = np.zeros(_FRAME)
        self._voiceless = False  # the last window with voice activity held no voiced frame
        # The last few windows' audio, for LUFS: samples from absolute index _ring_start.
        self._ring = np.zeros(0, np.int16)
        self._ring_start = 0
        # Current utterance: start time, time of its next frame, its audio.
        self._in_utt = False
        self._utt_start = 0.0
        self._utt_t = 0.0
        self._utt_pcm: list[bytes] = []
        self._utt_ms: list[float] = []  # its frames' mean squares (where to cut it)
        self._pad_rng = np.random.default_rng(0)
        # (seconds, syllable nuclei) of the latest utterances, for the decoder's frame rate.
        self._recent: deque[tuple[float, int]] = deque()
        self._frate = 100.0
        # Finished results, oldest first (pruned once no future window can need them).
        self._words: deque[Word] = deque()
        self._spans: deque[tuple[float, float]] = deque()
        # Utterances of noise, not voice (see _end_utterance): cut out of the spans.
        self._noise_utts: deque[tuple[float, float]] = deque()
        self._syllables: deque[float] = deque()
        self._span_start: float | None = None
        self._next_t = options.window_s  # end of the next window to write
        # Words, spans and syllables are kept this far back (the word window's longest reach).
        self._lookback_s = max(options.window_s, MAX_LOOKBACK * options.word_window_s)
        self._last_t = 0.0  # end of the last window written
        self._finished = False
        self._last_source: float | None = None
        #: the word-based metrics wait for the first words after a long pause (since when)
        self._resumed_at: float | None = None
        self._cal_words = 0.0  # recognised words and syllables in trusted windows
        self._cal_syl = 0.0
        #: Set to a list to collect each window's counts (bench and tests).
        self.window_log: list[dict[str, float]] | None = None
        #: Set to a list to collect every recognised word (bench).
        self.word_log: list[Word] | None = None
        # Totals over the whole input.
        self._n_words = 0
        self._n_syl = 0
        self._p_sum = 0.0
        self._speech_s = 0.0

    # ---- input -------------------------------------------------------------------------

    @property
    def duration_s(self) -> float:
        """Seconds of audio fed so far."""
        return self._n_samples / SAMPLE_RATE

    def feed(self, pcm: np.ndarray) -> list[Sample]:
        """Analyse the next block of audio; return the samples of every window now complete.

        Args:
            pcm: 16 kHz mono int16 samples, any length.

        Raises:
            ValueError: audio fed after :meth:`finish`, or not int16.
        """
        if self._finished:
            raise ValueError("SpeechAnalyser.feed after finish()")
        pcm = np.asarray(pcm)
        if pcm.dtype != np.int16:
            raise ValueError(f"expected int16 samples, got {pcm.dtype}")
        self._n_samples += pcm.size
        buf = np.concatenate([self._pending, pcm.reshape(-1)])
        n = len(buf) // _FRAME
        self._ring = np.concatenate([self._ring, buf[: n * _FRAME]])
        out: list[Sample] = []
        for i in range(n):
            self._frame(buf[i * _FRAME : (i + 1) * _FRAME])
            # Windows are written as soon as their audio is in (every hop, evenly), whatever
            # the block size: file input and a live input give the same lines.
            if self._next_t <= self._n_frames * _FRAME_S + 1e-9:
                out += self._emit(self._n_frames * _FRAME_S)
        self._pending = buf[n * _FRAME :]
        return out

    def finish(self) -> list[Sample]:
        """End of input: decode what is left and return the remaining windows.

        The last window ends at the end of the input (a window shorter than ``window_s`` when
        the whole input is shorter).
        """
        if self._finished:
            return []
        self._finished = True
        tail = self._pending
        self._pending = np.zeros(0, np.int16)
        if len(tail):
            ms = float(np.mean(tail.astype(np.float64) ** 2))
            self._frame_ms.append(ms)
            low, high, edge = _frame_spectrum(tail.astype(np.float64))
            self._frame_bands.append((low, high))
            self._frame_edge.append(edge)
            self._frame_clipped.append(_clipped_share(tail))
            self._frame_voiced.append(False)  # too short to find a pitch in
            self._frame_st.append(math.nan)
            self._frame_steady.append(False)
            self._ring = np.concatenate([self._ring, tail])
        # end_stream needs a non-empty partial frame; one zero sample flushes it all the same.
        speech = self._ep.end_stream(tail.tobytes() if len(tail) else b"\x00\x00")
        end = self._n_frames * _FRAME_S + len(tail) / SAMPLE_RATE
        if speech is not None:
            self._speech_frame(speech)
        stop = end
        if self._span_start is not None and self._span_start < self._ep.speech_end <= end:
            stop = float(self._ep.speech_end)
        if self._in_utt:
            self._end_utterance(stop)
        self._close_span(stop)
        out = self._emit(end)
        if end > self._last_t + 1e-6:
            out += self._window(end, final=True)
        return out

    def totals(self) -> SpeechTotals:
        """Figures over everything fed so far (final after :meth:`finish`)."""
        return SpeechTotals(
            duration_s=self.duration_s,
            speech_s=self._speech_s,
            words=self._n_words,
            syllables=self._n_syl,
            mean_posterior=self._p_sum / self._n_words if self._n_words else 0.0,
        )

    # ---- per frame ---------------------------------------------------------------------

    def _frame(self, frame: np.ndarray) -> None:
        x = frame.astype(np.float64)
        self._frame_ms.append(float(np.mean(x**2)))
        low, high, edge = _frame_spectrum(x)
        self._frame_bands.append((low, high))
        self._frame_edge.append(edge)
        self._frame_clipped.append(_clipped_share(frame))
        both = np.concatenate((self._prev_frame, x))
        ap, period = voicing(both)
        self._frame_voiced.append(ap < VOICED_APERIODICITY)
        self._frame_st.append(
            12.0 * math.log2(SAMPLE_RATE / period / 100.0) if period > 0.0 else math.nan
        )
        self._frame_steady.append(False)
        self._steady(period)
        self._buzz(ap, period, 10.0 * math.log10(max(self._frame_ms[-1], 1.0)))
        self._prev_frame = x
        speech = self._ep.process(frame.tobytes())
        self._n_frames += 1
        if speech is not None:
            self._speech_frame(speech)
            if not self._ep.in_speech:
                # The utterance may just have been cut at max_utterance_s on this very frame:
                # end it only if it is still open (ending it twice makes pocketsphinx raise).
                if self._in_utt:
                    self._end_utterance(self._ep.speech_end)
                self._close_span(self._ep.speech_end)

    def _steady(self, period: float) -> None:
        """Follow runs of voiced frames at one pitch; once a run lasts :data:`STEADY_PITCH_S`,
        its frames (and the next ones while it lasts) are a tone or hum: unvoiced, and steady."""
        i = len(self._frame_voiced) - 1
        ref, voiced = self._steady_period, self._frame_voiced[i]
        if not (voiced and ref is not None and abs(period - ref) <= STEADY_PITCH_TOL * ref):
            self._steady_period = period if voiced else None
            self._steady_from = i
        if self._steady_period is not None and (i + 1 - self._steady_from) * _FRAME_S >= (
            STEADY_PITCH_S - 1e-9
        ):
            self._mark_steady(self._steady_from, i, self._steady_marked)
            self._steady_marked = i + 1

    def _buzz(self, ap: float, period: float, db: float) -> None:
        """Follow runs of frames at one pitch and one level, through noise (the period read to
        :data:`STEADY_BUZZ_TOL` or as a multiple, frames periodic to
        :data:`STEADY_BUZZ_APERIODICITY`, gaps of :data:`STEADY_BUZZ_GAP` frames); once a run
        lasts :data:`STEADY_BUZZ_S`, its frames are a buzz: unvoiced, and steady."""
        i = len(self._frame_voiced) - 1
        ref, tol = self._buzz_period, STEADY_BUZZ_TOL
        fundamental = 0.0
        if (
            ref is not None
            and ap < STEADY_BUZZ_APERIODICITY
            and abs(db - self._buzz_db / self._buzz_n) <= STEADY_BUZZ_DB
        ):
            k = max(1, round(period / ref))
            if k <= 4 and abs(period - k * ref) <= tol * k * ref:
                fundamental = period / k  # the period, or a multiple of it read through noise
            else:
                k = round(ref / period)
                if 2 <= k <= 4 and abs(ref - k * period) <= tol * ref:
                    # the run had read a multiple: follow the fundamental from here on
                    fundamental, ref = period, ref / k
        if fundamental > 0.0 and ref is not None:
            self._buzz_period = ref + STEADY_BUZZ_FOLLOW * (fundamental - ref)
            self._buzz_db += db
            self._buzz_n += 1
            self._buzz_gap = 0
            if (i + 1 - self._buzz_from) * _FRAME_S >= STEADY_BUZZ_S - 1e-9:
                self._mark_steady(self._buzz_from, i, self._buzz_marked)
                self._buzz_marked = i + 1
        elif ref is not None and self._buzz_gap < STEADY_BUZZ_GAP:
            self._buzz_gap += 1
        elif ap < VOICED_APERIODICITY:
            self._buzz_period, self._buzz_db, self._buzz_n = period, db, 1
            self._buzz_from, self._buzz_gap = i, 0
        else:
            self._buzz_period = None

    def _mark_steady(self, first: int, last: int, marked: int) -> None:
        """Frames ``first`` to ``last`` (those from ``marked`` on) are a hum: unvoiced, steady."""
        for j in range(max(first, marked), last + 1):
            self._frame_voiced[j] = False
            self._frame_steady[j] = True

    def _speech_frame(self, speech: bytes) -> None:
        if not self._in_utt:
            if self._span_start is None:  # a new stretch of speech (not a cut utterance)
                self._utt_t = self._span_start = float(self._ep.speech_start)
            self._in_utt = True
            self._utt_start = self._utt_t
        self._utt_pcm.append(speech)
        self._utt_t += len(speech) / 2 / SAMPLE_RATE
        x = np.frombuffer(speech, dtype=np.int16).astype(np.float64)
        ms = float(np.mean(x**2)) if len(x) else 0.0
        self._utt_ms.append(ms)
        length = self._utt_t - self._utt_start
        max_s = self.options.max_utterance_s
        # A long utterance is cut in a gap between words where possible: in its last
        # CUT_SEARCH_S before the limit, at the first frame as quiet as its quietest 15 %.
        if length >= max_s or (
            length >= max_s - CUT_SEARCH_S
            and len(self._utt_ms) >= 20
            and ms <= float(np.percentile(self._utt_ms, 15))
        ):
            self._end_utterance(self._utt_t)  # the span goes on: still speech

    def _end_utterance(self, end: float) -> None:
        t0 = self._utt_start
        pcm = np.frombuffer(b"".join(self._utt_pcm), dtype=np.int16)
        t1 = t0 + len(pcm) / SAMPLE_RATE
        if t1 - t0 >= self.options.min_speech_s and self._utterance_voiced(t0, t1) < (
            MIN_VOICED_SHARE
        ):
            # Noise the voice-activity detector took for speech: as talk time, with its
            # made-up words and the syllable peaks of low-frequency noise (brown noise gave 2.4
            # a second), it would count in the word window after it (after 30 s of noise a
            # 175 wpm talk read 84-133 wpm, clarity 0.65 and `articulate`). It is a pause
            # instead, and not decoded, so the recogniser does not adapt to it either. Only
            # from min_speech_s: on the corpus only clicks and breaths (at most 0.6 s a file)
            # have under 1 % voiced frames, and they are left as they were.
            self._noise_utts.append((t0, t1))
            self._utt_pcm = []
            self._utt_ms = []
            self._in_utt = False
            self._utt_start = end
            return
        nuclei = syllable_nuclei(pcm)
        self._recent.append((len(pcm) / SAMPLE_RATE, len(nuclei)))
        frate = self._set_frame_rate()
        self._dec.start_utt()
        self._dec.process_raw(pcm.tobytes(), False, False)
        self._dec.end_utt()
        segs = list(self._dec.seg() or ())
        dur = len(pcm) / SAMPLE_RATE
        words_end = max((_seg_end(seg, frate) for seg in segs if _is_word(seg.word)), default=0.0)
        if dur >= 1.0 and np.sum(nuclei > words_end + 0.1) >= MIN_UNDECODED_SYLLABLES:
            # pocketsphinx's search can end mid-word and then returns no hypothesis, or only
            # the words before the last word it could end (seen on whole 10 s stretches of
            # fast speech, and on a 7 s utterance whose last 13 words were lost): where
            # syllables follow the last word, decode it again with a little quiet after it,
            # so that the last word can end, and keep the longer reading. Streamed (full_utt
            # False) like every other utterance: pocketsphinx 5.1.1's batch mode regrows its
            # feature buffer but not the frame positions beside it, and the next utterance
            # then writes past their end (a segfault, acmod_process_full_cep).
            pad = (self._pad_rng.standard_normal(int(0.3 * SAMPLE_RATE)) * 3.0).astype(np.int16)
            self._dec.start_utt()
            self._dec.process_raw(np.concatenate([pcm, pad]).tobytes(), False, False)
            self._dec.end_utt()
            again = [seg for seg in self._dec.seg() or () if seg.start_frame / frate < dur]
            if sum(_is_word(g.word) for g in again) > sum(_is_word(g.word) for g in segs):
                segs = again
        for seg in segs:
            w = seg.word
            if not _is_word(w):
                continue
            # Segment.prob is already a linear posterior (do not exp() it).
            prob = float(min(1.0, max(0.0, seg.prob)))
            start, stop = t0 + seg.start_frame / frate, t0 + _seg_end(seg, frate)
            word = Word(start, stop, w, prob)
            if self.options.other_voices:  # its level and pitch: only that rule reads them
                word = Word(
                    start, stop, w, prob, self._peak_db(start, stop), self._word_pitch(start, stop)
                )
            if self.word_log is not None:
                self.word_log.append(word)
            self._words.append(word)
            self._n_words += 1
            self._p_sum += prob
        for s in nuclei:
            self._syllables.append(t0 + float(s))
            self._n_syl += 1
        self._utt_pcm = []
        self._utt_ms = []
        self._in_utt = False
        self._utt_start = end

    def _set_frame_rate(self) -> float:
        """Set the decoder's frame rate for the utterance about to be decoded; return it.

        Rate normalisation: the acoustic model's phones have a minimum length in frames and
        the search a preferred word length, so at a fixed 100 frames/s pocketsphinx inserts
        words into slow speech and drops words from fast speech (up to +19 % at 110 wpm and
        -15 % at 210 wpm on the corpus's espeak-ng voices). The frame rate is scaled with the
        speaker's recent syllable rate (nuclei per second of utterance over the last
        :data:`RATE_HISTORY_S`, this utterance included), so that every speaker reaches the
        model at about :data:`REFERENCE_SYLLABLE_RATE`.
        """
        # Keep the fewest latest utterances that cover RATE_HISTORY_S (all, if they do not).
        recent = self._recent
        while len(recent) > 1 and sum(d for d, _ in recent) - recent[0][0] >= RATE_HISTORY_S:
            recent.popleft()
        dur = sum(d for d, _ in reversed(recent))
        n = float(sum(k for _, k in recent))
        frate = 100.0
        if dur >= MIN_RATE_HISTORY_S and n > 0:
            # A rate from a few seconds of speech is a rough guess: the scaling is trusted in
            # proportion to the speech heard, in full from RATE_FULL_TRUST_S.
            trust = min(1.0, dur / RATE_FULL_TRUST_S)
            ratio = (n / dur) / REFERENCE_SYLLABLE_RATE
            frate = 100.0 * ratio ** (FRAME_RATE_EXPONENT * trust)
        lo, hi = FRAME_RATE_RANGE
        frate = float(min(hi, max(lo, FRAME_RATE_STEP * round(frate / FRAME_RATE_STEP))))
        if frate != self._frate:
            # reinit_feat resets the cepstral mean to the model's initial one: keep the mean
            # learnt so far (the frame rate does not change it), or each change of rate would
            # decode the next utterance against the wrong mean.
            cmn = self._dec.get_cmn()
            self._dec.config["frate"] = int(frate)
            self._dec.reinit_feat()
            self._dec.set_cmn(cmn)
            self._frate = frate
        return frate

    def _close_span(self, end: float) -> None:
        if self._span_start is not None and end > self._span_start:
            self._spans.append((self._span_start, end))
            self._speech_s += end - self._span_start
        self._span_start = None

    def _finalised_until(self) -> float:
        """Input time before which every word, syllable and speech span is known."""
        if self._in_utt or self._ep.in_speech:
            return self._utt_start
        # Out of speech the endpointer may still open a span up to its window back.
        return self._n_frames * _FRAME_S - 0.3 - 2 * _FRAME_S

    # ---- windows -----------------------------------------------------------------------

    def _emit(self, until: float) -> list[Sample]:
        out: list[Sample] = []
        while self._next_t <= until + 1e-9:
            out += self._window(self._next_t)
            self._last_t = self._next_t
            self._next_t += self.options.hop_s
            # The word window ends where every word is known (_finalised_until), up to
            # max_utterance_s before the output time, and reaches back lookback_s from there:
            # prune from that end, not from the output time, or a window reaching back across a
            # long pause counts talk time whose words are gone (session 23: a 60 s pause, the
            # same window read 67 words, then 60, 120 wpm for a 158 wpm reader).
            reach = min(self._next_t, max(0.0, self._finalised_until()))
            self._prune(reach - self._lookback_s, self._next_t - self.options.window_s)
        return out

    def _prune(self, lo: float, lo_audio: float) -> None:
        while self._words and self._words[0].end <= lo:
            self._words.popleft()
        while self._spans and self._spans[0][1] <= lo:
            self._spans.popleft()
        while self._noise_utts and self._noise_utts[0][1] <= lo:
            self._noise_utts.popleft()
        while self._syllables and self._syllables[0] < lo:
            self._syllables.popleft()
        keep_from = max(0, int(lo_audio * SAMPLE_RATE) - self._ring_start)
        if keep_from > SAMPLE_RATE:  # trim in chunks, not every hop
            self._ring = self._ring[keep_from:]
            self._ring_start += keep_from

    def _talk_window(self, t: float, spans: list[tuple[float, float]]) -> tuple[float, float]:
        """The word window ending at ``t``: its start and the talk time in it.

        Walks back from ``t`` over speech spans and pauses, a pause counting at most
        ``max_pause_s``, until ``word_window_s`` of talk is found or the look-back ends; the
        talk time is less than ``word_window_s`` only in the latter case. Where in a long pause
        a start falls does not matter: no words or syllables lie in pauses. A pause counts only
        between two stretches of speech the window holds: the silence between the look-back's
        end (the input's start, or ``t`` minus the look-back) and the window's first speech
        precedes no talk of this window, so it is not talk time (counted as 2 s, it read a
        158 wpm reader 14-18 % low after 20 s of silence or a 100 s pause, session 23).
        """
        want, cap = self.options.word_window_s, self.options.max_pause_s
        floor = max(0.0, t - self._lookback_s)
        talk, cursor = 0.0, t
        for a, b in reversed(spans):
            a, b = max(a, floor), min(b, t)
            if b <= a:
                continue
            gap = max(0.0, cursor - b)
            if talk + min(gap, cap) >= want:
                return max(b, cursor - (want - talk)), want
            talk += min(gap, cap)
            if talk + (b - a) >= want:
                return b - (want - talk), want
            talk += b - a
            cursor = a
        return floor, talk

    def _window(self, t: float, *, final: bool = False) -> list[Sample]:
        """The samples of the window ending at ``t``.

        The levels cover the audio up to ``t``. The word-based metrics cover the word window
        ending where every word is known (:meth:`_finalised_until`, at most about
        ``max_utterance_s`` before ``t`` in continuous speech): written at ``t``, they describe
        talk that ended up to that much earlier, rather than being held back (which made the
        live output come in bursts up to 11 s apart).
        """
        opt = self.options
        lo = max(0.0, t - opt.window_s)
        dur = t - lo
        spans = list(self._spans)
        if self._span_start is not None:
            spans.append((self._span_start, t))
        if self._noise_utts:
            spans = _cut(spans, self._noise_utts)
        speech_s = sum(_overlap(a, b, lo, t) for a, b in spans)
        if dur <= 0:
            return []
        voiced = self._share(self._frame_voiced, lo, t, spans) if speech_s > 0 else 0.0
        heard = voiced >= MIN_VOICED_SHARE  # voice activity that is a voice
        out = [Sample(SPEECH_ACTIVITY, t, min(1.0, speech_s / dur) if heard else 0.0)]
        if speech_s < min(opt.min_speech_s, 0.5 * dur):
            # inside a stretch of sound without a voice (the detector fires on noise now and
            # then), a window it left alone is that stretch still, not the presenter's pause
            return [_untimed(t, Untimed.NO_VOICE if self._voiceless else Untimed.PAUSE), *out]
        if not heard:
            # Sound without a voice in it (noise, a fan, music without singing, a whisper):
            # not voiced speech, so neither quiet nor unclear nor slow speech. Said once per
            # stretch of it.
            if not self._voiceless:
                steady = self._share(self._frame_steady, lo, t, spans)
                what = (
                    f"a steady hum or tone ({100 * steady:.0f} % of it holds one pitch for "
                    f"{STEADY_PITCH_S:g} s or more)"
                    if steady >= 0.5
                    else "noise, music or a whisper (it has no pitch)"
                )
                log.warning(
                    "t=%.0f s: no voice heard: the voice-activity detector hears sound, but "
                    "%.1f %% of it is voiced (under %g %%): %s, not a voice; only "
                    "speech_activity (0) is written until a voice is heard",
                    t,
                    100 * voiced,
                    100 * MIN_VOICED_SHARE,
                    what,
                )
                self._voiceless = True
            return [_untimed(t, Untimed.NO_VOICE), Sample(SPEECH_ACTIVITY, t, 0.0)]
        if self._voiceless:
            log.info("t=%.0f s: a voice is heard again (%.0f %% voiced)", t, 100 * voiced)
            self._voiceless = False
        level = self._active_dbfs(lo, t, spans)
        if level is not None:
            out.append(Sample(SPEECH_VOLUME, t, level + opt.calibration_db))
        lufs = self._lufs(lo, t)
        if lufs is not None:
            out.append(Sample(SPEECH_LOUDNESS, t, lufs))
        words_until = t if final else min(t, max(0.0, self._finalised_until()))
        if not final and self._before_a_long_pause(t, words_until, spans):
            out.append(_untimed(t, Untimed.AFTER_PAUSE))
            return sorted(out, key=lambda smp: _ORDER[smp.metric])
        out += self._word_samples(t, words_until, spans, final=final)
        return sorted(out, key=lambda smp: _ORDER[smp.metric])

    def _before_a_long_pause(
        self, t: float, words_until: float, spans: list[tuple[float, float]]
    ) -> bool:
        """Whether every word known yet was said before a pause of ``window_s`` or more that
        the speaker has since broken: the word-based metrics then wait for the new words.

        While a pause lasts that long nothing is written (the window holds too little speech),
        and the word window is counted in talk time; so on resuming, the first values would be
        the pace from before the pause stamped now (session 20: a speaker at 193 wpm before a
        40 s pause read 193 for the first 6 s of a new speaker at 158, and a `slowDown` came).
        """
        # the stretch of speech going on past the known words, and the pause before it
        cur = next((a for a, b in spans if b > words_until + 1e-9), None)
        before = [b for _, b in spans if cur is not None and b <= cur + 1e-9]
        pause = cur - max(before) if cur is not None and before else 0.0
        # no word of that stretch known yet (its first utterance is not decoded: a cut
        # utterance later in a stretch leaves the known words inside it)
        fresh = cur is not None and words_until <= cur + _NEW_STRETCH_S
        if not (fresh and pause >= self.options.window_s - 1e-9):
            self._resumed_at = None
            return False
        if self._resumed_at is None:
            self._resumed_at = t
            log.info(
                "t=%.0f s: speech again after a %.0f s pause: speech_speed, articulation and "
                "clarity wait for its first words (the last ones were said before the pause)",
                t,
                pause,
            )
        return True

    def _word_samples(
        self, t_out: float, t: float, spans: list[tuple[float, float]], *, final: bool
    ) -> list[Sample]:
        """speech_speed and the other word-based metrics over the word window ending at ``t``,
        stamped ``t_out``.

        Nothing before ``window_s`` of talk has been heard, except at the end of the input.
        """
        opt = self.options
        lo, talk_s = self._talk_window(t, spans)
        if talk_s < MIN_WORD_TALK_S or (
            talk_s < min(opt.window_s, opt.word_window_s) - 1e-9 and not final
        ):
            return [_untimed(t_out, Untimed.TOO_LITTLE_TALK)]
        voiced_s = sum(_overlap(a, b, lo, t) for a, b in spans)
        n_asr = 0.0
        p_sum = 0.0
        covered = 0.0
        # Words far under the speaker's level are someone else's (people talking behind the
        # presenter; the recogniser gives their words in the presenter's pauses): not counted,
        # and where there are many of them the pace is not written (see OTHER_VOICE_GAP_DB).
        # Only with --other-voices (off by default: a lone presenter's quieter, lower endings
        # are taken for other voices too); without it no word is left out.
        ref = self._ref_db(lo, t, spans) if opt.other_voices else math.inf
        lo_st, hi_st = (
            self._pitch_range(lo, t, spans, ref) if opt.other_voices else (-math.inf, math.inf)
        )
        others = 0
        for w in self._words:
            if w.start >= t:
                break
            inside = _overlap(w.start, w.end, lo, t)
            if inside <= 0.0:
                continue
            gap = ref - w.peak_db
            # a word with no voiced frame has no pitch to tell: counted
            if (
                opt.other_voices
                and gap > OTHER_VOICE_GAP_DB
                and not (math.isnan(w.pitch_st) or lo_st <= w.pitch_st <= hi_st)
            ):
                if gap <= OTHER_VOICE_FLOOR_DB:
                    others += 1
                continue
            f = inside / max(w.end - w.start, 1e-3)
            n_asr += f
            p_sum += f * w.prob
            covered += inside
        other_voices = others >= MIN_OTHER_VOICE_WORDS
        n_syl = sum(1 for s in self._syllables if lo <= s < t)
        mean_post = p_sum / n_asr if n_asr > 0 else 0.0
        spoken = max(n_asr, n_syl / opt.syllables_per_word)
        coverage = covered / voiced_s if voiced_s > 0 else 0.0
        snr = self._snr_db(lo, t)
        band = self._band_db(lo, t)
        clipped = self._clipped(lo, t)
        source = self._choose_source(mean_post, coverage, snr)
        edge = self._edge_db(lo, t)
        narrowband = (
            edge is not None
            and edge <= NARROWBAND_EDGE_DB
            and band is not None
            and band >= CLEAN_SIGNAL_BAND_DB
        )
        if narrowband and source == SOURCE_RECOGNISER:
            # telephone audio: the recogniser's count is no count (see NARROWBAND_EDGE_DB)
            source = SOURCE_SYLLABLES if snr >= MIN_SYLLABLE_SNR_DB else SOURCE_NONE
        if clipped > MAX_CLIPPED_SHARE:
            source = SOURCE_NONE
            self.clipped_windows.append((t_out, clipped))
        if other_voices:
            source = SOURCE_NONE
        # Noise without a voice in or just before the word window: the utterances that join
        # it to the speech (up to max_utterance_s each) hold noise counted as talk time, so a
        # 175 wpm talk read 88-114 wpm just after 25 s of noise. No speed until it is out.
        reach = lo - opt.max_utterance_s
        near_noise = any(a < t + opt.max_utterance_s and b > reach for a, b in self._noise_utts)
        if near_noise:
            source = SOURCE_NONE
        if self.window_log is not None:
            self.window_log.append(
                {
                    "t": t_out,
                    "from": lo,
                    "until": t,
                    "talk_s": talk_s,
                    "voiced_s": voiced_s,
                    "n_asr": n_asr,
                    "n_syl_words": n_syl / opt.nuclei_per_word,
                    "mean_post": mean_post,
                    "coverage": coverage,
                    "snr_db": snr,
                    "band_db": band if band is not None else math.nan,
                    "edge_db": edge if edge is not None else math.nan,
                    "clipped": clipped,
                    "source": source,
                    "ref_db": ref,
                    "other_words": others,
                }
            )
        if source != self._last_source:
            if source == SOURCE_NONE and near_noise:
                log.warning(
                    "t=%.0f s: speech speed cannot be measured (noise without a voice in or "
                    "next to the last %.0f s of talk would count as talk time): speech_speed "
                    "and speech_articulation are not written until it is out of the window",
                    t_out,
                    opt.word_window_s,
                )
            elif source == SOURCE_NONE and clipped > MAX_CLIPPED_SHARE:
                log.warning(
                    "t=%.0f s: speech speed cannot be measured (the recording is clipped: "
                    "%.0f %% of the speech samples at or near full scale; record with less "
                    "input gain or farther from the microphone): speech_speed and "
                    "speech_articulation are not written until it can",
                    t_out,
                    100 * clipped,
                )
            elif source == SOURCE_NONE and other_voices:
                log.warning(
                    "t=%.0f s: speech speed cannot be measured (other voices near yours: %d "
                    "recognised words in the last %.0f s of talk lie %g-%g dB under your "
                    "speech, at another pitch than yours: someone else talking, and the count "
                    "cannot be told apart from theirs): "
                    "speech_speed and speech_articulation are not written until they are out of "
                    "the window",
                    t_out,
                    others,
                    opt.word_window_s,
                    OTHER_VOICE_GAP_DB,
                    OTHER_VOICE_FLOOR_DB,
                )
            elif source == SOURCE_NONE:
                # only the checks that failed: a posterior of 0.80 is no reason to say unsure
                doubts = []
                if mean_post < MIN_RELIABLE_POSTERIOR:
                    doubts.append(
                        f"mean word posterior {mean_post:.2f} (under {MIN_RELIABLE_POSTERIOR:g})"
                    )
                if coverage < MIN_WORD_COVERAGE:
                    doubts.append(
                        f"its words cover {100 * coverage:.0f} % of the voice "
                        f"(under {100 * MIN_WORD_COVERAGE:.0f} %)"
                    )
                if snr < MIN_RECOGNISER_SNR_DB:
                    doubts.append(f"SNR under its {MIN_RECOGNISER_SNR_DB:g} dB")
                if narrowband:
                    doubts.append(self._narrowband_reason(edge))
                log.warning(
                    "t=%.0f s: speech speed cannot be measured (too much noise for the syllable "
                    "count: estimated SNR %.0f dB, under %g dB; recogniser not trusted: %s): "
                    "speech_speed and speech_articulation are not written until it can",
                    t_out,
                    snr,
                    MIN_SYLLABLE_SNR_DB,
                    ", ".join(doubts),
                )
            elif source == SOURCE_SYLLABLES and narrowband:
                log.warning(
                    "t=%.0f s: speech speed from the syllable nuclei, not the recogniser: %s",
                    t_out,
                    self._narrowband_reason(edge),
                )
            else:
                log.info(
                    "t=%.0f s: speech speed from the %s (mean word posterior %.2f, words "
                    "cover %.0f %% of the voice, estimated SNR %.0f dB)",
                    t_out,
                    "recogniser" if source == SOURCE_RECOGNISER else "syllable nuclei",
                    mean_post,
                    100 * coverage,
                    snr,
                )
            self._last_source = source
        out = [
            Sample(SPEECH_SPEED_SYLLABLES, t_out, n_syl / opt.nuclei_per_word / talk_s * 60.0),
            Sample(SPEECH_SPEED_SOURCE, t_out, source),
            Sample(SPEECH_SNR, t_out, snr),
        ]
        # why no speed, or one from syllables: the first that applies, as the log says it
        why = (
            Untimed.NOISE_NEAR
            if near_noise
            else Untimed.CLIPPED
            if clipped > MAX_CLIPPED_SHARE
            else Untimed.OTHER_VOICES
            if other_voices
            else Untimed.NOISY
            if source == SOURCE_NONE
            else Untimed.NARROWBAND
            if source == SOURCE_SYLLABLES and narrowband
            else Untimed.UNSURE
            if source == SOURCE_SYLLABLES
            else None
        )
        if why is not None:
            out.append(_untimed(t_out, why))
        if source == SOURCE_RECOGNISER:
            words = n_asr
            # Per-speaker calibration of the syllable count, from the windows the recogniser
            # is trusted in (for later fallbacks; this voice's syllables per word).
            self._cal_words += n_asr
            self._cal_syl += n_syl
            # Speaking time = the time the words cover (pocketsphinx marks pauses as <sil>).
            speaking_s = covered
        elif source == SOURCE_SYLLABLES:
            words = n_syl / self._syllables_per_word()
            speaking_s = voiced_s
        else:
            words = speaking_s = 0.0
        if source != SOURCE_NONE:
            out.append(Sample(SPEECH_SPEED, t_out, words / talk_s * 60.0))
        if speaking_s > 0 and source != SOURCE_NONE:
            out.append(Sample(SPEECH_ARTICULATION, t_out, words / speaking_s * 60.0))
        if spoken > 0:
            confidence = min(1.0, p_sum / spoken)
            clean = snr >= CLEAN_SIGNAL_SNR_DB and band is not None and band >= CLEAN_SIGNAL_BAND_DB
            accuracy = min(1.0, confidence + CLEAN_SIGNAL_CREDIT) if clean else confidence
            out.append(Sample(SPEECH_ACCURACY, t_out, accuracy))
            out.append(Sample(SPEECH_CONFIDENCE, t_out, confidence))
            out.append(Sample(SPEECH_CLARITY, t_out, clarity_score(accuracy)))
        return out

    def _syllables_per_word(self) -> float:
        """This speaker's syllable nuclei per word, learnt while the recogniser was trusted
        (at least :data:`MIN_CALIBRATION_SYLLABLES` nuclei), else the prior."""
        if self._cal_syl >= MIN_CALIBRATION_SYLLABLES and self._cal_words > 0:
            return float(min(2.5, max(0.8, self._cal_syl / self._cal_words)))
        return self.options.nuclei_per_word

    @staticmethod
    def _narrowband_reason(edge: float | None) -> str:
        """Why a narrowband window's recogniser count is not trusted, for the log."""
        return (
            f"the audio is narrowband, a telephone line or an 8 kHz recording (the speech "
            f"above {NARROWBAND_ABOVE_HZ[0] / 1000:g} kHz is {-(edge or 0.0):.0f} dB under that "
            f"in {NARROWBAND_REFERENCE_HZ[0] / 1000:g}-{NARROWBAND_REFERENCE_HZ[1] / 1000:g} kHz,"
            f" more than {-NARROWBAND_EDGE_DB:g} dB): the recogniser misses or makes up words "
            "there with confident posteriors, so its word count is not trusted"
        )

    @staticmethod
    def _choose_source(mean_post: float, coverage: float, snr_db: float) -> float:
        """Which count speech_speed uses in a window: the rule of the module doc."""
        if (
            mean_post >= MIN_RELIABLE_POSTERIOR
            and coverage >= MIN_WORD_COVERAGE
            and snr_db >= MIN_RECOGNISER_SNR_DB
        ):
            return SOURCE_RECOGNISER
        if snr_db >= MIN_SYLLABLE_SNR_DB:
            return SOURCE_SYLLABLES
        return SOURCE_NONE

    def _frames(self, lo: float, t: float) -> tuple[int, int]:
        """The indices ``i0, i1`` of the 30 ms frames of ``[lo, t)`` analysed so far (every
        per-frame list is as long as ``_frame_ms``)."""
        return int(lo / _FRAME_S), min(len(self._frame_ms), int(math.ceil(t / _FRAME_S)))

    def _loud(self, i0: int, i1: int) -> np.ndarray:
        """Indices (from ``i0``) of the frames ``i0 .. i1 - 1`` within 30 dB of their 95th
        percentile: the speech, not the pauses, as for the volume."""
        db = 10.0 * np.log10(np.asarray(self._frame_ms[i0:i1]) + 1.0)
        return np.flatnonzero(db >= np.percentile(db, 95) - 30.0)

    def _snr_db(self, lo: float, t: float) -> float:
        """Estimated SNR of ``[lo, t)``: loud (p90) over quiet (p10) 30 ms frames, in dB.

        In speech with no pause the quiet frames are the speech's own weak sounds, so this
        under-reads clean speech (still >= 20 dB on the corpus); it is only meant to tell
        whether syllable peaks stand out of the noise.
        """
        i0, i1 = self._frames(lo, t)
        if i1 - i0 < 10:
            return 0.0
        ms = np.asarray(self._frame_ms[i0:i1]) + 1.0  # +1: int16 rounding floor
        p10, p90 = np.percentile(ms, [10, 90])
        return float(10.0 * np.log10(p90 / p10))

    def _ref_db(self, lo: float, t: float, spans: list[tuple[float, float]]) -> float:
        """The speaker's level over ``[lo, t)``: the 95th percentile of the levels of its 30 ms
        frames of voice activity (so silence in the window does not move it), dB (int16
        scale; 0 without such frames)."""
        i0, i1 = self._frames(lo, t)
        if i1 <= i0:
            return 0.0
        ms = np.asarray(self._frame_ms[i0:i1])[_in_spans(i0, i1, spans)]
        if len(ms) == 0:
            return 0.0
        return float(np.percentile(10.0 * np.log10(ms + 1.0), 95))

    def _band_db(self, lo: float, t: float) -> float | None:
        """Energy in 1.5-4 kHz over that in 0.1-1 kHz (dB) of the loud frames of ``[lo, t)``
        (within 30 dB of the 95th percentile, as for the volume); None without frames."""
        i0, i1 = self._frames(lo, t)
        if i1 - i0 < 10:
            return None
        bands = np.asarray(self._frame_bands[i0:i1])[self._loud(i0, i1)]
        low, high = float(bands[:, 0].sum()), float(bands[:, 1].sum())
        return 10.0 * math.log10((high + 1e-9) / (low + 1e-9))

    def _edge_db(self, lo: float, t: float) -> float | None:
        """Median :func:`edge_db` of the loud frames of ``[lo, t)`` (within 30 dB of the 95th
        percentile, as for the volume): how far the speech above the telephone band lies under
        that inside it; None without frames."""
        i0, i1 = self._frames(lo, t)
        if i1 - i0 < 10:
            return None
        return float(np.median(np.asarray(self._frame_edge[i0:i1])[self._loud(i0, i1)]))

    def _clipped(self, lo: float, t: float) -> float:
        """Share of clipped samples in the loud frames of ``[lo, t)`` (those within 30 dB of
        the 95th percentile, as for the volume): 0 without frames."""
        i0, i1 = self._frames(lo, t)
        if i1 - i0 < 10:
            return 0.0
        return float(np.mean(np.asarray(self._frame_clipped[i0:i1])[self._loud(i0, i1)]))

    def _pitch_range(
        self, lo: float, t: float, spans: list[tuple[float, float]], ref: float
    ) -> tuple[float, float]:
        """The presenter's pitch over ``[lo, t)``, widened by :data:`OTHER_VOICE_PITCH_ST` on
        each side: the 5th and 95th percentiles of the pitch (semitones above 100 Hz) of its
        voiced frames of voice activity within :data:`OTHER_VOICE_LOUD_DB` of ``ref``;
        (-inf, inf), every pitch the presenter's, with fewer than :data:`MIN_PITCH_FRAMES`."""
        i0, i1 = self._frames(lo, t)
        if i1 <= i0:
            return -math.inf, math.inf
        st = np.asarray(self._frame_st[i0:i1])
        db = 10.0 * np.log10(np.asarray(self._frame_ms[i0:i1]) + 1.0)
        keep = (
            _in_spans(i0, i1, spans)
            & np.asarray(self._frame_voiced[i0:i1], dtype=bool)
            & (db >= ref - OTHER_VOICE_LOUD_DB)
            & ~np.isnan(st)
        )
        if np.count_nonzero(keep) < MIN_PITCH_FRAMES:
            return -math.inf, math.inf
        p5, p95 = np.percentile(st[keep], [5, 95])
        return float(p5) - OTHER_VOICE_PITCH_ST, float(p95) + OTHER_VOICE_PITCH_ST

    def _word_pitch(self, t0: float, t1: float) -> float:
        """Median pitch of the voiced frames of ``[t0, t1)``, semitones above 100 Hz (NaN
        without one)."""
        i0, i1 = self._frames(t0, t1)
        st = np.asarray(self._frame_st[i0:i1])
        st = st[np.asarray(self._frame_voiced[i0:i1], dtype=bool) & ~np.isnan(st)]
        return float(np.median(st)) if len(st) else math.nan

    def _peak_db(self, t0: float, t1: float) -> float:
        """Level of the loudest 30 ms frame of ``[t0, t1)``, dB (int16 scale)."""
        i0, i1 = self._frames(t0, t1)
        if i1 <= i0:
            i1 = min(len(self._frame_ms), i0 + 1)
        if i1 <= i0:
            return 0.0
        return 10.0 * math.log10(max(self._frame_ms[i0:i1]) + 1.0)

    def _utterance_voiced(self, t0: float, t1: float) -> float:
        """Share of the frames of ``[t0, t1)`` that are voiced (1.0 when none is known yet)."""
        i0, i1 = self._frames(t0, t1)
        if i1 <= i0:
            return 1.0
        return float(np.count_nonzero(self._frame_voiced[i0:i1])) / (i1 - i0)

    def _share(
        self, flags: list[bool], lo: float, t: float, spans: list[tuple[float, float]]
    ) -> float:
        """Share of the voice-activity frames of ``[lo, t)`` whose per-frame flag is set
        (``_frame_voiced``: periodic; ``_frame_steady``: in a steady run of one pitch, a hum or
        a tone); 0 without such frames."""
        i0, i1 = self._frames(lo, t)
        if i1 <= i0:
            return 0.0
        in_speech = _in_spans(i0, i1, spans)
        n = int(np.count_nonzero(in_speech))
        if n == 0:
            return 0.0
        return float(np.count_nonzero(np.asarray(flags[i0:i1], dtype=bool) & in_speech)) / n

    def _active_dbfs(self, lo: float, t: float, spans: list[tuple[float, float]]) -> float | None:
        i0, i1 = self._frames(lo, t)
        if i1 <= i0:
            return None
        ms = np.asarray(self._frame_ms[i0:i1])
        ms = ms[_in_spans(i0, i1, spans) & (ms > 0)]
        if len(ms) == 0:
            return None
        db = 10.0 * np.log10(ms)
        active = ms[db >= np.percentile(db, 95) - 30.0]
        return float(10.0 * np.log10(np.mean(active) / 32768.0**2))

    def _lufs(self, lo: float, t: float) -> float | None:
        if self._meter is None:
            return None
        a = max(0, int(lo * SAMPLE_RATE) - self._ring_start)
        b = max(0, int(t * SAMPLE_RATE) - self._ring_start)
        x = self._ring[a:b].astype(np.float64) / 32768.0
        if len(x) < int(0.4 * SAMPLE_RATE):
            return None
        v = float(self._meter.integrated_loudness(x))
        return v if math.isfinite(v) else None


def _untimed(t: float, why: Untimed) -> Sample:
    """A ``speech_untimed_reason`` sample: why no speed was written at ``t``."""
    return Sample(SPEECH_UNTIMED_REASON, t, float(why))


def _cut(
    spans: list[tuple[float, float]], holes: Iterable[tuple[float, float]]
) -> list[tuple[float, float]]:
    """``spans`` without the intervals ``holes`` (both sorted by time)."""
    out = spans
    for h0, h1 in holes:
        nxt: list[tuple[float, float]] = []
        for a, b in out:
            if b <= h0 or a >= h1:
                nxt.append((a, b))
                continue
            if a < h0:
                nxt.append((a, h0))
            if b > h1:
                nxt.append((h1, b))
        out = nxt
    return out


def _in_spans(i0: int, i1: int, spans: list[tuple[float, float]]) -> np.ndarray:
    """Which of the 30 ms frames ``i0 .. i1 - 1`` lie (by their centre) in a speech span."""
    centres = (np.arange(i0, i1) + 0.5) * _FRAME_S
    inside = np.zeros(i1 - i0, bool)
    for a, b in spans:
        inside |= (centres >= a) & (centres < b)
    return inside


def _clipped_share(x: np.ndarray) -> float:
    """Share of the int16 samples of ``x`` at or above :data:`CLIPPED_LEVEL` of full scale."""
    if len(x) == 0:
        return 0.0
    return float(np.count_nonzero(np.abs(x.astype(np.int32)) >= CLIPPED_LEVEL * 32767) / len(x))


def analyse(
    blocks: Iterable[np.ndarray], options: SpeechOptions, *, loudness: bool = True
) -> tuple[list[Sample], SpeechTotals]:
    """Analyse a whole input (blocks of 16 kHz mono int16); return its samples and totals."""
    an = SpeechAnalyser(options, loudness=loudness)
    out: list[Sample] = []
    for b in blocks:
        out += an.feed(b)
    out += an.finish()
    return out, an.totals()


#: The session folder's record of how this module measures (read by
#: :func:`prezence.summary.estimate_notes`): the volume is an estimate until calibrated.
STATUS_FILE = "speech.json"


def write_status(
    out: Path, *, calibrated: bool, calibration_db: float, language: str = "en"
) -> None:
    """Write ``out/speech.json``: which metrics are estimates and why, and which are not
    measured and why (``off``: a talk not in English), so the report and the printed table
    say so next to the figures, not only ``speech.log``."""
    import json

    off = (
        {}
        if is_english(language)
        else {m: language_why(language) for m in METRICS if m in LANGUAGE_METRICS}
    )
    estimate = {}
    if not calibrated:
        estimate[SPEECH_VOLUME] = (
            f"an estimate: the microphone is not calibrated (dBFS + {calibration_db:g}, a rough "
            "guess for a laptop microphone; --calibration-db sets it, see docs/modules.md)"
        )
    status: dict[str, object] = {
        "format": 1,
        "calibration_db": calibration_db,
        "language": language,
        "estimate": estimate,
    }
    if off:
        status["off"] = off
    Path(out).mkdir(parents=True, exist_ok=True)
    (Path(out) / STATUS_FILE).write_text(json.dumps(status, indent=1) + "\n")


def record_clipping(out: Path, windows: list[tuple[float, float]], offset: float) -> None:
    """Add ``clipped`` to ``out/speech.json``: the word windows too clipped to count, so the
    report can say "the recording is clipped: record with less input gain" from a record, not
    from the wording of a log line. A missing or torn status file is left alone (the log still
    says it)."""
    import json

    path = Path(out) / STATUS_FILE
    try:
        status = json.loads(path.read_text())
    except (OSError, ValueError):
        return
    if not isinstance(status, dict):
        return
    status["clipped"] = {
        "first_s": round(offset + windows[0][0], 3),
        "windows": len(windows),
        "max_share": round(max(share for _, share in windows), 4),
    }
    try:
        path.write_text(json.dumps(status, indent=1) + "\n")
    except OSError as e:
        log.warning("could not write %s: %s", path, e)


def run(
    source: AudioSource,
    out: Path,
    options: SpeechOptions,
    *,
    t_offset: float | Callable[[], float] = 0.0,
    fresh: bool,
    stop: threading.Event | None = None,
    language: str = "en",
) -> SpeechTotals:
    """Analyse ``source`` and append its samples to the session's stream files.

    Args:
        source: a file or the microphone.
        out: the session folder.
        options: the analysis options.
        t_offset: seconds added to input time to get talk time (or a function giving it,
            called once the first block has arrived, for a live input).
        fresh: replace this module's old stream files (a file run again); else append.
        stop: set it to end a live input; the audio already captured is still analysed.
        language: the talk's language; for one not English (:func:`is_english`) the
            :data:`LANGUAGE_METRICS` are not written.

    Returns:
        The whole-input totals.

    Raises:
        ModuleInputError: the input cannot be read.
        InputCutShort: the file broke off before its end; raised after everything read has
            been analysed and written, the last window included.
        BackendUnavailable: pocketsphinx is missing.
    """
    an = SpeechAnalyser(options)
    heartbeat = Heartbeat()
    cpu0 = time.process_time()
    offset: float | None = None if callable(t_offset) else float(t_offset)
    last_warn = -math.inf
    behind_warned = False
    with StreamSet(out, METRICS, fresh=fresh) as streams:
        english = is_english(language)
        skip = frozenset() if english else LANGUAGE_METRICS

        def write(samples: list[Sample]) -> None:
            for s in samples:
                if not english and s.metric == SPEECH_SPEED_SOURCE:
                    # a word window: whatever else held, pace is not measured for the language
                    s = _untimed(s.t, Untimed.LANGUAGE)
                elif (
                    not english
                    and s.metric == SPEECH_UNTIMED_REASON
                    and s.value in WORD_WINDOW_REASONS
                ):
                    continue  # said by the language, from this window's source sample
                if s.metric not in skip:
                    streams.write(s.metric, (offset or 0.0) + s.t, s.value)

        cut: InputCutShort | None = None
        try:
            for block in source.blocks():
                heartbeat.beat()
                if offset is None and callable(t_offset):
                    offset = max(0.0, t_offset() - len(block) / SAMPLE_RATE)
                write(an.feed(block))
                behind = source.backlog_s
                if behind > BEHIND_WARN_S and an.duration_s - last_warn >= 10.0:
                    log.warning(
                        "falling behind real time: %.1f s of audio waiting (no audio is dropped)",
                        behind,
                    )
                    last_warn = an.duration_s
                    behind_warned = True
                elif behind_warned and behind < 0.5:
                    log.info("caught up with real time")
                    behind_warned = False
                if stop is not None and stop.is_set():
                    source.close()  # a live source ends after the audio it has captured
        except InputCutShort as e:
            cut = e  # a recording cut short: what was read is analysed to its last word
        write(an.finish())
    if an.clipped_windows:
        record_clipping(out, an.clipped_windows, offset or 0.0)
    totals = an.totals()
    cpu = time.process_time() - cpu0
    ratio = cpu / totals.duration_s if totals.duration_s > 0 else 0.0
    log.info(
        "%.1f s of audio, %.1f s of speech, %d words recognised (%.0f wpm by the recogniser's "
        "count, whether or not trusted: speech_speed_source says what was written), mean "
        "posterior %.2f; "
        "%.2f CPU s per audio s%s",
        totals.duration_s,
        totals.speech_s,
        totals.words,
        totals.wpm,
        totals.mean_posterior,
        ratio,
        " (slower than real time)" if ratio > 1.0 else "",
    )
    if cut is not None:
        raise cut
    return totals


def build_parser() -> argparse.ArgumentParser:
    """Return the parser of ``python -m prezence.modules.speech``."""
    p = argparse.ArgumentParser(
        prog="python -m prezence.modules.speech",
        description="Speech speed, articulation rate, volume and clarity from audio or the mic.",
    )
    p.add_argument(
        "--audio", required=True, help="an audio/video file (WAV, FLAC, MP3, MP4), or mic"
    )
    add_common_arguments(p)
    p.add_argument(
        "--window",
        type=float,
        default=10.0,
        help="level window (volume, loudness, voice activity), seconds (default %(default)s)",
    )
    p.add_argument(
        "--word-window",
        type=float,
        default=WORD_WINDOW_S,
        help="seconds of talk that speed, articulation and clarity count over "
        "(default %(default)s)",
    )
    p.add_argument(
        "--max-pause",
        type=float,
        default=MAX_PAUSE_S,
        help="a pause counts as at most this many seconds of talk (default %(default)s)",
    )
    p.add_argument(
        "--hop", type=float, default=CADENCE_S, help="seconds between lines (default %(default)s)"
    )
    p.add_argument(
        "--calibration-db",
        type=float,
        default=None,
        help=f"dB SPL = dBFS + this (default {DEFAULT_CALIBRATION_DB:g}, a rough guess)",
    )
    p.add_argument(
        "--language",
        default="en",
        help="the talk's language (default %(default)s); pace and clarity are measured for "
        "English only: for another language they are not written, and volume is",
    )
    p.add_argument(
        "--other-voices",
        action="store_true",
        help="other people talk near you: leave out quiet words at another pitch than yours "
        "(and leave the pace unwritten where there are many); off by default, as a lone "
        "speaker's quieter, lower sentence endings are taken for someone else's too",
    )
    p.add_argument("--device", default=None, help="mic: sounddevice device name or number")
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the module; return the exit status (0 done, 2 bad input or arguments)."""
    args = build_parser().parse_args(argv)
    setup_logging("speech", args)
    try:
        options = SpeechOptions(
            window_s=args.window,
            word_window_s=args.word_window,
            max_pause_s=args.max_pause,
            hop_s=args.hop,
            calibration_db=(
                DEFAULT_CALIBRATION_DB if args.calibration_db is None else args.calibration_db
            ),
            other_voices=args.other_voices,
        )
        source: FileSource | MicSource
        t_offset: float | Callable[[], float]
        if args.audio == "mic":
            device = int(args.device) if args.device and args.device.isdigit() else args.device
            source = MicSource(device=device)
            t0 = time.time() if args.t0 is None else args.t0
            t_offset = lambda: time.time() - t0  # noqa: E731 - evaluated at the first block
        else:
            resume = resume_offset(args)
            if resume:
                log.info("started %.1f s into the talk: the file continues from there", resume)
            source = FileSource(args.audio, realtime=args.realtime, start_s=resume)
            t_offset = resume
    except (ModuleInputError, ValueError) as e:
        return report_error("speech", e)
    if args.calibration_db is None:
        # a warning: `rehearse` and `up` run the module with -q, and the user must learn that
        # speech_volume is a guess before acting on "speak louder"
        log.warning(
            "volume is not calibrated: speech_volume = dBFS + %g is a rough guess "
            "(see --calibration-db)",
            DEFAULT_CALIBRATION_DB,
        )
    if not args.language.strip():
        return report_error(
            "speech", ValueError("--language is empty: give a tag such as en or de")
        )
    if not is_english(args.language):
        log.warning(
            "%s: speech_speed, speech_articulation and clarity are not written",
            language_why(args.language),
        )
    try:
        write_status(
            args.out,
            calibrated=args.calibration_db is not None,
            calibration_db=options.calibration_db,
            language=args.language,
        )
    except OSError as e:  # the streams will say what they can; the status is a courtesy
        log.warning("could not write %s: %s", Path(args.out) / STATUS_FILE, e)
    stop = threading.Event()

    def _on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _on_signal)
    try:
        run(
            source,
            args.out,
            options,
            t_offset=t_offset,
            fresh=args.audio != "mic",
            stop=stop,
            language=args.language,
        )
    except (PrezenceError, ValueError) as e:
        return report_error("speech", e)
    finally:
        source.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
