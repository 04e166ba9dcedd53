"""Issue 13: the report opened in headless Chromium; ``evaluate --ray local`` on loopback only."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from prezence.cli import main

CHROMIUM = next(
    (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome") if shutil.which(n)),
    None,
)


@pytest.mark.slow
@pytest.mark.skipif(CHROMIUM is None, reason="Chromium is not installed (apt-get install chromium)")
def test_the_report_renders_in_headless_chromium(tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    s = tmp_path / "talk"
    assert main(["run", "demo", "--out", str(s), "--plots", "-q"]) == 0
    page = s / "report" / "report.html"
    with tempfile.TemporaryDirectory(prefix="prezence-chromium-") as profile:
        common = [
            CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
            f"--user-data-dir={profile}",
        ]  # fmt: skip
        dom = subprocess.run(
            [*common, "--dump-dom", page.as_uri()],
            capture_output=True,
            text=True,
            timeout=120,
            check=True,
        ).stdout
        shot = tmp_path / "report.png"
        subprocess.run(
            [*common, f"--screenshot={shot}", "--window-size=1100,2400", page.as_uri()],
            capture_output=True,
            timeout=120,
            check=True,
        )
    # what the browser built: every section, the plots decoded as images, plain words
    for heading in ("Work on first", "Overview", "Timelines", "Head turns", "Cues"):
        assert f"<h2>{heading}</h2>" in dom
    assert len(re.findall(r'<img alt="[^"]+" src="data:image/png;base64,', dom)) >= 3
    assert "%·s" not in dom and "improved" not in dom
    assert shot.stat().st_size > 50_000  # a page with plots, not a blank one


_PROBE = """
import os, re, subprocess, sys
if sys.argv[1] == "ray first":
    import ray  # as a notebook or a test runner may have done before prezence sets Ray up
from prezence import evaluate
evaluate._run_ray([], "local", 1)
import ray


def children(pid):
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            return [int(c) for c in f.read().split()]
    except OSError:
        return []


ours, todo = set(), [os.getpid()]
while todo:
    pid = todo.pop()
    ours.add(pid)
    todo += children(pid)
out = subprocess.run(["ss", "-ltnpH"], capture_output=True, text=True).stdout
for line in out.splitlines():  # only this cluster's servers: another Ray may run on the machine
    if {int(p) for p in re.findall(r"pid=(\\d+)", line)} & ours:
        print(line)
ray.shutdown()
"""


@pytest.mark.slow
@pytest.mark.parametrize("order", ["prezence first", "ray first"])
def test_evaluate_ray_local_listens_on_loopback_only(tmp_path: Path, order: str) -> None:
    pytest.importorskip("ray")
    if shutil.which("ss") is None:
        pytest.skip("ss (iproute2) is needed to list listening sockets")
    if not Path(f"/proc/{os.getpid()}/task/{os.getpid()}/children").exists():
        pytest.skip("/proc/PID/task/PID/children is needed to find the cluster's processes")
    probe = tmp_path / "probe.py"
    probe.write_text(_PROBE)
    root = Path(__file__).resolve().parents[2]
    p = subprocess.run(
        [sys.executable, str(probe), order],
        capture_output=True,
        text=True,
        timeout=240,
        env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin"},
    )
    assert p.returncode == 0, p.stderr[-2000:]
    ray_lines = [
        ln
        for ln in p.stdout.splitlines()
        if any(k in ln for k in ("gcs_server", "raylet", "ray::"))
    ]
    assert ray_lines, "no Ray server found listening"
    for ln in ray_lines:
        local = ln.split()[3]
        assert local.startswith(("127.0.0.1:", "[::ffff:127.0.0.1]:", "[::1]:")), ln
