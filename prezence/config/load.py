"""Loading configuration files: the built-in default, TOML configs, seed line files, rooms.

``prezence check-config FILE…`` calls :func:`check_config_files`.
"""

from __future__ import annotations

import functools
import logging
from collections.abc import Iterable
from importlib import resources
from pathlib import Path

from prezence.config.lines import parse_lines
from prezence.config.model import Config, RoomProfile
from prezence.config.tomlconf import loads_config, loads_room
from prezence.errors import ConfigError

log = logging.getLogger(__name__)

DEFAULT_CONFIG = "default.toml"
DEFAULT_RULES = "rules.txt"


def default_path(name: str = DEFAULT_CONFIG) -> Path:
    """Path of a file in the built-in ``defaults/`` folder (``default.toml``, ``rules.txt``)."""
    return Path(str(resources.files("prezence.config").joinpath("defaults", name)))


def read_text(path: str | Path) -> str:
    """A config file's text (UTF-8, optional BOM); unreadable → :class:`ConfigError`."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise ConfigError(f"cannot read: {e.strerror or e}", path=path) from e
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise ConfigError(f"not UTF-8 text (byte {e.start})", path=path, line=line) from e


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
        return loads_config(text, path=path, room=room)
    base = default_config()
    room = room if room is not None else base.room
    rules = parse_lines(text, path=path, room=room)
    return Config(
        rules=rules, processor=base.processor, time=base.time, room=room, source=str(path)
    )


def load_room(path: str | Path) -> RoomProfile:
    """The ``[room]`` table of a TOML file (a room file or a whole config)."""
    return loads_room(read_text(path), path=path)


def config_problems(path: str | Path, *, room: RoomProfile | None = None) -> list[ConfigError]:
    """Every problem found in one config file (empty when it is fine)."""
    errors: list[ConfigError] = []
    try:
        text = read_text(path)
        if Path(path).suffix.lower() == ".toml":
            loads_config(text, path=path, room=room, errors=errors)
        else:
            base_room = room if room is not None else default_config().room
            parse_lines(text, path=path, room=base_room, errors=errors)
    except ConfigError as e:  # fatal ones: unreadable, TOML syntax, format
        errors.append(e)
    return errors


def check_config_files(paths: Iterable[str | Path]) -> list[str]:
    """Validate config files without running anything (``prezence check-config FILE…``).

    Returns:
        One message per problem, each starting with ``file:line:col:`` or ``file: key:``;
        an empty list when every file is fine.
    """
    out: list[str] = []
    for p in paths:
        problems = config_problems(p)
        log.info("%s: %d problem(s)", p, len(problems))
        out += [str(e) for e in problems]
    return out
