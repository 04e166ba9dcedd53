"""A conflict policy of your own: cue the metric that is furthest out of range right now.

Prezence's default (``weighted``) waits until a deviation has lasted (its weight, deviation
% x seconds, reaches the threshold). ``BiggestNow`` does not wait: at every decision point it
takes the metric whose deviation is largest at that moment, if it is at least
``min_deviation`` %. Time warnings still come first. The processor's refractory time and
minimum gap still apply, as for every policy that is not *whole*.

A policy of one's own is named ``MODULE:CLASS``, optionally with ``:key=value,...``, wherever
a policy is named; MODULE is imported as Python imports it (installed, ``PYTHONPATH``), then
from the current folder. From this folder::

    prezence run fast_talker --policy own_policy:BiggestNow --out ../sessions/biggest
    prezence replay ../sessions/biggest --policy own_policy:BiggestNow:min_deviation=25
    prezence evaluate --scenarios demo fast_talker --seeds 2 --jobs 2 \\
        --policies none weighted own_policy:BiggestNow own_policy:BiggestNow:min_deviation=25

Worker processes (``--jobs N``) import it by the same name.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import ClassVar

from prezence.processor import Bound, Candidate, ConflictPolicy, Kind


class BiggestNow(ConflictPolicy):
    """Time warnings first; then the metric furthest out now (deviation >= min_deviation %)."""

    name = "biggest_now"
    #: The processor offers every metric out of range now, not only those over the threshold.
    wants_all_out_of_range = True
    #: The spec keys of this policy and their defaults (``own_policy:BiggestNow:min_deviation=25``).
    defaults: ClassVar[Mapping[str, float]] = {"min_deviation": 10.0}
    #: The values each may take; a value outside is refused before the talk starts.
    bounds: ClassVar[Mapping[str, Bound]] = {"min_deviation": Bound(0.0, 1000.0, "%")}

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        times = [c for c in candidates if c.kind == Kind.TIME and c.eligible]
        if times:
            return times[0]
        limit = self.params["min_deviation"]
        out = [c for c in candidates if c.metric is not None and c.deviation >= limit]
        return max(out, key=lambda c: (c.deviation, c.recency)) if out else None
