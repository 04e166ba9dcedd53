"""Render a gesture as the PyBullet NAO performs it: a labelled contact sheet and a video.

Headless: PyBullet's CPU ``ER_TINY_RENDERER`` (DIRECT mode has no OpenGL). The robot is played
through :class:`sim.nao.NaoSim` exactly as in a talk (velocity-capped tracking of the planned
trajectory), so the pictures show what the simulated robot did, not just the plan.

Videos (the suffix picks the format, checked before anything is rendered):

* ``.mp4``: H.264 (``avc1``, what browsers play) when the OpenCV build can encode it, else
  MPEG-4 Part 2 (``mp4v``, which VLC and most desktop players play but browsers often do not);
  the result says which (``video_codec``).
* ``.gif``: an animated GIF through Pillow (installed with matplotlib, the ``report`` extra).
* ``.avi``: Motion JPEG.
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import sys
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p

from prezence.errors import ConfigError
from prezence.feedback.gestures import (
    DEFAULT_SPEED_FRACTION,
    GestureLibrary,
    build_trajectory,
    load_library,
)
from prezence.feedback.limits import load_limits
from prezence.feedback.trajectory import Trajectory
from sim.nao import NaoSim

log = logging.getLogger(__name__)

#: Physics step for rendering (fine: pictures are not on the talk's hot path).
RENDER_TIMESTEP = 1 / 240
FRAME_SIZE = (240, 240)
#: Two cameras side by side in every frame: nearly facing the robot (arm spread, head turn and
#: nod read best) and from its front-right (reach forward and head tilt read best).
CAMERA_TARGET = (0.0, 0.0, 0.30)
CAMERA_DISTANCE = 0.95
CAMERA_VIEWS = ((90.0 + 15.0, -8.0), (90.0 - 60.0, -10.0))
#: Video suffixes and the codecs tried, in order ("gif": written with Pillow, not OpenCV).
VIDEO_CODECS: Mapping[str, tuple[str, ...]] = {
    ".mp4": ("avc1", "mp4v"),
    ".gif": ("gif",),
    ".avi": ("MJPG",),
}


def _cv2() -> Any:
    try:
        import cv2
    except ModuleNotFoundError as e:  # an optional part of the sim extra
        from prezence.errors import BackendUnavailable

        raise BackendUnavailable(
            'rendering needs OpenCV: pip install "prezence[sim]" (opencv-python-headless)'
        ) from e
    return cv2


def check_video_path(path: Path | str) -> Path:
    """``path`` if its suffix is a video format this module writes, else a clear error.

    Raises:
        ConfigError: an unsupported suffix (naming the ones supported).
        BackendUnavailable: a GIF without Pillow, or a video without OpenCV.
    """
    from prezence.errors import BackendUnavailable, ConfigError

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in VIDEO_CODECS:
        supported = ", ".join(VIDEO_CODECS)
        raise ConfigError(
            f"cannot write a video as {suffix or 'a file without a suffix'!r}: use one of "
            f"{supported} (MP4 plays in browsers when OpenCV has H.264)",
            path=path,
        )
    if suffix == ".gif":
        try:
            import PIL.Image  # noqa: F401
        except ImportError as e:
            raise BackendUnavailable(
                'a GIF needs Pillow: pip install "prezence[report]" (or pillow), or write .mp4'
            ) from e
    else:
        _cv2()
    return path


def _add_floor(cid: int) -> None:
    vis = p.createVisualShape(
        p.GEOM_BOX,
        halfExtents=[0.6, 0.6, 0.005],
        rgbaColor=[0.80, 0.82, 0.78, 1],
        physicsClientId=cid,
    )
    p.createMultiBody(
        baseMass=0, baseVisualShapeIndex=vis, basePosition=[0, 0, -0.005], physicsClientId=cid
    )


def _cameras(cid: int, size: tuple[int, int]) -> list[tuple[list[float], list[float]]]:
    proj = p.computeProjectionMatrixFOV(40, size[0] / size[1], 0.05, 5.0, physicsClientId=cid)
    out = []
    for yaw, pitch in CAMERA_VIEWS:
        view = p.computeViewMatrixFromYawPitchRoll(
            list(CAMERA_TARGET), CAMERA_DISTANCE, yaw, pitch, 0, 2, physicsClientId=cid
        )
        out.append((list(view), list(proj)))
    return out


def _grab(
    cid: int, size: tuple[int, int], cameras: Sequence[tuple[list[float], list[float]]]
) -> np.ndarray:
    """One frame: the views side by side (RGB uint8)."""
    images = []
    for view, proj in cameras:
        w, h, rgba, _, _ = p.getCameraImage(
            size[0],
            size[1],
            view,
            proj,
            renderer=p.ER_TINY_RENDERER,
            lightDirection=[1.0, 0.6, 2.0],
            physicsClientId=cid,
        )
        images.append(np.reshape(np.asarray(rgba, dtype=np.uint8), (h, w, 4))[:, :, :3])
    return np.hstack(images)


def sheet_times(traj: Trajectory, n: int = 6) -> list[float]:
    """Times worth showing: the start, then the keyframe poses (mid-hold for held ones), ``n``
    picked evenly."""
    moments: list[float] = [0.0]
    knots = (0.0, *traj.times)
    pos = (traj.start, *traj.positions)
    for k in range(1, len(knots)):
        if pos[k] == pos[k - 1]:  # a hold: show its middle
            moments[-1] = (knots[k - 1] + knots[k]) / 2.0
        else:
            moments.append(knots[k])
    moments[-1] = traj.duration
    if len(moments) <= n:
        return moments
    pick = np.linspace(0, len(moments) - 1, n).round().astype(int)
    return [moments[i] for i in sorted(set(pick.tolist()))]


def contact_sheet(
    frames: Sequence[np.ndarray], labels: Sequence[str], title: str, *, cols: int = 2
) -> np.ndarray:
    """Frames in a grid with a label under each and a title bar (RGB uint8)."""
    cv2 = _cv2()
    h, w = frames[0].shape[:2]
    rows = math.ceil(len(frames) / cols)
    label_h, title_h = 24, 34
    sheet = np.full((title_h + rows * (h + label_h), cols * w, 3), 255, dtype=np.uint8)
    cv2.putText(sheet, title, (8, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (20, 20, 20), 1, cv2.LINE_AA)
    for i, (img, lab) in enumerate(zip(frames, labels, strict=True)):
        r, c = divmod(i, cols)
        y, x = title_h + r * (h + label_h), c * w
        sheet[y : y + h, x : x + w] = img
        cv2.putText(
            sheet,
            lab,
            (x + 6, y + h + 17),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.45,
            (40, 40, 40),
            1,
            cv2.LINE_AA,
        )
    return sheet


def render_gesture(
    name: str,
    out_png: Path | str,
    out_video: Path | str | None = None,
    *,
    params: Mapping[str, Any] | None = None,
    fps: int = 25,
    speed_fraction: float = DEFAULT_SPEED_FRACTION,
    size: tuple[int, int] = FRAME_SIZE,
    frames: int = 6,
    library: GestureLibrary | None = None,
) -> dict[str, Any]:
    """Play gesture ``name`` on the simulated NAO and save pictures of it.

    Args:
        name: gesture name (``time_left`` takes ``params={"minutes": N}``).
        out_png: contact sheet of ``frames`` labelled frames.
        out_video: ``.mp4``, ``.gif`` or ``.avi`` (see the module docstring); None for no
            video. Checked before rendering.
        params: gesture parameters.
        fps: video frame rate (frames are rendered at simulated times k / fps).
        speed_fraction: fraction of the URDF velocity limits.
        size: width and height of each view in pixels (a frame holds two views).
        frames: frames on the contact sheet.
        library: the gesture library (default: the built-in one; a library of one's own from
            :func:`~prezence.feedback.gestures.load_library_file`).

    Returns:
        Figures of the run: planned and measured duration, frames written, the video codec.

    Raises:
        ConfigError: a contact sheet suffix OpenCV cannot write or an unsupported video suffix
            (before anything is rendered).
        BackendUnavailable: OpenCV missing, or Pillow for a GIF.
    """
    cv2 = _cv2()
    out_png = Path(out_png)
    if not cv2.haveImageWriter(str(out_png)):
        kind = f"'{out_png.suffix}'" if out_png.suffix else "a file without a suffix"
        raise ConfigError(f"{out_png}: cannot write the contact sheet as {kind}: use .png or .jpg")
    if out_video is not None:
        out_video = check_video_path(out_video)
    limits = load_limits()
    lib = library if library is not None else load_library(limits)
    gesture = lib[name]  # unknown gesture raises before any work
    if params is not None:
        # values are clamped to the parameter's range: show and say what is played
        played = gesture.resolve_params(params)
        for key, value in params.items():
            if key not in played:
                log.warning("%s has no parameter %s: ignored", name, key)
            elif played[key] != value:
                p_ = gesture.params[key]
                log.warning(
                    "%s: %s = %s is outside %d..%d: rendered at %d, as a talk would play it",
                    name,
                    key,
                    value,
                    p_.low,
                    p_.high,
                    played[key],
                )
        params = played
    traj = build_trajectory(
        name, params=params, speed_fraction=speed_fraction, limits=limits, library=lib
    )
    sheet_at = sheet_times(traj, frames)
    video_at = [k / fps for k in range(int(math.ceil((traj.duration + 0.3) * fps)) + 1)]
    wanted = sorted({*sheet_at, *(video_at if out_video is not None else [])})
    shots: dict[float, np.ndarray] = {}
    with NaoSim(timestep=RENDER_TIMESTEP) as sim:
        cid = sim.client
        _add_floor(cid)
        camera = _cameras(cid, size)
        sim.follow(traj, speed_fraction=speed_fraction)
        for t in wanted:
            sim.step_to(t)
            shots[t] = _grab(cid, size, camera)
        while sim.following():
            sim.step_to(sim.time + 0.05)
        track = sim.tracking
    labels = [f"t = {t:.2f} s" for t in sheet_at]
    desc = name if not params else f"{name} {dict(params)}"
    title = f"{desc}: {traj.duration:.2f} s planned at {speed_fraction:.0%} speed"
    sheet = contact_sheet([shots[t] for t in sheet_at], labels, title)
    out_png.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out_png), cv2.cvtColor(sheet, cv2.COLOR_RGB2BGR)):
        raise OSError(f"cannot write {out_png}")
    result: dict[str, Any] = {
        "gesture": name,
        "planned_s": traj.duration,
        "measured_s": track.measured_s if track is not None else None,
        "png": str(out_png),
    }
    if out_video is not None:
        result["video_codec"] = write_video(out_video, [shots[t] for t in video_at], fps)
        result["video"] = str(out_video)
        result["video_frames"] = len(video_at)
    return result


@contextlib.contextmanager
def _stderr_to(sink: Any) -> Iterator[None]:
    """Send file descriptor 2 to ``sink`` for a while: OpenCV and FFmpeg print their failed
    encoder probes there directly, not through Python."""
    sys.stderr.flush()
    try:
        saved = os.dup(2)
    except OSError:  # no stderr to quieten
        yield
        return
    try:
        os.dup2(sink.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def write_video(path: Path | str, images: Sequence[np.ndarray], fps: int) -> str:
    """Write RGB frames as a video; the suffix picks the format (:data:`VIDEO_CODECS`).

    Returns:
        The codec used (``avc1``, ``mp4v``, ``MJPG`` or ``gif``).

    Raises:
        ConfigError: an unsupported suffix.
        BackendUnavailable: OpenCV (or, for a GIF, Pillow) is missing.
        OSError: no codec of the suffix could be opened, or the file cannot be written.
    """
    path = check_video_path(path)
    if not images:
        raise ValueError("no frames to write")
    path.parent.mkdir(parents=True, exist_ok=True)
    codecs = VIDEO_CODECS[path.suffix.lower()]
    if codecs == ("gif",):
        _write_gif(path, images, fps)
        return "gif"
    cv2 = _cv2()
    h, w = images[0].shape[:2]
    tried: list[str] = []
    for codec in codecs:
        with tempfile.TemporaryFile(mode="w+") as noise:
            with _stderr_to(noise):
                writer = cv2.VideoWriter(
                    str(path), cv2.VideoWriter_fourcc(*codec), float(fps), (w, h)
                )
            noise.seek(0)
            said = noise.read().strip()
        if writer.isOpened():
            break
        writer.release()
        tried.append(codec)
        log.info("OpenCV cannot encode %s as %s here (%s)", path.name, codec, said or "no reason")
    else:
        raise OSError(f"OpenCV cannot write {path} with any of {', '.join(tried)}")
    if tried:
        log.warning(
            "%s: written as %s, which browsers may not play (this OpenCV has no %s encoder); "
            "VLC plays it, or write a .gif",
            path,
            codec,
            tried[0],
        )
    try:
        for img in images:
            writer.write(cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
    finally:
        writer.release()
    return codec


def _write_gif(path: Path, images: Sequence[np.ndarray], fps: int) -> None:
    from PIL import Image

    frames = [Image.fromarray(np.ascontiguousarray(img)) for img in images]
    frames[0].save(
        path,
        save_all=True,
        append_images=frames[1:],
        duration=max(20, round(1000.0 / fps)),  # ms per frame; browsers clamp below 20
        loop=0,
        disposal=1,
    )


def _main(argv: list[str] | None = None) -> int:
    import argparse

    parser = argparse.ArgumentParser(description="render gestures to contact sheets")
    parser.add_argument("names", nargs="*", help="gestures (default: all)")
    parser.add_argument("--out", default="out/gestures", help="folder")
    parser.add_argument("--video", action="store_true")
    parser.add_argument("--minutes", type=int, default=3)
    args = parser.parse_args(argv)
    names = args.names or list(load_library(load_limits()).names)
    for n in names:
        params = {"minutes": args.minutes} if n == "time_left" else None
        png = Path(args.out) / f"{n}.png"
        video = png.with_suffix(".mp4") if args.video else None
        r = render_gesture(n, png, video, params=params)
        print(f"{n}: planned {r['planned_s']:.2f} s, measured {r['measured_s']:.2f} s -> {png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(_main())
