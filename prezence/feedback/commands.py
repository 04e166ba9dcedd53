"""The command table (data in ``data/commands.toml``): direction, gesture and phrase per command."""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

from prezence.errors import ConfigError, UnknownName
from prezence.feedback.direction import Direction
from prezence.tomlio import KeyLines, loads_toml

COMMANDS_FILE = "commands.toml"


@dataclass(frozen=True)
class Command:
    """One feedback command."""

    name: str
    direction: Direction
    gesture: str
    phrase: str
    phrase_one: str | None = None
    #: Said instead of ``phrase`` when the cue's ``noisy`` parameter is set: a clarity cue in
    #: a noisy room (:func:`prezence.coach.name_the_noise`).
    phrase_noisy: str | None = None
    #: The parameters the processor gives each cue of this command (``minutes``).
    params: tuple[str, ...] = ()
    #: Where the command is defined: ``commands.toml:LINE`` (its ``gesture =`` line), for
    #: messages about it; "" when not known.
    where: str = field(default="", compare=False)

    def say(self, params: Mapping[str, Any] | None = None) -> str:
        """The phrase with the cue's parameters filled in.

        Example:
            >>> Command("timeLeft", Direction.NEUTRAL, "time_left", "{minutes} minutes left.",
            ...         "One minute left.").say({"minutes": 2})
            '2 minutes left.'
        """
        params = dict(params or {})
        if self.phrase_one is not None and params.get("minutes") == 1:
            return self.phrase_one
        phrase = self.phrase
        if self.phrase_noisy is not None and params.get("noisy"):
            phrase = self.phrase_noisy
        try:
            return phrase.format(**params)
        except (KeyError, IndexError, ValueError) as e:
            raise ConfigError(
                f"command '{self.name}': phrase {phrase!r} needs a parameter the cue lacks "
                f"({e}); cue parameters: {sorted(params)}",
                path=COMMANDS_FILE,
            ) from e


def _parse(doc: Mapping[str, Any], path: str, text: str = "") -> dict[str, Command]:
    if doc.get("format") != 1:
        raise ConfigError(f"expected format = 1, found {doc.get('format')!r}", path=path)
    lines = KeyLines(text)
    out: dict[str, Command] = {}
    for name, entry in dict(doc.get("commands", {})).items():
        key = f"commands.{name}"
        line = lines.line(("commands", name, "gesture")) if text else None
        try:
            direction = Direction(entry["direction"])
            out[name] = Command(
                name=name,
                direction=direction,
                gesture=str(entry["gesture"]),
                phrase=str(entry["phrase"]),
                phrase_one=entry.get("phrase_one"),
                phrase_noisy=entry.get("phrase_noisy"),
                params=tuple(str(p) for p in entry.get("params", ())),
                where=f"{path}:{line}" if line is not None else path,
            )
        except KeyError as e:
            raise ConfigError(f"missing key {e}", path=path, key=key) from e
        except ValueError as e:
            raise ConfigError(
                f"direction must be raise, lower or neutral, not {entry.get('direction')!r}",
                path=path,
                key=key,
            ) from e
    return out


def commands_path() -> str:
    """The built-in command table's file (``…/prezence/feedback/data/commands.toml``)."""
    return str(resources.files("prezence.feedback").joinpath("data", COMMANDS_FILE))


@functools.cache
def load_commands() -> Mapping[str, Command]:
    """The built-in command table."""
    path = commands_path()
    text = resources.files("prezence.feedback").joinpath("data", COMMANDS_FILE).read_text()
    return _parse(loads_toml(text, path=path), path, text)


def get_command(name: str) -> Command:
    """Look up a command; an unknown name raises :class:`UnknownName` with a suggestion."""
    table = load_commands()
    try:
        return table[name]
    except KeyError:
        raise UnknownName("command", name, table) from None
