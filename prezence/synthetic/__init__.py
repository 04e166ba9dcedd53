"""Synthetic talks: scenario files, closed-loop presenters that play them, the headless runner.

Pure Python (no PyBullet, NAOqi or Gymnasium): ``prezence demo`` and ``prezence run`` need
nothing from the ``sim`` sandbox.
"""
