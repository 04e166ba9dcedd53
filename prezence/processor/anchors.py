"""The anchors: other coaches' published feedback rules, as whole policies of the processor.

Each keeps its own books (it sees every accepted sample, ``feed``) and its own timing
(``decide`` at every decision point), so Prezence can run, replay, evaluate and train against
them exactly as against its own policy: ``--policy pz16``, ``--policy presentation_trainer``
(``pt``), ``--policy rhema``. Their rules (not their code) come from the sources below, as
written out with the source of every number in ``shared/peers/README.md`` and ``policies.py``;
this module is Prezence's own implementation. Every number is a spec parameter
(``rhema:window_s=30``), with the default given here.

Where the coach's own machinery differs from the original system's, the anchor keeps the
original's timing: the processor's threshold, refractory and minimum gap do not apply to them,
they see the rules' bands (not their original thresholds) and they give the rules' commands.

``pz16`` — Prezence 2016, ``central_proc/tailored_cp.py`` and ``central_proc/config.txt``:
    an out-of-range sample is a *concern* that expires after ``expire_s`` = 10 s
    (``expireTime = 10``); a metric is eligible with more live concerns than its *allowance*;
    the lowest fixed *priority* wins; the cued metric's concerns are cleared ("they've learned
    now"); no cue within ``robot_delay_s`` = 10 s of the previous (``ROBOT_DELAY``); nothing in
    the first ``warmup_s`` = 9 s (``time.sleep(9)``); a decision only at a point that read a new
    concern (the code decides only ``if concern``); no time cues, and ``strict`` is ignored.
    (allowance, priority) from config.txt: speed (1, 4), volume (0, 3), clarity (1, 6), head
    gaze (2, 2); gestures (1, 5) and any other metric (1, 5) are ours (2016 had no gesture
    rate).

``presentation_trainer`` — Presentation Trainer (Schneider et al.), ``JudgementMaker.cs`` and
    ``RulesAnalyzerFIFO.cs``: a mistake (metric, side) counts once it has lasted
    ``persist_s`` = 0.3 s (``TIME_TO_CONSIDER_ACTION = 300``); mistakes queue first in, first
    out, and one lasting ``interrupt_s`` = 6 s (``TIME_TO_CONSIDER_INTERRUPTION``) moves to the
    front; one feedback event per ``between_s`` = 3.5 s (``timeBetweenFeedbacks``); the mistake
    on show is not repeated while it lasts; when it ends, a praise event (``praise`` = 1; the
    config's ``praise_command``, ``encourage`` by default). A sample stands for one sample period
    (persistence at 1 Hz: 1 sample for 0.3 s, 6 for 6 s). Not modelled: its pause of the session
    (a robot cannot pause the talk).

``rhema`` — Rhema (Tanveer et al., IUI 2015), ``MainActivity.java checkInputData``: every
    ``window_s`` = 20 s, per metric, count the window's last ``max_samples`` = 20 samples below
    and above the band; a direction with more than ``hits`` = 11 of them is a cue
    (``rangeHits = DATA_TO_DISPLAY/2 + 1``). The original's samples are one-second chunks
    (``TIME_FRAME_IN_MILIS = 1000``, ``DATA_TO_DISPLAY = 20``); the default counts raw samples,
    as the peers' reference does (equal cue for cue on their 1 Hz workload), so a metric written
    at 0.2 Hz (gestures: 4 a window) can never be cued and one at 5 Hz is judged on its last
    4 s. ``per_second`` = 1 counts each second of the window instead (the side of the value
    holding at its end), as the original does; on 1 Hz data the two agree.
    Rhema shows two words at once, a robot gives one
    cue, so the metric with most out-of-range samples wins (ties: config order), the others are
    dropped, never queued; a decision not given before the next one is replaced by it. Its
    "good!" display when nothing is out is off (a robot saying "good" every 20 s is not what
    the comparison is about).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Mapping
from typing import TYPE_CHECKING, ClassVar

from prezence.errors import ConfigError
from prezence.processor.resolve import ALIASES, Bound, ConflictPolicy, register_policy
from prezence.processor.types import Candidate, Cue, Kind

if TYPE_CHECKING:
    from prezence.config.model import Config, Rule

_SIGN = {"below": -1, "above": 1}
_DAY_S = 86400.0


def _candidate(
    rule: Rule, side: str, value: float, *, weight: float, onset: float | None, t: float
) -> Candidate | None:
    command = rule.below if side == "below" else rule.above
    if command is None:
        return None
    return Candidate(
        Kind.WEIGHTED,
        command,
        rule.metric,
        eligible=True,
        weight=weight,
        deviation=rule.deviation(value),
        value=value,
        side=side,
        onset=onset,
        recency=t,
    )


class _Anchor(ConflictPolicy):
    whole = True

    def __init__(self, **params: float) -> None:
        super().__init__(**params)
        self.rules: dict[str, Rule] = {}
        self.order: list[str] = []
        self.latest: dict[str, float] = {}

    def choose(self, candidates, order):  # type: ignore[no-untyped-def]
        return None  # whole policies decide in decide()

    def start(self, config: Config) -> None:
        self.rules = {r.metric: r for r in config.rules}
        self.order = [r.metric for r in config.rules]
        self.latest = {}
        self.praise_command = config.processor.praise_command

    def p(self, key: str) -> float:
        return float(self.params[key])


@register_policy
class PZ16Policy(_Anchor):
    """Prezence 2016: allowance of concerns, fixed priority, 10 s robot delay (module doc)."""

    name = "pz16"
    defaults: ClassVar[Mapping[str, float]] = {
        "expire_s": 10.0,
        "robot_delay_s": 10.0,
        "warmup_s": 9.0,
    }
    bounds: ClassVar[Mapping[str, Bound]] = {
        "expire_s": Bound(0.1, _DAY_S, "s"),
        "robot_delay_s": Bound(0.0, _DAY_S, "s"),
        "warmup_s": Bound(0.0, _DAY_S, "s"),
    }
    #: metric → (allowance, priority); lower priority number wins. central_proc/config.txt.
    TABLE: ClassVar[Mapping[str, tuple[int, int]]] = {
        "speech_speed": (1, 4),
        "speech_volume": (0, 3),
        "speech_accuracy": (1, 6),
        "cv_headGaze": (2, 2),
        "cv_gestures": (1, 5),  # ours: 2016 had no gesture-rate rule
        # the same modules under their 2016 / peers' workload names
        "volume": (0, 3),
        "gesture_rate": (1, 5),
    }
    DEFAULT: ClassVar[tuple[int, int]] = (1, 5)  # ours: any other metric

    def start(self, config: Config) -> None:
        super().start(config)
        self.concerns: dict[str, deque[tuple[float, str, float]]] = {m: deque() for m in self.order}
        self.new_concern = False
        self.last_cue_t = -math.inf

    def feed(self, rule: Rule, t: float, value: float) -> None:
        side = rule.side(value)
        if side is not None:
            self.concerns[rule.metric].append((t, side, value))
            self.new_concern = True

    def decide(self, now: float, robot_free: bool) -> Candidate | None:
        if now < self.p("warmup_s"):
            return None  # asleep: the readings wait in the files
        concern, self.new_concern = self.new_concern, False
        if not concern or not now - self.last_cue_t > self.p("robot_delay_s"):
            return None  # the concern is consumed either way, as in the 2016 loop
        if not robot_free:
            return None
        best: tuple[int, str] | None = None
        for m in self.order:
            q = self.concerns[m]
            while q and now - q[0][0] > self.p("expire_s"):
                q.popleft()
            allowance, priority = self.TABLE.get(m, self.DEFAULT)
            if len(q) > allowance and (best is None or priority < best[0]):
                best = (priority, m)
        if best is None:
            return None
        m = best[1]
        q = self.concerns[m]
        t, side, value = q[-1]  # the side of the newest concern, as the 2016 code did
        c = _candidate(self.rules[m], side, value, weight=len(q), onset=q[0][0], t=t)
        q.clear()
        self.last_cue_t = now
        return c


@register_policy
class PresentationTrainerPolicy(_Anchor):
    """Presentation Trainer: FIFO, 6 s interrupt class, 3.5 s between events (module doc)."""

    name = "presentation_trainer"
    defaults: ClassVar[Mapping[str, float]] = {
        "between_s": 3.5,
        "persist_s": 0.3,
        "interrupt_s": 6.0,
        "praise": 1.0,
        "period_s": 1.0,  # assumed sample period before a stream's second sample (ours)
    }
    bounds: ClassVar[Mapping[str, Bound]] = {
        "between_s": Bound(0.0, _DAY_S, "s"),
        "persist_s": Bound(0.0, _DAY_S, "s"),
        "interrupt_s": Bound(0.0, _DAY_S, "s"),
        "praise": Bound(0.0, 1.0, whole=True),  # 1: on, 0: off
        "period_s": Bound(0.01, _DAY_S, "s"),
    }

    def start(self, config: Config) -> None:
        super().start(config)
        self.run_side: dict[str, str | None] = {m: None for m in self.order}
        self.run_start: dict[str, float | None] = {m: None for m in self.order}
        self.last_t: dict[str, float | None] = {m: None for m in self.order}
        self.period = {m: self.p("period_s") for m in self.order}
        self.queue: list[tuple[str, str]] = []
        self.shown: tuple[str, str] | None = None
        self.last_event_t = -math.inf

    def feed(self, rule: Rule, t: float, value: float) -> None:
        m = rule.metric
        last = self.last_t[m]
        if last is not None and t > last:
            self.period[m] = t - last
        self.last_t[m] = t
        self.latest[m] = value
        side = rule.side(value)
        if side != self.run_side[m] or self.run_start[m] is None:
            self.run_side[m], self.run_start[m] = side, t

    def _lasted(self, m: str) -> float:
        start, last = self.run_start[m], self.last_t[m]
        if self.run_side[m] is None or start is None or last is None:
            return 0.0
        return last - start + self.period[m]

    def decide(self, now: float, robot_free: bool) -> Candidate | None:
        if not robot_free or not now - self.last_event_t > self.p("between_s"):
            return None
        present: dict[tuple[str, str], tuple[bool, float]] = {}
        for m in self.order:
            lasted = self._lasted(m)
            side, start = self.run_side[m], self.run_start[m]
            if side is not None and start is not None and lasted >= self.p("persist_s") - 1e-9:
                present[(m, side)] = (lasted >= self.p("interrupt_s") - 1e-9, start)
        self.queue = [k for k in self.queue if k in present]
        for k in sorted(present, key=lambda k: present[k][1]):
            if k not in self.queue:
                self.queue.append(k)
        self.queue.sort(key=lambda k: not present[k][0])  # stable: interrupts to the front
        if self.shown is not None and self.shown not in present:
            self.shown = None
            if self.p("praise") and self.praise_command:
                self.last_event_t = now
                for mm in self.order:  # JudgementMaker.clearLists(): runs start afresh
                    self.run_start[mm] = None
                # about no metric: a praise corrects nothing (the report and scoring agree)
                return Candidate(Kind.PRAISE, self.praise_command, None, eligible=True, recency=now)
        if self.queue and self.queue[0] != self.shown:
            m, side = self.queue[0]
            c = _candidate(
                self.rules[m],
                side,
                self.latest[m],
                weight=self._lasted(m),
                onset=self.run_start[m],
                t=self.last_t[m] or now,
            )
            self.shown = (m, side)
            self.last_event_t = now
            return c
        return None

    def cue_dropped(self, cue: Cue) -> None:
        self.shown = None


@register_policy
class RhemaPolicy(_Anchor):
    """Rhema: majority of a 20 s window's samples out of range, one decision per window."""

    name = "rhema"
    defaults: ClassVar[Mapping[str, float]] = {
        "window_s": 20.0,
        "max_samples": 20.0,
        "hits": 11.0,
        "per_second": 0.0,
    }
    #: window_s: 0 or less would never end a window (the talk hung); 0.1 s is far below any
    #: decision period that matters and keeps a 10-minute talk at 6000 windows.
    #: per_second: 0 counts the window's raw samples (the peers' reference, whatever rate a
    #: module writes at); 1 counts one-second chunks, as the original does.
    bounds: ClassVar[Mapping[str, Bound]] = {
        "window_s": Bound(0.1, _DAY_S, "s"),
        "max_samples": Bound(1.0, 1e6, whole=True),
        "hits": Bound(0.0, 1e6, whole=True),
        "per_second": Bound(0.0, 1.0, whole=True),
    }

    @classmethod
    def check_params(cls, params: Mapping[str, float]) -> None:
        super().check_params(params)
        if params["hits"] >= params["max_samples"]:
            raise ConfigError(
                f"hits must be less than max_samples ({params['max_samples']:g}): a cue needs "
                f"more than hits of the window's samples out, found {params['hits']:g}"
            )

    def start(self, config: Config) -> None:
        super().start(config)
        self.samples: dict[str, deque[tuple[float, str | None, float]]] = {
            m: deque() for m in self.order
        }
        self.next_decision = self.p("window_s")
        self.pending: Candidate | None = None
        #: per_second: each metric's last sample of the previous window (it holds on into the
        #: next window's first seconds until a new sample comes)
        self.held: dict[str, tuple[float, str | None, float]] = {}

    def feed(self, rule: Rule, t: float, value: float) -> None:
        self.samples[rule.metric].append((t, rule.side(value), value))

    def _seconds(
        self, m: str, window: list[tuple[float, str | None, float]], end: float
    ) -> list[tuple[float, str | None, float]]:
        """The window's one-second chunks (Rhema's ``TIME_FRAME_IN_MILIS = 1000``): for each
        second, the side of the value holding at its end (the last sample before it). A
        metric with no sample in the window gives no chunk (a dead module is not cued on its
        last value); one written every 5 s gives 20 chunks, not 4."""
        if not window:
            self.held.pop(m, None)  # a gap of a whole window: nothing holds across it
            return []
        start = end - self.p("window_s")
        held = self.held.get(m)
        self.held[m] = window[-1]
        chunks = []
        j = 0
        k = 0
        while start + k < end:
            chunk_end = min(start + k + 1.0, end)
            while j < len(window) and window[j][0] < chunk_end:
                held = window[j]
                j += 1
            if held is not None:
                chunks.append((start + k, held[1], held[2]))
            k += 1
        return chunks

    def decide(self, now: float, robot_free: bool) -> Candidate | None:
        while now >= self.next_decision:
            end = self.next_decision
            best: tuple[tuple[int, int], Candidate] | None = None
            for i, m in enumerate(self.order):
                q = self.samples[m]
                window = []
                while q and q[0][0] < end:
                    window.append(q.popleft())
                if self.p("per_second"):
                    window = self._seconds(m, window, end)
                window = window[-int(self.p("max_samples")) :]
                for side in ("below", "above"):
                    hit = [s for s in window if s[1] == side]
                    key = (len(hit), -i)
                    if len(hit) > self.p("hits") and (best is None or key > best[0]):
                        c = _candidate(
                            self.rules[m],
                            side,
                            hit[-1][2],
                            weight=len(hit),
                            onset=hit[0][0],
                            t=hit[-1][0],
                        )
                        if c is not None:
                            best = (key, c)
            self.pending = best[1] if best else None  # an older decision is not kept
            self.next_decision += self.p("window_s")
        if robot_free and self.pending is not None:
            c, self.pending = self.pending, None
            return c
        return None


ALIASES["pt"] = PresentationTrainerPolicy.name
