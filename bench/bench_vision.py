"""CPU seconds per second of video for each part of the vision module.

Parts: ``decode`` (reading the mp4), ``gestures`` (motion energy and bursts, OpenCV only),
``head`` (mediapipe FaceMesh + angles), and ``all`` (the module's whole loop, streams
included, every frame analysed). CPU time is ``time.process_time`` (all threads), divided by the
video's duration: below 1.0 keeps up with live video on this machine at that frame rate.

Frames are the test videos' (320x240, 15 fps); ``--scale 2`` upsamples them to 640x480 to see
how the cost grows with resolution. The head part needs mediapipe: from the main env this
script runs that part in the vision env (``python -m prezence.modules.vision_env install``).

    python bench/bench_vision.py [--scale 1 2]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from prezence.modules import vision, vision_env  # noqa: E402

MATERIAL = ROOT / "tests" / "modules" / "material_video"


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


def bench_gestures(scale: int) -> dict[str, float]:
    frames, fps, dec = load("gestures.mp4", scale)

    def go() -> None:
        det = vision.GestureDetector()
        for i, f in enumerate(frames):
            det.update(i / fps, f)

    return {
        "decode": dec / (len(frames) / fps),
        "gestures": cpu_per_video_s(go, len(frames), fps),
        "ms_per_frame_gestures": cpu_per_video_s(go, len(frames), fps) / fps * 1000,
    }


def bench_head(scale: int) -> dict[str, float]:
    frames, fps, _ = load("head_pose.mp4", scale)
    with vision.HeadPoseEstimator() as est:
        est.estimate(frames[0])  # the graph's first frame loads the models

        def go() -> None:
            for f in frames:
                est.estimate(f)

        head = cpu_per_video_s(go, len(frames), fps)
    with tempfile.TemporaryDirectory() as tmp:
        src = vision.FileSource(MATERIAL / "head_pose.mp4")
        t0 = time.process_time()
        vision.run(src, Path(tmp), vision.VisionOptions(fps=0, calibrate_s=2.0))
        whole = (time.process_time() - t0) / (len(frames) / fps)
        src.close()
    out = {"head": head, "ms_per_frame_head": head / fps * 1000}
    if scale == 1:
        out["all"] = whole
    return out


def head_elsewhere(scale: int) -> dict[str, float] | None:
    py = vision_env.find_python()
    if py is None:
        print(f"head: skipped, no vision env ({vision_env.INSTALL_HINT})")
        return None
    proc = subprocess.run(
        [str(py), __file__, "--head-only", "--scale", str(scale)],
        capture_output=True,
        text=True,
        check=True,
    )
    result: dict[str, float] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="CPU seconds per second of video, per part.")
    ap.add_argument("--scale", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--head-only", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.head_only:
        print(json.dumps(bench_head(args.scale[0])))
        return 0
    print(f"python {sys.version.split()[0]}, OpenCV {cv2.__version__}, numpy {np.__version__}")
    for scale in args.scale:
        res = bench_gestures(scale)
        head = bench_head(scale) if vision.mediapipe_available() else head_elsewhere(scale)
        if head:
            res.update(head)
        size = f"{320 * scale}x{240 * scale}"
        print(f"{size} @ 15 fps: CPU s per video s (ms per frame)")
        for part in ("decode", "gestures", "head", "all"):
            if part in res:
                ms = res.get(f"ms_per_frame_{part}")
                extra = f"  ({ms:.2f} ms/frame)" if ms is not None else ""
                print(f"  {part:9s} {res[part]:.3f}{extra}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
