"""The README's first code block is the contract with a new user: two complete commands."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def first_code_block() -> list[str]:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(r"```[a-z]*\n(.*?)```", text, re.S)
    assert m, "README.md has no code block"
    return [ln for ln in m.group(1).splitlines() if ln.strip()]


def test_readme_first_block_is_demo_then_tests() -> None:
    lines = first_code_block()
    assert len(lines) == 2
    demo, tests = lines
    assert "pip install" in demo and "prezence demo" in demo
    assert "pip install" in tests and "pytest" in tests


def test_ci_runs_the_readme_test_command() -> None:
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8")
    assert first_code_block()[1] in ci.splitlines()
