"""The sandbox: what needs PyBullet, NAOqi serving or Gymnasium (the NAO model, the sim backend,
the virtual NAO, rendering, the Gymnasium environment).

Importing it registers the Gymnasium environment ``prezence/Coach-v0`` (by its entry-point
string: the environment's module loads only when one is made) when Gymnasium is installed, as
environment packages do on import.
"""

from __future__ import annotations

import importlib.util

ENV_ID = "prezence/Coach-v0"
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


if importlib.util.find_spec("gymnasium") is not None:
    register()
