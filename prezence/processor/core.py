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
while the robot was busy is simply no longer a candidate, and a strict warning whose newest
out-of-range sample is older than the metric's stale time is dropped, not given late.

A cue the robot could not give (:meth:`Processor.cue_dropped`) leaves the metric as it was
before: no refractory, no reset of its weight, no spent time mark.

Escalation (policy parameter ``escalate_after`` = N > 0): once a metric has been cued N times
without coming back in range for ``effect_s`` in between, the coach stops cueing it for the rest
of the talk and records it in :attr:`Processor.escalations`, to be said once at the end and in
the report (:func:`end_of_talk_notes`).

Whole policies (:attr:`ConflictPolicy.whole`, the anchors of :mod:`prezence.processor.anchors`)
keep their own books: they see every accepted sample and decide on their own timing; the
processor still keeps the metric views for the decision log.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterable
from typing import Any

from prezence.config.model import Config
from prezence.metrics import default_stale_after_s
from prezence.processor.resolve import ConflictPolicy
from prezence.processor.state import MetricState
from prezence.processor.types import Candidate, Cue, Decision, Kind, MetricView, _logged
from prezence.samples import MAX_AHEAD_S, Sample

#: The reason of a free decision point with no candidate.
_NO_CUE = "all metrics in range or below threshold"


def _early(t: float) -> float:
    """``t`` a little early, so that rounding never makes a time bound late."""
    return t - 1e-6 * (1.0 + abs(t))


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
        #: The settings in force: the config's, with the policy's overrides applied.
        self.settings = policy.settings(s)
        s = self.settings
        if not s.decay_half_life_s > 0:
            raise ValueError("processor.decay_half_life_s must be > 0")
        self.persistence_s = float(policy.params.get("persistence_s", 0.0))
        self.escalate_after = int(policy.params.get("escalate_after", 0))
        effect_s = float(policy.params.get("effect_s", 10.0))
        self._states: dict[str, MetricState] = {
            r.metric: MetricState(
                rule=r,
                stale_after_s=(
                    r.stale_after_s
                    if r.stale_after_s is not None
                    else default_stale_after_s(r.metric, s.stale_after_s)
                ),
                half_life_s=s.decay_half_life_s,
                persistence_s=self.persistence_s,
                effect_s=effect_s,
                rearm_after_s=s.refractory_s,
                threshold=s.threshold,
            )
            for r in config.rules
        }
        policy.start(config)
        self._order = tuple(r.metric for r in config.rules)
        # A mark at or above the allocated time (a 90 s talk has no "2 min left") is never due.
        alloc = config.time.allocated_s
        self._time_marks_given: set[float] = {
            m for m in config.time.warn_at_s_left if alloc is not None and m >= alloc
        }
        self._last_overtime = -math.inf
        #: The time used at the last step (its ``spent``): the clock of the time warnings.
        self._spent = 0.0
        self._last_cue_t = -math.inf
        self._last_cue: Cue | None = None
        self.unknown_samples = 0
        self.cues: list[Cue] = []
        #: Metrics the coach stopped cueing (escalation): one record each, in order.
        self.escalations: list[dict[str, Any]] = []
        self._escalated: set[str] = set()
        #: The reason of a free decision point with no candidate (one string, made again only
        #: when a metric is escalated: the decision log compares it at every point).
        self._no_cue_why = _NO_CUE
        self._min_gap_why = f"min gap ({s.min_gap_s:g} s) since the robot became free"
        #: Each metric's place in the rules' order (and in :meth:`status`).
        self._index = {m: i for i, m in enumerate(self._states)}
        self._undo: tuple[Cue, str | None, MetricState | None, set[float], float] | None = None
        # status(): the last one worked out, and the time before which it cannot change
        # unless a sample or a cue changes it (then it is dropped)
        self._status: tuple[tuple[bool, str | None, bool], ...] = ()
        self._status_until = -math.inf
        # quiet_until(): the robot's free_since at the last step, and until when a step with
        # no sample would decide as it did (-inf: it gave a cue, or a candidate); the time
        # warnings' part of it (-inf: to be worked out again)
        self._quiet_free: float | None = None
        self._quiet = -math.inf
        self._time_quiet = -math.inf
        self._cand_quiet = -math.inf

    # -- input -----------------------------------------------------------------------------
    def ingest(self, samples: Iterable[Sample], *, now: float | None = None) -> None:
        """Take samples (any order within a batch; each metric's own order matters).

        Args:
            samples: the new samples.
            now: the talk clock; samples stamped after ``now + MAX_AHEAD_S`` are dropped
                and counted. None takes every sample's time as it is.
        """
        self._quiet = -math.inf  # quiet_until(): the state moves on
        states = self._states
        index = self._index
        whole = self.policy.whole
        horizon = math.inf if now is None else now + MAX_AHEAD_S
        # The status kept (see status()), while it holds: a sample leaves it so unless it
        # changes its metric's part of it (fresh, side, strict warning pending). A newer
        # sample only moves a fresh metric's stale time later: the time it was kept until
        # stays safe.
        kept = self._status if self._status_until > -math.inf else None
        for metric, t, value in samples:
            st = states.get(metric)
            if st is None:
                self.unknown_samples += 1
                continue
            if t > horizon:
                st.ahead += 1
                continue
            if st.ingest(t, value):
                if kept is not None:
                    stale, side, pending = kept[index[metric]]
                    if stale or side != st.side or pending != st.strict_pending:
                        self._status_until = -math.inf
                        kept = None
                if whole:
                    self.policy.feed(st.rule, t, value)

    def counts(self) -> dict[str, dict[str, int]]:
        """Per metric: samples used, and samples dropped as ``late`` or ``ahead`` of the clock."""
        return {
            m: {"used": st.samples, "late": st.late, "ahead": st.ahead}
            for m, st in self._states.items()
        }

    def state(self, metric: str) -> MetricState:
        return self._states[metric]

    def fired(self, metric: str, now: float) -> None:
        """``metric`` was cued at ``now`` (by the processor or an agent): its weight starts
        again from 0, its strict warning is spent, its refractory time begins."""
        self._states[metric].fired(now)
        self._status_until = -math.inf
        self._quiet = -math.inf

    def weight(self, metric: str, now: float) -> float:
        """``metric``'s weight W at ``now`` (%·s; see :mod:`prezence.processor.state`)."""
        return self._states[metric].weight_at(now)

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
        over: bool = False,
        spent: float | None = None,
    ) -> Decision:
        """Ingest ``samples``, integrate to ``now`` and decide.

        Args:
            now: seconds since the talk began.
            samples: new samples since the last step.
            free_since: when the robot last became free (None while it is busy). The minimum
                gap is counted from here.
            with_views: put every metric's view in the decision (False: an empty tuple; ask
                :meth:`views` when one is needed).
            over: ``now`` is the talk's end (its last decision point): the samples are
                taken in, but no cue is chosen, as the presenter can no longer act on one.
            spent: the time the presenter has used at ``now``, which the time warnings are
                judged on (None: ``now``). An ``up`` of recordings gives the recordings' own
                clock: the talk's clock runs ahead of it while the modules start up and on
                after the recordings' end, and the time used is the recordings' length.

        Returns:
            The decision; its ``cue`` is set when a cue must be given now.
        """
        if samples:
            self.ingest(samples, now=now)
        self._spent = now if spent is None else spent
        self._quiet = -math.inf
        self._quiet_free = free_since
        views = self.views(now) if with_views else ()
        if over:
            return Decision(now, None, "the talk is over", free_since is None, (), views)
        if self.policy.whole:
            chosen = self.policy.decide(now, free_since is not None)
            if chosen is None:
                why = "robot busy" if free_since is None else f"policy {self.policy.name}: no cue"
                return Decision(now, None, why, free_since is None, (), views)
            cue = self._fire(chosen, [chosen], now)
            return Decision(now, cue, cue.reason, False, (chosen,), views)
        if free_since is None:
            self._quiet = math.inf  # busy until the robot says otherwise
            return Decision(now, None, "robot busy", True, (), views)
        if self._last_cue is not None and now - free_since < self.settings.min_gap_s:
            self._quiet = _early(free_since + self.settings.min_gap_s)
            return Decision(now, None, self._min_gap_why, False, (), views)
        cands = self._candidates(now, self._spent)
        if not cands:
            self._quiet = self._cand_quiet
            return Decision(now, None, self._no_cue_why, False, (), views)
        chosen = self.policy.choose(cands, self._order)
        if chosen is None:
            return Decision(
                now, None, f"policy {self.policy.name} chose none", False, tuple(cands), views
            )
        cue = self._fire(chosen, cands, now)
        return Decision(now, cue, cue.reason, False, tuple(cands), views)

    def quiet_until(self, free_since: float | None) -> float:
        """How long a step with no new sample would decide as the last step did.

        For the robot as it is (``free_since``, as :meth:`step` takes it), a time ``T`` such
        that a step at any time after the last one and before ``T``, with no sample, would
        return the last decision again (its reason and busy flag, no candidate, no cue),
        change nothing but the time used, and leave :meth:`status` as it was. Nothing moves
        in between but time, and ``T`` is the first time at which time alone could bring a
        candidate (a weight reaching the threshold, a refractory time ending, a time warning,
        praise), end the minimum gap or change a metric's status; the times are taken a
        little early, as :meth:`status` takes its own. ``-inf`` when the last step gave a
        cue or a candidate, ran a whole policy, or had another ``free_since``: every point is
        then stepped (:attr:`prezence.coach.Coach.quiet_until`, :func:`prezence.talk.run_talk`).
        """
        if free_since != self._quiet_free:
            return -math.inf
        q = self._quiet
        return q if q < self._status_until else self._status_until

    def _time_until(self) -> float:
        """The first time used at which a time warning or an overtime cue could be due, when
        none is now (the time used never runs ahead of the talk's clock, so it is a time on
        the talk's clock too); kept until that time or a time cue."""
        if self._spent < self._time_quiet:
            return self._time_quiet
        self._time_quiet = until = self._time_bound()
        return until

    def _time_bound(self) -> float:
        ts = self.config.time
        alloc = ts.allocated_s
        if alloc is None:
            return math.inf
        if alloc - self._spent < 0.0:
            if ts.overtime_repeat_s > 0 and self._last_overtime > -math.inf:
                return _early(self._last_overtime + ts.overtime_repeat_s)
            return math.inf if self._last_overtime > -math.inf else -math.inf
        until = alloc
        for m in ts.warn_at_s_left:
            if m not in self._time_marks_given:
                until = min(until, _early(alloc - m))
        return until

    def views(self, now: float, only: Iterable[int] | None = None) -> tuple[MetricView, ...]:
        """Every metric's state at ``now`` (the decision log, live views); with ``only``,
        those of the metrics at these places in the rules' order."""
        if only is None:
            return tuple([self._view(st, now) for st in self._states.values()])
        states = tuple(self._states.values())
        return tuple([self._view(states[i], now) for i in only])

    def view_dicts(self, now: float, only: Iterable[int] | None = None) -> list[dict[str, Any]]:
        """``[v.to_dict() for v in self.views(now, only)]``, made without the views (the
        decision log's lines: a frozen view's fields are set one by one, at a cost)."""
        states = tuple(self._states.values())
        refractory_s = self.settings.refractory_s
        out = []
        for st in states if only is None else [states[i] for i in only]:
            offset = st.rule.offset
            value = st.value
            d = {
                "metric": st.rule.metric,
                "value": value + offset if offset and value is not None else value,
                "deviation": _logged(st.deviation()),
                "weight": _logged(st.weight_at(now)),
                "stale": st.stale(now),
                "refractory": now - st.last_fired < refractory_s,
                "strict_pending": st.strict_pending,
            }
            if offset:
                d["offset"] = offset
            out.append(d)
        return out

    def status(self, now: float) -> tuple[tuple[bool, str | None, bool], ...]:
        """A cheap summary of every metric's state: (stale or no value, side out of range,
        strict cue pending). The decision log writes a line when it changes."""
        if now < self._status_until:
            return self._status
        until = math.inf
        out = []
        for st in self._states.values():
            # side is None while there is no value
            stale = st.value is None or now - st.last_sample_t > st.stale_after_s
            out.append((stale, st.side, st.strict_pending))
            if not stale and st.last_sample_t + st.stale_after_s < until:
                until = st.last_sample_t + st.stale_after_s
        self._status = status = tuple(out)
        # a little early, so that rounding never keeps a status that has changed (with no
        # fresh metric, until stays inf: inf - inf would be nan, and nan keeps nothing)
        self._status_until = until - 1e-6 * (1.0 + abs(until)) if until < math.inf else until
        return status

    def _view(self, st: MetricState, now: float) -> MetricView:
        offset = st.rule.offset
        return MetricView(
            metric=st.rule.metric,
            value=st.value + offset if offset and st.value is not None else st.value,
            deviation=st.deviation(),
            weight=st.weight_at(now),
            stale=st.stale(now),
            refractory=now - st.last_fired < self.settings.refractory_s,
            strict_pending=st.strict_pending,
            offset=offset,
        )

    def _candidates(self, now: float, spent: float) -> list[Candidate]:
        s = self.settings
        out: list[Candidate] = self._time_candidates(spent)
        all_out = self.policy.wants_all_out_of_range
        praise_after_s = s.praise_after_s
        refractory_s = s.refractory_s
        escalated = self._escalated
        # With no candidate, until when time alone brings none (quiet_until): each metric's
        # part below; a stale metric stays stale without a sample
        until = -math.inf if all_out else math.inf
        for st in self._states.values():
            if not st.strict_pending and (st.dev <= 0.0 or (now < st.reach_t and not all_out)):
                if st.dev > 0.0 and st.reach_t < until:
                    until = st.reach_t
                continue  # in range, or its weight cannot have reached the threshold yet
            if st.value is None or now - st.last_sample_t > st.stale_after_s:
                continue  # no value, or stale
            if now - st.last_fired < refractory_s:
                end = _early(st.last_fired + refractory_s)
                if end < until:
                    until = end
                continue
            r = st.rule
            if r.metric in escalated:
                continue
            dev = st.dev
            side = st.side
            if r.strict and st.strict_pending and now - st.last_problem_t > st.stale_after_s:
                # The excursion ended longer ago than the stale time: too old to be worth a cue.
                self._status_until = -math.inf
                st.strict_pending = False
                st.strict_onset = None
                st.strict_peak = 0.0
                st.strict_side = None
            if r.strict and st.strict_pending:
                strict_side = side or st.strict_side
                command = r.below if strict_side == "below" else r.above
                if command is None:
                    # dropped as too old (its status changes) once the stale time has passed
                    end = _early(st.last_problem_t + st.stale_after_s)
                    if end < until:
                        until = end
                    continue
                if self._escalate(st, now, command):
                    continue
                out.append(
                    Candidate(
                        Kind.STRICT,
                        command,
                        r.metric,
                        eligible=True,
                        weight=max(st.strict_peak, dev),
                        deviation=dev,
                        value=st.value + r.offset if r.offset else st.value,
                        side=strict_side,
                        onset=st.strict_onset,
                        recency=st.last_sample_t,
                        offset=r.offset,
                    )
                )
                continue
            if dev <= 0.0 or side is None:
                continue
            if now < st.reach_t and not all_out:
                if st.reach_t < until:
                    until = st.reach_t
                continue  # (a strict warning just dropped as too old) cannot have reached it yet
            command = r.below if side == "below" else r.above
            if command is None:
                continue
            weight = st.weight_at(now)
            eligible = weight >= s.threshold
            if not eligible:
                # W grows by at most gain x deviation% a second (less while its persistence
                # builds up), so it cannot reach the threshold sooner than this
                rate = r.gain * dev
                end = _early(now + (s.threshold - weight) / rate) if rate > 0.0 else -math.inf
                if end < until:
                    until = end
            elif self._escalate(st, now, command):
                continue
            if eligible or all_out:
                out.append(
                    Candidate(
                        Kind.WEIGHTED,
                        command,
                        r.metric,
                        eligible=eligible,
                        weight=weight,
                        deviation=dev,
                        value=st.value + r.offset if r.offset else st.value,
                        side=side,
                        onset=st.out_since,
                        recency=st.last_sample_t,
                        offset=r.offset,
                    )
                )
        if s.praise_command and praise_after_s > 0 and not out:
            if now - max(self._last_cue_t, 0.0) < praise_after_s:
                end = _early(max(self._last_cue_t, 0.0) + praise_after_s)
            elif self._all_well_since(now, praise_after_s):
                out.append(
                    Candidate(Kind.PRAISE, s.praise_command, None, eligible=True, recency=now)
                )
                return out
            else:  # not all well: no sooner than the newest problem is a window old
                newest = max(st.last_problem_t for st in self._states.values())
                end = _early(newest + praise_after_s)
            if end < until:
                until = end
        if not out:
            tq = self._time_until()
            self._cand_quiet = tq if tq < until else until
        return out

    def _all_well_since(self, now: float, window_s: float) -> bool:
        """Some metric is fresh at ``now`` and none was out of range in the last ``window_s``
        (praise is due); worked out only when the rest of the praise is due. A metric gone
        stale counts by its last readings: a pace out at 1:40 and not measured through a
        pause was left out, and "Good, keep it up!" came at 3:13 as the volume came back."""
        any_fresh = False
        for st in self._states.values():
            if st.value is None:
                continue  # never measured
            if now - st.last_problem_t < window_s:
                return False
            any_fresh = any_fresh or now - st.last_sample_t <= st.stale_after_s
        return any_fresh

    def _time_candidates(self, now: float) -> list[Candidate]:
        """The time warning or overtime cue due when the presenter has used ``now`` seconds."""
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

    def _escalate(self, st: MetricState, now: float, command: str) -> bool:
        """True (and the metric escalated) once it has had ``escalate_after`` unheeded cues."""
        n = self.escalate_after
        if n <= 0 or st.unheeded < n:
            return False
        self._escalated.add(st.rule.metric)
        self._no_cue_why = (
            f"{_NO_CUE}; not repeating {', '.join(sorted(self._escalated))} (escalated)"
        )
        offset = st.rule.offset
        rec: dict[str, Any] = {
            "t": now,
            "metric": st.rule.metric,
            "command": command,
            "cues": st.unheeded,
            # as judged, as every other value of a rule with an offset is shown
            "value": st.value + offset if offset and st.value is not None else st.value,
        }
        if offset:
            rec["offset"] = offset
        self.escalations.append(rec)
        return True

    def cue_dropped(self, cue: Cue) -> None:
        """The robot could not give ``cue`` (backend gone): undo what choosing it changed.

        The metric keeps its weight and strict warning and starts no refractory, a time mark
        stays due, so the cue can be given once the robot is back. The minimum gap still
        counts from the attempt, so a lost robot is retried at that pace, not at every tick.
        A cue that is not the last one chosen is ignored.
        """
        undo = self._undo
        if undo is None or undo[0] is not cue:
            return
        _, metric, state, marks, overtime = undo
        self._quiet = self._time_quiet = -math.inf
        if metric is not None and state is not None:
            self._states[metric] = state
            self._status_until = -math.inf
        self._time_marks_given = marks
        self._last_overtime = overtime
        self.policy.cue_dropped(cue)
        self._undo = None

    def _fire(self, c: Candidate, cands: list[Candidate], now: float) -> Cue:
        reason = self._reason(c, cands)
        saved_state = (
            copy.copy(self._states[c.metric])
            if c.metric is not None and c.metric in self._states
            else None
        )
        saved = (set(self._time_marks_given), self._last_overtime)
        if c.kind == Kind.TIME:
            if c.command == self.config.time.overtime_command and "mark_s" not in c.params:
                self._last_overtime = self._spent  # repeated on the same clock
            else:
                mark = float(c.params["mark_s"])
                self._time_marks_given.update(
                    m for m in self.config.time.warn_at_s_left if m >= mark
                )
        elif c.metric is not None and c.metric in self._states and not self.policy.whole:
            self.fired(c.metric, now)
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
        self._time_quiet = -math.inf
        self.cues.append(cue)
        self._undo = (cue, c.metric, saved_state, *saved)
        return cue

    def _reason(self, c: Candidate, cands: list[Candidate]) -> str:
        thr = self.settings.threshold
        # what the policy chose on, in its own words (None: the weighted policy's: the weight)
        own = (
            self.policy.explain(c, cands, self._order)
            if c.metric is not None
            and c.kind in (Kind.WEIGHTED, Kind.STRICT)
            and not self.policy.whole
            else None
        )
        if c.kind == Kind.TIME:
            if "minutes" in c.params:
                why = f"{c.params['minutes']} min left of {self.config.time.allocated_s:g} s"
            else:
                why = f"over the allocated {self.config.time.allocated_s:g} s"
        elif c.kind == Kind.PRAISE:
            why = (
                "the mistake on show ended"
                if self.policy.whole
                else "every metric in range for a while"
            )
        elif c.metric not in self._states:
            why = f"{c.command} ({c.metric})"
        else:
            assert c.metric is not None  # noqa: S101 - metric candidates always carry one
            r = self._states[c.metric].rule
            bound = r.low if c.side == "below" else r.high
            unit = f" {r.unit}" if r.unit else ""
            since = f" since {c.onset:.1f} s" if c.onset is not None else ""
            # the value is as judged (offset added); an offset is named with the measured value
            shift = r.shift_words(c.value - c.offset) if c.offset and c.value is not None else ""
            if c.kind == Kind.STRICT:
                now_ = "" if c.deviation > 0 else f" (now {c.value:.4g}{shift}, back in range)"
                why = (
                    f"strict: {c.metric} went {c.side} {bound:g}{unit}{r.band_words()}{since}{now_}"
                )
                if own is not None:
                    why += f" ({own})"
            else:
                if r.scale is not None and c.value is not None and bound is not None:
                    # a deviation in scales read "-28.98 is 140% below -15 degrees", "47.7 is
                    # 204% below 60 dB SPL": the distance in the unit, the share of the scale
                    off = (
                        f"{abs(c.value - bound):.3g}{unit} {c.side} {bound:g}{unit} "
                        f"({c.deviation:.0f}% of its {r.scale:g}{unit} scale)"
                    )
                else:
                    off = f"{c.deviation:.0f}% {c.side} {bound:g}{unit}"
                why = f"{c.metric} {c.value:.4g}{shift} is {off}"
                if own is not None:  # not the threshold: the policy did not choose on it
                    why += f"{since} ({own})"
                elif c.eligible and not self.policy.whole:
                    why += f"{since} (weight {c.weight:.0f} >= {thr:g})"
                elif c.eligible:  # an anchor fires by its own rule, not by the threshold
                    why += since
        others = [o for o in cands if o is not c]
        if others:
            beat = ", ".join(
                f"{o.command}"
                + (f" ({o.weight:.0f})" if math.isfinite(o.weight) and own is None else "")
                for o in sorted(
                    others, key=lambda o: -o.weight if math.isfinite(o.weight) else -1e18
                )[:3]
            )
            why += f"; beat {beat} [{self.policy.name}]"
        elif self.policy.whole:
            why += f" [{self.policy.name}]"
        return why


def end_of_talk_notes(processor: Processor) -> list[dict[str, Any]]:
    """What the coach stopped repeating during the talk, to say once at the end and to report.

    One record per escalated metric: ``metric``, ``command`` (the cue it stopped giving),
    ``cues`` (how many were given without effect), ``t`` (when it stopped) and ``phrase``, a
    sentence for the robot's closing summary and the report. Empty when nothing escalated.
    """
    from prezence.errors import UnknownName
    from prezence.feedback.commands import get_command

    out = []
    for e in processor.escalations:
        try:
            said = get_command(e["command"]).say({})
        except UnknownName:
            said = e["command"]
        phrase = (
            f"I reminded you {e['cues']} times about {e['metric'].replace('_', ' ')} "
            f'("{said}") and stopped repeating it after {e["t"] / 60:.0f} min: '
            f"work on it before the next rehearsal."
        )
        out.append({**e, "phrase": phrase})
    return out
