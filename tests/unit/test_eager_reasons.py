"""Session 22, a researcher's walkthrough: the eager strategies' cue reasons say what the
strategy chose on, not the weighted policy's threshold, which they do not use."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from prezence.synthetic.runner import run_talk

WORDS = {
    "first_rule": "(the first rule out of range, in the rules' order)",
    "recent": "(the most recent out-of-range sample, at ",
    "most_conditions": "(the most conditions met, ",
    "random": "out of range)",
}


@pytest.mark.parametrize("policy", sorted(WORDS))
def test_an_eager_strategys_reason_says_what_it_chose_on(tmp_path: Path, policy: str) -> None:
    # Before: "speech_speed 215.4 is 20% above 180 wpm since 193.0 s (weight 767 >= 600)" from
    # first_rule, which cues whatever is out of range first in the rules, whatever its weight.
    cues = run_talk("report_conflict", out=tmp_path / "t", seed=0, policy=policy).cues
    about = [c for c in cues if c.get("metric")]
    assert about
    for c in about:
        assert WORDS[policy] in c["reason"], c["reason"]
        assert not re.search(r"weight \d+ >=", c["reason"]), c["reason"]
        assert not re.search(r"beat .*\(\d+\)", c["reason"]), c["reason"]  # no weights beaten


def test_the_weighted_policys_reason_still_gives_the_weight_and_threshold(tmp_path: Path) -> None:
    cues = run_talk("report_conflict", out=tmp_path / "t", seed=0, policy="weighted").cues
    weighted = [c for c in cues if c.get("kind") == "weighted"]
    assert weighted
    assert all(re.search(r"\(weight \d+ >= 600\)", c["reason"]) for c in weighted)
