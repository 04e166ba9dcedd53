"""Where a folder keeps its stream files (replays, rehearsals, reports, rebuilds).

Below the replay and the report, so that both can use it without importing each other
(:mod:`prezence.replay` re-exports these names).
"""

from __future__ import annotations

import difflib
from pathlib import Path

from prezence.config.model import Config
from prezence.errors import ConfigError


def locate_streams(src: Path, config: Config) -> dict[str, Path]:
    """The stream file of each rule that has one: ``src/streams/<file>``, else ``src/<file>``.

    The one stream discovery of replays, rehearsals and reports; rules without a file are
    left out.
    """
    found: dict[str, Path] = {}
    for rule in config.rules:
        for cand in (src / "streams" / rule.stream, src / rule.stream):
            if cand.is_file():
                found[rule.metric] = cand
                break
    return found


def no_streams_error(src: Path, config: Config) -> ConfigError:
    """The error for a folder in which :func:`locate_streams` finds nothing."""
    if not src.exists():
        return ConfigError("no such folder", path=src)
    if not src.is_dir():
        return ConfigError(
            "not a folder (give a session folder or a folder of stream files)", path=src
        )
    names = ", ".join(r.stream for r in config.rules)
    # The files that are there, so that a misspelt metric in the rules shows (session 20: a
    # rules file naming only 'speech_sped' said "no stream files found" of a folder holding
    # ten streams, speech_speed.txt among them).
    there = sorted({f.name for d in (src / "streams", src) if d.is_dir() for f in d.glob("*.txt")})
    if not there:
        return ConfigError(
            f"no stream files found (looked for {names} in streams/ and the folder)", path=src
        )
    hints = []
    for r in config.rules:
        close = difflib.get_close_matches(r.stream, there, n=1, cutoff=0.8)
        if close:
            hints.append(f"{close[0]} for {r.stream}?")
    shown = ", ".join(there[:12]) + (f" and {len(there) - 12} more" if len(there) > 12 else "")
    return ConfigError(
        f"no stream file for the rules' metrics (looked for {names} in streams/ and the "
        f"folder, which holds {shown})" + (f"; did you mean {' '.join(hints)}" if hints else ""),
        path=src,
    )
