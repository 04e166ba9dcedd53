"""Vision input module: head gaze, facing the audience and gesture rate, from a video or a camera.

Run it as its own process::

    python -m prezence.modules.vision --video talk.mp4 --out SESSION
    python -m prezence.modules.vision --video cam:0 --out SESSION --t0 1767225600.0
        [--calibrate-s 3] [--audience-yaw DEG --audience-pitch DEG] [--fps 8] [--realtime]
        [--gesture-source auto|body|motion]

It writes five metrics and one source stream, ``SESSION/streams/<name>.txt``, one
``<t> <value>`` line per sample,
``t`` in seconds since the talk began (video time for a file; for a camera, wall time minus
``--t0``, or since the module started):

================== ===================================================== ==================
metric              value                                                 rate
================== ===================================================== ==================
cv_headGaze         head pitch relative to the audience direction, deg,   each analysed frame
                    down negative (the rule ``cv_headGaze min ANGLE``)    with a face
cv_headYaw          head yaw relative to the audience direction, deg,     each analysed frame
                    > 0 when the presenter turns to their own left        with a face
cv_facingAudience   fraction of the analysed frames in the last           1 Hz
                    ``--facing-window`` s (5) with a face whose |yaw| and
                    |pitch| are within ``--facing-tolerance`` (20, 15 deg)
cv_gestures         gestures per minute over the last                     1 Hz, once 10 s
                    ``--gesture-window`` s (30; over all the video seen   of video have
                    so far, early in the talk), from the body             been seen
cv_gestures_motion  the same rate from the frame difference (the          as cv_gestures
                    fallback), instead of cv_gestures: no default rule
                    judges it
cv_gestures_source  where the rate came from: 1 the body's wrists, 2 the  1 Hz, with each
                    frame difference (fallback; the rate is in            rate, or
                    cv_gestures_motion), 0 not measured (the              instead of one
                    presenter's body out of view, another person's, or
                    its hands not seen well; no cv_gestures at that t),
                    3 the body's wrists, but in 10 % or more of the
                    window an arm was hidden (or the body out of view):
                    the gestures there could not all be counted, the
                    rate may be low
================== ===================================================== ==================

Head pose (needs ``mediapipe==0.10.21`` in the vision env):
    FaceMesh's 468 3D landmarks give raw angles: yaw = atan2(dz, dx) across the cheekbones
    (landmarks 234 and 454), pitch = atan2(-dz, dy) from forehead (10) to chin (152). FaceMesh's
    depth is not to scale, so each is multiplied by a gain measured on rendered faces at known
    angles (``tools/make_test_video.py``): :data:`YAW_GAIN`, :data:`PITCH_GAIN`. The audience
    direction is the median pose of the first ``--calibrate-s`` seconds (the presenter looks at
    the audience when they begin), or ``--audience-yaw/--audience-pitch`` in the same camera
    frame (then no calibration; an axis not given is 0). Samples of the calibration seconds are
    written once it ends, with their own times.

Gestures from the body (needs mediapipe, as head pose; the default):
    mediapipe Pose (BlazePose ``full``, the model inside the 0.10.21 wheel) gives the wrists,
    hands, shoulders and face keypoints; :class:`BodyGestureDetector` counts fast wrist
    movements away from the face, in shoulder widths relative to the shoulders, so head motion,
    a moving background and the presenter walking are not gestures. A gesture must move the
    arm: a wrist that moves while its elbow stays put is the model losing the hand, not a
    gesture. A hand held in a zone about the face keypoints (under the chin, at the cheek or
    ear) is at the face until it is seen away again, and its movements are not gestures,
    unless its elbow has moved out with it (a gesture beside the head); nor are the jumps of
    a wrist the model has lost (its visibility well below its usual level). A body out of view
    for half the window is "not measured" (no rate; ``cv_gestures_source`` 0 and a warning),
    and so is a body that is not the presenter's (not under the presenter's face, or jumped
    to another place or size; the other faces in view are hidden from the pose model) or
    whose hands cannot be seen (the image about the arms clipped black or white, or flat; or
    neither wrist seen by the model, or one arm's wrist and elbow not seen): the warning says
    which. An arm not seen makes no gestures of its own (the model's guesses are not counted).

Small faces: FaceMesh misses a face of about 30-45 px in a big frame (a presenter in a phone's
    tall frame). When it finds none in the whole frame and the pose model sees the head's
    keypoints, FaceMesh looks again in a square about them (2.5 times their extent), scaled up
    to :data:`CROP_SIZE`; the landmarks are mapped back to the whole frame's pixels (one scale on
    both axes, so the angles are the same geometry). A face it does find but narrower than
    :data:`SMALL_FACE_SHARE` of the frame's longer side can read far off: it is read from the
    close-up instead, when the close-up finds a face whose centre is in the whole frame's face
    box. With ``--no-gestures`` (no pose model) the square is about the face's own box
    (:data:`FACE_BOX_MARGIN` times it; the last close-up's box while there is one), and a face
    the whole frame does not find is looked for about its last box (for
    :data:`LOST_FACE_SEARCH_S`) or where mediapipe's full-range face detector sees one.

Mirrored video (``--mirrored``): a selfie camera or app mirrors the picture, which swaps the
    presenter's left and right: head yaw's sign flips, and the report's "head turned to your
    left" would mean their right. Nothing in the picture tells a mirrored video from a plain
    one, so the module cannot detect it; with ``--mirrored`` each analysed frame is flipped
    back (``cv2.flip``) before anything reads it, for files and cameras alike.

Two faces in view: FaceMesh finds up to 3; head pose follows the presenter's
    (:class:`PresenterFace`), and a second face is logged once.

Gestures from the frame difference (the fallback: OpenCV only, when mediapipe is not here,
or ``--gesture-source motion``; the log says so, and ``cv_gestures_source`` is 2). Its rate is
written as ``cv_gestures_motion``, not ``cv_gestures``, and ``vision.json`` lists
``cv_gestures`` as not measured, with why: the fallback misses most gestures, counts other
motion and cannot tell no one in view from a presenter who does not gesture (session 23: a
screencast of slides got "use your hands more"), so no default rule advises from it; a rule
of your own on ``cv_gestures_motion`` may.
    Motion energy = the fraction of pixels of the blurred grey frame (resized to 160 px wide)
    that changed by more than 15 grey levels since the last analysed frame, outside the face
    box (grown by half its size sideways and up, a quarter down) when head pose runs. A frame
    is active when its energy exceeds max(0.002, 3 x the median energy of the last 10 s).
    Active runs less than 0.5 s apart are one burst; a burst counts once it lasts 0.2 s.
    The rate is the bursts started in the window. Head motion outside the face box, a moving
    background and lighting changes count too.

Which python:
    mediapipe 0.10.21 needs numpy<2 and OpenCV<5, so it lives in a separate venv
    (:mod:`prezence.modules.vision_env`). Started from any other python, this module re-runs
    itself in that venv when one exists (``--no-reexec`` stops that). With no vision env, head
    pose is off with a message naming the one command that installs it, and the gesture rate
    falls back to the frame difference (saying so).

While it reads frames it touches the launcher's heartbeat file, ``$PREZENCE_HEARTBEAT``, about
once a second (:class:`prezence.modules.common.Heartbeat`).

Live input never drops frames silently: frames the analysis could not keep up with are
counted, and a warning every 10 s (and at the end) says how many and at what rate.

Exit status: 0 done; 2 bad input (missing, empty or wrong-format video, one truncated before
a frame can be read; a camera that cannot be opened) with ``error: FILE: …`` on stderr, or bad
arguments; 3 a video that ends before the frames it announces (a truncated recording), with
``warning: FILE: …`` on stderr once everything read has been analysed and written.

Measured accuracy and cost: see ``bench/bench_vision.py`` and ``tests/modules/test_vision.py``.
"""

from __future__ import annotations

import argparse
import importlib.util
import logging
import math
import os
import signal
import sys
import threading
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType, TracebackType
from typing import Any

try:
    import cv2
except ImportError as _e:  # the vision extra is not installed
    if __name__ == "__main__":
        # Run as the module: say so in one line, with the status of a module that cannot use
        # its input (2), so ``prezence up`` stops rather than restart it (a restart cannot help).
        print(
            'error: the vision module needs OpenCV (cv2): pip install "prezence[vision]"',
            file=sys.stderr,
        )
        raise SystemExit(2) from _e
    raise
import numpy as np

from prezence.errors import PrezenceError
from prezence.modules.common import (
    Heartbeat,
    InputCutShort,
    ModuleInputError,
    StreamSet,
    add_common_arguments,
    report_error,
    resume_offset,
    setup_logging,
)
from prezence.samples import GESTURES, GESTURES_MOTION, GESTURES_SOURCE, HEAD_GAZE

log = logging.getLogger(__name__)

HEAD_YAW = "cv_headYaw"
FACING_AUDIENCE = "cv_facingAudience"
METRICS = (HEAD_GAZE, HEAD_YAW, FACING_AUDIENCE, GESTURES, GESTURES_MOTION)
#: Every stream file this module writes: the metrics and where the gesture rate came from.
STREAMS = (*METRICS, GESTURES_SOURCE)

#: Raw FaceMesh yaw x this gain = degrees: fitted (grid, worst hold error) over -30..+30 deg on
#: two rendered faces (astronaut, hopper); three more are held out (bench/bench_vision.py).
YAW_GAIN = 1.10
#: Raw FaceMesh pitch x this gain = degrees (over -20..+20 deg, the same two faces).
PITCH_GAIN = 0.83

# Landmark indices (FaceMesh topology).
_CHEEK_RIGHT = 234  # the face contour at the presenter's right cheekbone, image left
_CHEEK_LEFT = 454
_FOREHEAD = 10
_CHIN = 152

_REEXEC_GUARD = "PREZENCE_VISION_REEXEC"

#: The side, pixels, a square about a small face is scaled to before FaceMesh looks again
#: (:meth:`HeadPoseEstimator.landmarks_in`).
CROP_SIZE = 256

#: A face the whole frame finds narrower than this share of the frame's longer side is read
#: from a close-up of the head instead (when the pose model sees it). Not a width in pixels:
#: the shipped 320x240 videos' faces are 41-57 px and read within 5 deg in the whole frame, the
#: same faces in a tall 240x426 or 320x568 frame (0.07-0.12 of it) up to 32 deg off.
SMALL_FACE_SHARE = 0.13

#: Without the pose model (``--no-gestures``) a small face's close-up is a square about its own
#: face box (FaceMesh's landmarks), this many times the box's longer side (session 20: 2.0 and
#: 2.5 read the tuned tall copies of ``gestures_b``/``c`` alike, within 0.5 deg) ...
FACE_BOX_MARGIN = 2.0
#: ... or about the box of mediapipe's full-range face detector (eyes to mouth: smaller).
DETECT_BOX_MARGIN = 2.5

#: Without the pose model, a small face lost in the whole frame is looked for in a close-up about
#: where it was last seen for this long, seconds, then no more (a presenter who left the view
#: is not searched for, and the cost stays one close-up a frame).
LOST_FACE_SEARCH_S = 2.0

#: No gesture rate is written before this much video has been seen (or the whole
#: ``--gesture-window`` when that is shorter).
GESTURE_MIN_WINDOW_S = 10.0


class VisionInputError(ModuleInputError):
    """A video file or camera cannot be read; the message names it (``source: reason``)."""


class VisionUnavailable(PrezenceError, RuntimeError):
    """Head pose cannot run here: mediapipe is not importable in this python."""


def install_hint() -> str:
    """Return the message that says how to get head pose working."""
    return (
        "head pose needs mediapipe==0.10.21 (numpy<2, OpenCV<5), which lives in its own venv; "
        "create it once with: python -m prezence.modules.vision_env install"
    )


def mediapipe_available() -> bool:
    """True when ``import mediapipe`` would find a package in this python."""
    return importlib.util.find_spec("mediapipe") is not None


# --------------------------------------------------------------------------------------------
# Head pose


@dataclass(frozen=True)
class HeadPose:
    """One face's pose in the camera frame.

    Attributes:
        yaw: degrees, > 0 when the presenter turns to their own left (nose to the image right).
        pitch: degrees, > 0 when the head tilts up.
        box: the face's bounding box ``(x0, y0, x1, y1)`` in pixels.
    """

    yaw: float
    pitch: float
    box: tuple[int, int, int, int]


def raw_angles(landmarks: np.ndarray) -> tuple[float, float]:
    """Return FaceMesh's raw (yaw, pitch) in degrees, before the gains.

    Args:
        landmarks: ``(468, 3)`` or more landmarks as (x, y, z) in pixel units (FaceMesh's
            normalised x and z times the image width, y times the height).

    Example:
        >>> pts = np.zeros((468, 3))
        >>> pts[234], pts[454] = (-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)
        >>> pts[10], pts[152] = (0.0, -1.0, 0.0), (0.0, 1.0, 0.0)
        >>> raw_angles(pts)
        (0.0, 0.0)
    """
    if landmarks.ndim != 2 or landmarks.shape[0] < 468 or landmarks.shape[1] != 3:
        raise ValueError(f"expected (468, 3) landmarks, got shape {landmarks.shape}")
    d = landmarks[_CHEEK_LEFT] - landmarks[_CHEEK_RIGHT]
    yaw = math.degrees(math.atan2(float(d[2]), float(d[0])))
    e = landmarks[_CHIN] - landmarks[_FOREHEAD]
    pitch = math.degrees(math.atan2(float(-e[2]), float(e[1])))
    return yaw + 0.0, pitch + 0.0


class HeadPoseEstimator:
    """mediapipe FaceMesh → :class:`HeadPose` per face found in a frame.

    Args:
        yaw_gain: multiplies the raw yaw (default :data:`YAW_GAIN`).
        pitch_gain: multiplies the raw pitch (default :data:`PITCH_GAIN`).
        static: treat every frame as unrelated (slower; for single images).
        max_faces: FaceMesh finds this many faces at most. With one, FaceMesh tracks whichever
            face it found first and may take a second person's (session 18: an audience head
            in view); :class:`PresenterFace` picks the presenter's among several.

    Raises:
        VisionUnavailable: mediapipe (or its FaceMesh solution) cannot be imported here.
    """

    def __init__(
        self,
        *,
        yaw_gain: float = YAW_GAIN,
        pitch_gain: float = PITCH_GAIN,
        static: bool = False,
        max_faces: int = 3,
    ) -> None:
        if max_faces < 1:
            raise ValueError(f"max_faces must be >= 1, got {max_faces!r}")
        try:
            import mediapipe as mp

            face_mesh = mp.solutions.face_mesh
        except (ImportError, AttributeError) as e:
            raise VisionUnavailable(f"{install_hint()} ({type(e).__name__}: {e})") from e
        self.yaw_gain = float(yaw_gain)
        self.pitch_gain = float(pitch_gain)
        self._static = static
        self._fm: Any = face_mesh.FaceMesh(
            static_image_mode=static,
            max_num_faces=int(max_faces),
            refine_landmarks=False,
            min_detection_confidence=0.5,
            min_tracking_confidence=0.5,
        )
        #: a second FaceMesh for :meth:`estimate_in` (its tracking must not follow the crops'
        #: coordinates into the whole frame's, nor the other way); made when first needed
        self._fm_crop: Any = None
        self._face_mesh = face_mesh
        #: mediapipe's full-range face detector (:meth:`face_boxes`); made when first needed
        self._fd: Any = None

    @staticmethod
    def _mesh(fm: Any, bgr: np.ndarray) -> list[np.ndarray]:
        h, w = bgr.shape[:2]
        res = fm.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        return [
            np.array([(p.x * w, p.y * h, p.z * w) for p in face.landmark], dtype=np.float64)
            for face in res.multi_face_landmarks or []
        ]

    def all_landmarks(self, bgr: np.ndarray) -> list[np.ndarray]:
        """Return each face's ``(468, 3)`` landmarks in pixel units (none found: ``[]``)."""
        if self._fm is None:
            raise ValueError("HeadPoseEstimator is closed")
        return self._mesh(self._fm, bgr)

    def landmarks_in(
        self, bgr: np.ndarray, square: tuple[int, int, int], *, size: int = CROP_SIZE
    ) -> np.ndarray | None:
        """FaceMesh on one square of the frame, scaled to ``size`` pixels: the face's landmarks
        in the whole frame's pixel units, or None when it finds none.

        Args:
            bgr: the whole frame.
            square: ``(x0, y0, side)`` in its pixels; parts outside the frame are padded with
                its edge.
            size: the side FaceMesh is given.

        The square is scaled by one factor on both axes, so the landmarks map back exactly:
        (x, y) to ``(x0, y0) + (x, y) * side / size`` and FaceMesh's depth (in units of the
        image width) by the same factor, i.e. in the whole frame's pixels as
        :meth:`all_landmarks` gives them, and :func:`raw_angles` sees the same geometry.
        """
        if self._fm is None:
            raise ValueError("HeadPoseEstimator is closed")
        x0, y0, side = (int(v) for v in square)
        if side < 8:
            return None
        h, w = bgr.shape[:2]
        pad = max(0, -x0, -y0, x0 + side - w, y0 + side - h)
        img = bgr
        if pad:
            img = cv2.copyMakeBorder(bgr, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
        crop = img[y0 + pad : y0 + pad + side, x0 + pad : x0 + pad + side]
        big = cv2.resize(crop, (size, size), interpolation=cv2.INTER_CUBIC)
        if self._fm_crop is None:
            self._fm_crop = self._face_mesh.FaceMesh(
                static_image_mode=self._static,
                max_num_faces=1,
                refine_landmarks=False,
                min_detection_confidence=0.5,
                min_tracking_confidence=0.5,
            )
        faces = self._mesh(self._fm_crop, big)
        if not faces:
            return None
        pts = faces[0] * (side / size)
        pts[:, 0] += x0
        pts[:, 1] += y0
        return pts

    def face_boxes(self, bgr: np.ndarray) -> list[tuple[int, int, int, int]]:
        """Boxes ``(x0, y0, x1, y1)``, pixels, of the faces mediapipe's full-range face detector
        finds in the frame (made for faces far from the camera: it finds the 25-50 px faces of
        tall frames that FaceMesh's own detector misses). No landmarks: where to look closer."""
        if self._fm is None:
            raise ValueError("HeadPoseEstimator is closed")
        if self._fd is None:
            import mediapipe as mp

            self._fd = mp.solutions.face_detection.FaceDetection(
                model_selection=1, min_detection_confidence=0.5
            )
        h, w = bgr.shape[:2]
        res = self._fd.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        boxes = []
        for d in res.detections or []:
            b = d.location_data.relative_bounding_box
            x0, y0 = int(round(b.xmin * w)), int(round(b.ymin * h))
            x1, y1 = int(round((b.xmin + b.width) * w)), int(round((b.ymin + b.height) * h))
            if x1 > x0 and y1 > y0:
                boxes.append((x0, y0, x1, y1))
        return boxes

    def estimate_in(
        self, bgr: np.ndarray, square: tuple[int, int, int], *, size: int = CROP_SIZE
    ) -> HeadPose | None:
        """The head pose of the face in ``square`` of the frame (:meth:`landmarks_in`), in the
        whole frame's pixels, or None."""
        pts = self.landmarks_in(bgr, square, size=size)
        return None if pts is None else self._pose(pts)

    def landmarks(self, bgr: np.ndarray) -> np.ndarray | None:
        """Return the biggest face's landmarks in pixel units, or None when no face is found."""
        faces = self.all_landmarks(bgr)
        if not faces:
            return None
        return max(faces, key=lambda pts: float(np.ptp(pts[:, 0]) * np.ptp(pts[:, 1])))

    def _pose(self, pts: np.ndarray) -> HeadPose:
        yaw, pitch = raw_angles(pts)
        x0, y0 = np.floor(pts[:, :2].min(axis=0)).astype(int)
        x1, y1 = np.ceil(pts[:, :2].max(axis=0)).astype(int)
        return HeadPose(
            yaw * self.yaw_gain, pitch * self.pitch_gain, (int(x0), int(y0), int(x1), int(y1))
        )

    def estimate_all(self, bgr: np.ndarray) -> list[HeadPose]:
        """Return the head pose of every face found, in the camera frame."""
        return [self._pose(pts) for pts in self.all_landmarks(bgr)]

    def estimate(self, bgr: np.ndarray) -> HeadPose | None:
        """Return the biggest face's head pose in the camera frame, or None when none is found."""
        pts = self.landmarks(bgr)
        return None if pts is None else self._pose(pts)

    def close(self) -> None:
        """Release the graphs; a second call does nothing."""
        fm, self._fm = self._fm, None
        crop, self._fm_crop = self._fm_crop, None
        fd, self._fd = self._fd, None
        for g in (fm, crop, fd):
            if g is not None:
                g.close()

    def __enter__(self) -> HeadPoseEstimator:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _centre(box: tuple[int, int, int, int]) -> np.ndarray:
    return np.array([(box[0] + box[2]) / 2.0, (box[1] + box[3]) / 2.0])


def _width(box: tuple[int, int, int, int]) -> float:
    return float(max(box[2] - box[0], 1))


def _inside(point: np.ndarray, box: tuple[int, int, int, int], grow: float = 0.0) -> bool:
    """True when ``point`` is in ``box`` grown by ``grow`` times its size on every side."""
    gx, gy = grow * (box[2] - box[0]), grow * (box[3] - box[1])
    return bool(box[0] - gx <= point[0] <= box[2] + gx and box[1] - gy <= point[1] <= box[3] + gy)


class PresenterFace:
    """Which of the faces found in a frame is the presenter's.

    A second face in view (someone in the audience, a face on a slide) must not be measured as
    the presenter (session 18: FaceMesh with one face tracked an audience head, facing 0.70
    instead of 0.90 and its turns written as the presenter's). Once the presenter's face is
    chosen, it is followed: the face nearest the last one, within ``max_step`` of its widths
    plus ``growth`` widths per second since it was last seen (a presenter walks; another face
    stays where it is). None of them that near: the presenter's face is not in this frame (no
    head sample, rather than someone else's). The first choice among several faces: the one
    the pose model's nose is in (the face with the body under it), else one with room for
    shoulders under it (an audience head in the foreground is cut by the frame's lower edge),
    else the biggest. A second face is logged once.
    """

    def __init__(self, *, max_step: float = 0.75, growth: float = 1.0) -> None:
        self.max_step = float(max_step)
        self.growth = float(growth)
        self.box: tuple[int, int, int, int] | None = None  #: the presenter's face, last seen
        self.seen_t = 0.0  #: when ``box`` was seen
        self.second_face_at: float | None = None  #: when a second face was first seen

    def choose(
        self,
        t: float,
        faces: list[HeadPose],
        *,
        frame_height: int,
        nose: np.ndarray | None = None,
    ) -> HeadPose | None:
        """Return the presenter's face among ``faces`` (None: not among them).

        Args:
            t: the frame's time.
            faces: every face found in the frame.
            frame_height: the frame's height, pixels.
            nose: where the pose model put the presenter's nose (a recent frame), if anywhere.
        """
        if len(faces) > 1 and self.second_face_at is None:
            self.second_face_at = t
            log.warning(
                "%d faces in view at %.1f s: head pose follows the presenter's (%s), "
                "not the others",
                len(faces),
                t,
                "the one the body is under" if self.box is None else "the one seen so far",
            )
        if not faces:
            return None
        chosen: HeadPose | None
        if self.box is None:
            chosen = self._first(faces, frame_height, nose)
        else:
            last, w = _centre(self.box), _width(self.box)
            reach = (self.max_step + self.growth * max(0.0, t - self.seen_t)) * w
            dist = [float(np.linalg.norm(_centre(f.box) - last)) for f in faces]
            k = int(np.argmin(dist))
            chosen = faces[k] if dist[k] <= reach else None
        if chosen is not None:
            self.box, self.seen_t = chosen.box, t
        return chosen

    @staticmethod
    def _first(faces: list[HeadPose], frame_height: int, nose: np.ndarray | None) -> HeadPose:
        if len(faces) == 1:
            return faces[0]
        if nose is not None:
            under = [f for f in faces if _inside(nose, f.box, grow=0.25)]
            if len(under) == 1:
                return under[0]
        room = [f for f in faces if frame_height - f.box[3] >= f.box[3] - f.box[1]]
        pool = room or faces
        return max(pool, key=lambda f: (f.box[2] - f.box[0]) * (f.box[3] - f.box[1]))


class GazeTracker:
    """Camera-frame poses → audience-relative (yaw, pitch) and the facing fraction.

    Args:
        calibrate_s: the audience direction is the median pose of frames with ``t`` below this
            (at least 3 faces; it waits for them). 0 means the camera is the audience direction.
        audience: ``(yaw, pitch)`` of the audience in the camera frame; skips calibration.
        facing_window_s: the window of :meth:`facing`.
        tolerance: ``(yaw, pitch)`` degrees within which the presenter faces the audience.
    """

    def __init__(
        self,
        *,
        calibrate_s: float,
        audience: tuple[float, float] | None = None,
        facing_window_s: float = 5.0,
        tolerance: tuple[float, float] = (20.0, 15.0),
    ) -> None:
        if not calibrate_s >= 0.0:
            raise ValueError(f"calibrate_s must be >= 0, got {calibrate_s!r}")
        if not facing_window_s > 0.0:
            raise ValueError(f"facing_window_s must be > 0, got {facing_window_s!r}")
        self.calibrate_s = float(calibrate_s)
        self.facing_window_s = float(facing_window_s)
        self.tolerance = (float(tolerance[0]), float(tolerance[1]))
        self.offset: tuple[float, float] | None = None
        if audience is not None:
            self.offset = (float(audience[0]), float(audience[1]))
        elif self.calibrate_s == 0.0:
            self.offset = (0.0, 0.0)
        self._pending: list[tuple[float, HeadPose | None]] = []
        self._recent: deque[tuple[float, bool]] = deque()

    @property
    def calibrated(self) -> bool:
        """True once the audience direction is known."""
        return self.offset is not None

    def update(self, t: float, pose: HeadPose | None) -> list[tuple[float, float, float]]:
        """Feed one analysed frame; return the samples ``(t, yaw, pitch)`` now ready.

        During calibration nothing is returned; when it ends, the calibration frames' samples
        come out at once, relative to the found direction.
        """
        if self.offset is None:
            self._pending.append((t, pose))
            seen = [(tt, p) for tt, p in self._pending if p is not None]
            if t < self.calibrate_s or len(seen) < 3:
                return []
            faces = [p for _, p in seen]
            if sum(1 for tt, _ in seen if tt < self.calibrate_s) < 3:
                # The face was not found in the calibration seconds (a small face in a portrait
                # frame, a late start): the first three faces found were taken as the audience
                # direction, mid head turn (session 17: -28 deg, then every yaw 28 deg off and
                # facing 0). Take the median of calibrate_s seconds from the first face found.
                first = seen[0][0]
                if t - first < self.calibrate_s:
                    return []
                faces = [p for tt, p in seen if tt <= first + self.calibrate_s]
                log.warning(
                    "fewer than 3 faces in the first %.1f s: the audience direction is the "
                    "median pose of %.1f-%.1f s, where the face was first found; give "
                    "--audience-yaw/--audience-pitch if the presenter did not face the "
                    "audience then",
                    self.calibrate_s,
                    first,
                    first + self.calibrate_s,
                )
            self.offset = (
                float(np.median([p.yaw for p in faces])),
                float(np.median([p.pitch for p in faces])),
            )
            log.info(
                "audience direction: yaw %.1f, pitch %.1f deg (camera frame, %d faces in %.1f s)",
                *self.offset,
                len(faces),
                t,
            )
            batch, self._pending = self._pending, []
        else:
            batch = [(t, pose)]
        out: list[tuple[float, float, float]] = []
        for tt, p in batch:
            facing = False
            if p is not None:
                yaw, pitch = p.yaw - self.offset[0], p.pitch - self.offset[1]
                out.append((tt, yaw, pitch))
                facing = abs(yaw) <= self.tolerance[0] and abs(pitch) <= self.tolerance[1]
            self._recent.append((tt, facing))
        return out

    def facing(self, t: float) -> float | None:
        """Fraction of analysed frames in ``(t - window, t]`` facing the audience, or None."""
        while self._recent and self._recent[0][0] <= t - self.facing_window_s:
            self._recent.popleft()
        if not self._recent or self.offset is None:
            return None
        return sum(f for _, f in self._recent) / len(self._recent)


# --------------------------------------------------------------------------------------------
# Gestures


def motion_energy(
    prev_gray: np.ndarray,
    gray: np.ndarray,
    *,
    diff_threshold: int = 15,
    exclude: tuple[int, int, int, int] | None = None,
) -> float:
    """Fraction of pixels that changed by more than ``diff_threshold`` grey levels.

    Args:
        prev_gray: the previous (blurred) grey frame.
        gray: the current one, same shape.
        diff_threshold: grey levels.
        exclude: a box ``(x0, y0, x1, y1)`` in these frames' pixels left out (the face).
    """
    if prev_gray.shape != gray.shape:
        raise ValueError(f"frame shapes differ: {prev_gray.shape} vs {gray.shape}")
    moved = cv2.absdiff(prev_gray, gray) > diff_threshold
    total = moved.size
    if exclude is not None:
        h, w = moved.shape
        x0, y0 = max(0, exclude[0]), max(0, exclude[1])
        x1, y1 = min(w, exclude[2]), min(h, exclude[3])
        if x1 > x0 and y1 > y0:
            moved[y0:y1, x0:x1] = False
            total -= (x1 - x0) * (y1 - y0)
    return float(moved.sum()) / max(total, 1)


class GestureDetector:
    """Motion energy per frame → gesture bursts → bursts per minute.

    Args:
        window_s: the rate's window.
        min_window_s: no rate until this many seconds of video have been seen (a calm start
            is not a lack of gestures); until ``window_s`` have, the rate is over all of it.
        floor: the lowest energy threshold.
        k: the threshold is ``max(floor, k * median energy of the last baseline_s)``.
        baseline_s: the median's window.
        merge_s: active runs closer than this are one burst.
        min_burst_s: a burst counts once its active frames span this long.
        width: frames are resized to this width first (the cost and the noise fall).
    """

    def __init__(
        self,
        *,
        window_s: float = 30.0,
        min_window_s: float = GESTURE_MIN_WINDOW_S,
        floor: float = 0.002,
        k: float = 3.0,
        baseline_s: float = 10.0,
        merge_s: float = 0.5,
        min_burst_s: float = 0.2,
        width: int = 160,
    ) -> None:
        if not window_s > 0.0 or not 0.0 < min_window_s <= window_s:
            raise ValueError(f"need 0 < min_window_s <= window_s, got {min_window_s}, {window_s}")
        self.window_s = float(window_s)
        self.min_window_s = float(min_window_s)
        self.floor = float(floor)
        self.k = float(k)
        self.baseline_s = float(baseline_s)
        self.merge_s = float(merge_s)
        self.min_burst_s = float(min_burst_s)
        self.width = int(width)
        self.bursts: list[float] = []  #: start times of the counted bursts
        self.first_t: float | None = None  #: time of the first frame fed
        self._prev: np.ndarray | None = None
        self._energies: deque[tuple[float, float]] = deque()
        self._run_start: float | None = None  # first active frame of the current burst
        self._last_active = -math.inf
        self._counted = False

    def _prepare(self, bgr: np.ndarray) -> tuple[np.ndarray, float]:
        h, w = bgr.shape[:2]
        s = self.width / w
        small = cv2.resize(bgr, (self.width, max(1, round(h * s))), interpolation=cv2.INTER_AREA)
        gray = cv2.cvtColor(small, cv2.COLOR_BGR2GRAY) if small.ndim == 3 else small
        return cv2.GaussianBlur(gray, (5, 5), 0), s

    def update(
        self, t: float, bgr: np.ndarray, exclude: tuple[int, int, int, int] | None = None
    ) -> float | None:
        """Feed one analysed frame (``exclude``: a box in its pixels, e.g. the face).

        Returns:
            The start time of a burst that has just been counted, else None.
        """
        if self.first_t is None:
            self.first_t = t
        gray, s = self._prepare(bgr)
        prev, self._prev = self._prev, gray
        if prev is None or prev.shape != gray.shape:
            return None
        box = None
        if exclude is not None:
            # Hair and ears move with the head: grow the face box by half its size sideways
            # and upwards, a quarter downwards (hands raised under the chin still count).
            x0, y0, x1, y1 = exclude
            fw, fh = x1 - x0, y1 - y0
            box = (
                int((x0 - 0.5 * fw) * s),
                int((y0 - 0.5 * fh) * s),
                int(math.ceil((x1 + 0.5 * fw) * s)),
                int(math.ceil((y1 + 0.25 * fh) * s)),
            )
        e = motion_energy(prev, gray, exclude=box)
        return self._step(t, e)

    def _step(self, t: float, e: float) -> float | None:
        self._energies.append((t, e))
        while self._energies and self._energies[0][0] < t - self.baseline_s:
            self._energies.popleft()
        base = float(np.median([x for _, x in self._energies]))
        active = e > max(self.floor, self.k * base)
        if not active:
            return None
        if self._run_start is None or t - self._last_active > self.merge_s:
            self._run_start = t
            self._counted = False
        self._last_active = t
        if not self._counted and t - self._run_start >= self.min_burst_s:
            self._counted = True
            self.bursts.append(self._run_start)
            return self._run_start
        return None

    def rate(self, t: float) -> float | None:
        """Bursts per minute that started in the window ending at ``t``.

        Returns:
            None until ``min_window_s`` of video has been seen (from the first frame fed, so a
            module restarted late in the talk waits too); then bursts / minutes seen, at most
            ``window_s``.
        """
        seen = t - self.first_t if self.first_t is not None else 0.0
        if seen < self.min_window_s - 1e-9:
            return None
        n = sum(1 for b in self.bursts if t - self.window_s < b <= t)
        return n / min(self.window_s, seen) * 60.0


# --------------------------------------------------------------------------------------------
# Gestures from the body (mediapipe Pose)

#: ``cv_gestures_source`` values: where the ``cv_gestures`` sample written at the same ``t``
#: came from (a stream line holds one number, so the source is a stream of its own).
SOURCE_NOT_MEASURED = 0.0  #: no cv_gestures sample at this t: the body was not seen well enough
SOURCE_BODY = 1.0  #: wrist keypoints of the pose model
SOURCE_MOTION = 2.0  #: frame difference (the fallback when the pose model cannot run)
#: wrist keypoints, but in :data:`PARTLY_COUNTED_SHARE` or more of the window's frames the
#: gestures of an arm could not be counted (hidden, not at the face; or the body out of view):
#: the rate counts what was seen over the whole window and may be low
SOURCE_BODY_PARTLY = 3.0
#: See :data:`SOURCE_BODY_PARTLY` (session 20: on the rendered presenters a-d at most 8 % of a
#: window's frames, a hand held at the chin; an overlay over one arm for 9 s, up to 28-70 %).
PARTLY_COUNTED_SHARE = 0.1
#: What an analysed frame gave the body's gesture rate: the presenter's body seen well, no
#: body, another person's body, the presenter's with the image about the arms too dark (or
#: bright, or flat), with neither hand seen by the pose model, or with one arm not seen
#: (wrist and elbow: its gestures cannot be counted).
FRAME_STATES = ("seen", "none", "other", "image", "hands", "arm")

# BlazePose landmark indices.
_NOSE = 0
_FACE = tuple(range(11))  #: nose, eyes (inner, centre, outer), ears, mouth corners
_SHOULDER_LEFT, _SHOULDER_RIGHT = 11, 12
_ELBOW_LEFT, _ELBOW_RIGHT = 13, 14
_WRIST_LEFT, _WRIST_RIGHT = 15, 16
#: The presenter's left and right hand: wrist, pinky, index, thumb.
_HAND_LEFT, _HAND_RIGHT = (15, 17, 19, 21), (16, 18, 20, 22)


@dataclass(frozen=True)
class BodyKeypoints:
    """The keypoints a gesture needs, in pixels: ``(x, y)`` arrays and the wrists' visibility.

    ``face`` (the centre of the pose model's face keypoints), ``hands`` (each hand's wrist,
    pinky, index and thumb, ``(4, 2)``) and ``elbows`` are optional: without them the nose and
    the wrist stand in, and without elbows a run is not asked to move the arm. ``clipped`` and
    ``spread`` describe the image about the arms (:func:`arm_region_exposure`); None: not known.
    """

    nose: np.ndarray
    shoulders: tuple[np.ndarray, np.ndarray]  #: the presenter's left, right
    wrists: tuple[np.ndarray, np.ndarray]  #: the presenter's left, right
    wrist_visibility: tuple[float, float]
    face: np.ndarray | None = None
    #: the face keypoints the model sees (visibility >= 0.5: nose, eyes, ears, mouth), ``(n, 2)``
    face_points: np.ndarray | None = None
    hands: tuple[np.ndarray, np.ndarray] | None = None
    elbows: tuple[np.ndarray, np.ndarray] | None = None  #: the presenter's left, right
    elbow_visibility: tuple[float, float] | None = None
    clipped: float | None = None  #: share of the pixels about the arms black or white (clipped)
    spread: float | None = None  #: standard deviation of their grey levels

    def head_square(self, *, margin: float = 2.5) -> tuple[int, int, int] | None:
        """A square ``(x0, y0, side)`` about the head, pixels, from the face keypoints the model
        sees: centred on them, ``margin`` times their extent (at least a third of the shoulder
        width, for a head in profile) on a side. None when it sees fewer than three of them.
        """
        pts = self.face_points
        if pts is None or len(pts) < 3:
            return None
        sw = float(np.linalg.norm(self.shoulders[0] - self.shoulders[1]))
        extent = max(float(np.ptp(pts[:, 0])), float(np.ptp(pts[:, 1])), sw / 3.0)
        side = int(round(margin * extent))
        c = pts.mean(axis=0)
        return int(round(c[0] - side / 2)), int(round(c[1] - side / 2)), side

    def face_centre(self) -> np.ndarray:
        """The centre of the face keypoints (the nose when there are none)."""
        return self.face if self.face is not None else self.nose

    def hand_points(self, k: int) -> np.ndarray:
        """Hand ``k``'s points (0 the presenter's left), ``(n, 2)``: at least the wrist."""
        if self.hands is not None:
            return self.hands[k]
        return self.wrists[k].reshape(1, 2)


def arm_region_exposure(
    gray: np.ndarray, points: np.ndarray, shoulder_width: float
) -> tuple[float, float]:
    """How well the arms can be seen: ``(clipped, spread)`` of the grey image about them.

    The region is the box around ``points`` (shoulders, elbows, wrists, nose) grown by half a
    shoulder width. ``clipped`` is the share of its pixels crushed to black (<= 4) or burnt to
    white (>= 251), ``spread`` the standard deviation of its grey levels.

    Why the image and not the pose model's own visibility: on a dark copy of ``gestures_a``
    (brightness -0.35, contrast 0.5) the model kept the wrists' and elbows' visibility at
    0.6-0.9 while it drew a dark sleeve against a dark sky barely moving (2 of 7 gestures
    lost). Clipping is what hides a dark arm against a dark background: on 11 darkened or
    flattened copies of ``gestures_a`` the gestures were lost (5-6 of 7) only on copies where
    40-75 % of this region was clipped, or its spread was 7 grey levels; on the rendered
    presenters a-d at most 5.5 % is clipped and the spread is 33 or more.
    """
    if gray.ndim != 2:
        raise ValueError(f"expected a grey image, got shape {gray.shape}")
    h, w = gray.shape
    pad = 0.5 * shoulder_width
    x0, y0 = np.floor(points.min(axis=0) - pad).astype(int)
    x1, y1 = np.ceil(points.max(axis=0) + pad).astype(int)
    x0, y0, x1, y1 = max(0, int(x0)), max(0, int(y0)), min(w, int(x1)), min(h, int(y1))
    if x1 - x0 < 2 or y1 - y0 < 2:
        return 1.0, 0.0  # the body is outside the frame: nothing of the arms to see
    r = gray[y0:y1, x0:x1]
    clipped = float(np.count_nonzero((r <= 4) | (r >= 251))) / r.size
    return clipped, float(r.std())


class PresenterBody:
    """Is the person the pose model found the presenter? (It finds one person, any person.)

    Session 18: with an audience head in view the pose model left the presenter and drew a
    body under that head, and its few wrist movements were written as the presenter's rate.
    With the presenter's face known in the frame (:class:`PresenterFace`), the body is the
    presenter's when its face keypoints are on that face (the face box grown by
    ``face_grow`` of its size each side). Without it, the body must continue the last one
    accepted: shoulders' midpoint within ``max_jump`` shoulder widths and width within a factor
    ``max_scale`` (a jump to another place or size is another person, for as long as the pose
    model stays on it); after ``keep_s`` with no body at all, a body anywhere is taken (the
    presenter left the view and came back elsewhere).
    """

    def __init__(
        self,
        *,
        face_grow: float = 0.5,
        max_jump: float = 1.0,
        max_scale: float = 1.5,
        keep_s: float = 2.0,
    ) -> None:
        self.face_grow = float(face_grow)
        self.max_jump = float(max_jump)
        self.max_scale = float(max_scale)
        self.keep_s = float(keep_s)
        self._last: tuple[np.ndarray, float] | None = None  #: shoulders' midpoint, width
        self._any_t: float | None = None  #: the last frame with a body, the presenter's or not

    def check(
        self, t: float, body: BodyKeypoints, face_box: tuple[int, int, int, int] | None
    ) -> bool:
        """True when ``body`` is the presenter's (and remember it)."""
        mid = (body.shoulders[0] + body.shoulders[1]) / 2.0
        sw = max(float(np.linalg.norm(body.shoulders[0] - body.shoulders[1])), 1.0)
        gap = self._any_t is None or t - self._any_t > self.keep_s
        self._any_t = t
        if face_box is not None:
            ok = _inside(body.face_centre(), face_box, grow=self.face_grow)
        elif self._last is not None and not gap:
            last_mid, last_sw = self._last
            ok = (
                float(np.linalg.norm(mid - last_mid)) <= self.max_jump * last_sw
                and 1.0 / self.max_scale <= sw / last_sw <= self.max_scale
            )
        else:
            ok = True
        if ok:
            self._last = (mid, sw)
        return ok


class BodyTracker:
    """mediapipe Pose (BlazePose, the ``full`` model that ships in the 0.10.21 wheel) →
    :class:`BodyKeypoints` per frame (one person).

    Raises:
        VisionUnavailable: mediapipe (or its Pose solution) cannot be imported here.
    """

    def __init__(self) -> None:
        try:
            import mediapipe as mp

            pose = mp.solutions.pose
        except (ImportError, AttributeError) as e:
            raise VisionUnavailable(f"{install_hint()} ({type(e).__name__}: {e})") from e
        # model_complexity=1 is the model inside the wheel (0 and 2 would be downloaded).
        self._pose: Any = pose.Pose(
            static_image_mode=False,
            model_complexity=1,
            smooth_landmarks=True,
            min_detection_confidence=0.5,
            min_tracking_confidence=0.5,
        )

    def keypoints(self, bgr: np.ndarray) -> BodyKeypoints | None:
        """Return the keypoints, or None when no person is found."""
        if self._pose is None:
            raise ValueError("BodyTracker is closed")
        h, w = bgr.shape[:2]
        res = self._pose.process(cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB))
        if res.pose_landmarks is None:
            return None
        lm = res.pose_landmarks.landmark

        def xy(*idx: int) -> np.ndarray:
            pts = np.array([(lm[i].x * w, lm[i].y * h) for i in idx], dtype=np.float64)
            return pts[0] if len(idx) == 1 else pts

        arm = xy(_NOSE, _SHOULDER_LEFT, _SHOULDER_RIGHT, _ELBOW_LEFT, _ELBOW_RIGHT)
        arm = np.vstack([arm, xy(_WRIST_LEFT, _WRIST_RIGHT)])
        gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY) if bgr.ndim == 3 else bgr
        clipped, spread = arm_region_exposure(gray, arm, float(np.linalg.norm(arm[1] - arm[2])))
        return BodyKeypoints(
            nose=xy(_NOSE),
            shoulders=(xy(_SHOULDER_LEFT), xy(_SHOULDER_RIGHT)),
            wrists=(xy(_WRIST_LEFT), xy(_WRIST_RIGHT)),
            wrist_visibility=(
                float(lm[_WRIST_LEFT].visibility),
                float(lm[_WRIST_RIGHT].visibility),
            ),
            face=xy(*_FACE).mean(axis=0),
            face_points=xy(*_FACE)[[lm[i].visibility >= 0.5 for i in _FACE]].reshape(-1, 2),
            hands=(xy(*_HAND_LEFT), xy(*_HAND_RIGHT)),
            elbows=(xy(_ELBOW_LEFT), xy(_ELBOW_RIGHT)),
            elbow_visibility=(
                float(lm[_ELBOW_LEFT].visibility),
                float(lm[_ELBOW_RIGHT].visibility),
            ),
            clipped=clipped,
            spread=spread,
        )

    def close(self) -> None:
        """Release the graph; a second call does nothing."""
        p, self._pose = self._pose, None
        if p is not None:
            p.close()


@dataclass
class _WristRun:
    """One wrist's current run of fast frames away from the face."""

    start: float
    last: float
    from_face: bool  #: the hand was at the face just before the run began
    doubtful: int = 0  #: frames of the run whose wrist keypoint was not trusted
    elbow0: np.ndarray | None = None  #: the elbow where the wrist started moving
    arm_moved: float = 0.0  #: how far the elbow got from ``elbow0``, shoulder widths


@dataclass
class _HandState:
    """One hand's memory between frames: is it at the face, and how well is it seen."""

    at_face: bool = False
    near_since: float | None = None  #: first frame of the current stretch near the face
    away_since: float | None = None  #: first frame of the current stretch seen away from it
    visibility: deque[tuple[float, float]] = field(default_factory=deque)


class BodyGestureDetector:
    """Wrist keypoints per frame → gesture bursts → bursts per minute.

    Positions are taken relative to the shoulders' midpoint and in shoulder widths (the median
    of the last ``baseline_s``), so the presenter moving, the camera's distance and the image
    size do not matter, and the head and the background are not looked at at all. A wrist is
    *fast* when it moves faster than ``speed`` shoulder widths per second between analysed
    frames. Its fast frames, less than ``merge_s`` apart, are one run; a run that has lasted
    ``min_burst_s`` is a gesture. Runs of the two hands that overlap or are less than
    ``merge_s`` apart are one gesture. A run is judged when it ends, so a gesture is counted
    ``merge_s`` after its last movement.

    Hands at the face are not gestures. A hand is *near* the face when any of its points
    (wrist, pinky, index, thumb) is inside an ellipse about the centre of the face keypoints
    (nose, eyes, ears, mouth) whose half-axes are ``face_zone`` shoulder widths (across, up and
    down). It *is at* the face once it has been near for
    ``face_enter_s`` (a hand held there, not a beat swinging past), and stays at the face
    (hysteresis) until it has been seen away, with a trusted wrist, for ``face_leave_s``. A
    run that begins at the face, reaches it or ends there is not a gesture (reaching, resting,
    scratching, coming back), and a hand at the face makes no runs.

    The wrist keypoint is not trusted in a frame where its visibility is below
    ``min_visibility``, or below ``visibility_drop`` times that wrist's own median over the last
    ``visibility_baseline_s`` (the pose model losing a hand, as at the face, puts the wrist on
    the chest and lets it jump): such frames make no speed, and a run with any frame not
    trusted is not a gesture.

    A gesture moves the arm, not only the wrist keypoint. A run counts only when the elbow
    keypoint got ``arm_move`` shoulder widths or more from where it was when the wrist began
    to move. The pose model places the small hand badly far more often than the elbow, a
    bigger and better seen joint: losing the hand at the face, it drew the wrist on the chest
    with its usual visibility and let it jump while the elbow stayed where it rests, and during
    head turns it let a resting hand's wrist jump the same way (on the rendered presenters
    a-d, the runs that were not gestures moved the elbow 0.56 shoulder widths or less, bar
    four where the model drew the whole arm out, 0.60-1.04; every true gesture's run 0.70 or
    more; ``arm_move`` is a round number in that gap). For the same reason a hand whose run
    has moved the elbow that far is not taken to be at the face: it is a gesture passing by
    or beside the head, drawn near the chin by the model (4 of c's 8 true gestures were lost
    that way), not a hand brought to the face, which on those videos left the elbow keypoint
    where it rests. Without elbow keypoints (``BodyKeypoints.elbows`` None) neither rule
    applies. What it costs: a beat of the forearm alone, the elbow kept still against the
    body, is not counted (the rendered beats go out to the side); a real hand raised to the
    ear with the elbow swung out would count.

    Args:
        window_s: the rate's window.
        min_window_s: no rate until this many seconds have been seen (see :class:`GestureDetector`).
        min_coverage: no rate when fewer than this share of the window's analysed frames had a
            body in them (the presenter out of view is "not measured", not "no gestures"). A
            frame counts as without a body too when the body is not the presenter's
            (``update(..., presenter=False)``) or its hands cannot be seen well enough: more
            than ``max_clipped`` of the image about the arms clipped, or a grey-level spread
            below ``min_spread`` (:func:`arm_region_exposure`; session 18: 2 of 7 gestures lost
            on a dark video and a rate of 0/min written as a measurement); or both wrists'
            visibility below ``min_hand_visibility`` (the pose model does not see either hand:
            with half the body covered it drew both wrists at 0.1-0.45 and made 5 false
            gestures; on the rendered presenters a-d at most 7 % of the frames are below 0.4),
            or one arm not seen: its wrist's visibility below ``min_hand_visibility`` and its
            elbow's below ``min_elbow_visibility``. Such an arm is guessed (session 19: under an
            overlay the model drew a hidden arm at wrist 0.1-0.36, elbow 0.2-0.44 and made 2
            false gestures): its keypoints make no speed and a run with such a frame is dropped,
            while the other hand is still counted; and as its gestures cannot be counted, the
            frame is not "seen" for the coverage. A hand in a pocket leaves its elbow seen (on
            the rendered presenters a-c, every counted gesture's elbow was at 0.57 or more, and
            at most 4 % of the frames had an arm not seen; d was held out: unchanged).
    """

    def __init__(
        self,
        *,
        window_s: float = 30.0,
        min_window_s: float = GESTURE_MIN_WINDOW_S,
        speed: float = 0.8,
        face_zone: tuple[float, float] = (0.5, 0.9),
        face_enter_s: float = 0.1,
        face_leave_s: float = 0.4,
        merge_s: float = 0.5,
        min_burst_s: float = 0.2,
        baseline_s: float = 5.0,
        min_visibility: float = 0.1,
        visibility_drop: float = 0.6,
        visibility_baseline_s: float = 20.0,
        min_coverage: float = 0.5,
        arm_move: float = 0.6,
        max_clipped: float = 0.25,
        min_spread: float = 10.0,
        min_hand_visibility: float = 0.4,
        min_elbow_visibility: float = 0.5,
    ) -> None:
        if not window_s > 0.0 or not 0.0 < min_window_s <= window_s:
            raise ValueError(f"need 0 < min_window_s <= window_s, got {min_window_s}, {window_s}")
        self.window_s = float(window_s)
        self.min_window_s = float(min_window_s)
        self.speed = float(speed)
        self.face_zone = np.array([float(face_zone[0]), float(face_zone[1])])
        self.face_enter_s = float(face_enter_s)
        self.face_leave_s = float(face_leave_s)
        self.merge_s = float(merge_s)
        self.min_burst_s = float(min_burst_s)
        self.baseline_s = float(baseline_s)
        self.min_visibility = float(min_visibility)
        self.visibility_drop = float(visibility_drop)
        self.visibility_baseline_s = float(visibility_baseline_s)
        self.min_coverage = float(min_coverage)
        self.arm_move = float(arm_move)
        self.max_clipped = float(max_clipped)
        self.min_spread = float(min_spread)
        self.min_hand_visibility = float(min_hand_visibility)
        self.min_elbow_visibility = float(min_elbow_visibility)
        self.bursts: list[float] = []  #: start times of the counted gestures
        self.first_t: float | None = None
        self._segments: list[list[float]] = []  #: counted gestures' [start, end]
        self._widths: deque[tuple[float, float]] = deque()
        #: (t, what the frame gave: one of :data:`FRAME_STATES`), for the coverage
        self._frames: deque[tuple[float, str]] = deque()
        #: (t, the gestures of an arm could not be counted in the frame), see :meth:`uncounted`
        self._uncounted: deque[tuple[float, bool]] = deque()
        #: the image about the arms in the last frame with a body: (clipped, spread)
        self.last_exposure: tuple[float, float] | None = None
        self._prev: tuple[float, list[np.ndarray | None], list[bool]] | None = None
        self._runs: list[_WristRun | None] = [None, None]
        self._prev_elbows: list[np.ndarray | None] = [None, None]
        self._hands = [_HandState(), _HandState()]

    def _trusted(self, k: int, t: float, visibility: float) -> bool:
        """Record wrist ``k``'s visibility; True when its keypoint can be trusted now."""
        hist = self._hands[k].visibility
        hist.append((t, visibility))
        while hist and hist[0][0] < t - self.visibility_baseline_s:
            hist.popleft()
        if visibility < self.min_visibility:
            return False
        base = float(np.median([v for _, v in hist]))
        return visibility >= self.visibility_drop * base

    def arm_unseen(self, body: BodyKeypoints, k: int) -> bool:
        """True when the pose model sees neither hand ``k``'s wrist nor its elbow: visibility
        below ``min_hand_visibility`` and ``min_elbow_visibility`` (False without elbows)."""
        if body.elbow_visibility is None:
            return False
        return (
            body.wrist_visibility[k] < self.min_hand_visibility
            and body.elbow_visibility[k] < self.min_elbow_visibility
        )

    def _arm_out(self, k: int, elbow: np.ndarray | None) -> bool:
        """True when hand ``k`` is in a run whose elbow has moved out (now or before)."""
        run = self._runs[k]
        if run is None or elbow is None or run.elbow0 is None:
            return False
        moved = max(run.arm_moved, float(np.linalg.norm(elbow - run.elbow0)))
        return moved >= self.arm_move - 1e-9

    def _face_state(self, k: int, t: float, near: bool, trusted: bool) -> bool:
        """Update hand ``k``'s at-the-face state with this frame; return it."""
        st = self._hands[k]
        if near:
            st.away_since = None
            if st.near_since is None:
                st.near_since = t
            if t - st.near_since >= self.face_enter_s - 1e-9:
                st.at_face = True
        else:
            st.near_since = None
            if trusted:
                if st.away_since is None:
                    st.away_since = t
                if t - st.away_since >= self.face_leave_s - 1e-9:
                    st.at_face = False
        return st.at_face

    def not_seen_well(self, body: BodyKeypoints) -> str | None:
        """Why ``body``'s hands cannot be seen well enough to count gestures: ``"image"`` (the
        image about the arms too dark, bright or flat), ``"hands"`` (the pose model sees
        neither wrist), ``"arm"`` (it sees neither the wrist nor the elbow of one arm:
        :meth:`arm_unseen`), or None (they can, as far as is known)."""
        if body.clipped is not None and body.clipped > self.max_clipped:
            return "image"
        if body.spread is not None and body.spread < self.min_spread:
            return "image"
        if max(body.wrist_visibility) < self.min_hand_visibility:
            return "hands"
        if self.arm_unseen(body, 0) or self.arm_unseen(body, 1):
            return "arm"
        return None

    def update(self, t: float, body: BodyKeypoints | None, *, presenter: bool = True) -> None:
        """Feed one analysed frame's keypoints (None: no body found in it; ``presenter``
        False: the body found is someone else's)."""
        if self.first_t is None:
            self.first_t = t
        state = "seen"
        if body is None:
            state = "none"
        elif not presenter:
            state, body = "other", None
        else:
            if body.clipped is not None and body.spread is not None:
                self.last_exposure = (body.clipped, body.spread)
            # Counted as not seen for the coverage; the keypoints still go to the gesture rule
            # (its own visibility test), so a frame of a poorly seen wrist mid-gesture does not
            # cut a true gesture in two (gestures_c lost one that way).
            state = self.not_seen_well(body) or "seen"
        self._frames.append((t, state))
        while self._frames and self._frames[0][0] <= t - self.window_s:
            self._frames.popleft()
        pos: list[np.ndarray | None] = [None, None]
        elbows: list[np.ndarray | None] = [None, None]
        at_face = [self._hands[0].at_face, self._hands[1].at_face]
        doubtful = [False, False]
        if body is not None:
            width = float(np.linalg.norm(body.shoulders[0] - body.shoulders[1]))
            if width > 1.0:
                self._widths.append((t, width))
            while self._widths and self._widths[0][0] < t - self.baseline_s:
                self._widths.popleft()
            if self._widths:
                sw = float(np.median([w for _, w in self._widths]))
                mid = (body.shoulders[0] + body.shoulders[1]) / 2.0
                face = body.face_centre()
                for k in (0, 1):
                    # An arm the model does not see (wrist and elbow, as under an overlay) is
                    # guessed: its keypoints make no speed, and a run with such a frame is
                    # dropped; the other hand is still counted.
                    trusted = self._trusted(k, t, body.wrist_visibility[k])
                    trusted = trusted and not self.arm_unseen(body, k)
                    near = False
                    if body.elbows is not None:
                        elbows[k] = (body.elbows[k] - mid) / sw
                    if body.wrist_visibility[k] >= self.min_visibility and not self._arm_out(
                        k, elbows[k]
                    ):
                        d = (body.hand_points(k) - face) / (sw * self.face_zone)
                        near = float((d * d).sum(axis=1).min()) < 1.0
                    at_face[k] = self._face_state(k, t, near, trusted)
                    doubtful[k] = not trusted
                    if trusted:
                        pos[k] = (body.wrists[k] - mid) / sw
        prev = self._prev
        for k in (0, 1):
            run = self._runs[k]
            fast = False
            p = pos[k]
            if prev is not None and p is not None and not at_face[k]:
                pp = prev[1][k]
                dt = t - prev[0]
                if pp is not None and 0.0 < dt <= 0.5:
                    fast = float(np.linalg.norm(p - pp)) / dt > self.speed
            if run is not None and doubtful[k] and not at_face[k]:
                run.doubtful += 1
            if fast:
                if run is None or t - run.last > self.merge_s:
                    if run is not None:
                        self._close(run, to_face=False)
                    was_at_face = prev is not None and prev[2][k]
                    e0 = self._prev_elbows[k] if self._prev_elbows[k] is not None else elbows[k]
                    self._runs[k] = _WristRun(t, t, was_at_face, elbow0=e0)
                else:
                    run.last = t
            elif run is not None and (at_face[k] or t - run.last > self.merge_s):
                self._close(run, to_face=at_face[k])
                self._runs[k] = None
            run, elbow = self._runs[k], elbows[k]
            if run is not None and elbow is not None:
                if run.elbow0 is None:
                    run.elbow0 = elbow
                run.arm_moved = max(run.arm_moved, float(np.linalg.norm(elbow - run.elbow0)))
        self._prev = (t, pos, at_face)
        self._prev_elbows = elbows
        # Could each arm's gestures be counted in this frame? Not with no body (or another
        # person's, or the arms lost in the image), nor for an arm the model does not see.
        # (A hand at the face counts too, though no gesture is lost there: the model loses
        # the arm at the chin, on b and d for 2.1 and 1.5 s. Leaving out hands at the face
        # left the hidden arm counted: under an overlay the model guessed that hand at the
        # face, and 0 of 37 windows were flagged on one copy.)
        lost = state in ("none", "other", "image")
        if body is not None and not lost:
            lost = self.arm_unseen(body, 0) or self.arm_unseen(body, 1)
        self._uncounted.append((t, lost))
        while self._uncounted and self._uncounted[0][0] <= t - self.window_s:
            self._uncounted.popleft()

    def _close(self, run: _WristRun, *, to_face: bool) -> None:
        if run.from_face or to_face or run.last - run.start < self.min_burst_s - 1e-9:
            return
        if run.doubtful > 0:
            return
        if run.elbow0 is not None and run.arm_moved < self.arm_move - 1e-9:
            return
        for seg in self._segments:
            if run.start <= seg[1] + self.merge_s and run.last >= seg[0] - self.merge_s:
                seg[0], seg[1] = min(seg[0], run.start), max(seg[1], run.last)
                return
        self._segments.append([run.start, run.last])
        self.bursts.append(run.start)
        log.debug("gesture at %.2f s (to %.2f s)", run.start, run.last)

    def coverage(self) -> float:
        """Share of the window's analysed frames that had the presenter's body in them, seen
        well enough."""
        if not self._frames:
            return 0.0
        return sum(1 for _, st in self._frames if st == "seen") / len(self._frames)

    def uncounted(self) -> float:
        """Share of the window's analysed frames in which the gestures of an arm could not be
        counted: no body (or another person's, or the image about the arms too dark, bright or
        flat), or an arm the pose model does not see (:meth:`arm_unseen`). The rate counts the
        gestures seen over the whole window, so with a share of :data:`PARTLY_COUNTED_SHARE`
        or more it may be low (:data:`SOURCE_BODY_PARTLY`).

        Why not a rate over the seen part only (the gestures that began in frames seen well,
        over their share of the window)? Session 20: on a/b's keypoints with one arm's
        gestures taken out over 6-12 s stretches (every 2 s, either arm) it was unbiased where
        the count read 0.8-1.4 a minute low, but its mean error per window was larger, 1.4-1.9
        against 1.0-1.5 a minute (on copies of a/b with one arm under a box for 9 s, 2.9
        against 1.6; held out: c/d's keypoints 1.7-2.9 against 1.1-2.0, boxed copies of a-d
        2.4 against 2.5): a window holds 3-6 gestures, and a rate from two thirds of them
        varies more than the hidden arm's share of them weighs.
        """
        if not self._uncounted:
            return 0.0
        return sum(1 for _, lost in self._uncounted if lost) / len(self._uncounted)

    def why_not_seen(self) -> str:
        """Why the window's frames lacked the presenter's body seen well, in words: each reason
        with its share of the window's frames, the most common first."""
        counts = {st: 0 for st in FRAME_STATES if st != "seen"}
        for _, st in self._frames:
            if st != "seen":
                counts[st] += 1
        total = max(len(self._frames), 1)
        words = {
            "none": "the presenter's body is out of view",
            "other": "the pose model follows another person, not the presenter",
            "hands": (
                f"the pose model does not see the presenter's hands (both wrists' visibility "
                f"below {self.min_hand_visibility:g}: covered, or out of the frame)"
            ),
            "arm": (
                f"the pose model does not see one of the presenter's arms (its wrist's "
                f"visibility below {self.min_hand_visibility:g} and its elbow's below "
                f"{self.min_elbow_visibility:g}: covered, or out of the frame), whose gestures "
                "cannot be counted"
            ),
            "image": "the presenter's arms cannot be told from the background (the image about "
            "them too dark, too bright or too flat"
            + (
                f": {100 * self.last_exposure[0]:.0f} % black or white, spread "
                f"{self.last_exposure[1]:.0f} grey levels)"
                if self.last_exposure is not None
                else ")"
            ),
        }
        order = sorted((n, st) for st, n in counts.items() if n > 0)[::-1]
        if not order:
            return words["none"]
        return "; ".join(f"{words[st]} in {100 * n / total:.0f} %" for n, st in order)

    def rate(self, t: float) -> float | None:
        """Gestures per minute that started in the window ending at ``t``.

        Returns:
            None until ``min_window_s`` have been seen, and while the body was in view in
            fewer than ``min_coverage`` of the window's analysed frames.
        """
        seen = t - self.first_t if self.first_t is not None else 0.0
        if seen < self.min_window_s - 1e-9 or self.coverage() < self.min_coverage:
            return None
        n = sum(1 for b in self.bursts if t - self.window_s < b <= t)
        return n / min(self.window_s, seen) * 60.0


def _close_up(
    estimator: HeadPoseEstimator, tracker: BodyTracker, frame: np.ndarray, seen: np.ndarray
) -> tuple[BodyKeypoints | None, HeadPose | None]:
    """The pose model's body in ``seen`` (the frame, other faces hidden or not) and the face
    FaceMesh finds in a close-up of its head in ``frame`` (None when either finds none)."""
    body = tracker.keypoints(seen)
    square = body.head_square() if body is not None else None
    return body, estimator.estimate_in(frame, square) if square is not None else None


def _box_square(box: tuple[int, int, int, int], margin: float) -> tuple[int, int, int]:
    """A square ``(x0, y0, side)`` centred on ``box``, ``margin`` times its longer side."""
    side = int(round(margin * max(box[2] - box[0], box[3] - box[1])))
    c = _centre(box)
    return int(round(c[0] - side / 2)), int(round(c[1] - side / 2)), side


def _close_up_no_body(
    estimator: HeadPoseEstimator,
    presenter_face: PresenterFace,
    frame: np.ndarray,
    t: float,
    pose: HeadPose | None,
    faces: list[HeadPose],
    last_face: tuple[tuple[int, int, int, int] | None, float],
    summary: RunSummary,
    name: str,
) -> tuple[HeadPose | None, list[HeadPose]]:
    """Small faces without the pose model (``--no-gestures``): the presenter's face and the
    frame's faces after a close-up about the face's own box.

    A small face the whole frame finds (narrower than :data:`SMALL_FACE_SHARE` of its longer
    side) is read from a close-up about its box (:data:`FACE_BOX_MARGIN`) when the close-up
    finds a face whose centre is in that box. A presenter's face not found in the whole frame
    is looked for in a close-up about its last box (for :data:`LOST_FACE_SEARCH_S` after it
    was last seen, when it was small), else about the face mediapipe's full-range face
    detector sees (:meth:`HeadPoseEstimator.face_boxes`; the one nearest the presenter's last
    face); a face found there is kept when it is small (a bigger one the whole frame would
    read) and :class:`PresenterFace` takes it (near enough the presenter's last face)."""
    longer = max(frame.shape[:2])
    last, last_t = last_face  # the presenter's face before this frame, and when
    recent = (
        last is not None
        and t - last_t <= LOST_FACE_SEARCH_S
        and _width(last) < SMALL_FACE_SHARE * longer
    )
    if pose is not None:
        if _width(pose.box) >= SMALL_FACE_SHARE * longer:
            return pose, faces
        # About the last close-up's box when there is one: the close-up's FaceMesh tracks the
        # face from crop to crop, and a square that jumps to the whole frame's box (itself off
        # when the fit is off) made it follow the misfit (session 20: 21 deg of yaw on p240_d)
        close = estimator.estimate_in(
            frame, _box_square(last if recent and last is not None else pose.box, FACE_BOX_MARGIN)
        )
        if close is None or not _inside(_centre(close.box), pose.box):
            return pose, faces
        summary.close_up_faces += 1
        summary.box_close_ups += 1
        if summary.box_close_ups == 1:
            log.info(
                "%s: the face is small in the frame at %.1f s (%.0f px, under %.0f %% of its "
                "side): read from a close-up of its box (no pose model with --no-gestures)",
                name,
                t,
                _width(pose.box),
                100 * SMALL_FACE_SHARE,
            )
        presenter_face.box = close.box
        return close, [close if f is pose else f for f in faces]
    found: HeadPose | None = None
    if recent and last is not None:
        found = estimator.estimate_in(frame, _box_square(last, FACE_BOX_MARGIN))
    if found is None:
        # Where the full-range face detector sees a face (the presenter's last place nearest)
        boxes = estimator.face_boxes(frame)
        if boxes:
            if last is not None:
                box = min(boxes, key=lambda b: float(np.linalg.norm(_centre(b) - _centre(last))))
            else:
                box = max(boxes, key=_width)
            found = estimator.estimate_in(frame, _box_square(box, DETECT_BOX_MARGIN))
            if found is not None and not _inside(_centre(found.box), box, grow=0.25):
                found = None
    if found is None or _width(found.box) >= SMALL_FACE_SHARE * longer:
        return pose, faces  # none, or not a small face (the whole frame reads those)
    found = presenter_face.choose(t, [found], frame_height=frame.shape[0])
    if found is None:
        return pose, faces  # not near enough the presenter's last face
    summary.close_up_faces += 1
    if summary.lost_face_close_ups == 0:
        log.info(
            "%s: the face is small in the frame at %.1f s and not found in the whole frame: "
            "found in a close-up about where it was last seen or where the full-range face "
            "detector sees it (no pose model with --no-gestures)",
            name,
            t,
        )
    summary.lost_face_close_ups += 1
    return found, [*faces, found]


def mask_boxes(bgr: np.ndarray, boxes: list[tuple[int, int, int, int]]) -> np.ndarray:
    """Return a copy of ``bgr`` with each box (grown by a fifth of its size each side) filled
    with the frame's mean colour."""
    out = bgr.copy()
    h, w = out.shape[:2]
    fill = out.reshape(-1, out.shape[2] if out.ndim == 3 else 1).mean(axis=0)
    for x0, y0, x1, y1 in boxes:
        gx, gy = (x1 - x0) // 5, (y1 - y0) // 5
        xa, ya, xb, yb = max(0, x0 - gx), max(0, y0 - gy), min(w, x1 + gx), min(h, y1 + gy)
        if xb > xa and yb > ya:
            out[ya:yb, xa:xb] = fill if out.ndim == 3 else fill[0]
    return out


# --------------------------------------------------------------------------------------------
# Frame sources


@dataclass
class SourceStats:
    """What a frame source delivered, for the end-of-run summary."""

    frames: int = 0  #: frames read
    not_analysed: int = 0  #: live only: frames the analysis could not keep up with
    expected_frames: int | None = None  #: files: the frame count the container announces


def _sound_only(path: Path) -> bool:
    """True when ``path`` is a media file with audio streams and no video stream, as far as
    PyAV or ``ffprobe`` can tell (False when neither is here or the file cannot be probed).

    An .mp4 of a voice memo is a good file: "wrong format, or truncated" sent the user looking
    for a fault that was not there (session 17)."""
    try:
        import av  # the speech extra's decoder; not in the vision env

        with av.open(str(path)) as c:
            return bool(c.streams.audio) and not c.streams.video
    except ImportError:
        pass
    except Exception:  # noqa: BLE001 - any decoder failure: not a sound file we can name
        return False
    import shutil
    import subprocess

    ffprobe = shutil.which("ffprobe")
    if ffprobe is None:
        return False
    try:
        out = subprocess.run(
            [ffprobe, "-v", "error", "-show_entries", "stream=codec_type", "-of", "csv=p=0"]
            + [str(path)],
            capture_output=True,
            text=True,
            timeout=20,
            check=False,
        ).stdout.split()
    except (OSError, subprocess.SubprocessError):
        return False
    return "audio" in out and "video" not in out


def open_video(path: Path) -> cv2.VideoCapture:
    """Open a video file, checking it is one.

    Raises:
        VisionInputError: missing, empty, not decodable, no frame rate; names the file.
    """
    if not path.exists():
        raise VisionInputError(path, "no such file")
    if not path.is_file():
        raise VisionInputError(path, "not a file")
    if path.stat().st_size == 0:
        raise VisionInputError(path, "empty file (0 bytes), not a video")
    # OpenCV's FFmpeg backend prints libav's own complaint ("[mov,mp4,…] moov atom not found")
    # to stderr before the error below says the same in words: quiet it (read when the backend
    # first opens a file; a user's own setting is kept, e.g. to debug a decoder).
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")
    cap = cv2.VideoCapture(str(path))
    if not cap.isOpened():
        if _sound_only(path):
            raise VisionInputError(
                path, "has sound but no video stream: there is nothing for the camera to see"
            )
        raise VisionInputError(
            path,
            "cannot be read as a video (no video stream, e.g. a sound-only recording; a wrong "
            "format; or a truncated file)",
        )
    # A phone stores a portrait video as landscape frames plus a rotation in its metadata.
    # OpenCV applies that rotation only where it is on by default (5.x, not the 4.x of the
    # vision env): sideways frames gave head yaws of +-190 deg and no facing. Ask for it.
    cap.set(cv2.CAP_PROP_ORIENTATION_AUTO, 1)
    fps = cap.get(cv2.CAP_PROP_FPS)
    if not (math.isfinite(fps) and fps > 0.0):
        cap.release()
        raise VisionInputError(path, "the video states no frame rate")
    return cap


class FileSource:
    """Frames of a video file with their video time; optionally paced at real time.

    In real-time mode the frames a slow analysis cannot keep up with are skipped and counted.
    """

    def __init__(self, path: Path, *, realtime: bool = False, start_s: float = 0.0) -> None:
        self.path = Path(path)
        self.realtime = realtime
        self._cap = open_video(self.path)
        self.fps = float(self._cap.get(cv2.CAP_PROP_FPS))
        n = int(self._cap.get(cv2.CAP_PROP_FRAME_COUNT))
        #: the first frame read (a module restarted mid-talk resumes at the talk's present)
        self.first_frame = max(0, int(round(start_s * self.fps))) if start_s > 0 else 0
        self.stats = SourceStats(expected_frames=max(0, n - self.first_frame) if n > 0 else None)
        self.name = str(self.path)

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """Yield ``(t, bgr)``; t is the frame's video time."""
        i = self.first_frame
        for _ in range(i):  # frame by frame: seeking is not exact in every container
            if not self._cap.grab():
                break
        start = time.monotonic() - i / self.fps
        prev_t: float | None = None
        while True:
            ok, frame = self._cap.read()
            if not ok or frame is None:
                break
            # The frame's own timestamp, not its index over the frame rate: a phone or a
            # stalling webcam records a variable frame rate, and i / fps put every frame after
            # a 6 s stall up to 4.6 s early against the sound. A container without usable
            # timestamps (none, or not increasing) falls back to one frame period.
            t = self._cap.get(cv2.CAP_PROP_POS_MSEC) / 1000.0
            if not math.isfinite(t) or t < 0.0 or (prev_t is not None and t <= prev_t):
                t = i / self.fps if prev_t is None else prev_t + 1.0 / self.fps
            prev_t = t
            i += 1
            self.stats.frames += 1
            if self.realtime:
                ahead = t - (time.monotonic() - start)
                if ahead > 0:
                    time.sleep(ahead)
                elif -ahead > 1.0 / self.fps:
                    self.stats.not_analysed += 1
                    continue
            yield t, frame
        if self.stats.frames == 0:
            raise VisionInputError(self.path, "no video frame could be decoded (truncated?)")

    def close(self) -> None:
        """Release the file."""
        self._cap.release()


class CameraSource:
    """Live camera frames. A reader thread keeps only the newest frame; the frames it had to
    replace before the analysis took them are counted (``stats.not_analysed``), never hidden.

    Args:
        index: the camera number (``cam:N``).
        t0: wall-clock time (``time.time()``) at which the talk began.
        capture: an opened ``cv2.VideoCapture``-like object to read instead (tests).
    """

    def __init__(self, index: int, *, t0: float, capture: Any = None) -> None:
        self.name = f"camera {index}"
        self._cap = cv2.VideoCapture(index) if capture is None else capture
        if not self._cap.isOpened():
            raise VisionInputError(self.name, "cannot be opened (is it connected and free?)")
        self.fps = float(self._cap.get(cv2.CAP_PROP_FPS)) or 30.0
        self.t0 = t0
        self.stats = SourceStats()
        self._cond = threading.Condition()
        self._frame: tuple[float, np.ndarray] | None = None
        self._taken = True
        self._stop = False
        self._thread = threading.Thread(target=self._read, name="prezence-camera", daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._stop:
            ok, frame = self._cap.read()
            t = time.time() - self.t0
            with self._cond:
                if not ok:
                    self._stop = True
                    self._cond.notify_all()
                    break
                self.stats.frames += 1
                if not self._taken:
                    self.stats.not_analysed += 1
                self._frame, self._taken = (max(t, 0.0), frame), False
                self._cond.notify_all()

    def frames(self) -> Iterator[tuple[float, np.ndarray]]:
        """Yield ``(t, bgr)`` of the newest frame each time the analysis is ready for one."""
        while True:
            with self._cond:
                while self._taken and not self._stop:
                    self._cond.wait(timeout=1.0)
                item = self._frame
                if self._taken or item is None:  # stopped and nothing new
                    return
                self._taken = True
            yield item

    def close(self) -> None:
        """Stop the reader and release the camera."""
        self._stop = True
        self._thread.join(timeout=2.0)
        self._cap.release()


# --------------------------------------------------------------------------------------------
# The module process


@dataclass
class VisionOptions:
    """Everything the run loop needs (the CLI's parsed flags)."""

    head: bool = True
    gestures: bool = True
    calibrate_s: float = 3.0
    audience: tuple[float, float] | None = None
    fps: float = 8.0  #: analysed frames per second at most; 0 = every frame
    facing_window_s: float = 5.0
    tolerance: tuple[float, float] = (20.0, 15.0)
    gesture_window_s: float = 30.0
    duration_s: float | None = None
    yaw_gain: float = YAW_GAIN
    pitch_gain: float = PITCH_GAIN
    #: ``auto``: the body's wrists when the pose model can run, else the frame difference;
    #: ``body`` or ``motion`` force one (``body`` fails without mediapipe).
    gesture_source: str = "auto"
    #: the video is mirrored (a selfie camera): each frame is flipped back before analysis
    mirrored: bool = False


@dataclass
class RunSummary:
    """What one run did."""

    analysed: int = 0
    faces: int = 0
    close_up_faces: int = 0  #: of ``faces``, found only in a close-up of the head
    #: of ``close_up_faces``, without the pose model: a small face the whole frame found, read
    #: from a close-up of its box
    box_close_ups: int = 0
    #: ... and one the whole frame did not find, found in a close-up (its last box or the face
    #: detector's)
    lost_face_close_ups: int = 0
    samples: dict[str, int] = field(default_factory=lambda: dict.fromkeys(STREAMS, 0))
    bursts: list[float] = field(default_factory=list)
    head: bool = False
    gesture_source: str = ""  #: "body", "motion" or "" (gestures off)
    source: SourceStats = field(default_factory=SourceStats)


#: The session folder's record of what this module could not measure, and how it measured
#: the gesture rate (read by :func:`prezence.summary.measurement_notes`).
STATUS_FILE = "vision.json"


def motion_fallback_why(opts: VisionOptions) -> str:
    """Why ``cv_gestures`` is not measured when the gesture rate comes from the frame
    difference (its rate goes to ``cv_gestures_motion`` instead, which no default rule
    judges), for ``vision.json`` and so the report."""
    why = (
        "--gesture-source motion was asked for"
        if opts.gesture_source == "motion"
        else "the pose model that counts gestures from the body cannot run here (it needs "
        "mediapipe: python -m prezence.modules.vision_env install)"
    )
    return (
        f"{why}; the frame-difference fallback's rate is in {GESTURES_MOTION}, too unreliable "
        "to advise on (it misses most gestures, counts other motion, and cannot tell no one "
        "in view from no gestures)"
    )


def write_status(out: Path, opts: VisionOptions, *, head_on: bool, gesture_source: str) -> None:
    """Write ``out/vision.json``: the metrics head pose would have given and why it did not
    (``off``), and where the gesture rate comes from, so the report can say so rather than
    "the camera saw no face". With the frame-difference fallback ``cv_gestures`` is in ``off``
    too (:func:`motion_fallback_why`)."""
    import json

    why = None
    if not opts.head:
        why = "head pose was turned off (--no-head)"
    elif not head_on:
        why = f"head pose was off: {install_hint()}"
    off = {m: why for m in (HEAD_GAZE, HEAD_YAW, FACING_AUDIENCE)} if why else {}
    if opts.gestures and gesture_source == "motion":
        off[GESTURES] = motion_fallback_why(opts)
    status = {
        "format": 1,
        "off": off,
        "gesture_source": gesture_source if opts.gestures else "off",
    }
    Path(out).mkdir(parents=True, exist_ok=True)
    (Path(out) / STATUS_FILE).write_text(json.dumps(status, indent=1) + "\n")


def run(
    source: FileSource | CameraSource,
    out: Path,
    opts: VisionOptions,
    *,
    fresh: bool = True,
    stop: threading.Event | None = None,
) -> RunSummary:
    """Analyse ``source`` and write the streams under ``out/streams``.

    Args:
        source: the frames.
        out: the session folder.
        opts: what to measure and how.
        fresh: replace this module's stream files (file input) rather than append (live).
        stop: set it to end the run cleanly (signals).

    Raises:
        VisionUnavailable: ``opts.head`` and ``opts.gestures`` are both off, or only head
            pose is asked for and mediapipe is missing.
    """
    if opts.gesture_source not in ("auto", "body", "motion"):
        raise ValueError(f"gesture source must be auto, body or motion: {opts.gesture_source!r}")
    summary = RunSummary(source=source.stats)
    estimator: HeadPoseEstimator | None = None
    if opts.head:
        try:
            estimator = HeadPoseEstimator(yaw_gain=opts.yaw_gain, pitch_gain=opts.pitch_gain)
        except VisionUnavailable:
            if not opts.gestures:
                raise
            log.error("%s; head pose is off, the gesture rate still runs", install_hint())
    summary.head = estimator is not None
    if estimator is None and not opts.gestures:
        raise VisionUnavailable("nothing to measure: head pose and gestures are both off")
    gaze = GazeTracker(
        calibrate_s=opts.calibrate_s,
        audience=opts.audience,
        facing_window_s=opts.facing_window_s,
        tolerance=opts.tolerance,
    )
    min_window = min(GESTURE_MIN_WINDOW_S, opts.gesture_window_s)
    motion = GestureDetector(window_s=opts.gesture_window_s, min_window_s=min_window)
    body_det = BodyGestureDetector(window_s=opts.gesture_window_s, min_window_s=min_window)
    tracker: BodyTracker | None = None
    if opts.gestures:
        if opts.gesture_source != "motion":
            try:
                tracker = BodyTracker()
            except VisionUnavailable:
                if opts.gesture_source == "body":
                    if estimator is not None:
                        estimator.close()
                    raise
        summary.gesture_source = "body" if tracker is not None else "motion"
        if tracker is not None:
            log.info("gesture rate from the body: wrist keypoints of the pose model")
        else:
            log.warning(
                "gesture rate from the frame difference (fallback%s): head motion outside the "
                "face box, a moving background or lighting may be counted as gestures, and no "
                "one in view reads as no gestures; it is written as %s, which no default rule "
                "judges, and %s is not measured",
                ", the pose model cannot run here" if opts.gesture_source == "auto" else "",
                GESTURES_MOTION,
                GESTURES,
            )
    source_code = SOURCE_BODY if tracker is not None else SOURCE_MOTION
    # the fallback's rate under a metric of its own, which no default rule judges: the
    # processor stays one path, and nothing advises from a source too unreliable to
    rate_metric = GESTURES if tracker is not None else GESTURES_MOTION
    presenter_face = PresenterFace()
    presenter_body = PresenterBody()
    last_nose: np.ndarray | None = None  #: the presenter's face keypoints (pose model), last
    write_status(out, opts, head_on=estimator is not None, gesture_source=summary.gesture_source)
    not_measured_since: float | None = None
    partly_since: float | None = None  #: the rate counts part of its window only, since
    streams = StreamSet(out, STREAMS, fresh=fresh).open()
    heartbeat = Heartbeat()

    def write(metric: str, t: float, value: float) -> None:
        streams.write(metric, round(t, 4), round(value, 3))
        summary.samples[metric] += 1

    step = 1.0 / opts.fps if opts.fps > 0 else 0.0
    next_t = -math.inf
    next_report = 1.0
    warn_at = -math.inf
    warned_dropped = warned_analysed = 0
    warned_at_t = 0.0
    last_t = 0.0
    try:
        for t, frame in source.frames():
            heartbeat.beat()
            if stop is not None and stop.is_set():
                break
            if opts.duration_s is not None and t > opts.duration_s:
                break
            if t < next_t - 1e-9:
                continue  # sampling to --fps, by choice
            next_t = t + step if next_t == -math.inf else max(next_t + step, t)
            last_t = t
            summary.analysed += 1
            if opts.mirrored:
                frame = cv2.flip(frame, 1)  # un-mirror: the presenter's left back on image right
            faces = estimator.estimate_all(frame) if estimator is not None else []
            body: BodyKeypoints | None = None
            body_read = False
            if not faces and estimator is not None and tracker is not None:
                # A face too small for FaceMesh in the whole frame (session 19: a presenter
                # in a tall phone frame, no head sample for the first 9.5 s while the pose
                # model saw the body): look again in a square about the pose model's head
                # keypoints, scaled up. Only then, so the cost stays bounded.
                body, close_up = _close_up(estimator, tracker, frame, frame)
                body_read = True
                if close_up is not None:
                    faces = [close_up]
                    summary.close_up_faces += 1
                    if summary.close_up_faces == 1:
                        log.info(
                            "%s: the face is small in the frame at %.1f s: found in a close-up "
                            "of the head the pose model sees",
                            source.name,
                            t,
                        )
            last_face = (presenter_face.box, presenter_face.seen_t)
            pose = presenter_face.choose(t, faces, frame_height=frame.shape[0], nose=last_nose)
            if (
                pose is not None
                and not body_read  # not a face the close-up above found
                and estimator is not None
                and tracker is not None
                and _width(pose.box) < SMALL_FACE_SHARE * max(frame.shape[:2])
            ):
                # A small face the whole frame does find can read far off (session 19: up to
                # 32 deg of yaw, 22 of pitch in tall frames, where a close-up read within 10
                # and 5): read it from a close-up of the head the pose model sees, when that
                # finds the same face. A second face FaceMesh puts over the presenter's (a
                # duplicate, seen in tall frames) is not hidden from the pose model: that would
                # hide the presenter's head.
                others = [
                    f.box for f in faces if f is not pose and not _inside(_centre(f.box), pose.box)
                ]
                seen = mask_boxes(frame, others) if others else frame
                body, close_up = _close_up(estimator, tracker, frame, seen)
                body_read = True
                if close_up is not None and _inside(_centre(close_up.box), pose.box):
                    faces = [close_up if f is pose else f for f in faces]
                    pose = close_up
                    summary.close_up_faces += 1
                    if summary.close_up_faces == 1:
                        log.info(
                            "%s: the face is small in the frame at %.1f s (%.0f px, under %.0f "
                            "%% of its side): read from a close-up of the head the pose model sees",
                            source.name,
                            t,
                            _width(pose.box),
                            100 * SMALL_FACE_SHARE,
                        )
            if estimator is not None and tracker is None:
                pose, faces = _close_up_no_body(
                    estimator,
                    presenter_face,
                    frame,
                    t,
                    pose,
                    faces,
                    last_face,
                    summary,
                    source.name,
                )
            if pose is not None:
                summary.faces += 1
            if estimator is not None:
                for tt, yaw, pitch in gaze.update(t, pose):
                    write(HEAD_YAW, tt, yaw)
                    write(HEAD_GAZE, tt, pitch)
            if tracker is not None:
                # The pose model finds one person, and would take another face's: hide the
                # faces that are not the presenter's from it once the presenter's is known.
                others = [f.box for f in faces if f is not pose]
                seen = mask_boxes(frame, others) if others and presenter_face.box else frame
                if not body_read:
                    body = tracker.keypoints(seen)
                mine = body is None or presenter_body.check(
                    t, body, pose.box if pose is not None else None
                )
                last_nose = body.face_centre() if body is not None and mine else None
                body_det.update(t, body, presenter=mine)
            elif opts.gestures:
                motion.update(t, frame, exclude=pose.box if pose is not None else None)
            if t - next_report > 5.0:  # a jump (a paused camera, a far --t0): no backlog
                next_report = float(math.floor(t))
            while t >= next_report:
                if estimator is not None:
                    f = gaze.facing(next_report)
                    if f is not None:
                        write(FACING_AUDIENCE, next_report, f)
                if opts.gestures:
                    det = body_det if tracker is not None else motion
                    rate = det.rate(next_report)
                    if rate is not None:
                        code = source_code
                        if tracker is not None and body_det.uncounted() >= PARTLY_COUNTED_SHARE:
                            code = SOURCE_BODY_PARTLY
                            if partly_since is None:
                                partly_since = next_report
                                log.warning(
                                    "%s: gesture rate from %.0f s may be low "
                                    "(cv_gestures_source %g): the gestures of an arm could not "
                                    "be counted in %.0f %% of the last %.0f s, and the rate "
                                    "counts those seen over the whole window. Not seen well: %s",
                                    source.name,
                                    next_report,
                                    SOURCE_BODY_PARTLY,
                                    100.0 * body_det.uncounted(),
                                    opts.gesture_window_s,
                                    body_det.why_not_seen(),
                                )
                        else:
                            partly_since = None
                        write(rate_metric, next_report, rate)
                        write(GESTURES_SOURCE, next_report, code)
                        if not_measured_since is not None:
                            log.info(
                                "%s: gesture rate measured again from %.0f s: the presenter's "
                                "body is in view and seen well",
                                source.name,
                                next_report,
                            )
                            not_measured_since = None
                    elif det.first_t is not None and next_report - det.first_t >= min_window:
                        # Seen long enough, but the presenter's body was not (out of view, another
                        # person's, or too dark to see the arms): say so, no number.
                        write(GESTURES_SOURCE, next_report, SOURCE_NOT_MEASURED)
                        if not_measured_since is None:
                            not_measured_since = next_report
                            log.warning(
                                "%s: gesture rate not measured from %.0f s: the presenter's "
                                "body is seen well in %.0f %% of the last %.0f s; %s",
                                source.name,
                                next_report,
                                100.0 * body_det.coverage(),
                                opts.gesture_window_s,
                                body_det.why_not_seen(),
                            )
                next_report += 1.0
            if warn_at == -math.inf:
                warn_at, warned_at_t = t + 10.0, t
            if t >= warn_at:
                dropped = source.stats.not_analysed - warned_dropped
                if dropped > 0:
                    log.warning(
                        "%s: falling behind: %d frames not analysed in the last %.0f s "
                        "(%d analysed); lower --fps or close other programs",
                        source.name,
                        dropped,
                        t - warned_at_t,
                        summary.analysed - warned_analysed,
                    )
                warned_dropped = source.stats.not_analysed
                warned_analysed = summary.analysed
                warned_at_t = t
                warn_at = t + 10.0
    finally:
        streams.close()
        if estimator is not None:
            estimator.close()
        if tracker is not None:
            tracker.close()
    if estimator is not None and not gaze.calibrated:
        log.warning("%s: too few faces to find the audience direction", source.name)
    summary.bursts = sorted(body_det.bursts if tracker is not None else motion.bursts)
    if source.stats.not_analysed:
        log.warning(
            "%s: %d of %d frames were not analysed (the analysis fell behind real time)",
            source.name,
            source.stats.not_analysed,
            source.stats.frames,
        )
    log.info(
        "%s: %.1f s, %d frames analysed, %d with a face, %d gestures (%s)",
        source.name,
        last_t,
        summary.analysed,
        summary.faces,
        len(summary.bursts),
        {"body": "from the body's wrists", "motion": "from the frame difference"}.get(
            summary.gesture_source, "gestures off"
        ),
    )
    return summary


def parse_source(spec: str) -> tuple[str, int | Path]:
    """Parse ``--video``: ``cam``, ``cam:N`` or a file path.

    Example:
        >>> parse_source("cam:1")
        ('cam', 1)
        >>> parse_source("talk.mp4")
        ('file', PosixPath('talk.mp4'))
    """
    if spec == "cam":
        return "cam", 0
    if spec.startswith("cam:"):
        try:
            return "cam", int(spec[4:])
        except ValueError as e:
            raise ValueError(f"--video {spec!r}: expected cam:N with a camera number") from e
    return "file", Path(spec)


def build_parser() -> argparse.ArgumentParser:
    """Return the parser of ``python -m prezence.modules.vision``."""
    p = argparse.ArgumentParser(
        prog="python -m prezence.modules.vision",
        description="Head gaze, facing the audience and gesture rate from a video or camera.",
    )
    p.add_argument("--video", required=True, help="a video file, or cam / cam:N for a camera")
    add_common_arguments(p)  # --out, --t0, --realtime, -v, -q
    p.add_argument("--calibrate-s", type=float, default=3.0, help="seconds (default %(default)s)")
    p.add_argument("--audience-yaw", type=float, default=None, help="degrees, camera frame")
    p.add_argument("--audience-pitch", type=float, default=None, help="degrees, camera frame")
    p.add_argument("--fps", type=float, default=8.0, help="analysed fps at most; 0 = all")
    p.add_argument("--facing-window", type=float, default=5.0, help="seconds")
    p.add_argument(
        "--facing-tolerance", type=float, nargs=2, default=(20.0, 15.0), metavar=("YAW", "PITCH")
    )
    p.add_argument("--gesture-window", type=float, default=30.0, help="seconds")
    p.add_argument("--duration", type=float, default=None, help="stop after this many seconds")
    p.add_argument("--no-head", action="store_true", help="gestures only (no mediapipe needed)")
    p.add_argument("--no-gestures", action="store_true", help="head pose only")
    p.add_argument("--no-reexec", action="store_true", help="do not switch to the vision env")
    p.add_argument(
        "--gesture-source",
        choices=("auto", "body", "motion"),
        default="auto",
        help="body: wrist keypoints of the pose model; motion: frame difference (fallback); "
        "auto: body when mediapipe is here (default)",
    )
    p.add_argument(
        "--mirrored",
        action="store_true",
        help="the video or camera is mirrored (a selfie view): flip each frame back before "
        "analysis, or head yaw's sign and the report's left and right are swapped; it cannot "
        "be told from the picture",
    )
    return p


def _maybe_reexec(argv: list[str]) -> None:
    """Re-run in the vision venv when mediapipe is missing here and that venv exists."""
    if os.environ.get(_REEXEC_GUARD) or mediapipe_available():
        return
    from prezence.modules import vision_env

    py = vision_env.find_python()
    if py is None:
        return
    if Path(sys.prefix).resolve() == py.parent.parent.resolve():
        return
    log.info("mediapipe is not here; running in the vision env %s", py)
    sys.stdout.flush()
    sys.stderr.flush()
    env = vision_env.child_env({**os.environ, _REEXEC_GUARD: "1"})
    os.execve(str(py), [str(py), "-m", "prezence.modules.vision", *argv], env)


def main(argv: list[str] | None = None) -> int:
    """Run the module; return the exit status (0 done, 2 bad input or arguments)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    setup_logging("vision", args)
    if args.no_head and args.no_gestures:
        print("error: --no-head and --no-gestures leave nothing to measure", file=sys.stderr)
        return 2
    if not args.no_reexec and (not args.no_head or args.gesture_source != "motion"):
        _maybe_reexec(argv)  # head pose and the body's keypoints both need mediapipe
    audience = None
    if args.audience_yaw is not None or args.audience_pitch is not None:
        audience = (args.audience_yaw or 0.0, args.audience_pitch or 0.0)
    try:
        opts = VisionOptions(
            head=not args.no_head,
            gestures=not args.no_gestures,
            calibrate_s=args.calibrate_s,
            audience=audience,
            fps=args.fps,
            facing_window_s=args.facing_window,
            tolerance=(args.facing_tolerance[0], args.facing_tolerance[1]),
            gesture_window_s=args.gesture_window,
            duration_s=args.duration,
            gesture_source=args.gesture_source,
            mirrored=args.mirrored,
        )
        kind, where = parse_source(args.video)
        source: FileSource | CameraSource
        if isinstance(where, Path):
            resume = resume_offset(args)
            if resume:
                log.info("started %.1f s into the talk: the video continues from there", resume)
            source = FileSource(where, realtime=args.realtime, start_s=resume)
        else:
            source = CameraSource(where, t0=args.t0 if args.t0 is not None else time.time())
    except (VisionInputError, ValueError) as e:
        return report_error("vision", e)
    stop = threading.Event()

    def _on_signal(signum: int, frame: FrameType | None) -> None:
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, _on_signal)
    try:
        summary = run(source, args.out, opts, fresh=kind == "file", stop=stop)
    except (VisionInputError, VisionUnavailable, ValueError) as e:
        return report_error("vision", e)
    finally:
        source.close()
    n = source.stats.expected_frames
    ended_early = n is not None and source.stats.frames < n - max(2, n // 50)
    whole_file = isinstance(source, FileSource) and opts.duration_s is None and not stop.is_set()
    if whole_file and ended_early:
        # a recording that breaks off (a phone that died mid-talk) is not a bad input: all of
        # it that could be read was measured, and rehearse and up go on with that
        return report_error(
            "vision",
            InputCutShort(
                source.name,
                f"the video ended after {source.stats.frames} of the {n} frames it announces "
                "(truncated?); the streams hold what was read",
            ),
        )
    if opts.head and not summary.head:
        print(f"vision: head pose was off: {install_hint()}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
