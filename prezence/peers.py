"""The peers' reference harness, in Prezence: for comparing the anchors' cue counts.

``shared/peers/replay.py`` replays a folder of ``<metric>.txt`` streams plus ``rules.conf`` through
one policy, deciding every ``tick`` seconds, with a robot kept busy a fixed ``duration`` per cue.
:func:`load_folder` reads such a folder with Prezence's own readers and :func:`replay_fixed_busy`
drives the processor the same way, so the two cue counts can be set side by side
(``bench/bench_anchors.py``, ``tests/unit/test_anchors.py``).
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from prezence.config.lines import parse_lines
from prezence.config.load import complete_rules, default_config
from prezence.config.model import Config
from prezence.processor import Cue, Processor, make_policy
from prezence.replay import load_samples
from prezence.samples import Sample


def load_folder(folder: Path) -> tuple[Config, list[Sample]]:
    """The rules of ``folder/rules.conf`` (seed line format, built-in settings, no allocated
    time) and every sample of ``folder/streams/``, in time order."""
    conf = folder / "rules.conf"
    rules, _ = complete_rules(parse_lines(conf.read_text(), path=conf))
    base = default_config()
    cfg = Config(rules=rules, processor=base.processor, time=base.time, room=base.room)
    paths = {r.metric: folder / "streams" / f"{r.metric}.txt" for r in rules}
    # The peers' reader takes every finite value; so does this one, so that both harnesses
    # feed their policies the same samples (the shared workload stays inside the physical
    # ranges, where `prezence replay` takes the same samples too).
    return cfg.with_allocated(None), load_samples(paths, ranges=None)


def replay_fixed_busy(
    cfg: Config,
    samples: Sequence[Sample],
    policy: str,
    *,
    duration: float,
    tick: float,
    end: float | None = None,
) -> list[Cue]:
    """Decisions every ``tick`` s over ``samples`` (sorted by time), up to ``end`` (default: the
    last sample) plus a tick; each cue keeps the robot busy ``duration`` s. Returns the cues."""
    p = Processor(cfg, policy=make_policy(policy))
    busy_until = -math.inf
    i, n = 0, len(samples)
    end = end if end is not None else (samples[-1].t if samples else 0.0)
    out: list[Cue] = []
    k = 0
    while (now := round((k := k + 1) * tick, 9)) <= end + tick:
        j = i
        while j < n and samples[j].t <= now + 1e-9:
            j += 1
        free = now >= busy_until - 1e-9
        d = p.step(now, samples[i:j], free_since=busy_until if free else None)
        i = j
        if d.cue is not None:
            out.append(d.cue)
            busy_until = now + duration
    return out


def reference_cues(
    peers: Path, folder: Path, policy: str, *, duration: float, tick: float
) -> list[dict[str, Any]]:
    """The cues of the peers' own ``replay.py`` (run as its own process) on ``folder``, with
    the same tick and busy time and no allocated time; written to ``folder/peers-<policy>.jsonl``.
    """
    out = folder / f"peers-{policy}.jsonl"
    argv = [sys.executable, str(peers / "replay.py"), str(folder), "--policy", policy]
    argv += ["--duration", str(duration), "--tick", str(tick), "--allocated", "0"]
    subprocess.run([*argv, "--out", str(out)], check=True, capture_output=True)
    return [json.loads(line) for line in out.read_text().splitlines() if line.strip()]
