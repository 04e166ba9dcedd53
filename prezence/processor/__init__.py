"""The Central Processor: rules, weights, conflict resolution, decisions."""

from prezence.processor.core import Processor, end_of_talk_notes
from prezence.processor.resolve import (
    POLICIES,
    Bound,
    ConflictPolicy,
    make_policy,
    parse_spec,
    policy_names,
    register_policy,
)
from prezence.processor.types import Candidate, Cue, Decision, Kind

__all__ = [
    "POLICIES",
    "Bound",
    "Candidate",
    "ConflictPolicy",
    "Cue",
    "Decision",
    "Kind",
    "Processor",
    "end_of_talk_notes",
    "make_policy",
    "parse_spec",
    "policy_names",
    "register_policy",
]
