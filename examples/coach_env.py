"""Evaluate cueing policies in the Gymnasium environment ``prezence/Coach-v1``.

Compares, by mean episode return on held-out seeds:

- no cues at all;
- a random policy (a random cue about 1 step in 50);
- the seed's rule processor (``RuleBaseline``: weighted conflict resolution);
- a threshold policy whose trigger level and gap are tuned by grid search on training seeds.

Run::

    python examples/coach_env.py [--train 4] [--test 6] [--scenarios demo fast_talker ...]

A return is the talk's mean time in range (1.0 = every metric in range all the time) minus
0.005 per cue and 0.01 per cue about a metric that was in range; "in range" is that first
part alone, "time cues" and "praise" the cues/talk that were time warnings and praise (they
earn nothing in v0).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Mapping
from typing import Any

import gymnasium as gym

import sim.gym_env  # noqa: F401  (registers prezence/Coach-v1)
from prezence.errors import PrezenceError
from sim.gym_env import ENV_ID, CoachEnv
from sim.policies import EnvPolicy, RandomCuePolicy, RuleBaseline, grid_search, run_episode


class NoCue:
    """The control condition."""

    def reset(self, env: CoachEnv, seed: int) -> None:
        pass

    def act(self, obs: Any, info: Mapping[str, Any]) -> int:
        return 0


def seeds(text: str) -> int:
    """A count of seeds: a whole number, at least 1 (a mean over none is no figure)."""
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a whole number of seeds, got {text!r}"
        ) from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"at least 1 seed is needed, got {n}")
    return n


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--train", type=seeds, default=4, help="training seeds for the grid search")
    p.add_argument("--test", type=seeds, default=6, help="held-out seeds for the comparison")
    p.add_argument("--scenarios", nargs="+", help="scenario names or paths (default: all)")
    args = p.parse_args(argv)

    try:
        env: CoachEnv = gym.make(ENV_ID, scenarios=args.scenarios).unwrapped  # type: ignore[assignment]
    except PrezenceError as e:  # an unknown scenario, a damaged scenario file
        p.error(str(e))
    train = list(range(args.train))
    test = list(range(1000, 1000 + args.test))

    t0 = time.perf_counter()
    tuned, train_return = grid_search(env, train)
    print(
        f"grid search on {len(train)} seeds: level {tuned.level:g} × threshold, gap "
        f"{tuned.min_gap_s:g} s (train return {train_return:.4f}, {time.perf_counter() - t0:.0f} s)"
    )
    policies: dict[str, EnvPolicy] = {
        "no cues": NoCue(),
        "random": RandomCuePolicy(0.02),
        "rules (seed processor)": RuleBaseline("weighted"),
        "threshold (tuned)": tuned,
    }
    names = ", ".join(s.name for s in env.scenarios)
    print(f"\nmean return over {len(test)} held-out seeds ({names})")
    head = f"{'policy':<24} {'return':>8} {'in range':>9} {'cues/talk':>10} {'time cues':>10}"
    print(f"{head} {'praise':>7}")
    for name, policy in policies.items():
        eps = [run_episode(env, policy, s) for s in test]
        ret, tir, cues, tcues, praise = (
            sum(e[k] for e in eps) / len(eps)
            for k in ("return", "time_in_range", "cues", "time_cues", "praise")
        )
        print(f"{name:<24} {ret:>8.4f} {tir:>9.4f} {cues:>10.1f} {tcues:>10.1f} {praise:>7.1f}")
    env.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
