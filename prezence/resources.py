"""Where the data files live, from a checkout and from an installed wheel.

The wheel maps ``assets/`` to ``prezence/_data/assets`` and ``scenarios/`` to
``prezence/_data/scenarios`` (hatchling ``force-include`` in ``pyproject.toml``). A checkout (or an
editable install) has them at the repository root instead. Each function tries the package's
``_data`` folder first, then the repository root, and raises ``FileNotFoundError`` naming both.
"""

from __future__ import annotations

import logging
from pathlib import Path

log = logging.getLogger(__name__)

_PACKAGE_DIR = Path(__file__).resolve().parent
_DATA_DIR = _PACKAGE_DIR / "_data"
_REPO_ROOT = _PACKAGE_DIR.parent


def _find(name: str) -> Path:
    candidates = (_DATA_DIR / name, _REPO_ROOT / name)
    for c in candidates:
        if c.is_dir():
            return c
    raise FileNotFoundError(
        f"cannot find the {name!r} data folder; looked in "
        + " and ".join(str(c) for c in candidates)
    )


def assets_dir() -> Path:
    """The ``assets`` folder (robot model and other data files)."""
    return _find("assets")


def scenarios_dir() -> Path:
    """The ``scenarios`` folder (synthetic presenter scripts)."""
    return _find("scenarios")


def urdf_path() -> Path:
    """The project's NAO URDF, ``assets/nao_urdf/nao.urdf``."""
    path = assets_dir() / "nao_urdf" / "nao.urdf"
    if not path.is_file():
        raise FileNotFoundError(f"NAO URDF missing: {path}")
    return path
