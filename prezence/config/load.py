"""Loading configuration files: the built-in default, TOML configs, seed line files, rooms.

``prezence check-config FILE…`` calls :func:`check_config_files`.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import logging
from collections.abc import Iterable, Sequence
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from prezence.config.lines import SLOTS, parse_lines
from prezence.config.model import Config, RoomProfile, Rule
from prezence.config.tomlconf import loads_config, loads_room
from prezence.errors import ConfigError
from prezence.metrics import METRICS
from prezence.tomlio import read_text

if TYPE_CHECKING:
    from prezence.feedback.gestures import GestureLibrary

log = logging.getLogger(__name__)

DEFAULT_CONFIG = "default.toml"
DEFAULT_RULES = "rules.txt"


def default_path(name: str = DEFAULT_CONFIG) -> Path:
    """Path of a file in the built-in ``defaults/`` folder (``default.toml``, ``rules.txt``)."""
    return Path(str(resources.files("prezence.config").joinpath("defaults", name)))


@functools.cache
def default_config() -> Config:
    """The built-in configuration (``defaults/default.toml``): the seed's ideal delivery."""
    path = default_path()
    return loads_config(read_text(path), path=path)


def load_config(path: str | Path | None = None, *, room: RoomProfile | None = None) -> Config:
    """Load a configuration. Raises :class:`ConfigError` with the file and line or key path.

    Args:
        path: None for the built-in default; a ``.toml`` file for the TOML form; any other
            file is read as seed line-format rules, with the default settings.
        room: overrides the room (named values and ``at=listener`` are resolved against it).
    """
    if path is None:
        if room is None:
            return default_config()
        return loads_config(read_text(default_path()), path=default_path(), room=room)
    text = read_text(path)
    if Path(path).suffix.lower() == ".toml":
        config = loads_config(text, path=path, room=room)
    else:
        base = default_config()
        room = room if room is not None else base.room
        rules = parse_lines(text, path=path, room=room)
        config = Config(
            rules=rules, processor=base.processor, time=base.time, room=room, source=str(path)
        )
    rules, notes = complete_rules(config.rules)
    for n in notes:
        log.warning("%s", n)
    return dataclasses.replace(config, rules=rules)


def keep_recorded_time(config: Config, recorded: Config | None, where: Path) -> Config:
    """``config`` with the recorded talk's allocated time (``recorded``, read from ``where``):
    the time a speaker had is a fact of the talk, not a rule to try, so rules given to judge a
    recording again (a rules file of the seed's format has no time and loads the default 600
    s) must not move the time warnings and the over/under figure. Warns when it differs."""
    if recorded is None or config.time.allocated_s == recorded.time.allocated_s:
        return config

    def said(s: float | None) -> str:
        return "no time" if s is None else f"{s:g} s"

    log.warning(
        "%s: the recording's talk had %s allocated; kept (the rules given say %s)",
        where,
        said(recorded.time.allocated_s),
        said(config.time.allocated_s),
    )
    return config.with_allocated(recorded.time.allocated_s)


def complete_rules(rules: Sequence[Rule]) -> tuple[tuple[Rule, ...], list[str]]:
    """Fill in what the seed's short lines leave out, and flag likely typos.

    The seed writes rules without commands (``speech_speed inRange 140 180``): such a rule on a
    metric of the built-in configuration takes that rule's commands (for the sides its check
    has). A rule on such a metric that gives no deviation scale takes the built-in rule's scale
    too (``speech_volume min 60`` judges 54 dB as 100 % below, as the built-in 6 dB scale says,
    not as 10 % of 60), since the scale belongs to the metric's unit, not to the bound.
    A rule that names no unit takes its metric record's
    (:attr:`prezence.metrics.Metric.shown_unit`).
    A rule on a metric no shipped module writes is kept (your own module may write it) but
    noted with a "did you mean", as is a rule that has no command at all (it can never cue).

    Returns:
        The rules, completed, and one ``file:line: …`` note per questionable rule.
    """
    defaults = {r.metric: r for r in default_config().rules}
    out: list[Rule] = []
    notes: list[str] = []
    for r in rules:
        where = f"{r.source}: " if r.source else ""
        if r.below is None and r.above is None and r.metric in defaults:
            d = defaults[r.metric]
            slots = SLOTS[r.check]
            r = dataclasses.replace(
                r,
                below=d.below if "below" in slots else None,
                above=d.above if "above" in slots else None,
            )
        d_scale = defaults[r.metric].scale if r.metric in defaults else None
        if r.scale is None and d_scale is not None:
            r = dataclasses.replace(r, scale=d_scale)
        record = METRICS.get(r.metric)  # read now: a record added at run time counts too
        if not r.unit and record is not None:  # the seed's lines give no unit
            r = dataclasses.replace(r, unit=record.shown_unit)
        if record is None:
            close = difflib.get_close_matches(r.metric, list(METRICS), n=1, cutoff=0.6)
            hint = f"; did you mean '{close[0]}'?" if close else ""
            notes.append(
                f"{where}no shipped module writes '{r.metric}' (fine if your own module does){hint}"
            )
        if r.below is None and r.above is None:
            notes.append(f"{where}rule on '{r.metric}' has no feedback command: it never cues")
        out.append(r)
    return tuple(out), notes


def load_room(path: str | Path) -> RoomProfile:
    """The ``[room]`` table of a TOML file (a room file or a whole config)."""
    return loads_room(read_text(path), path=path)


def config_problems(
    path: str | Path,
    *,
    room: RoomProfile | None = None,
    notes: list[str] | None = None,
    library: GestureLibrary | None = None,
) -> list[ConfigError]:
    """Every problem found in one config file (empty when it is fine).

    Args:
        path: the file.
        room: the room profile named values come from (default: the file's own or the
            built-in one).
        notes: if given, warnings that are not errors (see :func:`complete_rules`) are
            appended to it.
        library: the gesture library the talks will play (``--gestures``; None: the built-in
            one): a command the rules (or the coach, by these settings) can give whose gesture
            it lacks is a problem, as a talk refuses it
            (:func:`prezence.feedback.gestures.missing_gestures`).
    """
    from prezence.feedback.gestures import missing_gestures

    errors: list[ConfigError] = []
    rules: Sequence[Rule] = ()
    config: Config | None = None
    try:
        text = read_text(path)
        if Path(path).suffix.lower() == ".toml":
            config = loads_config(text, path=path, room=room, errors=errors)
            rules = config.rules
        else:
            base_room = room if room is not None else default_config().room
            rules = parse_lines(text, path=path, room=base_room, errors=errors)
            if not rules and not errors:
                errors.append(ConfigError("no rules", path=path))
            base = default_config()
            config = Config(
                rules=tuple(rules), processor=base.processor, time=base.time, source=str(path)
            )
    except ConfigError as e:  # fatal ones: unreadable, TOML syntax, format
        errors.append(e)
    if not errors and config is not None:
        completed = dataclasses.replace(config, rules=complete_rules(rules)[0])
        errors += [ConfigError(m) for m in missing_gestures(library, completed.talk_commands())]
    if notes is not None and not errors:
        notes += complete_rules(rules)[1]
    return errors


def check_config_files(
    paths: Iterable[str | Path],
    *,
    room: RoomProfile | None = None,
    notes: list[str] | None = None,
    library: GestureLibrary | None = None,
) -> list[str]:
    """Validate config files without running anything (``prezence check-config FILE…``).

    Args:
        paths: config files (TOML or seed line format).
        room: the room profile for named values (``--room``); None: each file's own or the
            built-in room.
        notes: if given, warnings (unknown metric, rule without command) are appended to it.
        library: the gesture library of the talks (``--gestures``; None: the built-in one).

    Returns:
        One message per problem, each starting with ``file:line:col:`` or ``file: key:``;
        an empty list when every file is fine.
    """
    out: list[str] = []
    for p in paths:
        problems = config_problems(p, room=room, notes=notes, library=library)
        log.info("%s: %d problem(s)", p, len(problems))
        out += [str(e) for e in problems]
    return out
