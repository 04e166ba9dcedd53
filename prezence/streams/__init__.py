"""Module stream files: one append-only ``<t> <value>`` line per sample.

- :mod:`.codec`: one line per sample (``format_line``, ``parse_line``).
- :mod:`.writer`: for input-module authors (``StreamWriter``, ``append_sample``).
- :mod:`.tail`: following files while they grow (``StreamTailer``, ``MultiTailer``) and reading
  them whole (``read_stream``), coping with partial lines, bad lines, truncated, replaced and
  missing files.
"""

from prezence.streams.codec import StreamLineError, format_line, parse_line
from prezence.streams.tail import (
    MultiTailer,
    StreamProblem,
    StreamTailer,
    TailStats,
    inotify_available,
    read_stream,
    stamps_path,
)
from prezence.streams.writer import StreamWriter, append_sample

__all__ = [
    "MultiTailer",
    "StreamLineError",
    "StreamProblem",
    "StreamTailer",
    "StreamWriter",
    "TailStats",
    "append_sample",
    "format_line",
    "inotify_available",
    "parse_line",
    "read_stream",
    "stamps_path",
]
