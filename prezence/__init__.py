"""Prezence: a NAO humanoid coaches a person while they rehearse a talk.

The product package. It never imports pybullet, gymnasium or qi at import time: the simulator
(``sim``) is reached only through :mod:`prezence.backends.registry`, and ``qi`` only inside
:class:`prezence.backends.naoqi.NaoqiBackend`.
"""

__version__ = "0.1.0"
