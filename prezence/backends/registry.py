"""Backends by name. Concrete backends are imported on use, so ``prezence`` never imports
pybullet or qi unless that backend is asked for."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any

from prezence.backends.base import Backend
from prezence.errors import BackendUnavailable, UnknownName


@dataclass(frozen=True)
class BackendRecord:
    """A robot backend: where it lives, what to install for it, whether it moves in real time
    and whether it moves a physical body.

    Attributes:
        name: the ``--backend`` name.
        entry_point: ``module:Class``, imported only when the backend is asked for.
        extra: the ``prezence[extra]`` that installs what it needs (None: nothing).
        realtime: the class's own :attr:`~prezence.backends.base.Backend.realtime` (what the
            loop reads; repeated here so that a listing needs no import; a test keeps them
            equal).
        physical: the class's own :attr:`~prezence.backends.base.Backend.physical` (what a
            command reads to refuse gestures whose self-collision was not checked before it
            runs a module or writes a folder; a test keeps them equal).
    """

    name: str
    entry_point: str
    extra: str | None
    realtime: bool
    physical: bool


BACKENDS: dict[str, BackendRecord] = {
    r.name: r
    for r in (
        BackendRecord("fake", "prezence.backends.fake:FakeBackend", None, False, False),
        BackendRecord("sim", "sim.backend:SimBackend", "sim", False, False),
        BackendRecord("naoqi", "prezence.backends.naoqi:NaoqiBackend", "naoqi", True, True),
    )
}


#: Sandbox tools the command line offers (``gestures render``, ``sim serve``): entry points
#: in the ``sim`` extra, imported by name on use so that the product never imports ``sim``.
TOOLS: dict[str, str] = {
    "render": "sim.render:render_gesture",
    "serve": "sim.virtual_nao:main",
}
#: The extras each tool needs (the virtual NAO serves NAOqi through qi).
TOOL_EXTRAS: dict[str, str] = {"render": "sim", "serve": "sim,naoqi"}


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
    return _load(target, f"the {name} tool", TOOL_EXTRAS.get(name, "sim"))


def make_backend(name: str, **kwargs: Any) -> Backend:
    """Construct (not open) the backend called ``name``."""
    try:
        rec = BACKENDS[name]
    except KeyError:
        raise UnknownName("backend", name, BACKENDS) from None
    cls = _load(rec.entry_point, f"the {name} backend", rec.extra or name)
    backend: Backend = cls(**kwargs)
    return backend
