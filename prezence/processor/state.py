"""Per-metric memory of the talk: latest value, weight, onset, staleness.

The weight of a non-strict rule is an integral over time, not a count of samples:

    while out of range:  dW/dt = gain × deviation% × P        (unit: %·s)
    while in range:      W halves every ``decay_half_life_s``
    while stale:         W decays the same way (the module went quiet; we cannot tell)

``P`` is the metric's *persistence*, the share of the recent past it spent out of range: an
exponential average of "out of range" (1) and "in range" (0) with time constant
``persistence_s``, so ``dP/dt = (out - P) / persistence_s``. A deviation held for a while has
P near 1 and weighs its full deviation × time; a flicker (out 1 s of every 2 s) has P near 0.5,
so each of its out-of-range seconds weighs about half, and the decay in between takes back most
of it: the seed's "a brief or intermittent deviation weighs less". With ``persistence_s = 0``
P is 1 at once (the plain integral). Both W and P are integrated in closed form from the last
event (a sample taken, a cue given) to the time asked, and only events move that base: neither
the batching of samples nor when or how often the weight is looked at changes the result.

The held value (the newest sample) applies from its timestamp until the next sample, so a module
that writes twice as often reaches the threshold at the same time, not twice as soon.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from prezence.config.model import Rule


@dataclass(slots=True)
class MetricState:
    """The processor's running memory of one metric."""

    rule: Rule
    stale_after_s: float
    half_life_s: float
    persistence_s: float = 0.0
    effect_s: float = 10.0
    value: float | None = None
    last_sample_t: float = -math.inf
    #: W and P are kept as of this time (the last sample taken or cue given): between two
    #: such events they follow in closed form (:meth:`weight_at`), so looking at the weight
    #: at any time changes nothing, and the result does not depend on when it is looked at.
    base_t: float = 0.0
    base_weight: float = 0.0
    base_persistence: float = 0.0  # share of the recent past out of range (see the module doc)
    out_since: float | None = None  # onset of the current out-of-range stretch (sample time)
    last_problem_t: float = -math.inf  # newest sample time that was out of range
    strict_pending: bool = False
    strict_onset: float | None = None
    strict_peak: float = 0.0
    strict_side: str | None = None
    # A strict rule warns once per excursion: cueing it disarms it; an in-range sample re-arms
    # it, and so does a sample still out of range once ``rearm_after_s`` has passed since the
    # cue (the processor sets it to the refractory time: a held strict problem is reminded).
    strict_armed: bool = True
    rearm_after_s: float = math.inf
    last_fired: float = -math.inf
    # Escalation: cues about this metric since it last came back in range for ``effect_s``.
    unheeded: int = 0
    in_range_since: float | None = None
    samples: int = 0
    late: int = 0  # samples older than the newest one already seen: dropped
    ahead: int = 0  # samples stamped too far ahead of the talk clock: dropped
    #: The weight the processor's threshold asks for (only :attr:`reach_t` uses it).
    threshold: float = math.inf
    # The held value's deviation and side of the band, set with it in ingest (the hot path
    # reads them every step instead of recomputing them from the rule).
    dev: float = field(default=0.0, repr=False, compare=False)
    side: str | None = field(default=None, repr=False, compare=False)
    #: No earlier than this can W reach ``threshold`` with the value held now (W grows by at
    #: most gain × deviation% per second), so before it the weight need not be worked out.
    reach_t: float = field(default=math.inf, repr=False, compare=False)

    def _integrate(self, to_t: float) -> tuple[float, float]:
        """W and P at ``to_t``, integrated from ``base_t`` with the value held since then."""
        t0 = self.base_t
        w = self.base_weight
        p = self.base_persistence
        if to_t <= t0 or self.value is None:
            return w, p
        fresh_until = self.last_sample_t + self.stale_after_s
        dev = self.dev
        tau = self.persistence_s
        # Fresh part of the interval: grow (out of range) or decay (in range).
        t_fresh_end = to_t if to_t <= fresh_until else fresh_until  # min(), without the call
        if t_fresh_end > t0:
            dt = t_fresh_end - t0
            if dev > 0.0:
                if tau > 0.0:
                    # integral of P over dt, P relaxing from p toward 1
                    k = math.exp(-dt / tau)
                    w += self.rule.gain * dev * (dt - (1.0 - p) * tau * (1.0 - k))
                    p = 1.0 - (1.0 - p) * k
                else:
                    w += self.rule.gain * dev * dt
                    p = 1.0
            else:
                w *= 0.5 ** (dt / self.half_life_s)
                p = p * math.exp(-dt / tau) if tau > 0.0 else 0.0
            t0 = t_fresh_end
        # Stale part: decay (nothing is known, so nothing counts as out of range).
        if to_t > t0:
            if w > 0.0:
                w *= 0.5 ** ((to_t - t0) / self.half_life_s)
            p = p * math.exp(-(to_t - t0) / tau) if tau > 0.0 else 0.0
        return w, p

    def weight_at(self, now: float) -> float:
        """The weight W at ``now`` (``now`` at or after the last sample or cue)."""
        return self._integrate(now)[0]

    def _move_base(self, t: float) -> None:
        """Integrate W and P up to ``t`` and keep them as of ``t`` (a sample or a cue)."""
        if t > self.base_t:
            self.base_weight, self.base_persistence = self._integrate(t)
            self.base_t = t

    def _reach(self) -> None:
        """When W reaches the threshold at the present deviation (``reach_t``): -inf once it
        has, inf when it cannot. :meth:`ingest` writes this out for speed; keep the two alike
        (a test compares them)."""
        rate = self.rule.gain * self.dev
        if self.base_weight >= self.threshold:
            self.reach_t = -math.inf
        elif rate > 0.0:
            # a little early, so that rounding never makes it late
            reach = self.base_t + (self.threshold - self.base_weight) / rate
            self.reach_t = reach - 1e-6 * (1.0 + abs(reach))
        else:
            self.reach_t = math.inf

    def ingest(self, t: float, value: float) -> bool:
        """Take a new sample at time ``t``.

        A sample older than the newest one already taken is counted in ``late`` and dropped:
        the value held since then is the newer one, and an old value (a module restarted from
        the start of its file, a file replaced and read again) must neither overwrite it nor
        re-arm a strict rule.
        """
        last_t = self.last_sample_t
        if t < last_t:
            self.late += 1
            return False
        rule = self.rule
        stale_after_s = self.stale_after_s
        # _move_base(t), with the value held until now: _integrate(t) written out, as it runs
        # once per sample (a test compares the two); the same operations in the same order
        t0 = self.base_t
        w = self.base_weight
        if t > t0:
            if self.value is not None:
                p = self.base_persistence
                fresh_until = last_t + stale_after_s
                held = self.dev
                tau = self.persistence_s
                t_fresh_end = t if t <= fresh_until else fresh_until
                if t_fresh_end > t0:
                    dt = t_fresh_end - t0
                    if held > 0.0:
                        if tau > 0.0:
                            k = math.exp(-dt / tau)
                            w += rule.gain * held * (dt - (1.0 - p) * tau * (1.0 - k))
                            p = 1.0 - (1.0 - p) * k
                        else:
                            w += rule.gain * held * dt
                            p = 1.0
                    else:
                        w *= 0.5 ** (dt / self.half_life_s)
                        p = p * math.exp(-dt / tau) if tau > 0.0 else 0.0
                    t0 = t_fresh_end
                if t > t0:
                    if w > 0.0:
                        w *= 0.5 ** ((t - t0) / self.half_life_s)
                    p = p * math.exp(-(t - t0) / tau) if tau > 0.0 else 0.0
                self.base_weight = w
                self.base_persistence = p
            self.base_t = t
        # After a gap longer than the staleness limit nothing is known of the time between:
        # an out-of-range stretch starts again at this sample (session 20: a 40 s pause, with
        # no speed written, counted in "since 22 s, 65 s after onset", and a report's delay
        # was counted across 28 s without a sample).
        if t - last_t > stale_after_s:
            self.out_since = None
            self.in_range_since = None  # nor is a stretch back in range known across it
            if self.strict_pending:
                self.strict_onset = t
        self.value = value
        self.last_sample_t = t
        self.samples += 1
        # rule.judge(value), written out (once per sample; a test compares the two)
        v = value + rule.offset
        low = rule.low
        high = rule.high
        if low is not None and v < low:
            ref = rule.scale if rule.scale is not None else low
            dev = 100.0 * (low - v) / ref
            side: str | None = "below"
        elif high is not None and v > high:
            ref = rule.scale if rule.scale is not None else high
            dev = 100.0 * (v - high) / ref
            side = "above"
        else:
            dev = 0.0
            side = None
        self.dev = dev
        self.side = side
        # _reach(), written out (once per sample)
        rate = rule.gain * dev
        threshold = self.threshold
        if w >= threshold:
            self.reach_t = -math.inf
        elif rate > 0.0:  # a little early, as in _reach
            reach = self.base_t + (threshold - w) / rate
            self.reach_t = reach - 1e-6 * (1.0 + abs(reach))
        else:
            self.reach_t = math.inf
        if dev > 0.0:
            if self.out_since is None:
                self.out_since = t
            self.last_problem_t = t
            self.in_range_since = None
            if rule.strict and not self.strict_armed and t - self.last_fired >= self.rearm_after_s:
                self.strict_armed = True
            if rule.strict and self.strict_armed:
                if not self.strict_pending:
                    self.strict_pending = True
                    self.strict_onset = t
                    self.strict_peak = dev
                    self.strict_side = side
                elif dev > self.strict_peak:
                    self.strict_peak = dev
                    self.strict_side = side
        else:
            self.out_since = None
            self.strict_armed = True
            if self.in_range_since is None:
                self.in_range_since = t
            if t - self.in_range_since >= self.effect_s:
                self.unheeded = 0  # back in range for a while: the cues had an effect
        return True

    def stale(self, now: float) -> bool:
        """True if there is no sample, or the newest one is older than the stale time."""
        return now - self.last_sample_t > self.stale_after_s

    def deviation(self) -> float:
        return 0.0 if self.value is None else self.dev

    def fired(self, now: float) -> None:
        """Reset after this metric was cued at ``now``: its weight starts again from 0."""
        self._move_base(now)
        self.base_weight = 0.0
        self._reach()
        self.strict_pending = False
        self.strict_onset = None
        self.strict_peak = 0.0
        self.strict_side = None
        self.strict_armed = False
        self.last_fired = now
        self.unheeded += 1
