"""Headless talks: a synthetic presenter, the real processor and a robot backend, on simulated time.

The presenter writes module files exactly as real modules would; the coach reads them back
through the same tailer a live talk uses, so a headless talk exercises the whole path from a
line in a file to a gesture on the robot. The run's clock drives everything (presenter, tailer,
processor, physics): the same seed gives the same decision log, byte for byte.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from prezence.backends.base import Backend
from prezence.backends.registry import make_backend
from prezence.clock import ManualClock
from prezence.coach import Coach, default_planner
from prezence.config.load import load_config
from prezence.config.model import Config
from prezence.config.tomlconf import dumps_config
from prezence.processor import Cue, Decision, Processor, make_policy
from prezence.samples import MAX_AHEAD_S
from prezence.session import SessionDir, dumps, read_jsonl
from prezence.streams.tail import MultiTailer
from prezence.streams.writer import StreamWriter
from prezence.summary import summarize_session
from prezence.synthetic.presenters import SyntheticPresenter
from prezence.synthetic.scenario import Scenario, load_scenario

log = logging.getLogger(__name__)

#: Progress callback: (simulated seconds done, talk length).
Progress = Callable[[float, float], None]


@dataclass
class TalkResult:
    """What a headless talk leaves: its folder, its cues and its summary."""

    session: SessionDir
    scenario: Scenario
    cues: list[dict[str, Any]]
    summary: dict[str, Any]
    decisions: int
    wall_s: float


def run_talk(
    scenario: Scenario | str | Path,
    *,
    out: Path,
    seed: int | None = None,
    backend: str | Backend = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    config: Config | None = None,
    policy: str = "weighted",
    speed_fraction: float = 0.6,
    realtime: bool = False,
    progress: Progress | None = None,
    on_decision: Callable[[Decision], None] | None = None,
    report: bool = False,
) -> TalkResult:
    """Run one synthetic talk from start to end and write its session folder.

    Args:
        scenario: a Scenario, a scenario name (``fast_talker``) or a path to a scenario TOML.
        out: the session folder (created; earlier files in it are replaced).
        seed: presenter noise and reactions; None uses the scenario's own seed.
        backend: ``fake``, ``sim``, ``naoqi`` or an (unopened) Backend instance.
        backend_kwargs: passed to the backend's constructor when ``backend`` is a name.
        config: rules and settings; None loads the built-in default. The scenario's
            allocated time replaces the config's.
        policy: conflict resolution policy name.
        speed_fraction: fraction of each joint's velocity limit used by gestures.
        realtime: pace the simulated clock to the wall clock.
        progress: called after every decision point.
        on_decision: called with every decision (tests, live views).
        report: after the talk, have the robot say the spoken summary and write ``report/``
            (HTML, plots, JSON). Off by default: evaluations run thousands of talks.
    """
    sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
    seed = sc.seed if seed is None else seed
    cfg = (config or load_config(None)).with_allocated(sc.allocated_s)
    session = SessionDir(Path(out)).create()
    session.config.write_text(dumps_config(cfg))
    bk = (
        backend if isinstance(backend, Backend) else make_backend(backend, **(backend_kwargs or {}))
    )
    session.write_meta(
        {
            "kind": "synthetic",
            "scenario": sc.name,
            "seed": seed,
            "backend": bk.name,
            "policy": policy,
            "speed_fraction": speed_fraction,
            "talk_s": sc.duration_s,
        }
    )
    presenter = SyntheticPresenter(sc, cfg, seed=seed)
    streams = {r.metric: session.stream(r.stream) for r in cfg.rules}
    writers = {m: StreamWriter(p) for m, p in streams.items()}
    for w in writers.values():
        w.open()
    tailer = MultiTailer(streams, max_ahead_s=MAX_AHEAD_S, record_stamps=True)
    processor = Processor(cfg, policy=make_policy(policy, seed=seed))

    def heard(cue: Cue) -> None:
        presenter.on_cue(cue.t, cue.command, cue.metric, dict(cue.params))

    clock = ManualClock()
    dt = cfg.processor.decision_period_s
    wall0 = time.perf_counter()

    def pace(t: float) -> None:
        ahead = t - (time.perf_counter() - wall0)
        if ahead > 0:
            time.sleep(ahead)

    paced = pace if realtime else None
    bk.open()
    coach = Coach(processor, bk, session, planner=default_planner(speed_fraction), on_cue=heard)
    try:
        n_steps = int(round(sc.duration_s / dt))
        for i in range(1, n_steps + 1):
            now = i * dt
            clock.set(now)
            for s in presenter.advance(now):
                w = writers.get(s.metric)
                if w is not None:
                    w.write(s.t, s.value)
            for metric, text in presenter.garbage(now):
                # a misbehaving module: a line the tailer must skip, count and report
                with streams[metric].open("a", encoding="utf-8") as f:
                    f.write(text + "\n")
            decision = coach.tick(now, tailer.poll(now))
            if on_decision is not None:
                on_decision(decision)
            if progress is not None:
                progress(now, sc.duration_s)
            if paced is not None:
                paced(now)
        end = coach.drain(clock.now(), step_s=dt, pace=paced)
        wall = time.perf_counter() - wall0
        post: dict[str, Any] | None = None
        if report:
            from prezence.report.build import build_report
            from prezence.report.speech import summary_phrase

            phrase = summary_phrase(build_report(session.root, config=cfg))
            post = coach.post_talk(phrase, end, step_s=dt, pace=paced)
        backend_stats = bk.stats()
    finally:
        coach.close()
        for w in writers.values():
            w.close()
        bk.close()
    truth = presenter.truth()
    with session.truth.open("w") as f:
        for row in truth:
            f.write(dumps(row, sort_keys=True) + "\n")
    summary = summarize_session(
        session,
        cfg,
        talk_s=sc.duration_s,
        truth=truth,
        backend_stats=backend_stats,
        live=tailer,
        processor=processor,
        extra={
            "scenario": sc.name,
            "seed": seed,
            "policy": policy,
            "backend": bk.name,
            "decisions": coach.decisions,
            "ended_at_s": round(end, 3),
            "wall_s": round(wall, 4),
            "realtime_factor": round(sc.duration_s / wall, 1) if wall > 0 else None,
            **({"post_talk": post} if post is not None else {}),
        },
    )
    if report:
        from prezence.report.build import write_report

        write_report(session.root, config=cfg)
    return TalkResult(session, sc, read_jsonl(session.cues), summary, coach.decisions, wall)
