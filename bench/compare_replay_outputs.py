"""Whether two checkouts of Prezence write the same files, byte for byte, for the same talks.

    python bench/compare_replay_outputs.py OLD_CHECKOUT NEW_CHECKOUT [--load DIR ...] [--work DIR]

For each checkout in turn (``PYTHONPATH`` set to it, the same Python), into the same output
paths (so that the paths a file records are the same), it runs: ``prezence replay`` of each
``--load`` folder (the peers' workloads, with their ``rules.conf`` and ``room.toml``, without
the report), also under every policy the command line offers; ``prezence demo --backend
fake``; ``prezence run SCENARIO --backend fake`` for every scenario in ``scenarios/`` and a
``prezence replay`` of each of those folders; and, for three scenarios (the first two by
name and note_reader), a replay under every policy. Each command's folder is moved aside,
then every file the two checkouts wrote is compared byte for byte, and the command's stdout
too.

Excluded, as wall-clock times: in any JSON file the keys ``wall_s`` (and any ending in it),
``realtime_factor``, ``started_at`` and ``label`` (the report's progress table names each
session by when it was run); in any other file a date and time like "26 Nov 2026 02:09:28"
(the same table in ``report.html``) and the command's "in 0.45 s wall (1316.7x real time)".
Paths are the same on both sides (the same output folders), so nothing is excluded for them.
Prints each difference and exits 1 when there is one.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

#: JSON keys whose values are wall-clock times (not what the coach decided).
WALL_KEYS = ("wall_s", "realtime_factor", "started_at", "label")


def policies(checkout: Path) -> list[str]:
    """The policy names the command line offers (the registry, with the anchors)."""
    code = (
        "from prezence.processor import make_policy\n"
        "from prezence.processor.resolve import POLICIES\n"
        "print(' '.join(POLICIES))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "PYTHONPATH": str(checkout)},
        capture_output=True,
        text=True,
        check=True,
    )
    return out.stdout.split()


def commands(checkout: Path, loads: list[Path], work: Path) -> list[tuple[str, list[str]]]:
    """(name, argv after ``prezence``) of every run, in order (a replay after its run)."""
    out: list[tuple[str, list[str]]] = []
    names = policies(checkout)
    for load in loads:
        base = [
            "replay",
            str(load),
            "--config",
            str(load / "rules.conf"),
            "--room",
            str(load / "room.toml"),
            "--no-report",
            "-q",
        ]
        out.append((f"load_{load.name}", [*base, "--out", str(work / f"load_{load.name}")]))
        for p in names:
            name = f"load_{load.name}_{p}"
            out.append((name, [*base, "--policy", p, "--out", str(work / name)]))
    out.append(("demo", ["demo", "--backend", "fake", "-q", "--out", str(work / "demo")]))
    scenarios = sorted(p.stem for p in (checkout / "scenarios").glob("*.toml"))
    for sc in scenarios:
        run = work / f"run_{sc}"
        out.append((f"run_{sc}", ["run", sc, "--backend", "fake", "-q", "--out", str(run)]))
        out.append((f"rep_{sc}", ["replay", str(run), "-q", "--out", str(work / f"rep_{sc}")]))
    for sc in scenarios[:2] + ["note_reader"]:
        for p in names:
            name = f"rep_{sc}_{p}"
            out.append(
                (
                    name,
                    [
                        "replay",
                        str(work / f"run_{sc}"),
                        "--policy",
                        p,
                        "-q",
                        "--out",
                        str(work / name),
                    ],
                )
            )
    return out


def run_all(checkout: Path, loads: list[Path], work: Path, keep: Path) -> None:
    """Run every command with ``checkout``'s code, then move its folders to ``keep``."""
    env = {**os.environ, "PYTHONPATH": str(checkout), "PYTHONDONTWRITEBYTECODE": "1"}
    cmds = commands(checkout, loads, work)
    for name, argv in cmds:
        p = subprocess.run(
            [sys.executable, "-m", "prezence", *argv], env=env, capture_output=True, text=True
        )
        keep.mkdir(parents=True, exist_ok=True)
        (keep / f"{name}.stdout").write_text(f"exit {p.returncode}\n{p.stdout}")
    for name, _ in cmds:
        src = work / name
        if src.exists():
            shutil.move(str(src), str(keep / name))


def _drop_wall(v: Any) -> Any:
    if isinstance(v, dict):
        return {
            k: _drop_wall(x)
            for k, x in v.items()
            if k not in WALL_KEYS and not k.endswith("wall_s")
        }
    if isinstance(v, list):
        return [_drop_wall(x) for x in v]
    return v


#: A session's label in the report's progress table: the date and time it was run.
_WHEN = re.compile(rb"\d{1,2} [A-Z][a-z]{2} \d{4} \d\d:\d\d(:\d\d)?")
#: The command's closing line: "simulated 590 s in 0.45 s wall (1316.7x real time)".
_WALL = re.compile(rb"in [\d.]+ s wall \([\d.]+x real time\)")


def comparable(path: Path) -> bytes:
    """The file's bytes, wall-clock fields taken out (see the module's doc)."""
    data = path.read_bytes()
    if path.suffix == ".json":
        try:
            return json.dumps(_drop_wall(json.loads(data)), sort_keys=True).encode()
        except ValueError:
            return data
    return _WALL.sub(b"in (wall)", _WHEN.sub(b"(when)", data))


def compare(old: Path, new: Path) -> tuple[list[str], int]:
    """The differences between the two trees (and how many files both have)."""
    diffs: list[str] = []
    files_old = {p.relative_to(old) for p in old.rglob("*") if p.is_file()}
    files_new = {p.relative_to(new) for p in new.rglob("*") if p.is_file()}
    for rel in sorted(files_old ^ files_new):
        diffs.append(f"only in {'old' if rel in files_old else 'new'}: {rel}")
    for rel in sorted(files_old & files_new):
        if comparable(old / rel) != comparable(new / rel):
            diffs.append(f"differs: {rel}")
    return diffs, len(files_old & files_new)


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--load", type=Path, action="append", default=[])
    ap.add_argument("--work", type=Path, default=Path("/tmp/compare_replay_outputs"))
    args = ap.parse_args()
    work: Path = args.work
    if work.exists():
        shutil.rmtree(work)
    out = work / "out"
    out.mkdir(parents=True)
    run_all(args.old.resolve(), args.load, out, work / "old")
    run_all(args.new.resolve(), args.load, out, work / "new")
    diffs, n = compare(work / "old", work / "new")
    for d in diffs:
        print(d)
    print(f"{n} files compared, {len(diffs)} differences")
    return 1 if diffs else 0


if __name__ == "__main__":
    sys.exit(main())
