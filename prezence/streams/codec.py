"""One sample per line: ``<t> <value>\\n``, the format of every module stream file.

``t`` is seconds since the talk began and ``value`` the measurement, both written with Python's
shortest round-tripping float form (``repr``), so ``parse_line(format_line(t, v)) == (t, v)``
exactly. A line holding only ``<value>`` (the seed report's format, where modules wrote bare
values) is read too: a live reader stamps it with its own clock and notes the stamp in the
stream's ``.stamps`` sidecar; read afterwards without such a note it has no time, and the
readers skip it as a bad line (see :mod:`.tail`).

Numbers are plain ASCII decimals as Python's ``float()`` reads them (``12``, ``-0.5``, ``1e-3``);
NaN and infinities, digit-group underscores (``1_000``) and non-ASCII digits are refused, and so
is a negative ``t``. Fields are separated by any whitespace, and a trailing ``\\r`` (a file
written on Windows) is ignored.
"""

from __future__ import annotations

import math

from prezence.errors import PrezenceError

__all__ = ["StreamLineError", "format_line", "parse_line"]

_SHOW_MAX = 40  # characters of a bad field quoted in a reason


class StreamLineError(PrezenceError, ValueError):
    """A stream line cannot be read as a sample.

    Attributes:
        reason: what is wrong, without a location (the tailer adds ``file:line``).
    """

    def __init__(self, reason: str) -> None:
        self.reason = reason
        super().__init__(reason)


def format_line(t: float, value: float) -> str:
    """Return the stream line for one sample, newline included.

    Args:
        t: seconds since the talk began; finite and >= 0.
        value: the measurement; finite.

    Returns:
        ``"<t> <value>\\n"`` in the shortest form that reads back to the same floats.

    Raises:
        ValueError: ``t`` or ``value`` is NaN or infinite, or ``t`` is negative.
        TypeError: either is not a real number.

    Example:
        >>> format_line(12.5, 153.25)
        '12.5 153.25\\n'
        >>> format_line(3, 0.1)
        '3.0 0.1\\n'
        >>> format_line(-1.0, 60.0)
        Traceback (most recent call last):
        ...
        ValueError: t must be >= 0, got -1.0
    """
    # float() first: numpy scalars would otherwise print as "np.float64(…)".
    ft = float(t) + 0.0  # + 0.0 turns -0.0 into 0.0
    fv = float(value)
    if not math.isfinite(ft):
        raise ValueError(f"t must be finite, got {ft!r}")
    if not math.isfinite(fv):
        raise ValueError(f"value must be finite, got {fv!r}")
    if ft < 0.0:
        raise ValueError(f"t must be >= 0, got {ft!r}")
    return f"{ft!r} {fv!r}\n"


def parse_line(text: str) -> tuple[float | None, float]:
    """Read one stream line.

    Args:
        text: the line, with or without its newline.

    Returns:
        ``(t, value)``; ``t`` is None for a bare ``<value>`` line.

    Raises:
        StreamLineError: blank line, more than two fields, a field that is not a plain finite
            decimal number, or a negative ``t``; ``reason`` says which.

    Example:
        >>> parse_line("12.5 153.25\\n")
        (12.5, 153.25)
        >>> parse_line("0.82")
        (None, 0.82)
        >>> parse_line("12.5 153.25 7")
        Traceback (most recent call last):
        ...
        prezence.streams.codec.StreamLineError: expected '<t> <value>' or '<value>', got 3 fields
        >>> parse_line("3.0 nan")
        Traceback (most recent call last):
        ...
        prezence.streams.codec.StreamLineError: value is not finite: 'nan'
    """
    fields = text.split()
    n = len(fields)
    if n == 2:
        t = _number(fields[0], "t")
        if t < 0.0:
            raise StreamLineError(f"t is negative: {_show(fields[0])}")
        return t, _number(fields[1], "value")
    if n == 1:
        return None, _number(fields[0], "value")
    if n == 0:
        raise StreamLineError("blank line")
    raise StreamLineError(f"expected '<t> <value>' or '<value>', got {n} fields")


def _number(field: str, what: str) -> float:
    try:
        x = float(field)
    except ValueError as e:
        raise StreamLineError(f"{what} is not a number: {_show(field)}") from e
    if not math.isfinite(x):
        raise StreamLineError(f"{what} is not finite: {_show(field)}")
    # float() also takes "1_000" and non-ASCII digits; a module writing those is broken.
    if "_" in field or not field.isascii():
        raise StreamLineError(f"{what} is not a plain decimal number: {_show(field)}")
    return x


def _show(field: str) -> str:
    if len(field) > _SHOW_MAX:
        field = field[:_SHOW_MAX] + "…"
    return repr(field)
