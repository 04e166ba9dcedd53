"""Headless talks: a synthetic presenter, the real processor and a robot backend, on simulated time.

The presenter writes module files exactly as real modules would; the coach reads them back
through the same tailer a live talk uses, so a headless talk exercises the whole path from a
line in a file to a gesture on the robot. The talk runs through the one loop,
:func:`prezence.talk.run_talk`, on a stepped clock: the same seed gives the same decision log,
byte for byte.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from prezence.backends.base import Backend
from prezence.backends.registry import make_backend
from prezence.config.load import load_config
from prezence.config.model import Config
from prezence.feedback.gestures import library_for_talk
from prezence.processor import Cue, Decision
from prezence.samples import MAX_AHEAD_S, Sample
from prezence.session import SessionDir
from prezence.streams.tail import MultiTailer
from prezence.streams.writer import StreamWriter
from prezence.synthetic.presenters import SyntheticPresenter
from prezence.synthetic.scenario import Scenario, load_scenario
from prezence.talk import Progress, RunOptions, SourceBase
from prezence.talk import run_talk as run_loop

log = logging.getLogger(__name__)


class SyntheticSource(SourceBase):
    """A synthetic presenter as a sample source.

    With ``files`` (the default) the presenter writes module files (and, as a misbehaving
    module would, garbage lines) that the coach tails back, as in a live talk; without, its
    samples go to the processor directly (the Gymnasium environment's fast path).
    """

    kind = "synthetic"

    def __init__(
        self, scenario: Scenario, config: Config, *, seed: int, files: bool = True
    ) -> None:
        self.scenario = scenario
        self.seed = seed
        self.files = files
        self.presenter = SyntheticPresenter(scenario, config, seed=seed)
        self._writers: dict[str, StreamWriter] = {}
        self._streams: dict[str, Path] = {}
        self._tailer: MultiTailer | None = None
        self._session: SessionDir | None = None
        self._truth: list[dict[str, Any]] | None = None

    @property
    def talk_s(self) -> float | None:
        return self.scenario.duration_s

    def start(self, session: SessionDir, config: Config) -> None:
        self._session = session
        if not self.files:
            return
        # a file only for what the persona plays: a metric no module writes is "not
        # measured" in the summary and the report, as in a live talk without that module
        played = {m.metric for m in self.scenario.metrics}
        self._streams = {
            r.metric: session.stream(r.stream) for r in config.rules if r.metric in played
        }
        self._writers = {m: StreamWriter(p) for m, p in self._streams.items()}
        for w in self._writers.values():
            w.open()
        self._tailer = MultiTailer(
            self._streams,
            max_ahead_s=MAX_AHEAD_S,
            record_stamps=True,
            ranges=config.value_ranges(),
        )

    def poll(self, now: float) -> Sequence[Sample]:
        samples = self.presenter.advance(now)
        garbage = self.presenter.garbage(now)
        if self._tailer is None:
            return samples
        for s in samples:
            w = self._writers.get(s.metric)
            if w is not None:
                w.write(s.t, s.value)
        for metric, text in garbage:
            # a misbehaving module: a line the tailer must skip, count and report
            with self._streams[metric].open("a", encoding="utf-8") as f:
                f.write(text + "\n")
        return self._tailer.poll(now)

    def on_cue(self, cue: Cue) -> None:
        self.presenter.on_cue(cue.t, cue.command, cue.metric, dict(cue.params))

    def stop(self) -> None:
        for w in self._writers.values():
            w.close()
        self._writers = {}

    def tailer(self) -> MultiTailer | None:
        return self._tailer

    def truth(self) -> list[dict[str, Any]] | None:
        if self._truth is None:
            self._truth = self.presenter.truth()
        return self._truth

    def meta(self) -> dict[str, Any]:
        return {"scenario": self.scenario.name, "seed": self.seed, "talk_s": self.talk_s}

    def summary_extra(self) -> dict[str, Any]:
        # the presenter's reaction to each cue (ground truth, as truth.jsonl is): the report
        # says whether the presenter reacted, not only what the metric did after a cue
        reactions = [
            {k: r[k] for k in ("t", "command", "reacted", "why") if k in r}
            for r in self.presenter.reactions
        ]
        return {"scenario": self.scenario.name, "seed": self.seed, "reactions": reactions}


@dataclass
class TalkResult:
    """What a headless talk leaves: its folder, its cues and its summary."""

    session: SessionDir
    scenario: Scenario
    cues: list[dict[str, Any]]
    summary: dict[str, Any]
    decisions: int
    wall_s: float
    #: Ctrl-C or SIGTERM stopped the talk before its end (its folder is written up to there).
    interrupted: bool = False


def run_talk(
    scenario: Scenario | str | Path,
    *,
    out: Path,
    options: RunOptions | None = None,
    seed: int | None = None,
    backend: str | Backend = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    config: Config | None = None,
    progress: Progress | None = None,
    on_decision: Callable[[Decision], None] | None = None,
    **option_changes: Any,
) -> TalkResult:
    """Run one synthetic talk from start to end and write its session folder.

    Args:
        scenario: a Scenario, a scenario name (``fast_talker``) or a path to a scenario TOML.
        out: the session folder (created; earlier files in it are replaced).
        options: how to run it (None: :meth:`RunOptions.default` with ``option_changes``,
            e.g. ``policy="seed"``, ``report=True``); its seed is not used: ``seed`` is.
        seed: presenter noise and reactions (and the policy's chance); None uses the
            scenario's own seed.
        backend: ``fake``, ``sim``, ``naoqi`` or an (unopened) Backend instance.
        backend_kwargs: passed to the backend's constructor when ``backend`` is a name.
        config: rules and settings; None loads the built-in default. The scenario's
            allocated time replaces the config's.
        progress: called after every decision point.
        on_decision: called with every decision (tests, live views).
    """
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    seed = sc.seed if seed is None else seed
    opts = options if options is not None else RunOptions.default(**option_changes)
    if options is not None and option_changes:
        raise TypeError("give either options or option keywords, not both")
    opts = dataclasses.replace(opts, seed=seed)
    cfg = (config or load_config(None)).with_allocated(sc.allocated_s)
    # before the robot opens or the folder is written: a command the rules can give whose
    # gesture the library lacks would stop the talk at its first cue
    library_for_talk(
        opts.gestures or None, speed_fraction=opts.speed_fraction, commands=cfg.talk_commands()
    )
    bk = (
        backend if isinstance(backend, Backend) else make_backend(backend, **(backend_kwargs or {}))
    )
    source = SyntheticSource(sc, cfg, seed=seed)
    run = run_loop(
        source,
        config=cfg,
        session=SessionDir(Path(out)),
        backend=bk,
        options=opts,
        on_decision=on_decision,
        progress=progress,
    )
    return TalkResult(
        run.session, sc, run.cues, run.summary, run.decisions, run.wall_s, run.interrupted
    )
