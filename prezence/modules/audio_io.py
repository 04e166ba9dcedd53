"""Audio input for the speech module: files (WAV, FLAC, MP3, MP4…) and the microphone.

Everything comes out as 16 kHz mono 16-bit PCM in numpy ``int16`` blocks, the format the
recogniser wants. Files are decoded with PyAV (``av``: ffmpeg inside the wheel), which reads all
of WAV, FLAC, MP3 and the audio track of MP4 with one dependency; soundfile (libsndfile) cannot
read MP4. The microphone is read with ``sounddevice`` (PortAudio) when it is installed.

No audio is ever dropped: a live source queues every block it captures, and the consumer reports
how far behind it is (:attr:`AudioSource.backlog_s`).
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Generator, Iterator
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from prezence.modules.common import InputCutShort, ModuleInputError

log = logging.getLogger(__name__)

#: The recogniser's sample rate (pocketsphinx's en-US model is 16 kHz).
SAMPLE_RATE = 16000
#: Samples per block handed to the consumer (0.1 s).
BLOCK = SAMPLE_RATE // 10


class AudioSource(Protocol):
    """A stream of 16 kHz mono int16 blocks."""

    name: str

    def blocks(self) -> Iterator[np.ndarray]:
        """Yield int16 blocks in order until the input ends (a live input runs until stopped)."""
        ...

    @property
    def backlog_s(self) -> float:
        """Seconds of audio captured but not yet taken by the consumer (0 for unpaced files)."""
        ...

    def close(self) -> None:
        """Stop capturing; safe to call twice."""
        ...


#: Containers whose index (MP4's moov) is written when the recording stops: a file cut off
#: before that cannot be opened at all.
_INDEXED_AT_THE_END = frozenset({".m4a", ".mp4", ".mov", ".m4v", ".3gp"})


def _av() -> Any:
    try:
        import av
    except ImportError as e:  # pragma: no cover - depends on the install
        raise ModuleInputError(
            "audio", 'decoding audio files needs PyAV: pip install "prezence[speech]"'
        ) from e
    return av


def decode_file(path: str | Path) -> Generator[np.ndarray, None, None]:
    """Decode an audio or video file to 16 kHz mono int16 blocks of any length.

    Args:
        path: a WAV, FLAC, MP3, MP4 (audio track) or any other file ffmpeg reads.

    Yields:
        int16 arrays, in order.

    Raises:
        ModuleInputError: the file is missing, empty or not audio.
        InputCutShort: the file breaks off mid-stream, or holds less audio than it announces;
            raised after the last block read has been yielded.
    """
    path = Path(path)
    if not path.is_file():
        raise ModuleInputError(path, "no such file")
    if path.stat().st_size == 0:
        raise ModuleInputError(path, "the file is empty")
    wav_short = _wav_shortfall(path)
    av = _av()
    try:
        container = av.open(str(path), mode="r")
    except (av.error.FFmpegError, UnicodeDecodeError) as e:
        # e reads "[Errno 1094995529] Invalid data found …: 'path'": its strerror is the part
        # that means something to a person
        why = getattr(e, "strerror", None) or str(e)
        hint = ""
        if path.suffix.lower() in _INDEXED_AT_THE_END:
            # session 23's student: a phone's .m4a cut off while recording (its index, written
            # last, is missing) was called a file of the wrong kind
            hint = (
                f"; a {path.suffix} recording cut off before it was saved (the recording app or "
                "the battery stopped it) has no index and no player can read it: export it "
                "again, or repair it with a tool that rebuilds the index"
            )
        raise ModuleInputError(
            path, f"not an audio or video file the decoder can read ({why}){hint}"
        ) from e
    n_out = 0
    try:
        if not container.streams.audio:
            raise ModuleInputError(path, "the file has no audio track")
        stream = container.streams.audio[0]
        # every channel kept (planar), mixed down here: see _Downmix
        resampler = av.AudioResampler(format="s16p", rate=SAMPLE_RATE)
        mix = _Downmix()
        try:
            for frame in container.decode(stream):
                for out in resampler.resample(frame):
                    pcm = mix(out.to_ndarray())
                    n_out += len(pcm)
                    yield pcm
            for out in resampler.resample(None):
                pcm = mix(out.to_ndarray())
                n_out += len(pcm)
                yield pcm
        except av.error.FFmpegError as e:
            if n_out == 0:
                raise ModuleInputError(path, f"the audio is damaged or truncated ({e})") from e
            raise InputCutShort(
                path,
                f"the audio is damaged or truncated after {n_out / SAMPLE_RATE:.1f} s ({e}); "
                "what was read has been analysed",
                n_out / SAMPLE_RATE,
            ) from e
        announced = _announced_s(container, stream)
    finally:
        container.close()
    if n_out == 0:
        raise ModuleInputError(path, "the file holds no audio samples")
    got = n_out / SAMPLE_RATE
    if wav_short is not None:
        have, n = wav_short
        raise InputCutShort(
            path,
            f"the WAV data is cut short ({have} of the {n} bytes its header announces): the "
            f"file is truncated; the {got:.1f} s read have been analysed",
            got,
        )
    if announced is not None and got < 0.98 * announced - 0.1:
        raise InputCutShort(
            path,
            f"the audio ends after {got:.1f} s of the {announced:.1f} s the file announces "
            "(truncated?); what was read has been analysed",
            got,
        )


#: A channel mix whose energy falls this far under its loudest channel's (so far in the file)
#: is not used: the loudest channel is. Two channels of the same voice mix at 1.0 of it, two
#: unrelated ones of equal level at 0.5 (-3 dB); one silent channel gives 0.25 (-6 dB: a
#: lapel microphone on input 1 of a stereo recorder read 6 dB quiet), and a channel wired
#: in opposite phase cancels the voice (near 0: "nothing measured" for a clear recording).
MIN_MIX_ENERGY_RATIO = 0.35


class _Downmix:
    """Planar int16 blocks (channels x samples) to mono: the channels' mean, as ffmpeg's
    downmix, unless that mean has lost the voice (:data:`MIN_MIX_ENERGY_RATIO`), then the
    loudest channel. Decided on the energies summed since the file's start, so the choice
    settles within the first words and the level does not jump from block to block."""

    def __init__(self) -> None:
        self._channels: np.ndarray | None = None
        self._mix = 0.0

    def __call__(self, planar: np.ndarray) -> np.ndarray:
        x = np.asarray(planar)
        if x.ndim == 1 or x.shape[0] == 1:
            return x.reshape(-1).astype(np.int16, copy=False)
        f = x.astype(np.float64)
        mean = f.mean(axis=0)
        energy = (f**2).sum(axis=1)
        self._channels = energy if self._channels is None else self._channels + energy
        self._mix += float((mean**2).sum())
        loudest = int(np.argmax(self._channels))
        if self._mix < MIN_MIX_ENERGY_RATIO * float(self._channels[loudest]):
            return x[loudest].astype(np.int16, copy=True)
        return np.round(mean).astype(np.int16)


def _wav_shortfall(path: Path) -> tuple[int, int] | None:
    """For a RIFF/WAVE file whose data chunk runs past the end of the file, ``(bytes of data
    present, bytes its header announces)``; else None.

    ffmpeg estimates a WAV's duration from the file size, so a cut-off WAV would otherwise
    decode quietly as a shorter talk.
    """
    size = path.stat().st_size
    with path.open("rb") as f:
        head = f.read(12)
        if len(head) < 12 or head[:4] != b"RIFF" or head[8:12] != b"WAVE":
            return None
        pos = 12
        while pos + 8 <= size:
            f.seek(pos)
            chunk = f.read(8)
            n = int.from_bytes(chunk[4:8], "little")
            if chunk[:4] == b"data":
                if n != 0xFFFFFFFF and pos + 8 + n > size:  # 0xFFFFFFFF: streamed, unknown
                    return size - pos - 8, n
                return None
            pos += 8 + n + (n & 1)
    return None


def _announced_s(container: Any, stream: Any) -> float | None:
    """The duration the file's header announces, in seconds, if it gives one."""
    if stream.duration is not None and stream.time_base is not None:
        return float(stream.duration * stream.time_base)
    if container.duration is not None:
        return float(container.duration) / 1_000_000.0  # av.time_base: microseconds
    return None


def read_file(path: str | Path) -> np.ndarray:
    """Decode a whole file to one 16 kHz mono int16 array (see :func:`decode_file`)."""
    parts = list(decode_file(path))
    return np.concatenate(parts) if parts else np.zeros(0, np.int16)


def _reblock(parts: Iterator[np.ndarray], size: int = BLOCK) -> Iterator[np.ndarray]:
    """Cut a stream of arrays of any length into blocks of ``size`` (the last may be shorter)."""
    buf = np.zeros(0, np.int16)
    try:
        for p in parts:
            buf = np.concatenate([buf, p]) if len(buf) else p
            while len(buf) >= size:
                yield buf[:size]
                buf = buf[size:]
    except InputCutShort:
        if len(buf):  # the audio read before the break is analysed too
            yield buf
        raise
    if len(buf):
        yield buf


class FileSource:
    """Blocks from a file, as fast as they decode, or paced at real time (``realtime=True``).

    Paced, a reader thread puts each block in a queue when its audio time has come, like a
    microphone would; the queue is unbounded, so a slow consumer falls behind but loses nothing.
    """

    def __init__(self, path: str | Path, *, realtime: bool, start_s: float = 0.0) -> None:
        self.path = Path(path)
        self.name = str(path)
        self.realtime = realtime
        #: audio before this (seconds) is skipped: a module restarted mid-talk resumes here
        self.start_s = max(0.0, float(start_s))
        self._live: _Queued | None = None
        self._closed = False
        # Fail early on a missing/empty/non-audio file, before a session is started.
        first = decode_file(self.path)
        self._first_block = next(first, None)
        self._rest = first

    def _all(self) -> Iterator[np.ndarray]:
        skip = int(round(self.start_s * SAMPLE_RATE))
        for part in self._parts():
            if skip >= len(part):
                skip -= len(part)
                continue
            yield part[skip:] if skip else part
            skip = 0

    def _parts(self) -> Iterator[np.ndarray]:
        if self._first_block is not None:
            yield self._first_block
        yield from self._rest

    def blocks(self) -> Iterator[np.ndarray]:
        if not self.realtime:
            for block in _reblock(self._all()):
                if self._closed:
                    return
                yield block
            return
        live = self._live = _Queued(self.name)
        t_start = time.monotonic()

        def produce() -> None:
            sent = 0
            for block in _reblock(self._all()):
                # A block is "captured" once its last sample's time has come.
                delay = t_start + (sent + len(block)) / SAMPLE_RATE - time.monotonic()
                if delay > 0 and live.stop.wait(delay):
                    return
                live.put(block)
                sent += len(block)

        yield from live.run(produce)

    @property
    def backlog_s(self) -> float:
        return self._live.backlog_s if self._live is not None else 0.0

    def close(self) -> None:
        self._closed = True
        if self._live is not None:
            self._live.close()


class MicSource:
    """Blocks from the default microphone via ``sounddevice`` (PortAudio), until closed."""

    def __init__(self, *, device: str | int | None = None) -> None:
        self.name = "mic"
        try:
            import sounddevice
        except (ImportError, OSError) as e:
            raise ModuleInputError(
                "mic",
                "microphone input needs sounddevice and the PortAudio library: "
                "pip install sounddevice (and apt-get install libportaudio2), or pass --audio FILE",
            ) from e
        self._sd = sounddevice
        self._device = device
        self._live = _Queued("mic")

    def blocks(self) -> Iterator[np.ndarray]:
        def produce() -> None:
            def callback(indata: Any, frames: int, t: Any, status: Any) -> None:
                if status:
                    log.warning("microphone: %s", status)
                self._live.put(np.frombuffer(bytes(indata), dtype=np.int16).copy())

            try:
                with self._sd.RawInputStream(
                    samplerate=SAMPLE_RATE,
                    blocksize=BLOCK,
                    channels=1,
                    dtype="int16",
                    device=self._device,
                    callback=callback,
                ):
                    self._live.stop.wait()
            except self._sd.PortAudioError as e:
                self._live.fail(ModuleInputError("mic", f"cannot open the microphone ({e})"))

        yield from self._live.run(produce)

    @property
    def backlog_s(self) -> float:
        return self._live.backlog_s

    def close(self) -> None:
        self._live.close()


class _Queued:
    """An unbounded queue between a capture thread and the consumer, with a backlog figure."""

    _END = object()

    def __init__(self, name: str) -> None:
        self.name = name
        self.stop = threading.Event()
        self._q: queue.Queue[Any] = queue.Queue()
        self._queued_samples = 0
        self._lock = threading.Lock()
        self._error: BaseException | None = None
        self._thread: threading.Thread | None = None

    def put(self, block: np.ndarray) -> None:
        with self._lock:
            self._queued_samples += len(block)
        self._q.put(block)

    def fail(self, err: BaseException) -> None:
        self._error = err

    @property
    def backlog_s(self) -> float:
        with self._lock:
            return self._queued_samples / SAMPLE_RATE

    def run(self, produce: Any) -> Iterator[np.ndarray]:
        def target() -> None:
            try:
                produce()
            except BaseException as e:  # handed to the consumer, re-raised there
                self._error = e
            finally:
                self._q.put(self._END)

        self._thread = threading.Thread(target=target, name=f"audio-{self.name}", daemon=True)
        self._thread.start()
        while True:
            item = self._q.get()
            if item is self._END:
                break
            with self._lock:
                self._queued_samples -= len(item)
            yield item
        if self._error is not None:
            raise self._error

    def close(self) -> None:
        self.stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=5.0)
