"""What a feedback command asks the presenter to do to its metric.

Below the configuration and the command table, so that ``prezence.feedback`` never imports
``prezence.config`` (the seed-format rules reader looks commands up; the commands need only
this).
"""

from __future__ import annotations

import enum


class Direction(enum.Enum):
    """What a feedback command asks the presenter to do to the metric."""

    RAISE = "raise"
    LOWER = "lower"
    NEUTRAL = "neutral"
