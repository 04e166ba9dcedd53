"""``prezence rehearse``: a recorded rehearsal (phone video or audio) gives the same session folder
and report as a live talk.

The input modules run over the recording as fast as the machine allows (in parallel, one
process each), writing stream files stamped with the recording's own time; then the coach runs
over those files on the recording's clock, exactly as it does on a live talk's files.
"""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path
from typing import Any

from prezence.config.load import load_config
from prezence.config.model import Config
from prezence.config.tomlconf import dumps_config
from prezence.errors import ConfigError, PrezenceError
from prezence.replay import ReplayResult, find_streams, load_samples, process_recorded
from prezence.session import SessionDir

log = logging.getLogger(__name__)

AUDIO_EXT = {".wav", ".flac", ".mp3", ".ogg", ".m4a"}
VIDEO_EXT = {".mp4", ".mov", ".mkv", ".avi", ".webm"}


def module_commands(
    recording: Path, session: Path, *, realtime: bool = False
) -> dict[str, list[str]]:
    """The module command lines for a recording: speech for audio, speech and vision for video."""
    ext = recording.suffix.lower()
    if ext not in AUDIO_EXT | VIDEO_EXT:
        known = ", ".join(sorted(AUDIO_EXT | VIDEO_EXT))
        raise ConfigError(
            f"not an audio or video file I know (extensions: {known})", path=recording
        )
    pace = ["--realtime"] if realtime else []
    cmds = {
        "speech": [
            sys.executable,
            "-m",
            "prezence.modules.speech",
            "--audio",
            str(recording),
            "--out",
            str(session),
            "-q",
            *pace,
        ]
    }
    if ext in VIDEO_EXT:
        cmds["vision"] = [
            sys.executable,
            "-m",
            "prezence.modules.vision",
            "--video",
            str(recording),
            "--out",
            str(session),
            "-q",
            *pace,
        ]
    return cmds


def rehearse(
    recording: Path,
    *,
    out: Path,
    config: Config | None = None,
    policy: str = "weighted",
    backend: str = "fake",
    backend_kwargs: dict[str, Any] | None = None,
    speed_fraction: float = 0.6,
    modules: dict[str, list[str]] | None = None,
) -> ReplayResult:
    """Analyse ``recording`` with the input modules, then coach over the result.

    Raises:
        ConfigError: the recording is missing or of an unknown kind.
        PrezenceError: every module failed (their messages are included).
    """
    recording = Path(recording)
    if not recording.is_file():
        raise ConfigError("no such recording", path=recording)
    config = config or load_config(None)
    session = SessionDir(Path(out)).create()
    session.config.write_text(dumps_config(config))
    cmds = modules if modules is not None else module_commands(recording, session.root)
    procs = {
        name: subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for name, argv in cmds.items()
    }
    failures: dict[str, str] = {}
    for name, p in procs.items():
        _, err = p.communicate()
        (session.root / f"{name}.log").write_text(err)
        if p.returncode != 0:
            msg = err.strip().splitlines()[-1] if err.strip() else f"exit status {p.returncode}"
            failures[name] = msg
            log.warning("module %s failed: %s", name, msg)
    if len(failures) == len(procs):
        raise PrezenceError("; ".join(f"{n}: {m}" for n, m in failures.items()))
    paths = find_streams(session.root, config)
    samples = load_samples(paths)
    talk_s = samples[-1].t if samples else 0.0
    session.write_meta(
        {
            "kind": "rehearsal",
            "recording": str(recording),
            "talk_s": talk_s,
            "policy": policy,
            "backend": backend,
        }
    )
    return process_recorded(
        session,
        config,
        samples,
        talk_s=talk_s,
        policy=policy,
        backend=backend,
        backend_kwargs=backend_kwargs,
        speed_fraction=speed_fraction,
        extra={"kind": "rehearsal", "recording": str(recording), "module_failures": failures},
    )
