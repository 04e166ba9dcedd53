"""Backends by name. Concrete backends are imported on use, so ``prezence`` never imports
pybullet or qi unless that backend is asked for."""

from __future__ import annotations

import importlib
from typing import Any

from prezence.backends.base import Backend
from prezence.errors import BackendUnavailable, UnknownName

BACKENDS: dict[str, str] = {
    "fake": "prezence.backends.fake:FakeBackend",
    "sim": "sim.backend:SimBackend",
    "naoqi": "prezence.backends.naoqi:NaoqiBackend",
}

_EXTRA = {"sim": "sim", "naoqi": "naoqi"}


def make_backend(name: str, **kwargs: Any) -> Backend:
    """Construct (not open) the backend called ``name``."""
    try:
        target = BACKENDS[name]
    except KeyError:
        raise UnknownName("backend", name, BACKENDS) from None
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as e:
        extra = _EXTRA.get(name, name)
        raise BackendUnavailable(
            f'the {name} backend needs {e.name}: pip install "prezence[{extra}]"'
        ) from e
    cls = getattr(module, attr)
    backend: Backend = cls(**kwargs)
    return backend
