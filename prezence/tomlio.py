"""The one TOML reader: stdlib ``tomllib``, with every syntax error as a
:class:`~prezence.errors.ConfigError` naming the file, line and column.

``tomllib`` gives the position as attributes only from Python 3.14; before, it is in the
message (``... (at line 3, column 7)``, or ``(at end of document)``). Both are read here, so
config files, rules, scenarios, the gesture library and the command table report positions
alike on every supported Python.

``tomllib`` keeps no positions for values: :func:`locate` finds the line of a key path by a
scan of the text (best effort), so that semantic errors of configs and scenarios can say
``file:line: key.path: …`` too.
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any

from prezence.errors import ConfigError

#: A key path: table names, keys and array indexes (``("rules", 2, "above")``).
KeyPath = tuple[str | int, ...]

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


def read_text(path: str | Path) -> str:
    """A TOML or rules file's text (UTF-8, optional BOM); unreadable → :class:`ConfigError`."""
    try:
        data = Path(path).read_bytes()
    except OSError as e:
        raise ConfigError(f"cannot read: {e.strerror or e}", path=path) from e
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise ConfigError(f"not UTF-8 text (byte {e.start})", path=path, line=line) from e


def keypath_str(kp: KeyPath) -> str:
    """``("rules", 2, "above")`` → ``rules[2].above``."""
    out = ""
    for part in kp:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


_HEADER = re.compile(r"\s*(\[\[?)([^\[\]]+)\]\]?\s*(?:#.*)?\Z")
_KEYPART = r"""(?:[A-Za-z0-9_-]+|"[^"]*"|'[^']*')"""
_KEYLINE = re.compile(rf"\s*({_KEYPART}(?:\s*\.\s*{_KEYPART})*)\s*=")


def _split_key(s: str) -> tuple[str, ...]:
    # Best effort: a quoted key containing '.' is split too.
    return tuple(p.strip().strip("\"'") for p in s.split("."))


class KeyLines:
    r"""Where each key path of a TOML text is defined (tomllib keeps no positions), from one
    scan of the text: looking up many keys (every keyframe of a gesture library) costs one
    pass, not one pass per key.

    Example:
        >>> kl = KeyLines("format = 1\n[gestures.wave]\nhold = 2\n")
        >>> kl.line(("gestures", "wave", "hold")), kl.line(("gestures", "wave", "x"))
        (3, 2)
        >>> kl.line(("nothing",)) is None
        True
    """

    def __init__(self, text: str) -> None:
        #: each prefix of each defined key path → the first line whose path starts with it
        self._first: dict[KeyPath, int] = {}
        counts: dict[tuple[str, ...], int] = {}
        ctx: KeyPath = ()
        for lineno, line in enumerate(text.split("\n"), start=1):
            m = _HEADER.match(line)
            if m:
                name = _split_key(m.group(2))
                if m.group(1) == "[[":
                    counts[name] = counts.get(name, -1) + 1
                    ctx = (*name, counts[name])
                else:
                    ctx = name
                full = ctx
            else:
                k = _KEYLINE.match(line)
                if not k:
                    continue
                full = (*ctx, *_split_key(k.group(1)))
            for n in range(len(full) + 1):
                self._first.setdefault(full[:n], lineno)

    def line(self, kp: KeyPath) -> int | None:
        """The line that defines ``kp``, else the line of its nearest enclosing table or key
        (the first line sharing the longest prefix with it), else None."""
        for n in range(len(kp), 0, -1):
            found = self._first.get(tuple(kp[:n]))
            if found is not None:
                return found
        return None if kp else self._first.get(())


def locate(text: str, kp: KeyPath) -> int | None:
    """Best-effort line of a key path in TOML text (tomllib keeps no positions).

    Returns the line that defines the key, else the line of its nearest enclosing table or key,
    else None. For many keys of one text, build :class:`KeyLines` once.
    """
    return KeyLines(text).line(kp)


_PART = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


def parse_keypath(key: str) -> KeyPath:
    """``rules[2].above`` → ``("rules", 2, "above")``, the inverse of :func:`keypath_str`.

    Example:
        >>> parse_keypath("episodes[1].at")
        ('episodes', 1, 'at')
    """
    return tuple(int(i) if i else name for name, i in _PART.findall(key))
