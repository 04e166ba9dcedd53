"""The Central Processor: production rules over metric streams, one cue at a time.

Pure and deterministic: time comes in as ``now``, samples come in as values, no files, no clock,
no unseeded chance. Call :meth:`Processor.step` at every decision point (the coach does it every
``decision_period_s``); samples may arrive in any batch size: the weights integrate over the
samples' own timestamps, so the batching does not change the result.

Samples stamped more than :data:`prezence.samples.MAX_AHEAD_S` after ``now`` are dropped and
counted (``MetricState.ahead``): one bogus timestamp far in the future would otherwise make
every later real sample look late and silence the metric for the rest of the talk. Samples older
than the metric's newest one are dropped and counted too (``MetricState.late``).

No backlog: a cue is chosen only when the robot is free (``free_since`` is not None), from the
latest data at that moment. Nothing is queued behind a cue being performed; a problem that ended
while the robot was busy is simply no longer a candidate.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from prezence.config.model import Config
from prezence.metrics import default_stale_after_s
from prezence.processor.resolve import ConflictPolicy
from prezence.processor.state import MetricState
from prezence.processor.types import Candidate, Cue, Decision, Kind, MetricView
from prezence.samples import MAX_AHEAD_S, Sample


class Processor:
    """Keeps the books of the talk and decides.

    Args:
        config: rules and settings.
        policy: the conflict resolution policy (required: it changes behaviour).
    """

    def __init__(self, config: Config, *, policy: ConflictPolicy) -> None:
        self.config = config
        self.policy = policy
        s = config.processor
        if not s.decay_half_life_s > 0:
            raise ValueError("processor.decay_half_life_s must be > 0")
        self._states: dict[str, MetricState] = {
            r.metric: MetricState(
                rule=r,
                stale_after_s=(
                    r.stale_after_s
                    if r.stale_after_s is not None
                    else default_stale_after_s(r.metric, s.stale_after_s)
                ),
                half_life_s=s.decay_half_life_s,
            )
            for r in config.rules
        }
        self._order = tuple(r.metric for r in config.rules)
        # A mark at or above the allocated time (a 90 s talk has no "2 min left") is never due.
        alloc = config.time.allocated_s
        self._time_marks_given: set[float] = {
            m for m in config.time.warn_at_s_left if alloc is not None and m >= alloc
        }
        self._last_overtime = -math.inf
        self._last_cue_t = -math.inf
        self._last_cue: Cue | None = None
        self.unknown_samples = 0
        self.cues: list[Cue] = []

    # -- input -----------------------------------------------------------------------------
    def ingest(self, samples: Iterable[Sample], *, now: float | None = None) -> None:
        """Take samples (any order within a batch; each metric's own order matters).

        Args:
            samples: the new samples.
            now: the talk clock; samples stamped after ``now + MAX_AHEAD_S`` are dropped
                and counted. None takes every sample's time as it is.
        """
        states = self._states
        horizon = math.inf if now is None else now + MAX_AHEAD_S
        for s in samples:
            st = states.get(s.metric)
            if st is None:
                self.unknown_samples += 1
                continue
            if s.t > horizon:
                st.ahead += 1
                continue
            st.ingest(s.t, s.value)

    def counts(self) -> dict[str, dict[str, int]]:
        """Per metric: samples used, and samples dropped as ``late`` or ``ahead`` of the clock."""
        return {
            m: {"used": st.samples, "late": st.late, "ahead": st.ahead}
            for m, st in self._states.items()
        }

    def state(self, metric: str) -> MetricState:
        return self._states[metric]

    @property
    def states(self) -> tuple[MetricState, ...]:
        return tuple(self._states.values())

    # -- decision --------------------------------------------------------------------------
    def step(
        self,
        now: float,
        samples: Iterable[Sample] = (),
        *,
        free_since: float | None,
        with_views: bool = True,
    ) -> Decision:
        """Ingest ``samples``, integrate to ``now`` and decide.

        Args:
            now: seconds since the talk began.
            samples: new samples since the last step.
            free_since: when the robot last became free (None while it is busy). The minimum
                gap is counted from here.
            with_views: put every metric's view in the decision (False: an empty tuple; ask
                :meth:`views` when one is needed).

        Returns:
            The decision; its ``cue`` is set when a cue must be given now.
        """
        self.ingest(samples, now=now)
        for st in self._states.values():
            st.advance(now)
        views = self.views(now) if with_views else ()
        if free_since is None:
            return Decision(now, None, "robot busy", True, (), views)
        gap = self.config.processor.min_gap_s
        if self._last_cue is not None and now - free_since < gap:
            return Decision(
                now, None, f"min gap ({gap:g} s) since the robot became free", False, (), views
            )
        cands = self._candidates(now)
        if not cands:
            return Decision(now, None, "all metrics in range or below threshold", False, (), views)
        chosen = self.policy.choose(cands, self._order)
        if chosen is None:
            return Decision(
                now, None, f"policy {self.policy.name} chose none", False, tuple(cands), views
            )
        cue = self._fire(chosen, cands, now)
        return Decision(now, cue, cue.reason, False, tuple(cands), views)

    def views(self, now: float) -> tuple[MetricView, ...]:
        """Every metric's state at ``now`` (the decision log, live views)."""
        return tuple(self._view(st, now) for st in self._states.values())

    def status(self, now: float) -> tuple[tuple[bool, str | None, bool], ...]:
        """A cheap summary of every metric's state: (stale or no value, side out of range,
        strict cue pending). The decision log writes a line when it changes."""
        return tuple(
            [
                (
                    st.value is None or now - st.last_sample_t > st.stale_after_s,
                    None if st.value is None else st.rule.side(st.value),
                    st.strict_pending,
                )
                for st in self._states.values()
            ]
        )

    def _view(self, st: MetricState, now: float) -> MetricView:
        return MetricView(
            metric=st.rule.metric,
            value=st.value,
            deviation=st.deviation(),
            weight=st.weight,
            stale=st.stale(now),
            refractory=now - st.last_fired < self.config.processor.refractory_s,
            strict_pending=st.strict_pending,
        )

    def _candidates(self, now: float) -> list[Candidate]:
        s = self.config.processor
        out: list[Candidate] = []
        out.extend(self._time_candidates(now))
        all_out = self.policy.wants_all_out_of_range
        any_problem_recent = False
        for st in self._states.values():
            r = st.rule
            if st.value is None or st.stale(now):
                continue
            if now - st.last_problem_t < s.praise_after_s:
                any_problem_recent = True
            if now - st.last_fired < s.refractory_s:
                continue
            dev = st.deviation()
            side = r.side(st.value)
            if r.strict and st.strict_pending:
                strict_side = side or st.strict_side
                command = r.below if strict_side == "below" else r.above
                if command is None:
                    continue
                out.append(
                    Candidate(
                        Kind.STRICT,
                        command,
                        r.metric,
                        eligible=True,
                        weight=max(st.strict_peak, dev),
                        deviation=dev,
                        value=st.value,
                        side=strict_side,
                        onset=st.strict_onset,
                        recency=st.last_sample_t,
                    )
                )
                continue
            if dev <= 0.0 or side is None:
                continue
            command = r.below if side == "below" else r.above
            if command is None:
                continue
            eligible = st.weight >= s.threshold
            if eligible or all_out:
                out.append(
                    Candidate(
                        Kind.WEIGHTED,
                        command,
                        r.metric,
                        eligible=eligible,
                        weight=st.weight,
                        deviation=dev,
                        value=st.value,
                        side=side,
                        onset=st.out_since,
                        recency=st.last_sample_t,
                    )
                )
        if (
            s.praise_command
            and s.praise_after_s > 0
            and not out
            and not any_problem_recent
            and now - max(self._last_cue_t, 0.0) >= s.praise_after_s
            and any(st.value is not None and not st.stale(now) for st in self._states.values())
        ):
            out.append(Candidate(Kind.PRAISE, s.praise_command, None, eligible=True, recency=now))
        return out

    def _time_candidates(self, now: float) -> list[Candidate]:
        ts = self.config.time
        if ts.allocated_s is None:
            return []
        left = ts.allocated_s - now
        if left < 0.0:
            due = self._last_overtime == -math.inf or (
                ts.overtime_repeat_s > 0 and now - self._last_overtime >= ts.overtime_repeat_s
            )
            if not due:
                return []
            over = -left
            return [
                Candidate(
                    Kind.TIME,
                    ts.overtime_command,
                    None,
                    eligible=True,
                    weight=math.inf,
                    recency=now,
                    onset=ts.allocated_s,
                    params={"minutes_over": int(over // 60)},
                )
            ]
        # The most urgent crossed mark not yet given; earlier marks it supersedes are skipped.
        crossed = [m for m in ts.warn_at_s_left if left <= m and m not in self._time_marks_given]
        if not crossed:
            return []
        mark = min(crossed)
        minutes = max(1, int(round(mark / 60.0)))
        return [
            Candidate(
                Kind.TIME,
                ts.warn_command,
                None,
                eligible=True,
                weight=math.inf,
                recency=now,
                onset=ts.allocated_s - mark,
                params={"minutes": minutes, "mark_s": mark},
            )
        ]

    def _fire(self, c: Candidate, cands: list[Candidate], now: float) -> Cue:
        reason = self._reason(c, cands)
        if c.kind == Kind.TIME:
            if c.command == self.config.time.overtime_command and "mark_s" not in c.params:
                self._last_overtime = now
            else:
                mark = float(c.params["mark_s"])
                self._time_marks_given.update(
                    m for m in self.config.time.warn_at_s_left if m >= mark
                )
        elif c.metric is not None:
            self._states[c.metric].fired(now)
        params = {k: v for k, v in c.params.items() if k != "mark_s"}
        cue = Cue(
            t=now,
            command=c.command,
            metric=c.metric,
            kind=c.kind,
            reason=reason,
            params=params,
            onset=c.onset,
            deviation=c.deviation,
            weight=c.weight,
        )
        self._last_cue_t = now
        self._last_cue = cue
        self.cues.append(cue)
        return cue

    def _reason(self, c: Candidate, cands: list[Candidate]) -> str:
        thr = self.config.processor.threshold
        if c.kind == Kind.TIME:
            if "minutes" in c.params:
                why = f"{c.params['minutes']} min left of {self.config.time.allocated_s:g} s"
            else:
                why = f"over the allocated {self.config.time.allocated_s:g} s"
        elif c.kind == Kind.PRAISE:
            why = "every metric in range for a while"
        else:
            assert c.metric is not None  # noqa: S101 - metric candidates always carry one
            r = self._states[c.metric].rule
            bound = r.low if c.side == "below" else r.high
            unit = f" {r.unit}" if r.unit else ""
            since = f" since {c.onset:.1f} s" if c.onset is not None else ""
            if c.kind == Kind.STRICT:
                now_ = "" if c.deviation > 0 else f" (now {c.value:.4g}, back in range)"
                why = f"strict: {c.metric} went {c.side} {bound:g}{unit}{since}{now_}"
            else:
                why = f"{c.metric} {c.value:.4g} is {c.deviation:.0f}% {c.side} {bound:g}{unit}"
                if c.eligible:
                    why += f"{since} (weight {c.weight:.0f} >= {thr:g})"
        others = [o for o in cands if o is not c]
        if others:
            beat = ", ".join(
                f"{o.command}" + (f" ({o.weight:.0f})" if math.isfinite(o.weight) else "")
                for o in sorted(
                    others, key=lambda o: -o.weight if math.isfinite(o.weight) else -1e18
                )[:3]
            )
            why += f"; beat {beat} [{self.policy.name}]"
        return why
