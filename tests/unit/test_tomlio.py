"""Where a key of a TOML file is defined: errors name that line (tomllib keeps no positions)."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

import pytest

from prezence.tomlio import _HEADER, _KEYLINE, KeyLines, KeyPath, _split_key

ROOT = Path(__file__).resolve().parents[2]


def _line_by_scan(text: str, kp: KeyPath) -> int | None:
    """The definition read literally: a scan of the whole text for one key path."""
    counts: dict[tuple[str, ...], int] = {}
    ctx: KeyPath = ()
    best, best_n = None, 0
    for lineno, line in enumerate(text.split("\n"), start=1):
        m = _HEADER.match(line)
        if m:
            name = _split_key(m.group(2))
            if m.group(1) == "[[":
                counts[name] = counts.get(name, -1) + 1
                ctx = (*name, counts[name])
            else:
                ctx = name
            full = ctx
        else:
            k = _KEYLINE.match(line)
            if not k:
                continue
            full = (*ctx, *_split_key(k.group(1)))
        n = 0
        while n < min(len(full), len(kp)) and full[n] == kp[n]:
            n += 1
        if n == len(kp):
            return lineno
        if n > best_n:
            best, best_n = lineno, n
    return best


def _paths(node: Any, prefix: KeyPath = ()) -> list[KeyPath]:
    out = [prefix]
    if isinstance(node, dict):
        for k, v in node.items():
            out += _paths(v, (*prefix, k))
            out.append((*prefix, k, "no_such_key"))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += _paths(v, (*prefix, i))
    return out


FILES = sorted(
    [
        *ROOT.glob("prezence/feedback/data/*.toml"),
        *ROOT.glob("prezence/config/defaults/*.toml"),
        *ROOT.glob("scenarios/*.toml"),
        *ROOT.glob("examples/**/*.toml"),
    ]
)


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_one_scan_finds_every_key_where_a_scan_per_key_does(path: Path) -> None:
    # a library's keyframes each ask for their line: one scan serves them all (session 14:
    # a scan per keyframe cost every talk ~0.02 s); the lines are the same as before
    text = path.read_text()
    lines = KeyLines(text)
    paths = [*_paths(tomllib.loads(text)), ("nothing", "here")]
    assert len(paths) > 5
    for kp in paths:
        assert lines.line(kp) == _line_by_scan(text, kp), kp
