"""Fuzz what a user's files can hold: stream files, configs, session files. Prints counts.

    python bench/fuzz_trust.py [--seed 1] [--streams 3000] [--configs 3000] [--sessions 600]

Each case is fed to what reads it in real use: a stream file to ``read_stream`` (and, for
one case in ten, a whole ``replay``); a config to ``loads_config``; a session folder with a
mutated ``session.json``, ``cues.jsonl``, ``truth.jsonl``, ``config.toml`` or stream file to
``build_report`` and ``replay``. An outcome is

- ``ok``: read without complaint;
- ``clear``: refused with a :class:`prezence.errors.PrezenceError` (a message naming the file);
- ``traceback``: any other exception (a bug);
- ``hang``: still running after ``--timeout`` seconds (SIGALRM; a bug).

Seed 0 is what the checks were developed on; report figures on other seeds too (held out).
Exits 1 when any traceback or hang was seen.
"""

from __future__ import annotations

import argparse
import json
import logging
import random
import shutil
import signal
import sys
import tempfile
import time
import traceback
from collections import Counter
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from prezence.config.load import default_path  # noqa: E402
from prezence.config.tomlconf import loads_config  # noqa: E402
from prezence.errors import PrezenceError  # noqa: E402
from prezence.replay import replay  # noqa: E402
from prezence.report.build import build_report  # noqa: E402
from prezence.streams.tail import read_stream  # noqa: E402
from prezence.talk import RunOptions  # noqa: E402

#: A replay as the command line runs it, without the report (build_report is fuzzed apart).
replay_cli = partial(replay, options=RunOptions.default())


class Hang(Exception):
    pass


def _alarm(signum: int, frame: Any) -> None:
    raise Hang()


def run_case(fn: Callable[[], object], timeout_s: float, log: list[str], what: str) -> str:
    signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    try:
        fn()
        return "ok"
    except Hang:
        log.append(f"HANG {what}")
        return "hang"
    except PrezenceError:
        return "clear"
    except RecursionError:
        log.append(f"TRACEBACK {what}: RecursionError")
        return "traceback"
    except Exception as e:  # noqa: BLE001 - counting them is the point
        log.append(f"TRACEBACK {what}: {type(e).__name__}: {e}\n{traceback.format_exc(limit=4)}")
        return "traceback"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)


# -- material -----------------------------------------------------------------------------------

WEIRD = [
    "nan", "inf", "-inf", "1e9", "1e308", "-1e308", "1e-300", "-0", "0x10", "1_000", "١٢", "",
    " ", "\t", "1e999", "9" * 400, "-5", "3.", ".5", "+7", "1,5", "None", "true",
]  # fmt: skip


VALUES = [*WEIRD, "[]", "{}", "false", '"x"', "-1"]


def stream_text(rng: random.Random) -> bytes:
    n = rng.randint(0, 300)
    out = bytearray()
    t = 0.0
    for _ in range(n):
        r = rng.random()
        if r < 0.6:
            t += rng.uniform(-0.5, 1.0)
            out += f"{t:.3f} {rng.uniform(-500, 500):.2f}\n".encode()
        elif r < 0.8:
            out += f"{rng.choice(WEIRD)} {rng.choice(WEIRD)}\n".encode()
        elif r < 0.9:
            out += bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 80)))
        elif r < 0.95:
            out += b"x" * rng.randint(4000, 9000) + b"\n"
        else:
            out += f"{rng.uniform(0, 100):.2f}\n".encode()  # bare value
    if rng.random() < 0.3 and out:
        out = out[: rng.randint(0, len(out))]  # torn
    return bytes(out)


def mutate_text(text: str, rng: random.Random) -> str:
    lines = text.splitlines()
    for _ in range(rng.randint(1, 4)):
        if not lines:
            lines = [""]
        i = rng.randrange(len(lines))
        op = rng.random()
        if op < 0.2:
            del lines[i]
        elif op < 0.35:
            lines.insert(i, lines[rng.randrange(len(lines))])
        elif op < 0.55:
            head, sep, _ = lines[i].partition("=")
            if sep:
                lines[i] = f"{head}= {rng.choice(VALUES)}"
        elif op < 0.65:
            depth = rng.choice([10, 100, 1000, 5000])
            lines.insert(i, "deep = " + "[" * depth + "]" * depth)
        elif op < 0.8:
            cut = rng.randrange(len(lines[i]) + 1)
            lines[i] = lines[i][:cut]
        elif op < 0.9:
            chars = list(lines[i])
            if chars:
                chars[rng.randrange(len(chars))] = chr(rng.randint(0, 0x2FF))
            lines[i] = "".join(chars)
        else:
            lines.insert(i, rng.choice(["[processor]", "[[rules]]", "[time]", "[room]", "x = 1"]))
    return "\n".join(lines) + ("\n" if rng.random() < 0.9 else "")


def base_session(root: Path) -> Path:
    """A small recorded live talk to mutate (speech_speed out of range, then in)."""
    s = root / "base"
    (s / "streams").mkdir(parents=True)
    cfg = default_path().read_text()
    (s / "config.toml").write_text(cfg)
    lines = [f"{i / 2:.1f} {200.0 if i < 40 else 160.0}" for i in range(120)]
    (s / "streams" / "speech_speed.txt").write_text("\n".join(lines) + "\n")
    (s / "streams" / "speech_volume.txt").write_text("".join(f"{i:.1f} 65\n" for i in range(60)))
    meta = {"format": 1, "kind": "live", "t0_epoch": 1.7e9, "talk_s": 60.0, "policy": "weighted"}
    (s / "session.json").write_text(json.dumps(meta))
    cue = {"t": 20.0, "command": "slowDown", "metric": "speech_speed", "kind": "weighted",
           "deviation": 11.0, "reason": "r", "ok": True, "dropped": False}  # fmt: skip
    (s / "cues.jsonl").write_text(json.dumps(cue) + "\n")
    (s / "truth.jsonl").write_text(json.dumps({"metric": "speech_speed", "start": 0, "end": 20}))
    return s


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--streams", type=int, default=3000)
    ap.add_argument("--configs", type=int, default=3000)
    ap.add_argument("--sessions", type=int, default=600)
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds before a case hangs")
    ap.add_argument("--log", type=Path, help="write tracebacks and hangs here")
    args = ap.parse_args(argv)
    logging.disable(logging.CRITICAL)
    rng = random.Random(args.seed)
    problems: list[str] = []
    counts: dict[str, Counter[str]] = {}
    base_cfg = default_path().read_text()
    t_start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="prezence-fuzz-") as tmp:
        root = Path(tmp)
        base = base_session(root)

        c = counts.setdefault("stream files", Counter())
        for i in range(args.streams):
            f = root / "s.txt"
            f.write_bytes(stream_text(rng))
            c[run_case(partial(read_stream, f, "speech_speed", max_t=100.0), args.timeout,
                       problems, f"stream {i}")] += 1  # fmt: skip
            if i % 10 == 0:
                s = root / f"r{i}"
                shutil.copytree(base, s)
                shutil.copyfile(f, s / "streams" / "speech_speed.txt")
                c[run_case(partial(replay_cli, s, out=root / f"o{i}"), args.timeout, problems,
                           f"replay of stream {i}")] += 1  # fmt: skip
                shutil.rmtree(s)
                shutil.rmtree(root / f"o{i}", ignore_errors=True)

        c = counts.setdefault("configs", Counter())
        for i in range(args.configs):
            text = mutate_text(base_cfg, rng)
            c[run_case(partial(loads_config, text, path="fuzz.toml"), args.timeout, problems,
                       f"config {i}: {text[:200]!r}")] += 1  # fmt: skip

        c = counts.setdefault("session files", Counter())
        names = ["session.json", "cues.jsonl", "truth.jsonl", "config.toml",
                 "streams/speech_speed.txt"]  # fmt: skip
        for i in range(args.sessions):
            s = root / f"m{i}"
            shutil.copytree(base, s)
            name = rng.choice(names)
            p = s / name
            if rng.random() < 0.3:
                p.write_bytes(bytes(rng.getrandbits(8) for _ in range(rng.randint(0, 200))))
            else:
                p.write_text(mutate_text(p.read_text(), rng))
            c[run_case(partial(build_report, s), args.timeout, problems,
                       f"report, {name} mutated ({i})")] += 1  # fmt: skip
            c[run_case(partial(replay_cli, s, out=root / f"mo{i}"), args.timeout, problems,
                       f"replay, {name} mutated ({i})")] += 1  # fmt: skip
            shutil.rmtree(s)
            shutil.rmtree(root / f"mo{i}", ignore_errors=True)
    wall = time.perf_counter() - t_start
    print(f"fuzz seed {args.seed}: {wall:.0f} s")
    print(f"{'material':<15} {'cases':>6} {'ok':>6} {'clear':>6} {'traceback':>10} {'hang':>5}")
    bad = 0
    for what, c in counts.items():
        n = sum(c.values())
        bad += c["traceback"] + c["hang"]
        print(f"{what:<15} {n:>6} {c['ok']:>6} {c['clear']:>6} {c['traceback']:>10} {c['hang']:>5}")
    if args.log:
        args.log.write_text("\n".join(problems))
    for p in problems[:10]:
        print(p, file=sys.stderr)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
