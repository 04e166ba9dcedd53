"""The Central Processor: rules, weights, conflict resolution, decisions."""

from prezence.processor.core import Processor
from prezence.processor.resolve import POLICIES, ConflictPolicy, make_policy
from prezence.processor.types import Candidate, Cue, Decision, Kind

__all__ = [
    "POLICIES",
    "Candidate",
    "ConflictPolicy",
    "Cue",
    "Decision",
    "Kind",
    "Processor",
    "make_policy",
]
