"""A Gymnasium environment for learning when to cue: ``prezence/Coach-v1``.

``import sim`` registers the id (as environment packages do on import), with
``max_episode_steps`` (:data:`MAX_EPISODE_STEPS`): an episode cut short by that limit ends
``truncated``, one that reaches the end of the talk ``terminated``. ``gymnasium.make(
"sim.gym_env:prezence/Coach-v1")`` also works with no import (Gymnasium imports the module named
before the colon).

An episode is a talk run by the one loop (:class:`prezence.talk.Talk`): the agent's actions are
the cues, given through the coach exactly as the processor's would be (gesture and phrase on the
robot, the presenter hears it); the processor itself stays silent and keeps the state the
observations show. ``render_mode="rgb_array"`` runs the talk on the PyBullet NAO and returns
camera images of it; ``"ansi"`` returns a text line.
"""

from __future__ import annotations

import math
import numbers
import shutil
import tempfile
import warnings
import weakref
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces

from prezence.backends.base import Backend
from prezence.backends.fake import FakeBackend
from prezence.config.load import load_config
from prezence.config.model import Config, Rule
from prezence.errors import UnknownName, did_you_mean
from prezence.feedback.gestures import library_for_talk
from prezence.processor import Cue, Processor
from prezence.processor.types import Kind
from prezence.samples import Sample
from prezence.session import SessionDir
from prezence.synthetic.presenters import PHYSICAL_RANGES, SyntheticPresenter
from prezence.synthetic.runner import SyntheticSource
from prezence.synthetic.scenario import Scenario, list_scenarios, load_scenario
from prezence.talk import RunOptions, Talk
from sim import ENV_ID, MAX_EPISODE_STEPS, register

#: Observation columns per metric, then the global ones.
METRIC_FEATURES = ("value", "signed_deviation", "weight", "fresh")
GLOBAL_FEATURES = ("robot_busy", "busy_left_s", "time_fraction", "time_left")

_DEV_CLIP = 10.0  # signed deviation / 100, clipped: ±1000 %
_WEIGHT_CLIP = 10.0  # weight / threshold, clipped
_BUSY_CLIP_S = 30.0

#: The keys ``reset(options=…)`` takes.
RESET_OPTIONS = ("presenter_seed", "scenario")


_NO_COPY = (
    "a CoachEnv cannot be copied or pickled: its episode is a running talk (a robot, open "
    "files in its own folder); make another env with the same arguments and reset it with "
    "the same seed for the same episode"
)


def _number(name: str, value: Any) -> float:
    """``value`` as a finite float; a clear error naming the argument otherwise."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {type(value).__name__} ({value!r})")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be a finite number, got {x}")
    return x


def _render_size(size: Any) -> tuple[int, int]:
    """``(width, height)`` of the rgb_array image: two positive integers."""
    ok = (
        isinstance(size, Sequence)
        and not isinstance(size, str)
        and len(size) == 2
        and all(isinstance(v, numbers.Integral) and not isinstance(v, bool) for v in size)
        and all(int(v) > 0 for v in size)
    )
    if not ok:
        raise ValueError(f"render_size must be two positive integers (width, height), got {size!r}")
    return (int(size[0]), int(size[1]))


def _reset_options(options: Any) -> Mapping[str, Any]:
    """``reset``'s options, checked: a mapping with only :data:`RESET_OPTIONS` as keys."""
    if options is None:
        return {}
    if not isinstance(options, Mapping):
        raise ValueError(
            f"options must be a dict (keys: {', '.join(RESET_OPTIONS)}) or None, got "
            f"{type(options).__name__} ({options!r})"
        )
    for key in options:
        if key not in RESET_OPTIONS:
            raise ValueError(
                f"unknown reset option {key!r}{did_you_mean(str(key), RESET_OPTIONS)} "
                f"(the options are: {', '.join(RESET_OPTIONS)})"
            )
    return options


class CoachEnv(gym.Env[npt.NDArray[np.float32], np.int64]):
    """The coach's choice at every decision point: which cue, if any, the robot gives now.

    ## Description

    A synthetic presenter (:class:`SyntheticPresenter`) plays a scenario: metric
    samples (speech speed, volume, clarity, head gaze, gesture rate) that drift out of their
    ideal bands in scripted episodes. At every step (``step_s`` of talk time, by default the
    configuration's decision period, 0.5 s) the agent may have the robot give one cue; step
    ``k`` (from 1) runs from ``(k − 1) × step_s`` to ``k × step_s`` of talk time (the last one
    ends at the talk's end), the headless talk's decision points, so times never drift. The
    robot is busy for the cue's planned duration (the gesture, timed against the URDF joint
    limits, and the phrase, whichever is longer, on the fake backend); a cue asked for while it
    is busy is ignored and costs nothing. The presenter reacts to a corrective cue as the
    scenario says (with a delay, by a seeded fraction, for a while), so good timing pays.

    The seed's rule processor is available as a baseline policy
    (:class:`sim.policies.RuleBaseline`).

    ## Action Space

    ``Discrete(1 + K)``: 0 is no cue; then, in the order of :attr:`actions`, every
    ``(command, metric)`` pair a rule of the configuration can give (its ``below`` then its
    ``above`` command, rules in config order), then the time-left and overtime commands and
    the praise command (``processor.praise_command``, when the configuration has one; all three
    with ``metric`` None). With the default configuration ``K = 10`` (``Discrete(11)``): speedUp,
    slowDown, louder, articulate, lookUp, gestureMore, gestureLess, timeLeft, overtime,
    encourage (see :attr:`actions`; :attr:`rules` says which command of a rule is its
    ``below`` and which its ``above``). The praise action is what lets
    :class:`~sim.policies.RuleBaseline` give a headless talk's cues, praise included.

    An action is an ``int``, a numpy integer or a 0-d integer array; anything else (a float
    such as 2.7, a string, None) raises ``TypeError``, an integer outside the space
    ``ValueError``, both naming the action and the space.

    Every action is always legal (no exception), but not every one is given. A cue about a
    metric the episode's persona does not have (an audio-only persona has no ``cv_headGaze``
    and no ``cv_gestures``; a configuration may have a rule for a metric of its own) is
    refused: the robot stays still, the step is a no-op like action 0, it costs nothing and
    ``info["invalid_action"]`` is True. The seed's processor can never cue a metric it has no
    sample of, there is no truth to judge it by, and the presenter has nothing to change. A
    cue asked for while the robot is busy is likewise not given (``info["ignored"]``).
    ``info["action_mask"]`` (and :meth:`action_masks`, the name sb3-contrib's ``MaskablePPO``
    calls) is an ``int8`` array, 1 for the actions that would be given at the next step:
    always 0 (no cue), and the others only while the robot is free and only for metrics the
    persona has. Time and praise cues are never masked (only while the robot is busy): a
    ``timeLeft`` or ``overtime`` is given whenever it is asked for, at t = 0 too ("You are over
    time" with ``minutes_over`` 0), and costs ``cue_cost`` like any cue.

    ## Observation Space

    ``Box(float32)`` of ``4 × n_rules + 4`` values. Per rule, in config order:

    | column           | meaning                                              | range          |
    |------------------|------------------------------------------------------|----------------|
    | value            | newest sample (a value in the band before the first) | physical range |
    | signed_deviation | deviation % / 100, negative below the band           | [-10, 10]      |
    | weight           | the processor's time-integrated weight / threshold   | [0, 10]        |
    | fresh            | 1 if the newest sample is newer than the stale time  | {0, 1}         |

    then ``robot_busy`` (0/1), ``busy_left_s`` (planned seconds left of the cue, [0, 30]),
    ``time_fraction`` (talk time done / talk length, [0, 1]) and ``time_left``
    ((allocated − now) / allocated, [-1, 1]; 1 when no time is allocated). Weights are those
    of the seed's processor (growth ∝ deviation × time, halving in range), reset when the agent
    cues that metric.

    ``value`` is the band's midpoint, or a one-sided rule's bound, before the first sample
    (``signed_deviation``, ``weight`` and ``fresh`` 0): the in-range value the rule itself
    names. A one-sided band has no midpoint of its own, and one taken with the physical range
    is far from any presenter (95 dB for ≥ 60 dB, the head raised 37.5° for ≥ −15°). A metric
    the persona does not have keeps these values all episode.

    ## Rewards

    Per step: ``step_s / talk length × (share of metrics really in range at the end of the
    step)`` − ``cue_cost`` per cue given − ``in_range_penalty`` per corrective cue about a metric
    that was really (noise-free) in range when given. "Really in range" is the presenter's
    noise-free value judged by the rule; only the metrics the persona has are counted (an
    audio-only persona is judged on its three speech metrics). Without costs, an episode's
    return is the talk's mean time in range (1.0 for a perfect talk); time cues and praise earn
    nothing in v0 (the presenter's talk length is scripted, and the presenter does not react
    to praise) and cost ``cue_cost``; ``in_range_penalty`` is charged for corrective cues only.
    A cue not given (the robot busy, or a metric the persona does not have) costs nothing.

    ## Starting State

    ``reset(seed=…)`` picks a scenario uniformly from ``scenarios`` and a presenter seed, both
    from the environment's generator, so the same seed gives the same episode. ``options``
    (a dict, or None) may fix them: ``{"scenario": name or path, "presenter_seed": K}``.
    With ``presenter_seed`` K the episode is the talk of ``prezence run SCENARIO --seed K``
    and of ``prezence evaluate --first-seed K --seeds 1 --presenters free`` (the generator
    still draws its own, so the draws after it do not move); ``info["presenter_seed"]`` says
    the seed of every episode. Any other key, or options that are not a dict, raise
    ``ValueError`` naming the known keys. The talk starts at t = 0 with the robot free and all
    weights 0.

    The presenter is always the ``free`` one of ``prezence evaluate`` (a cue costs the
    presenter nothing); the ``cost`` presenter of its main tables is not available here, and
    an env policy cannot be run inside ``prezence evaluate`` (whose policies of one's own are
    conflict policies, ``MODULE:CLASS``).

    ## Episode End

    Terminated when the talk's scripted length is reached; a further ``step`` raises
    ``RuntimeError`` ("the episode ended at … s; call reset()"). Truncated when the
    registration's ``max_episode_steps`` (:data:`sim.MAX_EPISODE_STEPS`, 2400, or the one
    given to ``make``) cuts the talk short. The limit counts steps, not seconds: 2400 steps of
    the default 0.5 s are 1200 s, longer than every built-in scenario (the longest is 690 s),
    but with ``step_s=0.1`` they are 240 s. An env made by ``gymnasium.make`` warns
    (``UserWarning``, at its first ``reset``) when ``step_s × 2400`` is shorter than one of
    its scenarios, with the ``max_episode_steps`` to pass to ``make`` for whole talks (a limit
    passed to ``make`` is not seen by the env, so the warning shows then too). A
    ``CoachEnv`` made directly has no step limit.

    ## Info

    ``t`` (talk time), ``scenario``, ``presenter_seed``, ``samples`` (the step's new samples),
    ``robot_busy``, ``robot_free_since``, ``cue`` (the cue given at the start of the step, or
    None: a dict of ``t``, ``command``, ``metric``, ``kind`` (``corrective``, ``time`` or
    ``praise``), ``params``, ``phrase``, ``planned_s``), ``ignored`` (a cue asked for while
    the robot was busy), ``invalid_action`` (a cue about a metric the persona does not have),
    ``action_mask`` (see Action Space) and ``in_range`` (the share of the persona's metrics
    really in range at ``t``).

    ## Arguments

    ``gymnasium.make("prezence/Coach-v1", scenarios=None, config=None, step_s=None,
    cue_cost=0.005, in_range_penalty=0.01, speed_fraction=0.6, render_mode=None,
    render_size=(240, 240))``

    * ``scenarios``: a name or path, or a list of them (default: every built-in scenario).
    * ``config``: a :class:`~prezence.config.model.Config`, or the path of a config file
      (read as ``--config FILE`` is, by :func:`prezence.config.load.load_config`); default:
      the built-in one. Each scenario's allocated time replaces the config's, as in headless
      talks.
    * ``step_s``: seconds of talk per step (default: ``decision_period_s``), finite and > 0.
      The step limit counts steps (see Episode End).
    * ``cue_cost``, ``in_range_penalty``: reward terms above, finite and >= 0 (costs).
    * ``speed_fraction``: fraction of the joints' velocity limits used by gestures; one at
      which a gesture fails ``prezence gestures check`` (takes more than 10 s) raises
      :class:`~prezence.errors.GestureCheckFailed` (a ``ValueError``) naming the lowest that
      passes.
    * ``gestures``: a gesture library file of one's own, as ``--gestures FILE`` (its gestures
      replace the built-in ones of the same name; checked here as every talk checks it, a
      failure raising with the file and line).
    * ``render_mode``: None, ``"ansi"`` (a one-line text state) or ``"rgb_array"`` (the talk
      runs on the PyBullet NAO; ``render()`` returns a camera image of it, ``render_size``:
      (width, height), two positive integers).

    Every argument is checked here: a bad one raises ``ValueError`` (or ``TypeError`` for a
    wrong type) naming it, before anything runs.

    ## Copies and the working folder

    An episode is a running talk with a working folder of its own (a private temporary
    folder, ``prezence-gym-…``, reused by every episode: ``config.toml``, ``session.json``
    with ``"policy": "agent"``, ``cues.jsonl``). It is not a session folder: the talk is never
    finished, so there is no ``summary.json`` or report. The folder is removed at
    :meth:`close`, when the env is garbage-collected, or at interpreter exit. ``copy.copy``,
    ``copy.deepcopy`` and ``pickle`` of an env raise ``TypeError`` (Gymnasium does not ask
    for them): make another env with the same arguments and reset it with the same seed.
    Vector envs (``make_vec``, sync or async) work, as they make each env in its process.

    ## Version History

    * v0: initial version; episodes run on the one talk loop (the agent's cues go through
      the coach, as the processor's do). Session 14, kept v0 (an episode with the default
      ``step_s`` gives the same observations and rewards, bit for bit): a cue about a metric
      the persona does not have is refused (``invalid_action``) instead of raising
      ``UnknownName``; ``action_mask`` is given; step ``k`` ends at ``k × step_s`` (it
      drifted with a ``step_s`` such as 0.2, so a cue due on a boundary, the 8:00 timeLeft,
      came a step late).
      Session 22, kept v0 (actions 0 to 9 mean what they did; a policy trained on
      ``Discrete(10)`` still runs, it never praises): the praise command has an action (the
      last, ``Discrete(11)`` by default), so ``RuleBaseline`` gives a headless talk's cues
      (it gave "no cue" for praise and drifted from ``prezence run``, by 16 points of time in
      range with ``presentation_trainer``); ``reset`` options are checked and may give the
      presenter seed; a step after the end raises; arguments and actions are checked.
    """

    metadata: dict[str, Any] = {"render_modes": ["ansi", "rgb_array"], "render_fps": 2}

    def __init__(
        self,
        scenarios: str | Sequence[str] | None = None,
        *,
        config: Config | str | Path | None = None,
        step_s: float | None = None,
        cue_cost: float = 0.005,
        in_range_penalty: float = 0.01,
        speed_fraction: float = 0.6,
        gestures: str | Path | None = None,
        render_mode: str | None = None,
        render_size: tuple[int, int] = (240, 240),
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be None, 'ansi' or 'rgb_array', got {render_mode!r}"
            )
        if isinstance(scenarios, str | Path):
            names = [str(scenarios)]
        else:
            names = [str(n) for n in (scenarios if scenarios is not None else list_scenarios())]
        if not names:
            raise ValueError("scenarios is empty: give scenario names or paths, or None for all")
        self.scenarios: tuple[Scenario, ...] = tuple(load_scenario(n) for n in names)
        if isinstance(config, str | Path):
            config = load_config(config)  # as every command's --config FILE
        elif config is not None and not isinstance(config, Config):
            raise TypeError(
                f"config must be a Config, a path to a config file or None, got "
                f"{type(config).__name__} ({config!r})"
            )
        self.config = config if config is not None else load_config(None)
        self.step_s = _number(
            "step_s", step_s if step_s is not None else self.config.processor.decision_period_s
        )
        if not self.step_s > 0:
            raise ValueError(f"step_s must be > 0 (seconds of talk per step), got {self.step_s}")
        self.cue_cost = _number("cue_cost", cue_cost)
        self.in_range_penalty = _number("in_range_penalty", in_range_penalty)
        for name, value in (
            ("cue_cost", self.cue_cost),
            ("in_range_penalty", self.in_range_penalty),
        ):
            if value < 0:
                raise ValueError(
                    f"{name} must be >= 0 (a cost, subtracted from the reward), got {value:g}"
                )
        self.render_mode = render_mode
        self.render_size = _render_size(render_size)
        self.speed_fraction = float(speed_fraction)
        # as every talk: refused here, not at reset, when a gesture would take so long at this
        # speed that the robot could give no other cue (GestureCheckFailed, a ValueError)
        self.gestures = None if gestures is None else str(gestures)
        library_for_talk(self.gestures, speed_fraction=self.speed_fraction)
        self._limit_checked = False
        self._tmp: Path | None = None
        self._remove_tmp: weakref.finalize[Any, Any] | None = None
        self._camera: Any = None
        self.rules: tuple[Rule, ...] = self.config.rules
        acts: list[tuple[str | None, str | None]] = [(None, None)]
        for r in self.rules:
            for cmd in (r.below, r.above):
                if cmd is not None and (cmd, r.metric) not in acts:
                    acts.append((cmd, r.metric))
        self._time_commands = (self.config.time.warn_command, self.config.time.overtime_command)
        praise = self.config.processor.praise_command
        for cmd in (*self._time_commands, praise):
            if cmd is not None and (cmd, None) not in acts:
                acts.append((cmd, None))
        #: ``actions[i]`` is the ``(command, metric)`` of action ``i`` (``(None, None)``: no cue).
        self.actions: tuple[tuple[str | None, str | None], ...] = tuple(acts)
        self.action_space = spaces.Discrete(len(self.actions))
        low: list[float] = []
        high: list[float] = []
        for r in self.rules:
            lo, hi = PHYSICAL_RANGES.get(r.metric, (-1e4, 1e4))
            low += [lo, -_DEV_CLIP, 0.0, 0.0]
            high += [hi, _DEV_CLIP, _WEIGHT_CLIP, 1.0]
        low += [0.0, 0.0, 0.0, -1.0]
        high += [1.0, _BUSY_CLIP_S, 1.0, 1.0]
        self.observation_space = spaces.Box(
            np.array(low, dtype=np.float32), np.array(high, dtype=np.float32), dtype=np.float32
        )
        self._episode: dict[str, Any] = {}

    def _check_step_limit(self) -> None:
        """Warn once when the registered step limit would cut one of the scenarios short.

        Only an env made by ``gymnasium.make`` (its ``spec`` is set then) has a step limit; a
        limit given to ``make`` itself is not seen here.
        """
        self._limit_checked = True
        spec = gym.registry.get(self.spec.id) if self.spec is not None else None
        limit = spec.max_episode_steps if spec is not None else None
        if limit is None:
            return
        longest = max(self.scenarios, key=lambda sc: sc.duration_s)
        if self.step_s * limit < longest.duration_s - 1e-9:
            need = math.ceil(longest.duration_s / self.step_s - 1e-9)
            warnings.warn(
                f"step_s={self.step_s:g}: the registered step limit, max_episode_steps={limit} "
                f"(steps, not seconds), ends an episode at {self.step_s * limit:g} s of talk, "
                f"so longer talks end truncated (the longest, {longest.name!r}, is "
                f"{longest.duration_s:g} s); for whole talks pass max_episode_steps={need} (or "
                "more) to gymnasium.make",
                UserWarning,
                stacklevel=3,
            )

    def __copy__(self) -> CoachEnv:
        raise TypeError(_NO_COPY)

    def __deepcopy__(self, memo: dict[int, Any]) -> CoachEnv:
        raise TypeError(_NO_COPY)

    def __reduce_ex__(self, protocol: Any) -> Any:
        raise TypeError(_NO_COPY)

    # -- helpers -----------------------------------------------------------------------------

    def action_index(self, command: str, metric: str | None) -> int:
        """The action that gives ``command`` about ``metric``.

        Raises:
            UnknownName: no action gives it.
        """
        for i, (c, m) in enumerate(self.actions):
            if c == command and (m == metric or metric is None or m is None):
                return i
        raise UnknownName("action", command, [c for c, _ in self.actions if c])

    @property
    def episode_config(self) -> Config:
        """The configuration of the current episode (the scenario's allocated time applied)."""
        cfg: Config = self._episode["config"]
        return cfg

    @property
    def scenario(self) -> Scenario:
        """The current episode's persona."""
        sc: Scenario = self._episode["scenario"]
        return sc

    @property
    def presenter_seed(self) -> int:
        """The current episode's presenter seed (``prezence run --seed`` of the same talk)."""
        return int(self._episode["seed"])

    @property
    def now(self) -> float:
        """Talk time of the current step."""
        return float(self._episode["t"])

    @property
    def talk(self) -> Talk:
        """The current episode's talk (the one loop, driven one step at a time)."""
        talk: Talk = self._episode["talk"]
        return talk

    def _truly_in_range(self, metric: str, t: float) -> bool:
        pres: SyntheticPresenter = self._episode["source"].presenter
        rule = self._episode["config"].rule(metric)
        return rule.side(pres.true_value(metric, t)) is None

    def _judged_metrics(self) -> list[str]:
        sc: Scenario = self._episode["scenario"]
        have = {m.metric for m in sc.metrics}
        return [r.metric for r in self.rules if r.metric in have]

    def _robot_busy(self) -> bool:
        coach = self.talk.coach
        return bool(self.talk.backend.busy) or (coach is not None and coach.current is not None)

    def action_masks(self) -> npt.NDArray[np.int8]:
        """1 for each action the robot would give at the next step (see Action Space)."""
        if not self._episode:
            raise RuntimeError("call reset() before action_masks()")
        can: npt.NDArray[np.int8] = self._episode["can_cue"]
        if self._robot_busy():
            only_none = np.zeros_like(can)
            only_none[0] = 1
            return only_none
        return can.copy()

    def _obs(self) -> npt.NDArray[np.float32]:
        ep = self._episode
        proc: Processor = self.talk.processor
        t = float(ep["t"])
        thr = self.config.processor.threshold
        out: list[float] = []
        for r in self.rules:
            st = proc.state(r.metric)
            if st.value is None:
                mid = [x for x in (r.low, r.high) if x is not None]
                value = sum(mid) / len(mid) if mid else 0.0
                signed = 0.0
            else:
                value = st.value
                dev = st.deviation() / 100.0
                signed = -dev if r.side(st.value) == "below" else dev
            lo, hi = PHYSICAL_RANGES.get(r.metric, (-1e4, 1e4))
            out += [
                min(max(value, lo), hi),
                min(max(signed, -_DEV_CLIP), _DEV_CLIP),
                min(st.weight_at(t) / thr, _WEIGHT_CLIP) if thr > 0 else 0.0,
                0.0 if st.stale(t) else 1.0,
            ]
        perf = self.talk.coach.current if self.talk.coach is not None else None
        motions = perf.motions if perf is not None else []
        busy_left = max((m.started_at + m.planned_s - t for m in motions), default=0.0)
        busy = bool(self.talk.backend.busy)
        duration = float(ep["scenario"].duration_s)
        alloc = ep["config"].time.allocated_s
        left = 1.0 if not alloc else min(max((alloc - t) / alloc, -1.0), 1.0)
        out += [
            1.0 if busy else 0.0,
            min(max(busy_left, 0.0), _BUSY_CLIP_S) if busy else 0.0,
            min(t / duration, 1.0),
            left,
        ]
        return np.array(out, dtype=np.float32)

    def _info(
        self,
        samples: list[Sample],
        cue: dict[str, Any] | None,
        ignored: bool,
        invalid: bool = False,
    ) -> dict[str, Any]:
        ep = self._episode
        return {
            "t": float(ep["t"]),
            "scenario": ep["scenario"].name,
            "presenter_seed": ep["seed"],
            "samples": samples,
            "robot_busy": bool(self.talk.backend.busy),
            "robot_free_since": None if self.talk.backend.busy else self._free_since(),
            "cue": cue,
            "ignored": ignored,
            "invalid_action": invalid,
            "action_mask": self.action_masks(),
            "in_range": ep["in_range"],
        }

    # -- Gymnasium API -------------------------------------------------------------------------

    def _free_since(self) -> float | None:
        coach = self.talk.coach
        return coach.free_since if coach is not None else None

    def _end_episode(self) -> None:
        if self._episode:
            talk = self.talk
            if talk.coach is not None:
                talk.coach.close()
            talk.backend.close()
            self._episode = {}
        self._camera = None

    def _backend(self) -> Backend:
        if self.render_mode == "rgb_array":
            from prezence.backends.registry import make_backend

            return make_backend("sim", speed_fraction=self.speed_fraction)
        return FakeBackend()

    def reset(
        self, *, seed: int | None = None, options: Mapping[str, Any] | None = None
    ) -> tuple[npt.NDArray[np.float32], dict[str, Any]]:
        opts = _reset_options(options)  # refused before anything changes
        if not self._limit_checked:
            self._check_step_limit()
        super().reset(seed=seed)
        self._end_episode()
        if "scenario" in opts:
            name = opts["scenario"]
            if not isinstance(name, str | Path):
                raise ValueError(
                    f"options['scenario'] must be a scenario name or path, got {name!r}"
                )
            sc = next((s for s in self.scenarios if s.name == name), None)
            sc = sc if sc is not None else load_scenario(str(name))
        else:
            sc = self.scenarios[int(self.np_random.integers(len(self.scenarios)))]
        # drawn even when the option gives it, so the generator's later draws do not move
        pseed = int(self.np_random.integers(0, 2**31 - 1))
        if "presenter_seed" in opts:
            given = opts["presenter_seed"]
            if (
                isinstance(given, bool)
                or not isinstance(given, numbers.Integral)
                or not 0 <= int(given) < 2**63
            ):
                raise ValueError(
                    "options['presenter_seed'] must be an integer >= 0 (prezence run --seed, "
                    f"prezence evaluate --first-seed), got {given!r}"
                )
            pseed = int(given)
        cfg = self.config.with_allocated(sc.allocated_s)
        if self._tmp is None:
            self._tmp = Path(tempfile.mkdtemp(prefix="prezence-gym-"))
            # removed with the env: at close(), when it is garbage-collected, or at exit
            self._remove_tmp = weakref.finalize(
                self, shutil.rmtree, str(self._tmp), ignore_errors=True
            )
        source = SyntheticSource(sc, cfg, seed=pseed, files=False)
        talk = Talk(
            source,
            config=cfg,
            session=SessionDir(self._tmp / "episode"),
            backend=self._backend(),
            options=RunOptions(
                policy="none",
                seed=pseed,
                speed_fraction=self.speed_fraction,
                gestures=self.gestures,
                realtime=False,
                report=False,
                decision_log="off",
            ),
        )
        talk.start()
        # the folder's metadata says who chose the cues: the agent (the processor is silent)
        talk.session.write_meta({**talk.session.read_meta(), "policy": "agent"})
        have = {m.metric for m in sc.metrics}
        can_cue = np.array([m is None or m in have for _, m in self.actions], dtype=np.int8)
        self._episode = {
            "scenario": sc,
            "seed": pseed,
            "config": cfg,
            "source": source,
            "talk": talk,
            "t": 0.0,
            "k": 0,
            "in_range": 1.0,
            "cues": 0,
            "can_cue": can_cue,
            "terminated": False,
        }
        source.poll(0.0)
        return self._obs(), self._info([], None, False)

    def _params(self, command: str, t: float) -> dict[str, Any]:
        ts = self._episode["config"].time
        if ts.allocated_s is None:
            return {"minutes": 1} if command == ts.warn_command else {}
        left = ts.allocated_s - t
        if command == ts.warn_command:
            return {"minutes": max(1, int(round(left / 60.0)))}
        if command == ts.overtime_command:
            return {"minutes_over": int(max(0.0, -left) // 60)}
        return {}

    def _perform(self, command: str, metric: str | None, t: float) -> dict[str, Any] | None:
        """Give the agent's cue through the coach; None when the robot is busy."""
        ep = self._episode
        params = self._params(command, t)
        if metric is not None:
            kind = Kind.WEIGHTED
        else:
            kind = Kind.TIME if command in self._time_commands else Kind.PRAISE
        cue = Cue(t, command, metric, kind, "the agent's choice", params)
        if not self.talk.perform(cue):
            return None
        ep["cues"] += 1
        coach = self.talk.coach
        perf = coach.current if coach is not None else None
        planned = max((m.planned_s for m in perf.motions), default=0.0) if perf else 0.0
        return {
            "t": t,
            "command": command,
            "metric": metric,
            "kind": {Kind.TIME: "time", Kind.PRAISE: "praise"}.get(kind, "corrective"),
            "params": params,
            "phrase": perf.phrase if perf is not None else "",
            "planned_s": planned,
        }

    def step(
        self, action: np.int64 | int
    ) -> tuple[npt.NDArray[np.float32], float, bool, bool, dict[str, Any]]:
        if not self._episode:
            raise RuntimeError("call reset() before step()")
        if self._episode["terminated"]:
            raise RuntimeError(
                f"the episode ended at {self.now:g} s (terminated: the talk is over); call "
                "reset() to start another"
            )
        index = self._action(action)
        ep = self._episode
        t0 = float(ep["t"])
        reward = 0.0
        cue: dict[str, Any] | None = None
        ignored = invalid = False
        command, metric = self.actions[index]
        if command is not None and not ep["can_cue"][index]:
            invalid = True  # a metric this persona does not have: refused, costs nothing
        elif command is not None:
            cue = self._perform(command, metric, t0)
            if cue is None:
                ignored = True  # the robot is busy: the cue is not given and costs nothing
            else:
                reward -= self.cue_cost
                if metric is not None and self._truly_in_range(metric, t0):
                    reward -= self.in_range_penalty
        duration = float(ep["scenario"].duration_s)
        # step k ends at k × step_s, as the headless runner's decision points (SteppedClock):
        # adding step_s at every step drifted (479.9999999999813 after 2400 steps of 0.2 s)
        ep["k"] += 1
        t1 = min(ep["k"] * self.step_s, duration)
        self.talk.step(t1)
        samples = list(self.talk.last_samples)
        ep["t"] = t1
        metrics = self._judged_metrics()
        share = sum(self._truly_in_range(m, t1) for m in metrics) / len(metrics) if metrics else 1.0
        ep["in_range"] = share
        reward += (t1 - t0) / duration * share
        terminated = t1 >= duration - 1e-9
        info = self._info(samples, cue, ignored, invalid)
        obs = self._obs()
        ep["terminated"] = terminated  # the talk is over: a further step is refused
        return obs, float(reward), terminated, False, info

    def _action(self, action: Any) -> int:
        """``action`` as an index into :attr:`actions`: an int, a numpy integer or a 0-d integer
        array in the action space; a clear error naming it and the space otherwise."""
        integral = isinstance(action, numbers.Integral) or (
            isinstance(action, np.ndarray)
            and action.shape == ()
            and np.issubdtype(action.dtype, np.integer)
        )
        if not integral:
            raise TypeError(
                f"action {action!r} is not in {self.action_space}: an integer from 0 to "
                f"{len(self.actions) - 1} is expected, got {type(action).__name__}"
            )
        n = len(self.actions)
        index = int(action)
        if not 0 <= index < n:
            raise ValueError(
                f"action {action!r} is not in {self.action_space}: it must be from 0 to {n - 1}"
            )
        return index

    def render(self) -> Any:
        if self.render_mode is None or not self._episode:
            return None
        if self.render_mode == "rgb_array":
            return self._frame()
        ep = self._episode
        proc: Processor = self.talk.processor
        parts = [f"t={ep['t']:6.1f}s", "busy" if self.talk.backend.busy else "free"]
        for r in self.rules:
            st = proc.state(r.metric)
            v = "-" if st.value is None else f"{st.value:.3g}"
            parts.append(f"{r.metric}={v}(w{st.weight_at(float(ep['t'])):.0f})")
        return " ".join(parts)

    def _frame(self) -> npt.NDArray[np.uint8]:
        """The PyBullet NAO as it stands now: one RGB image (height, width, 3)."""
        from sim.render import _add_floor, _cameras, _grab

        cid = self.talk.backend.sim.client  # type: ignore[attr-defined]
        if self._camera is None:
            _add_floor(cid)
            self._camera = _cameras(cid, self.render_size)[:1]
        frame: npt.NDArray[np.uint8] = _grab(cid, self.render_size, self._camera)
        return frame

    def close(self) -> None:
        self._end_episode()
        if self._remove_tmp is not None:
            self._remove_tmp()  # removes the folder (once) and forgets it
            self._remove_tmp = None
        self._tmp = None


register()

__all__ = [
    "ENV_ID",
    "GLOBAL_FEATURES",
    "MAX_EPISODE_STEPS",
    "METRIC_FEATURES",
    "CoachEnv",
    "register",
]
