"""Conflict resolution policies: given the candidates of one decision point, choose one.

The seed's policy (:class:`WeightedPolicy`) is the default. The others are the simpler
strategies the design report names (Bullinaria's list), kept so that closed-loop evaluation can
measure the seed's choice against them.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence

import numpy as np

from prezence.errors import UnknownName
from prezence.processor.types import Candidate, Kind


class ConflictPolicy(abc.ABC):
    """Chooses at most one candidate. Subclasses fill in :meth:`choose`."""

    name: str = "base"

    #: If True the processor offers every out-of-range metric (the rule's condition holds now),
    #: not only those whose seed firing condition (strict / weight over threshold) holds.
    wants_all_out_of_range: bool = False

    @abc.abstractmethod
    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        """Pick one of ``candidates`` (all allowed now), or None for no cue.

        Args:
            candidates: allowed candidates (refractory and stale metrics already removed).
            order: metric names in config order.
        """

    def reset(self, seed: int | None = None) -> None:  # noqa: B027 - optional hook
        """Start a new talk (policies with chance reseed here)."""


def _seed_key(c: Candidate) -> tuple[float, float, float]:
    # strict classes first; then the biggest priority; then the most recent data.
    return (float(c.kind), -c.weight, -c.recency)


class WeightedPolicy(ConflictPolicy):
    """The seed's policy: time warnings, then strict rules, then the non-strict rule with the
    highest weight (∝ deviation % × time); ties go to the most recent data."""

    name = "weighted"

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.eligible]
        return min(ok, key=_seed_key) if ok else None


class FirstRulePolicy(ConflictPolicy):
    """Fire the first satisfied rule in config order (a flat production system)."""

    name = "first_rule"
    wants_all_out_of_range = True

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        rank = {m: i for i, m in enumerate(order)}

        def key(c: Candidate) -> tuple[int, int]:
            if c.kind == Kind.TIME:
                return (0, 0)
            return (1, rank.get(c.metric or "", len(rank)))

        ok = [c for c in candidates if c.eligible or c.kind in (Kind.WEIGHTED, Kind.STRICT)]
        ok = [c for c in ok if c.kind != Kind.PRAISE]
        return min(ok, key=key) if ok else None


class RecentPolicy(ConflictPolicy):
    """Respond to the most recent out-of-range data only."""

    name = "recent"
    wants_all_out_of_range = True

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.kind != Kind.PRAISE and (c.eligible or c.metric)]
        return max(ok, key=lambda c: (c.recency, -float(c.kind))) if ok else None


class RandomPolicy(ConflictPolicy):
    """Pick uniformly among out-of-range rules (seeded)."""

    name = "random"
    wants_all_out_of_range = True

    def __init__(self, seed: int = 0) -> None:
        self._rng = np.random.default_rng(seed)

    def reset(self, seed: int | None = None) -> None:
        self._rng = np.random.default_rng(seed)

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.kind != Kind.PRAISE and (c.eligible or c.metric)]
        if not ok:
            return None
        return ok[int(self._rng.integers(len(ok)))]


class MostConditionsPolicy(ConflictPolicy):
    """Prefer the rule with the most conditions met: out of range now, out of range for at least
    the threshold's worth of time, strict, and weight over the threshold (Bullinaria's 4th)."""

    name = "most_conditions"
    wants_all_out_of_range = True

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.kind != Kind.PRAISE and (c.eligible or c.metric)]
        if not ok:
            return None

        def met(c: Candidate) -> int:
            return (
                int(c.deviation > 0)
                + int(c.kind in (Kind.STRICT, Kind.TIME))
                + int(c.eligible)
                + int(c.onset is not None)
            )

        return max(ok, key=lambda c: (met(c), c.recency))


class SilentPolicy(ConflictPolicy):
    """No feedback at all (the control condition)."""

    name = "none"

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        return None


POLICIES: dict[str, type[ConflictPolicy]] = {
    p.name: p
    for p in (
        WeightedPolicy,
        FirstRulePolicy,
        RecentPolicy,
        RandomPolicy,
        MostConditionsPolicy,
        SilentPolicy,
    )
}


def make_policy(name: str, *, seed: int = 0) -> ConflictPolicy:
    """Build a policy by name (``weighted``, ``first_rule``, ``recent``, ``random``,
    ``most_conditions``, ``none``)."""
    try:
        cls = POLICIES[name]
    except KeyError:
        raise UnknownName("policy", name, POLICIES) from None
    if cls is RandomPolicy:
        return RandomPolicy(seed)
    return cls()
