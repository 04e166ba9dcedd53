"""Per-metric memory of the talk: latest value, weight, onset, staleness.

The weight of a non-strict rule is an integral over time, not a count of samples:

    while out of range:  dW/dt = gain × deviation%            (unit: %·s)
    while in range:      W halves every ``decay_half_life_s``
    while stale:         W decays the same way (the module went quiet; we cannot tell)

The held value (the newest sample) applies from its timestamp until the next sample, so a module
that writes twice as often reaches the threshold at the same time, not twice as soon.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from prezence.config.model import Rule


@dataclass
class MetricState:
    """The processor's running memory of one metric."""

    rule: Rule
    stale_after_s: float
    half_life_s: float
    value: float | None = None
    last_sample_t: float = -math.inf
    integrated_to: float = 0.0
    weight: float = 0.0
    out_since: float | None = None  # onset of the current out-of-range stretch (sample time)
    last_problem_t: float = -math.inf  # newest sample time that was out of range
    strict_pending: bool = False
    strict_onset: float | None = None
    strict_peak: float = 0.0
    strict_side: str | None = None
    last_fired: float = -math.inf
    samples: int = 0
    late: int = 0  # samples older than the newest one already seen: dropped
    ahead: int = 0  # samples stamped too far ahead of the talk clock: dropped

    def advance(self, to_t: float) -> None:
        """Integrate the held value's deviation from ``integrated_to`` up to ``to_t``."""
        t0 = self.integrated_to
        if to_t <= t0:
            return
        self.integrated_to = to_t
        if self.value is None:
            return
        fresh_until = self.last_sample_t + self.stale_after_s
        dev = self.rule.deviation(self.value)
        w = self.weight
        # Fresh part of the interval: grow (out of range) or decay (in range).
        t_fresh_end = min(to_t, fresh_until)
        if t_fresh_end > t0:
            dt = t_fresh_end - t0
            if dev > 0.0:
                w += self.rule.gain * dev * dt
            else:
                w *= 0.5 ** (dt / self.half_life_s)
            t0 = t_fresh_end
        # Stale part: decay.
        if to_t > t0 and w > 0.0:
            w *= 0.5 ** ((to_t - t0) / self.half_life_s)
        self.weight = w

    def ingest(self, t: float, value: float) -> None:
        """Take a new sample at time ``t``.

        A sample older than the newest one already taken is counted in ``late`` and dropped:
        the value held since then is the newer one, and an old value (a module restarted from
        the start of its file, a file replaced and read again) must neither overwrite it nor
        re-arm a strict rule.
        """
        if t < self.last_sample_t:
            self.late += 1
            return
        self.advance(t)
        self.value = value
        self.last_sample_t = t
        self.samples += 1
        dev = self.rule.deviation(value)
        if dev > 0.0:
            if self.out_since is None:
                self.out_since = t
            self.last_problem_t = t
            if self.rule.strict:
                if not self.strict_pending:
                    self.strict_pending = True
                    self.strict_onset = t
                    self.strict_peak = dev
                    self.strict_side = self.rule.side(value)
                elif dev > self.strict_peak:
                    self.strict_peak = dev
                    self.strict_side = self.rule.side(value)
        else:
            self.out_since = None

    def stale(self, now: float) -> bool:
        """True if there is no sample, or the newest one is older than the stale time."""
        return now - self.last_sample_t > self.stale_after_s

    def deviation(self) -> float:
        return 0.0 if self.value is None else self.rule.deviation(self.value)

    def fired(self, now: float) -> None:
        """Reset after this metric was cued."""
        self.weight = 0.0
        self.strict_pending = False
        self.strict_onset = None
        self.strict_peak = 0.0
        self.strict_side = None
        self.last_fired = now
