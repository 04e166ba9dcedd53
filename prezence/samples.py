"""The one value that crosses every boundary: a timestamped measurement from one module."""

from __future__ import annotations

from typing import Any, NamedTuple

from prezence.metrics import METRICS as _METRICS


class Sample(NamedTuple):
    """One measurement (immutable).

    A named tuple rather than a frozen dataclass: a replay makes one per line of every stream
    file (200k in the peers' workload), and a frozen dataclass's ``__init__`` (one
    ``object.__setattr__`` per field) took 0.67 µs each against 0.30 µs (timeit, 100k samples).

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


#: How far after the reader's clock a sample may be stamped and still be used (module clocks,
#: window ends). One later than that is bad input: a single bogus future stamp would otherwise
#: make every later real sample look late and silence its metric for the rest of the talk.
MAX_AHEAD_S = 1.0

#: Metric names used by the default configuration (the seed's module names).
SPEECH_SPEED = "speech_speed"  # words per minute
SPEECH_VOLUME = "speech_volume"  # dB SPL at the laptop
SPEECH_ACCURACY = "speech_accuracy"  # recogniser confidence, 0..1
HEAD_GAZE = "cv_headGaze"  # head pitch relative to the audience, degrees (down is negative)
GESTURES = "cv_gestures"  # gestures per minute
#: where each ``cv_gestures`` value came from (the body, the frame difference, not measured):
#: a stream of the vision module's own, read by the report, not a metric the rules judge
GESTURES_SOURCE = "cv_gestures_source"
#: the frame-difference fallback's gesture rate (gestures per minute): written under a metric of
#: its own, which no default rule judges, rather than as ``cv_gestures`` (session 23: the
#: processor judged it like the body's rate and cued "use your hands more" on a video with no
#: one in it, while the report called it too unreliable to advise on)
GESTURES_MOTION = "cv_gestures_motion"
DEFAULT_METRICS = (SPEECH_SPEED, SPEECH_VOLUME, SPEECH_ACCURACY, HEAD_GAZE, GESTURES)
#: Every metric the shipped modules write: the metric records (:data:`prezence.metrics.METRICS`).
#: A rule on another metric is allowed (your own module) but gets a "did you mean" warning, as
#: it is most often a typo.
KNOWN_METRICS: tuple[str, ...] = tuple(_METRICS)
