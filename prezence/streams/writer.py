"""Writing a module stream: for input-module authors.

Each :meth:`StreamWriter.write` is one ``os.write`` of one whole line on a file opened with
``O_APPEND``. There is no Python-level buffer, so a line is in the OS as soon as ``write``
returns: a reader sees either nothing or the whole line (short of the instant the system call is
in flight), and a crash of the module loses no finished line. Lines are not ``fsync``-ed: a power
cut may still lose the last ones. Two processes appending small lines to one file do not
interleave within a line on a local file system, but give each module its own file.

Example::

    from prezence.streams import StreamWriter

    with StreamWriter(session.stream("speech_speed.txt")) as w:
        for t, wpm in measurements():
            w.write(t, wpm)
"""

from __future__ import annotations

import os
from pathlib import Path
from types import TracebackType

from prezence.streams.codec import format_line

__all__ = ["StreamWriter", "append_sample"]

# O_BINARY keeps Windows from turning "\n" into "\r\n"; it is 0 (absent) elsewhere.
_FLAGS = os.O_WRONLY | os.O_APPEND | os.O_CREAT | getattr(os, "O_BINARY", 0)


class StreamWriter:
    """Appends ``<t> <value>`` lines to one stream file.

    The file (and its parent folders) is created by :meth:`open` or ``with``, not by the
    constructor. :meth:`close` may be called more than once.

    Args:
        path: the stream file.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        self._fd: int | None = None

    @property
    def closed(self) -> bool:
        """True before :meth:`open` and after :meth:`close`."""
        return self._fd is None

    def open(self) -> StreamWriter:
        """Open the file for appending, creating it and its parent folders if needed.

        Returns:
            ``self``, so that ``w = StreamWriter(p).open()`` reads well.
        """
        if self._fd is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._fd = os.open(self.path, _FLAGS, 0o644)
        return self

    def write(self, t: float, value: float) -> None:
        """Append one sample as one whole line.

        Args:
            t: seconds since the talk began; finite and >= 0.
            value: the measurement; finite.

        Raises:
            ValueError: the writer is not open, or ``t``/``value`` is NaN, infinite or ``t`` < 0
                (nothing is written then).
            OSError: the OS refused the write (disk full, …).
        """
        if self._fd is None:
            raise ValueError(f"{self.path}: StreamWriter is not open; call open() or use 'with'")
        data = format_line(t, value).encode("ascii")
        _write_all(self._fd, data)

    def close(self) -> None:
        """Close the file; a second call does nothing."""
        fd, self._fd = self._fd, None
        if fd is not None:
            os.close(fd)

    def __enter__(self) -> StreamWriter:
        return self.open()

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def __repr__(self) -> str:
        state = "closed" if self.closed else "open"
        return f"StreamWriter({str(self.path)!r}, {state})"


def append_sample(path: str | os.PathLike[str], t: float, value: float) -> None:
    """Append one sample to ``path`` (opened and closed around it; parents created).

    Convenient for a module that writes rarely; one that writes often should keep a
    :class:`StreamWriter` open.

    Raises:
        ValueError: ``t`` or ``value`` is NaN or infinite, or ``t`` < 0.
    """
    format_line(t, value)  # validate before creating any file or folder
    with StreamWriter(path) as w:
        w.write(t, value)


def _write_all(fd: int, data: bytes) -> None:
    # A regular file takes the whole line in one call; loop only for the rare short write
    # (signal, nearly full disk) so that no line is ever left half written by us.
    view = memoryview(data)
    while view:
        n = os.write(fd, view)
        view = view[n:]
