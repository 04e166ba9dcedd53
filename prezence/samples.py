"""The one value that crosses every boundary: a timestamped measurement from one module."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True)
class Sample:
    """One measurement.

    Attributes:
        metric: the metric (module stream) name, e.g. ``speech_speed``.
        t: seconds since the talk began.
        value: the measured value in the metric's unit (finite).
    """

    metric: str
    t: float
    value: float

    def to_dict(self) -> dict[str, Any]:
        return {"metric": self.metric, "t": self.t, "value": self.value}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Sample:
        return cls(str(d["metric"]), float(d["t"]), float(d["value"]))


#: Metric names used by the default configuration (the seed's module names).
SPEECH_SPEED = "speech_speed"  # words per minute
SPEECH_VOLUME = "speech_volume"  # dB SPL at the laptop
SPEECH_ACCURACY = "speech_accuracy"  # recogniser confidence, 0..1
HEAD_GAZE = "cv_headGaze"  # head pitch relative to the audience, degrees (down is negative)
GESTURES = "cv_gestures"  # gestures per minute
DEFAULT_METRICS = (SPEECH_SPEED, SPEECH_VOLUME, SPEECH_ACCURACY, HEAD_GAZE, GESTURES)
