"""Exception hierarchy: one root, each subclass also inherits the builtin it resembles."""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from pathlib import Path
from typing import Any


class PrezenceError(Exception):
    """Root of every error Prezence raises on purpose."""


class ConfigError(PrezenceError, ValueError):
    """A configuration, scenario or data file is invalid.

    The message starts with ``file:line:col:`` (or ``file: key.path:`` for TOML semantic errors)
    so that editors and terminals can jump to it.
    """

    def __init__(
        self,
        message: str,
        *,
        path: str | Path | None = None,
        line: int | None = None,
        col: int | None = None,
        key: str | None = None,
    ) -> None:
        self.path = str(path) if path is not None else None
        self.line = line
        self.col = col
        self.key = key
        self.reason = message
        super().__init__(self._format())

    def _format(self) -> str:
        where = ""
        if self.path is not None:
            where = self.path
            if self.line is not None:
                where += f":{self.line}"
                if self.col is not None:
                    where += f":{self.col}"
            where += ": "
        if self.key:
            where += f"{self.key}: "
        return where + self.reason


class UnknownName(PrezenceError, LookupError):
    """A name (command, gesture, metric, backend, scenario…) is not known."""

    def __init__(self, kind: str, name: str, known: Iterable[str], hint: str = "") -> None:
        self.kind = kind
        self.name = name
        self.known = sorted(known)
        self.hint = hint
        super().__init__(unknown_message(kind, name, self.known) + (f" ({hint})" if hint else ""))

    def __str__(self) -> str:  # LookupError would quote the whole message otherwise
        return str(self.args[0])

    def __reduce__(self) -> tuple[Any, ...]:
        # Exception pickles as cls(*self.args), i.e. with the message alone, which this
        # __init__ cannot take: a worker process's error would break the process pool.
        return (type(self), (self.kind, self.name, self.known, self.hint), self.__dict__)


class BackendUnavailable(PrezenceError, RuntimeError):
    """A robot backend cannot be used: a missing extra, an unreachable robot, a lost connection."""


class LimitViolation(PrezenceError, ValueError):
    """A gesture or target breaks a joint's position or velocity limit."""


class GestureCheckFailed(PrezenceError, ValueError):
    """A gesture a talk would play fails ``prezence gestures check`` at the talk's speed (it
    takes too long, say): the talk is refused before it starts, as for a limit breach."""


def did_you_mean(name: str, known: Iterable[str]) -> str:
    """Return ``"; did you mean 'x'?"`` when a close match exists, else ``""``."""
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return f"; did you mean '{close[0]}'?" if close else ""


def unknown_message(kind: str, name: str, known: Iterable[str]) -> str:
    """Build ``unknown command 'slowDwn'; did you mean 'slowDown'?`` (or list the known names)."""
    known = sorted(known)
    hint = did_you_mean(name, known)
    if not hint:
        hint = "; known: " + ", ".join(known) if known else "; none are defined"
    return f"unknown {kind} '{name}'{hint}"
