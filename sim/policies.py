"""Policies that drive :class:`sim.gym_env.CoachEnv`, and helpers to score and tune them.

Every policy has ``reset(env, seed)`` (start of an episode) and ``act(obs, info) -> int``:

- :class:`RuleBaseline`: the seed's Central Processor itself (any conflict policy), fed the
  samples the environment reports, so the environment reproduces a headless talk's decisions
  (``prezence run --policy P --seed <info["presenter_seed"]>``), its praise included;
- :class:`RandomCuePolicy`: a random cue now and then (a floor);
- :class:`ThresholdPolicy`: cue the metric with the largest weight once it passes a threshold,
  from the observation alone; :func:`grid_search` tunes its threshold and gap.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from prezence.processor import Processor, make_policy
from sim.gym_env import GLOBAL_FEATURES, METRIC_FEATURES, CoachEnv

Obs = npt.NDArray[np.float32]


class EnvPolicy(Protocol):
    """What :func:`run_episode` drives."""

    def reset(self, env: CoachEnv, seed: int) -> None: ...

    def act(self, obs: Obs, info: Mapping[str, Any]) -> int: ...


class RuleBaseline:
    """The seed's rule processor as a policy.

    Args:
        policy: conflict resolution policy name (``weighted`` is the seed's).

    Every command the processor gives has an action (the praise command too, when the
    configuration has one), so the robot gives what a headless talk's would, when it would:
    with the default configuration the episode's cues are those of ``prezence run SCENARIO
    --policy P --seed <info["presenter_seed"]>``. The policy's chance (``random``) is seeded
    with the episode's presenter seed, as a headless talk's is. A command with no action (a
    policy of one's own may name any) raises :class:`~prezence.errors.UnknownName`.
    """

    def __init__(self, policy: str = "weighted") -> None:
        self.policy = policy
        self._env: CoachEnv | None = None
        self._proc: Processor | None = None

    def reset(self, env: CoachEnv, seed: int) -> None:
        self._env = env
        policy = make_policy(self.policy, seed=env.presenter_seed)
        self._proc = Processor(env.episode_config, policy=policy)

    def act(self, obs: Obs, info: Mapping[str, Any]) -> int:
        if self._env is None or self._proc is None:
            raise RuntimeError("call reset(env, seed) first")
        d = self._proc.step(info["t"], info["samples"], free_since=info["robot_free_since"])
        if d.cue is None:
            return 0
        return self._env.action_index(d.cue.command, d.cue.metric)


class RandomCuePolicy:
    """A random action with probability ``p_cue`` at each step (seeded per episode)."""

    def __init__(self, p_cue: float = 0.02) -> None:
        if not 0.0 <= p_cue <= 1.0:
            raise ValueError(f"p_cue must be in [0, 1], got {p_cue}")
        self.p_cue = p_cue
        self._rng = np.random.default_rng(0)
        self._n = 1

    def reset(self, env: CoachEnv, seed: int) -> None:
        self._rng = np.random.default_rng(seed)
        self._n = len(env.actions)

    def act(self, obs: Obs, info: Mapping[str, Any]) -> int:
        if self._rng.random() >= self.p_cue:
            return 0
        return int(self._rng.integers(1, self._n))


@dataclass
class ThresholdPolicy:
    """Cue the metric with the largest weight once ``weight / threshold >= level``.

    Reads only the observation: per metric its ``weight`` and ``signed_deviation`` columns, and
    ``robot_busy``. Waits ``min_gap_s`` after the robot becomes free. Gives no time cues.

    Attributes:
        level: weight, as a multiple of the configuration's threshold, that triggers a cue.
        min_gap_s: quiet time after each cue ends.
    """

    level: float = 1.0
    min_gap_s: float = 6.0

    def __post_init__(self) -> None:
        self._env: CoachEnv | None = None
        self._cols: list[tuple[int, int, int]] = []
        self._busy_col = 0

    def reset(self, env: CoachEnv, seed: int) -> None:
        self._env = env
        k = len(METRIC_FEATURES)
        w, d = METRIC_FEATURES.index("weight"), METRIC_FEATURES.index("signed_deviation")
        self._cols = [(i, i * k + w, i * k + d) for i in range(len(env.rules))]
        self._busy_col = len(env.rules) * k + GLOBAL_FEATURES.index("robot_busy")

    def act(self, obs: Obs, info: Mapping[str, Any]) -> int:
        env = self._env
        if env is None:
            raise RuntimeError("call reset(env, seed) first")
        free = info.get("robot_free_since")
        if obs[self._busy_col] > 0.5 or free is None or info["t"] - free < self.min_gap_s:
            return 0
        best = max(self._cols, key=lambda c: (float(obs[c[1]]), -c[0]))
        i, wcol, dcol = best
        if float(obs[wcol]) < self.level or float(obs[dcol]) == 0.0:
            return 0
        rule = env.rules[i]
        command = rule.below if float(obs[dcol]) < 0 else rule.above
        if command is None:
            return 0
        return env.action_index(command, rule.metric)


def run_episode(env: CoachEnv, policy: EnvPolicy, seed: int) -> dict[str, Any]:
    """One episode.

    Returns:
        ``return``; ``time_in_range`` (the return's time-in-range part, before the cue costs);
        ``cues`` given and, of them, ``time_cues`` and ``praise`` (no metric: they earn
        nothing in v0);
        ``ignored`` actions (the robot busy); ``invalid`` actions (a metric the persona does
        not have); ``scenario``.
    """
    obs, info = env.reset(seed=seed)
    policy.reset(env, seed)
    talk_s = float(env.scenario.duration_s)
    total, in_range, t = 0.0, 0.0, 0.0
    cues = time_cues = praise = ignored = invalid = 0
    done = False
    while not done:
        obs, reward, terminated, truncated, info = env.step(policy.act(obs, info))
        total += reward
        in_range += (info["t"] - t) / talk_s * info["in_range"]
        t = info["t"]
        cue = info["cue"]
        cues += cue is not None
        time_cues += cue is not None and cue["kind"] == "time"
        praise += cue is not None and cue["kind"] == "praise"
        ignored += bool(info["ignored"])
        invalid += bool(info["invalid_action"])
        done = terminated or truncated
    return {
        "return": total,
        "time_in_range": in_range,
        "cues": cues,
        "time_cues": time_cues,
        "praise": praise,
        "ignored": ignored,
        "invalid": invalid,
        "scenario": info["scenario"],
    }


def mean_return(env: CoachEnv, policy: EnvPolicy, seeds: Iterable[int]) -> float:
    """Mean episode return over ``seeds``."""
    returns = [run_episode(env, policy, s)["return"] for s in seeds]
    return float(np.mean(returns))


def grid_search(
    env: CoachEnv,
    seeds: Sequence[int],
    *,
    levels: Sequence[float] = (0.25, 0.5, 1.0, 2.0),
    gaps: Sequence[float] = (2.0, 6.0, 15.0),
) -> tuple[ThresholdPolicy, float]:
    """Tune :class:`ThresholdPolicy` on ``seeds``: the best (level, gap) and its mean return."""
    best: tuple[ThresholdPolicy, float] | None = None
    for level, gap in itertools.product(levels, gaps):
        p = ThresholdPolicy(level, gap)
        r = mean_return(env, p, seeds)
        if best is None or r > best[1]:
            best = (p, r)
    if best is None:
        raise ValueError("empty grid")
    return best
