"""Session folders made safely: a new folder per talk, never one that holds a recording.

``prezence up``, ``replay`` and ``rehearse`` write into a folder of their own. Without ``--out``
it is ``sessions/<kind>-YYYYMMDD-HHMMSS`` (a ``-2``, ``-3`` … suffix when two start in the same
second). With ``--out DIR``, an existing non-empty ``DIR`` is refused; ``--force`` moves it
aside to ``DIR.old-YYYYMMDD-HHMMSS`` first, so that even then nothing recorded is deleted.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterator
from pathlib import Path

from prezence.errors import ConfigError

#: Where sessions go when no ``--out`` is given.
SESSIONS_ROOT = Path("sessions")


def _stamp(t: float | None = None) -> str:
    return time.strftime("%Y%m%d-%H%M%S", time.localtime(t))


def _is_empty_dir(path: Path) -> bool:
    return path.is_dir() and not any(path.iterdir())


def default_session_dir(kind: str, *, root: Path = SESSIONS_ROOT, now: float | None = None) -> Path:
    """``root/<kind>-YYYYMMDD-HHMMSS`` that does not exist yet (suffixed ``-2``, ``-3`` …)."""
    base = root / f"{kind}-{_stamp(now)}"
    cand, n = base, 1
    while cand.exists():
        n += 1
        cand = base.with_name(f"{base.name}-{n}")
    return cand


def claim_session_dir(
    out: str | Path | None,
    kind: str,
    *,
    force: bool = False,
    root: Path = SESSIONS_ROOT,
    protect: tuple[Path, ...] = (),
    default: Path | None = None,
) -> Path:
    """Create and return a new, empty session folder.

    Args:
        out: the folder the user asked for (None: :func:`default_session_dir`).
        kind: ``live``, ``replay``, ``rehearsal``: the default folder's prefix.
        force: move an existing non-empty ``out`` aside (``out.old-<stamp>``) instead of refusing.
        protect: folders that must not be moved aside nor written into (a replay's source):
            ``out`` may be none of them, nor inside one, nor hold one.
        default: the folder to use when ``out`` is None (suffixed ``-2``, ``-3`` … when it
            exists); None: ``root/<kind>-<time>``.

    The folder is held (:class:`prezence.session.FolderLock`) until the talk that writes into
    it ends, or the process: two commands started together never share a folder.

    Raises:
        ConfigError: ``out`` exists and is not empty (without ``force``), is a file, cannot be
            made, overlaps a protected folder, or another process is writing into it.
    """
    from prezence.session import FolderInUse, FolderLock

    if out is None:
        path = default_session_dir(kind, root=root) if default is None else default
        base, n = path.name, 1
        while True:
            if not path.exists() or _is_empty_dir(path):
                try:  # held from here on: a second process at the same moment moves on
                    FolderLock.take(_mkdir(path))
                    return path
                except FolderInUse:
                    pass
            n += 1
            path = path.with_name(f"{base}-{n}")
    path = Path(out)
    for p in protect:
        if overlaps(path, p):
            raise ConfigError(
                f"--out overlaps the recording {p}: it is never written into or over; "
                "give another folder",
                path=path,
            )
    if path.exists() and not path.is_dir():
        raise ConfigError("--out is a file, not a folder", path=path)
    if path.exists() and not _is_empty_dir(path):
        if not force:
            raise ConfigError(
                "already exists and is not empty; nothing recorded is overwritten: give "
                "another --out, leave --out out for a new folder of its own, or add --force "
                f"to move it aside to {path.name}.old-<time>",
                path=path,
            )
        aside = path.with_name(f"{path.name}.old-{_stamp()}")
        n = 1
        while aside.exists():
            n += 1
            aside = path.with_name(f"{path.name}.old-{_stamp()}-{n}")
        path.rename(aside)
    FolderLock.take(_mkdir(path))  # another process's command into it now: refused
    return path


def _mkdir(path: Path) -> Path:
    """Make ``path``; one that cannot be made (no permission, a file above it) is an error line."""
    from prezence.session import folder_error

    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise folder_error(path, e, what="folder") from None
    return path


def overlaps(a: Path, b: Path) -> bool:
    """Whether folder ``a`` is ``b``, inside ``b``, or holds ``b`` (links resolved)."""
    ra, rb = Path(a).resolve(), Path(b).resolve()
    return ra == rb or rb in ra.parents or ra in rb.parents


@contextlib.contextmanager
def drop_if_left_empty(folder: Path) -> Iterator[None]:
    """Remove ``folder`` again when the command fails before writing anything into it (an
    empty folder only: ``rmdir`` never deletes a file)."""
    from prezence.session import release_folder

    try:
        yield
    except BaseException:
        release_folder(folder)
        with contextlib.suppress(OSError):
            folder.rmdir()
        raise
