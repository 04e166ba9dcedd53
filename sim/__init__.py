"""The sandbox: what needs PyBullet, NAOqi serving or Gymnasium (the NAO model, the sim backend,
the virtual NAO, rendering, the Gymnasium environment).

Importing it registers the Gymnasium environment ``prezence/Coach-v1`` (by its entry-point
string: the environment's module loads only when one is made) when Gymnasium is installed, as
environment packages do on import. When Gymnasium is not imported yet, the registration waits
for its import: ``prezence demo --backend sim`` imports this package for the sim backend and
would otherwise pay for importing Gymnasium (about 0.08 s, a tenth of the whole run) that it
never uses. ``import sim; import gymnasium`` and ``import gymnasium; import sim`` both register.
"""

from __future__ import annotations

import importlib.abc
import importlib.machinery
import importlib.util
import sys
from collections.abc import Sequence
from types import ModuleType

ENV_ID = "prezence/Coach-v1"
#: The registration's step limit: a 20-minute talk at the default 0.5 s step. An episode cut
#: short by it ends ``truncated``.
MAX_EPISODE_STEPS = 2400


def register() -> None:
    """Register :data:`ENV_ID` with Gymnasium (again: nothing happens)."""
    import gymnasium as gym

    if ENV_ID not in gym.registry:
        gym.register(
            id=ENV_ID, entry_point="sim.gym_env:CoachEnv", max_episode_steps=MAX_EPISODE_STEPS
        )


class _RegisterOnImport(importlib.abc.MetaPathFinder):
    """Finds nothing itself: when ``gymnasium`` is first imported, it lets the usual finders
    find it and has the loader register :data:`ENV_ID` once the package has run."""

    def find_spec(
        self,
        fullname: str,
        path: Sequence[str] | None,
        target: ModuleType | None = None,
    ) -> importlib.machinery.ModuleSpec | None:
        if fullname != "gymnasium":
            return None
        sys.meta_path.remove(self)  # once: the real finders take it from here
        spec = importlib.util.find_spec(fullname)
        loader = spec.loader if spec is not None else None
        if spec is None or loader is None or not hasattr(loader, "exec_module"):
            return spec
        run = loader.exec_module

        def exec_module(module: ModuleType) -> None:
            run(module)
            register()

        loader.exec_module = exec_module  # type: ignore[method-assign]
        return spec


if "gymnasium" in sys.modules:
    register()
elif importlib.util.find_spec("gymnasium") is not None and not any(
    isinstance(f, _RegisterOnImport) for f in sys.meta_path
):
    sys.meta_path.insert(0, _RegisterOnImport())
