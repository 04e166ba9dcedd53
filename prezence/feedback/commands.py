"""The command table (data in ``data/commands.toml``): direction, gesture and phrase per command."""

from __future__ import annotations

import functools
import logging
import unicodedata
from collections.abc import Mapping
from dataclasses import dataclass, field
from importlib import resources
from typing import Any

from prezence.errors import ConfigError, UnknownName
from prezence.feedback.direction import Direction
from prezence.tomlio import KeyLines, loads_toml

log = logging.getLogger(__name__)

COMMANDS_FILE = "commands.toml"

#: The language the robot's text-to-speech speaks the phrases in. Prezence never sets it: a
#: NAO speaks in the language installed and chosen on it, English out of the box (the virtual
#: NAO's too), and the phrases of the command table are written for it.
TTS_LANGUAGE = "English"


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
    """The built-in command table. A phrase the robot's voice may not say as written
    (:func:`unsayable`) is warned of once, with its file and line."""
    text = resources.files("prezence.feedback").joinpath("data", COMMANDS_FILE).read_text()
    return parse_commands(text, commands_path())


def parse_commands(text: str, path: str) -> dict[str, Command]:
    """A command table from its TOML text (``path`` names it in messages), with a warning per
    phrase the robot's voice may not say as written (:func:`phrase_notes`).

    Raises:
        ConfigError: not a command table (``file:line:`` or ``file: key:``).
    """
    table = _parse(loads_toml(text, path=path), path, text)
    for note in phrase_notes(table, text, path):
        log.warning("%s", note)
    return table


def unsayable(phrase: str) -> list[str]:
    """The characters of ``phrase`` that the robot's :data:`TTS_LANGUAGE` voice may not say as
    meant, each named once in order (``'🙂' (SLIGHTLY SMILING FACE)``): every character outside
    Latin-1 (an emoji, a typographic quote or dash, a symbol: a voice skips them, spells them
    out or stops at them) and, the voice being English, the accented letters of Latin-1 (``é``:
    read with English sounds).

    Example:
        >>> unsayable("Très bien 🙂")
        ["'è' (LATIN SMALL LETTER E WITH GRAVE)", "'🙂' (SLIGHTLY SMILING FACE)"]
        >>> unsayable("Slow down a little.")
        []
    """
    out: list[str] = []
    for ch in phrase:
        if ch.isascii():
            continue
        if ord(ch) < 0x100 and not ch.isalpha():
            continue  # Latin-1 punctuation (« », ¿, the no-break space): read or skipped quietly
        shown = f"{ch!r} ({unicodedata.name(ch, f'U+{ord(ch):04X}')})"
        if shown not in out:
            out.append(shown)
    return out


def phrase_notes(table: Mapping[str, Command], text: str, path: str) -> list[str]:
    """A ``file:line: …`` note per phrase with characters the robot's voice may not say
    (:func:`unsayable`): a warning, not an error (the report, ``cues.jsonl`` and the
    simulated robot show them as written; only the real robot's voice is in question)."""
    lines = KeyLines(text)
    out = []
    for name, c in table.items():
        for key, phrase in (
            ("phrase", c.phrase),
            ("phrase_one", c.phrase_one),
            ("phrase_noisy", c.phrase_noisy),
        ):
            odd = unsayable(phrase or "")
            if not odd:
                continue
            line = lines.line(("commands", name, key))
            out.append(
                f"{path}:{line}: commands.{name}.{key}: {', '.join(odd)} may not be said as "
                f"written: the robot speaks its phrases with its {TTS_LANGUAGE} voice "
                "(Prezence does not change the robot's language), which skips or spells out "
                "what is not in its alphabet, emoji and symbols included"
            )
    return out


def get_command(name: str) -> Command:
    """Look up a command; an unknown name raises :class:`UnknownName` with a suggestion."""
    table = load_commands()
    try:
        return table[name]
    except KeyError:
        raise UnknownName("command", name, table) from None
