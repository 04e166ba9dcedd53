"""Progress bars with an ETA on the terminal (``evaluate``, ``run``, ``rehearse``, ``report``).

:func:`progress_bar` is a context manager that yields a ``(done, total)`` callback, or None when
stderr is not a terminal (logs and pipes get no bar). The bar is finished and its line ended
when the block exits, so a table printed afterwards starts on a line of its own.
"""

from __future__ import annotations

import contextlib
import sys
from collections.abc import Callable, Iterator
from typing import IO

Update = Callable[[float, float], None]


@contextlib.contextmanager
def progress_bar(
    label: str, *, stream: IO[str] | None = None, seconds: bool = False
) -> Iterator[Update | None]:
    """A bar labelled ``label`` with the share done, the count and the time remaining.

    Args:
        stream: where to draw (default stderr); not a terminal: yields None.
        seconds: ``done``/``total`` are seconds of talk (shown as such), not counts.
    """
    out = stream or sys.stderr
    try:
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TaskProgressColumn,
            TextColumn,
            TimeRemainingColumn,
        )
    except ImportError:
        yield None
        return
    if not out.isatty():
        yield None
        return
    count = TextColumn("{task.completed:.0f} s of talk") if seconds else MofNCompleteColumn()
    with Progress(
        TextColumn(label),
        BarColumn(),
        TaskProgressColumn(),
        count,
        TextColumn("ETA"),
        TimeRemainingColumn(),
        console=Console(file=out),
        transient=False,
    ) as bar:
        task = bar.add_task(label, total=None)

        def update(done: float, total: float) -> None:
            bar.update(task, completed=done, total=total)

        yield update


def auto_bar(label: str, *, seconds: bool = False, stream: IO[str] | None = None) -> Update | None:
    """Like :func:`progress_bar`, without a ``with``: the bar starts at the first update and
    ends (its line finished) once ``done`` reaches ``total``. None when not on a terminal."""
    out = stream or sys.stderr
    if not out.isatty():
        return None
    stack = contextlib.ExitStack()
    fns: list[Update | None] = []
    ended = [False]

    def update(done: float, total: float) -> None:
        if ended[0]:
            return
        if not fns:
            fns.append(stack.enter_context(progress_bar(label, stream=out, seconds=seconds)))
        fn = fns[0]
        if fn is not None:
            fn(done, total)
        if total and done >= total:
            ended[0] = True
            stack.close()

    return update
