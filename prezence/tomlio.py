"""The one TOML reader: stdlib ``tomllib``, with every syntax error as a
:class:`~prezence.errors.ConfigError` naming the file, line and column.

``tomllib`` gives the position as attributes only from Python 3.14; before, it is in the
message (``... (at line 3, column 7)``, or ``(at end of document)``). Both are read here, so
config files, rules, scenarios, the gesture library and the command table report positions
alike on every supported Python.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

from prezence.errors import ConfigError

_POS = re.compile(r"\s*\(at line (\d+), column (\d+)\)\Z")
_END = re.compile(r"\s*\(at end of document\)\Z")


def loads_toml(text: str, *, path: str | Path) -> dict[str, Any]:
    """Parse ``text`` (read from ``path``, named in errors).

    Raises:
        ConfigError: a syntax error, with its line and column (the end of the file when the
            document ends too early), or nesting too deep.

    Example:
        >>> loads_toml("a = 1\\nb = = 2\\n", path="x.toml")
        Traceback (most recent call last):
        ...
        prezence.errors.ConfigError: x.toml:2:5: TOML: Invalid value
    """
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(getattr(e, "msg", "") or e)
        line = getattr(e, "lineno", None)
        col = getattr(e, "colno", None)
        m = _POS.search(str(e))
        if m:
            line, col = int(m.group(1)), int(m.group(2))
            msg = str(e)[: m.start()]
        elif line is None:
            lines = text.split("\n")
            line, col = len(lines), len(lines[-1]) + 1
            msg = _END.sub("", str(e)) + " (at the end of the file)"
        raise ConfigError(f"TOML: {msg}", path=path, line=line, col=col) from e
    except RecursionError as e:
        raise ConfigError("TOML: nested too deeply", path=path, line=1) from e
