"""A sample source written to :class:`prezence.talk.SampleSource` without ``SourceBase``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from prezence.backends.fake import FakeBackend
from prezence.config.model import Check, Config, ProcessorSettings, Rule, TimeSettings
from prezence.processor import Cue
from prezence.samples import Sample
from prezence.session import SessionDir
from prezence.streams.tail import MultiTailer
from prezence.talk import RunOptions, run_talk


class OwnSource:
    """Every method the Protocol had before session 23, and no ``time_used``."""

    kind = "replay"
    keep_streams = False
    error: str | None = None

    def __init__(self, samples: Sequence[Sample], talk_s: float) -> None:
        self._samples = list(samples)
        self._talk_s = talk_s

    @property
    def talk_s(self) -> float | None:
        return self._talk_s

    def start(self, session: SessionDir, config: Config) -> None:
        return None

    def poll(self, now: float) -> Sequence[Sample]:
        given = [s for s in self._samples if s.t <= now]
        self._samples = self._samples[len(given) :]
        return given

    def wait(self, timeout_s: float) -> bool:
        return False

    def ended(self, now: float) -> bool:
        return False

    def events(self, now: float) -> list[str]:
        return []

    def on_cue(self, cue: Cue) -> None:
        return None

    def finish_input(self) -> None:
        return None

    def stop(self) -> None:
        return None

    def meta(self) -> dict[str, Any]:
        return {"talk_s": self._talk_s}

    def summary_extra(self) -> dict[str, Any]:
        return {}

    def truth(self) -> list[dict[str, Any]] | None:
        return None

    def tailer(self) -> MultiTailer | None:
        return None

    def readings(self) -> Mapping[str, Any] | None:
        return None


def test_a_source_without_time_used_runs_on_the_talks_clock(tmp_path: Path) -> None:
    # Session 23, a review: the talk called source.time_used(now), which the Protocol had
    # just gained, so a source written to it before (not based on SourceBase) raised
    # AttributeError at its first decision point.
    config = Config(
        rules=(Rule("speech_speed", Check.IN_RANGE, 140, 180, below="speedUp", above="slowDown"),),
        processor=ProcessorSettings(threshold=40.0, praise_after_s=0),
        time=TimeSettings(allocated_s=4.0),
    )
    samples = [Sample("speech_speed", 0.5 * i, 160.0) for i in range(1, 13)]
    run = run_talk(
        OwnSource(samples, 6.0),
        config=config,
        session=tmp_path / "s",
        backend=FakeBackend(),
        options=RunOptions.default(),
    )
    # judged on the talk's clock: the first decision point past the allocated 4 s
    assert [(c["command"], c["t"]) for c in run.cues] == [("overtime", 4.5)]
