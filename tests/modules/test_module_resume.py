"""A module restarted mid-talk on a file played as if live continues on the talk's clock.

Before, a restarted speech module deleted its own stream files and read its file again from
0 s: every sample it wrote was stamped in the talk's past, and its metrics stayed stale.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("pocketsphinx", reason='the speech module needs "prezence[speech]"')

HERE = Path(__file__).parent
AUDIO = HERE / "material" / "rate_175.flac"


def _stamps(path: Path) -> list[float]:
    return [float(line.split()[0]) for line in path.read_text().splitlines() if line.strip()]


@pytest.mark.slow
def test_a_restarted_speech_module_appends_and_resumes_at_the_talks_present(
    tmp_path: Path,
) -> None:
    streams = tmp_path / "streams"
    streams.mkdir()
    earlier = streams / "speech_activity.txt"
    earlier.write_text("0.500 1\n1.000 1\n")  # what the module wrote before it died
    late_s = 8.0  # the restart comes 8 s into the talk
    env = {**os.environ, "PREZENCE_APPEND": "1"}
    argv = [sys.executable, "-m", "prezence.modules.speech", "--audio", str(AUDIO)]
    argv += ["--out", str(tmp_path), "--realtime", "--t0", str(time.time() - late_s), "-q"]
    proc = subprocess.run(argv, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    stamps = _stamps(earlier)
    assert stamps[:2] == [0.5, 1.0]  # the record before the restart is kept
    resumed = stamps[2:]
    assert resumed, "the restarted module wrote nothing"
    # on the talk's clock: from about where the talk was when it restarted, never back at 0 s
    assert min(resumed) >= late_s
    assert max(resumed) <= 24.0  # the file's end (22.6 s of audio), not 8 s past it


def test_resume_offset_only_for_a_late_start_of_a_paced_file() -> None:
    import argparse

    from prezence.modules.common import resume_offset

    paced = argparse.Namespace(realtime=True, t0=1000.0)
    assert resume_offset(paced, now=1000.3) == 0.0  # the talk's own start
    assert resume_offset(paced, now=1042.0) == pytest.approx(42.0)
    # a file analysed as fast as it decodes (rehearse) has no talk clock to follow
    assert resume_offset(argparse.Namespace(realtime=False, t0=1000.0), now=1042.0) == 0.0
    assert resume_offset(argparse.Namespace(realtime=True, t0=None), now=1042.0) == 0.0
