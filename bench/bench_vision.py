"""The vision module's figures: CPU per video second, gesture-rate error, head-pose error per face.

Figures, never assertions. Material: ``tests/modules/material_video`` (``tools/make_test_video.py``
rebuilds it; its manifest holds the truth and which videos the module was tuned on).

``cpu``
    CPU seconds (``time.process_time``, all threads) per second of video for the parts:
    ``decode`` (reading the mp4), ``motion`` (the frame-difference fallback), ``face``
    (FaceMesh + angles), ``body`` (Pose keypoints) and ``module`` (the module's whole loop at
    its default ``--fps``, streams included, head pose and gestures from the body). Below 0.25
    leaves a core for the rest on a 2-core laptop. ``--scale 2`` upsamples to 640x480.
``gestures``
    Each gesture video through the module (default options, the rate's window the whole
    video): true gestures found (within 0.6 s of a true start), false ones, and the rate read
    against the true one; then the same with the frame-difference fallback.
``head``
    Each face's head-pose video through the module (every frame, 2 s calibration): per axis,
    the median and the worst absolute error over the holds, and the share of hold frames within
    5 deg; the faces the gains were fitted on and the held-out ones apart.

Needs mediapipe: from the main env the script re-runs itself in the vision env
(``python -m prezence.modules.vision_env install``).

    python bench/bench_vision.py [--part cpu gestures head] [--scale 1 2] [--material DIR]

``--material DIR`` reads another folder of videos and its manifest (held-out presenters made
with ``tools/make_test_video.py --random-gestures``, kept outside the repository).
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from prezence.modules import vision, vision_env  # noqa: E402

MATERIAL = ROOT / "tests" / "modules" / "material_video"
MANIFEST: dict[str, Any] = json.loads((MATERIAL / "manifest.json").read_text())
MATCH_S = 0.6


def load(name: str, scale: int) -> tuple[list[np.ndarray], float, float]:
    """Decode a video; return its frames, fps and the CPU seconds decoding took."""
    t0 = time.process_time()
    cap = cv2.VideoCapture(str(MATERIAL / name))
    fps = cap.get(cv2.CAP_PROP_FPS)
    frames = []
    while True:
        ok, f = cap.read()
        if not ok:
            break
        frames.append(f)
    cap.release()
    dec = time.process_time() - t0
    if scale != 1:
        h, w = frames[0].shape[:2]
        frames = [cv2.resize(f, (w * scale, h * scale)) for f in frames]
    return frames, fps, dec


def cpu_per_video_s(fn: Callable[[], None], n_frames: int, fps: float) -> float:
    t0 = time.process_time()
    fn()
    return (time.process_time() - t0) / (n_frames / fps)


def bench_cpu(scale: int) -> None:
    name = MANIFEST["gestures_a"]["file"]
    frames, fps, dec = load(name, scale)
    dur = len(frames) / fps
    res = {"decode": dec / dur}

    def motion() -> None:
        det = vision.GestureDetector()
        for i, f in enumerate(frames):
            det.update(i / fps, f)

    res["motion"] = cpu_per_video_s(motion, len(frames), fps)
    with vision.HeadPoseEstimator() as est:
        est.estimate(frames[0])  # the first frame loads the model

        def face() -> None:
            for f in frames:
                est.estimate(f)

        res["face"] = cpu_per_video_s(face, len(frames), fps)
    tracker = vision.BodyTracker()
    tracker.keypoints(frames[0])

    def body() -> None:
        for f in frames:
            tracker.keypoints(f)

    res["body"] = cpu_per_video_s(body, len(frames), fps)
    tracker.close()
    print(f"{320 * scale}x{240 * scale} @ {fps:g} fps ({name}): CPU s per video s")
    for part in ("decode", "motion", "face", "body"):
        print(f"  {part:8s} {res[part]:.3f}  ({res[part] / fps * 1000:.1f} ms/frame, every frame)")
    if scale == 1:
        opts = vision.VisionOptions(calibrate_s=2.0)
        with tempfile.TemporaryDirectory() as tmp:
            src = vision.FileSource(MATERIAL / name)
            t0 = time.process_time()
            vision.run(src, Path(tmp), opts)
            whole = (time.process_time() - t0) / dur
            src.close()
        print(f"  module   {whole:.3f}  (head pose + body gestures at --fps {opts.fps:g}, decode)")


def run_module(
    name: str, opts: vision.VisionOptions
) -> tuple[vision.RunSummary, dict[str, list[tuple[float, float]]], float]:
    """One video through the module's loop: its summary, its streams (read, and the session
    folder removed: each call left one in the temp folder) and the CPU seconds it took."""
    tmp = Path(tempfile.mkdtemp(prefix="bench-vision-"))
    try:
        src = vision.FileSource(MATERIAL / name)
        t0 = time.process_time()
        try:
            summary = vision.run(src, tmp, opts)
        finally:
            src.close()
        cpu = time.process_time() - t0
        streams = {p.stem: read_stream(p) for p in (tmp / "streams").glob("*.txt")}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return summary, streams, cpu


def bench_gestures() -> None:
    print("gestures: found / true, false, rate read vs true (per min, the whole video)")
    for key in sorted(k for k in MANIFEST if k.startswith("gestures_")):
        entry = MANIFEST[key]
        truth = [(g["start"], g["end"]) for g in entry["gestures"]]
        for src in ("body", "motion"):
            opts = vision.VisionOptions(
                calibrate_s=2.0, gesture_window_s=entry["duration_s"], gesture_source=src
            )
            summary, streams, cpu = run_module(entry["file"], opts)
            found = summary.bursts
            hits = sum(1 for s, _ in truth if any(abs(f - s) <= MATCH_S for f in found))
            false = [f for f in found if all(not (s - MATCH_S <= f <= e) for s, e in truth)]
            # the fallback's rate goes to its own stream (session 23), the body's to cv_gestures
            t_end, read = streams["cv_gestures_motion" if src == "motion" else "cv_gestures"][-1]
            # The last sample's rate is over the video seen until then.
            n_true = sum(1 for s, _ in truth if s <= t_end)
            true = n_true / min(entry["duration_s"], t_end) * 60.0
            print(
                f"  {key} ({entry['role']}, face {entry['face']}), {src:6s}: "
                f"{hits}/{len(truth)} found, {len(false)} false "
                f"{[round(f, 1) for f in false]}; rate {read:.2f} vs {true:.2f} "
                f"({read - true:+.2f}/min); CPU {cpu / entry['duration_s']:.3f} s/s"
            )


def read_stream(path: Path) -> list[tuple[float, float]]:
    return [(float(t), float(v)) for t, v in (ln.split() for ln in path.read_text().splitlines())]


def bench_head() -> None:
    print("head pose: |error| deg over the holds: median / worst, share within 5 deg")
    for role in ("fit", "held-out"):
        for entry in MANIFEST["heads"].values():
            if entry["role"] != role:
                continue
            opts = vision.VisionOptions(fps=0, calibrate_s=entry["calibration_s"], gestures=False)
            _, streams, _ = run_module(entry["file"], opts)
            est = {"yaw": streams["cv_headYaw"], "pitch": streams["cv_headGaze"]}
            parts = []
            for axis in ("yaw", "pitch"):
                errs = []
                for h in entry["holds"][1:]:
                    errs += [abs(v - h[axis]) for t, v in est[axis] if h["start"] <= t <= h["end"]]
                e = np.array(errs)
                parts.append(f"{axis} {np.median(e):.1f} / {e.max():.1f}, {np.mean(e <= 5.0):.0%}")
            print(f"  {entry['face']:10s} ({role:8s}): " + "; ".join(parts))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="The vision module's figures.")
    ap.add_argument("--part", nargs="+", choices=("cpu", "gestures", "head"), default=None)
    ap.add_argument("--scale", type=int, nargs="+", default=[1])
    ap.add_argument("--material", type=Path, default=None, help="another video folder")
    args = ap.parse_args(argv)
    if args.material is not None:
        global MATERIAL, MANIFEST
        MATERIAL = args.material.resolve()
        MANIFEST = json.loads((MATERIAL / "manifest.json").read_text())
    parts = args.part or ["cpu", "gestures", "head"]
    if not vision.mediapipe_available():
        py = vision_env.find_python()
        if py is None:
            print(f"needs the vision env: {vision_env.INSTALL_HINT}", file=sys.stderr)
            return 2
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        cmd = [str(py), __file__, *(argv if argv is not None else sys.argv[1:])]
        return subprocess.run(cmd, env=env, check=False).returncode
    logging.basicConfig(level=logging.ERROR)
    print(f"python {sys.version.split()[0]}, OpenCV {cv2.__version__}, numpy {np.__version__}")
    if "cpu" in parts:
        for scale in args.scale:
            bench_cpu(scale)
    if "gestures" in parts:
        bench_gestures()
    if "head" in parts:
        bench_head()
    return 0


if __name__ == "__main__":
    sys.exit(main())
