"""Stream tailing: parse throughput of poll() and write-to-wake latency of wait().

Prints:
- lines/s parsed by ``StreamTailer.poll`` reading a big file in one poll, and appended in chunks
  (one poll per chunk), each as a ratio to a bare ``map(float, line.split())`` loop;
- the cost of a poll that finds nothing new (one ``stat``);
- the latency from a writer thread's ``os.write`` of one line to ``MultiTailer.wait`` returning,
  p50/p99 over N writes, with inotify and with 5 ms stat polling.

Usage: ``python bench/bench_tail.py [--lines 500000] [--writes 500]``
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import tempfile
import threading
import time
from pathlib import Path

from prezence.samples import Sample
from prezence.streams import MultiTailer, StreamTailer, format_line, inotify_available


def make_file(path: Path, n: int) -> bytes:
    rng = random.Random(1)
    data = "".join(format_line(i * 0.1, rng.uniform(100.0, 200.0)) for i in range(n)).encode()
    path.write_bytes(data)
    return data


def baseline(path: Path) -> int:
    n = 0
    with open(path) as f:
        for line in f:
            _t, _v = map(float, line.split())
            n += 1
    return n


def baseline_samples(path: Path) -> list[Sample]:
    with open(path) as f:
        return [Sample("m", *map(float, line.split())) for line in f]


def best_of(fn: object, repeat: int = 3) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()  # type: ignore[operator]
        best = min(best, time.perf_counter() - t0)
    return best


def throughput(d: Path, n: int) -> None:
    path = d / "big.txt"
    data = make_file(path, n)
    print(f"file: {n} lines, {len(data) / 1e6:.1f} MB")

    def one_poll() -> None:
        got = StreamTailer(path, "m").poll(0.0)
        if len(got) != n:
            raise RuntimeError(f"expected {n} samples, got {len(got)}")

    base = best_of(lambda: baseline(path))
    base_s = best_of(lambda: baseline_samples(path))
    whole = best_of(one_poll)
    print(f"  baseline A: map(float, split)   : {n / base / 1e6:6.2f} M lines/s")
    print(f"  baseline B: A + Sample()        : {n / base_s / 1e6:6.2f} M lines/s")
    print(
        f"  poll(), whole file at once      : {n / whole / 1e6:6.2f} M lines/s"
        f"  ({base / whole:.2f}x A, {base_s / whole:.2f}x B)"
    )

    # Appended in chunks of 1000 lines, one poll after each (the live case, in bulk).
    chunk = 1000
    lines = data.splitlines(keepends=True)
    pieces = [b"".join(lines[i : i + chunk]) for i in range(0, len(lines), chunk)]
    inc = d / "inc.txt"
    inc.write_bytes(b"")
    tail = StreamTailer(inc, "m")
    fd = os.open(inc, os.O_WRONLY | os.O_APPEND)
    spent = 0.0
    got = 0
    try:
        for p in pieces:
            os.write(fd, p)
            t0 = time.perf_counter()
            got += len(tail.poll(0.0))
            spent += time.perf_counter() - t0
    finally:
        os.close(fd)
    if got != n:
        raise RuntimeError(f"expected {n} samples, got {got}")
    print(
        f"  poll() per {chunk}-line append    : {n / spent / 1e6:6.2f} M lines/s"
        f"  ({base / spent:.2f}x A, {base_s / spent:.2f}x B)"
    )

    reps = 20000
    t0 = time.perf_counter()
    for _ in range(reps):
        tail.poll(0.0)
    idle = (time.perf_counter() - t0) / reps
    print(f"  idle poll() (nothing new)       : {idle * 1e6:6.2f} us")


def latency(d: Path, writes: int, watch: str) -> list[float]:
    path = d / f"lat-{watch}.txt"
    path.write_bytes(b"")
    ready = threading.Event()
    stamps: list[float] = []
    stop = False

    def writer() -> None:
        rng = random.Random(2)
        fd = os.open(path, os.O_WRONLY | os.O_APPEND)
        try:
            for i in range(writes):
                if not ready.wait(10.0) or stop:
                    return
                ready.clear()
                time.sleep(rng.uniform(0.0005, 0.002))  # let the reader block in wait()
                stamps.append(time.perf_counter())
                os.write(fd, format_line(i, 1.0).encode())
        finally:
            os.close(fd)

    out: list[float] = []
    with MultiTailer({"m": path}, watch=watch) as tails:  # type: ignore[arg-type]
        tails.poll(0.0)
        th = threading.Thread(target=writer)
        th.start()
        try:
            for i in range(writes):
                ready.set()
                if not tails.wait(5.0):
                    raise RuntimeError(f"wait() timed out at write {i}")
                woke = time.perf_counter()
                while len(stamps) <= i:  # the stamp is appended before the write
                    time.sleep(0)
                out.append(woke - stamps[i])
                if len(tails.poll(float(i))) != 1:
                    raise RuntimeError("expected one sample per write")
        finally:
            stop = True
            ready.set()
            th.join()
    return out


def pct(xs: list[float], q: int) -> float:
    return statistics.quantiles(xs, n=100, method="inclusive")[q - 1] if len(xs) > 1 else xs[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=500_000)
    ap.add_argument("--writes", type=int, default=500)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        throughput(d, args.lines)
        print(f"write -> wait() latency, {args.writes} writes from a writer thread:")
        modes = ["inotify", "poll"] if inotify_available() else ["poll"]
        p50s = {}
        for watch in modes:
            lat = latency(d, args.writes, watch)
            p50, p99 = pct(lat, 50), pct(lat, 99)
            p50s[watch] = p50
            print(
                f"  {watch:8s}: p50 {p50 * 1e3:7.3f} ms  p99 {p99 * 1e3:7.3f} ms"
                f"  max {max(lat) * 1e3:7.3f} ms"
            )
        if len(p50s) == 2:
            print(f"  poll/inotify p50 ratio: {p50s['poll'] / p50s['inotify']:.1f}x")


if __name__ == "__main__":
    main()
