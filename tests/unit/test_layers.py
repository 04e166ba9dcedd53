"""No import cycles between the product's layers (module level and inside functions)."""

from __future__ import annotations

import ast
from pathlib import Path

import prezence

ROOT = Path(prezence.__file__).parent


def _imports() -> dict[str, set[str]]:
    """Module → the prezence modules it imports (anywhere in the file)."""
    out: dict[str, set[str]] = {}
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT.parent).with_suffix("")
        name = ".".join(rel.parts).removesuffix(".__init__")
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                deps.add(node.module)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        out[name] = {d for d in deps if d.startswith("prezence")}
    return out


def test_feedback_does_not_import_config() -> None:
    """config → feedback only (the seed-format reader looks commands up)."""
    imports = _imports()
    bad = {
        m: d
        for m, d in imports.items()
        if m.startswith("prezence.feedback")
        for x in d
        if x.startswith("prezence.config")
    }
    assert bad == {}


def test_the_loop_and_replay_do_not_import_each_other_in_a_cycle() -> None:
    imports = _imports()
    assert "prezence.replay" not in imports["prezence.talk"]
    assert "prezence.streams.locate" in imports["prezence.replay"]
