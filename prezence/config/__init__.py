"""Configuration: rules, room profile and settings as frozen dataclasses, and their two front ends.

- :mod:`prezence.config.model`: the dataclasses (what the processor consumes).
- :mod:`prezence.config.lines`: the seed's line format (``rules.txt``), file:line:col errors.
- :mod:`prezence.config.tomlconf`: the TOML form (``config.toml``), file + key-path errors.
- :mod:`prezence.config.load`: :func:`load_config`, :func:`load_room`, :func:`check_config_files`.

The formats are documented in ``prezence/config/defaults/README.md``.
"""

from prezence.config.lines import format_rule, parse_lines
from prezence.config.load import check_config_files, default_config, load_config, load_room
from prezence.config.model import (
    FORMAT,
    Check,
    Config,
    Direction,
    ProcessorSettings,
    RoomProfile,
    Rule,
    TimeSettings,
)
from prezence.config.tomlconf import dumps_config, loads_config

__all__ = [
    "FORMAT",
    "Check",
    "Config",
    "Direction",
    "ProcessorSettings",
    "RoomProfile",
    "Rule",
    "TimeSettings",
    "check_config_files",
    "default_config",
    "dumps_config",
    "format_rule",
    "load_config",
    "load_room",
    "loads_config",
    "parse_lines",
]
