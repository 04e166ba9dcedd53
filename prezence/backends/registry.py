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


#: Sandbox tools the command line offers (``gestures render``, ``sim serve``): entry points
#: in the ``sim`` extra, imported by name on use so that the product never imports ``sim``.
TOOLS: dict[str, str] = {
    "render": "sim.render:render_gesture",
    "serve": "sim.virtual_nao:main",
}


def _load(target: str, what: str, extra: str) -> Any:
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as e:
        raise BackendUnavailable(f'{what} needs {e.name}: pip install "prezence[{extra}]"') from e
    return getattr(module, attr)


def load_tool(name: str) -> Any:
    """The sandbox tool called ``name`` (see :data:`TOOLS`)."""
    try:
        target = TOOLS[name]
    except KeyError:
        raise UnknownName("tool", name, TOOLS) from None
    return _load(target, f"the {name} tool", "sim")


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
