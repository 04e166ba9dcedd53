"""Make the vision module's test videos, with their truth in a JSON manifest.

Two small videos (320x240, 15 fps, mp4v) go to ``tests/modules/material_video/``:

``head_pose.mp4``
    A real face at KNOWN head angles. The frontal photo ``skimage.data.astronaut()`` (it ships
    inside the scikit-image wheel) is lifted into a textured 3D mesh: mediapipe FaceMesh gives
    468 3D landmarks on the photo, a ring of vertices around them (hair, ears, pushed back) closes
    the head, Delaunay triangles join them and each triangle keeps its patch of the photo. The
    mesh is rotated by a known yaw or pitch about a pivot behind the face, projected with a
    webcam-like perspective camera, and drawn triangle by triangle (affine warps, painter's
    order, back faces culled) over a blurred static background, with camera noise. A flat
    warp of the photo would not do: it has no parallax, so no estimator sees the turn.

    Timeline: 2 s frontal (calibration), then yaw steps -30..+30 deg, then pitch steps
    -20..+20 deg; each step is a 0.4 s linear move and a 0.8 s hold. Convention: yaw > 0 when
    the presenter turns to their own left (the nose moves to the image's right); pitch > 0 when
    the head tilts up.

    Caveat (honest): the mesh's depth is FaceMesh's own z for this face; ``--depth-scale``
    stretches it, to measure how much an estimator's gain depends on that.

``gestures.mp4``
    A static photo of a person with camera noise and a slow light flicker, and a skin-coloured
    "hand" that swings at 1.6-2.4 Hz during known bursts (start, end) in the lower body region,
    and rests (still) between them.

Run it with the vision env's python (mediapipe and scikit-image are needed only here)::

    python -m prezence.modules.vision_env install --tools
    $(python -m prezence.modules.vision_env where) tools/make_test_video.py

The output is deterministic for a given seed, up to the video encoder.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

OUT_DIR = Path(__file__).resolve().parents[1] / "tests" / "modules" / "material_video"
W, H = 320, 240
FPS = 15.0
SS = 2  # supersampling factor of the renderer (anti-aliasing)

# FaceMesh's face-oval landmark indices, in order around the face.
FACE_OVAL = (
    10, 338, 297, 332, 284, 251, 389, 356, 454, 323, 361, 288, 397, 365, 379, 378, 400, 377,
    152, 148, 176, 149, 150, 136, 172, 58, 132, 93, 234, 127, 162, 21, 54, 103, 67, 109,
)  # fmt: skip


@dataclass(frozen=True)
class HeadMesh:
    """A textured head mesh in source-image pixel units (x right, y down, z away)."""

    texture: np.ndarray  # the source photo, RGB
    uv: np.ndarray  # (n, 2) vertex positions in the photo
    xyz: np.ndarray  # (n, 3) vertex positions in 3D (x, y as uv; z from FaceMesh)
    tris: np.ndarray  # (m, 3) vertex indices
    pivot: np.ndarray  # (3,) rotation centre, behind the face
    face_width: float


def build_head_mesh(depth_scale: float = 1.0) -> HeadMesh:
    """Lift the astronaut photo's face into a textured 3D mesh (needs mediapipe, skimage)."""
    import mediapipe as mp
    from scipy.spatial import Delaunay
    from skimage import data

    img = np.ascontiguousarray(data.astronaut()[:, :, :3])
    h, w = img.shape[:2]
    with mp.solutions.face_mesh.FaceMesh(static_image_mode=True, max_num_faces=1) as fm:
        res = fm.process(img)
    if not res.multi_face_landmarks:
        raise RuntimeError("FaceMesh found no face in skimage.data.astronaut()")
    lm = np.array([(p.x * w, p.y * h, p.z * w) for p in res.multi_face_landmarks[0].landmark])
    lm[:, 2] *= depth_scale
    oval = lm[list(FACE_OVAL)]
    centre = oval[:, :2].mean(axis=0)
    face_w = float(oval[:, 0].max() - oval[:, 0].min())
    # Close the head: two rings outside the face oval, further out and further back, so that
    # hair and ears turn with the face and the face detector sees a head, not a floating mask.
    rings = []
    for grow, back in ((1.25, 0.22), (1.55, 0.55)):
        ring = oval.copy()
        ring[:, :2] = centre + grow * (oval[:, :2] - centre)
        ring[:, 2] = oval[:, 2] + back * face_w
        rings.append(ring)
    xyz = np.vstack([lm, *rings])
    uv = xyz[:, :2].copy()
    tris = Delaunay(uv).simplices.astype(np.int64)
    pivot = np.array(
        [centre[0], centre[1] + 0.1 * face_w, float(np.median(oval[:, 2])) + 0.35 * face_w]
    )
    return HeadMesh(img, uv, xyz, tris, pivot, face_w)


def rotation(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Rotation matrix (x right, y down, z away from the camera) for the stated convention."""
    a, b = math.radians(yaw_deg), math.radians(pitch_deg)
    # yaw > 0: a point in front of the pivot (z < 0) moves to +x.
    ry = np.array(
        [[math.cos(a), 0.0, -math.sin(a)], [0.0, 1.0, 0.0], [math.sin(a), 0.0, math.cos(a)]]
    )
    # pitch > 0: a point in front of the pivot moves up (-y).
    rp = np.array(
        [[1.0, 0.0, 0.0], [0.0, math.cos(b), math.sin(b)], [0.0, -math.sin(b), math.cos(b)]]
    )
    return rp @ ry


def render_head(
    mesh: HeadMesh, yaw: float, pitch: float, background: np.ndarray, scale: float
) -> np.ndarray:
    """Render the head at (yaw, pitch) degrees over ``background`` (H*SS x W*SS RGB)."""
    out = background.copy()
    d = mesh.xyz - mesh.pivot
    p = d @ rotation(yaw, pitch).T
    # Perspective: the camera is 6 face widths from the pivot (about 85 cm for a real head).
    dist = 6.0 * mesh.face_width
    k = dist / (dist + p[:, 2])
    sx = scale * SS
    u = W * SS / 2 + sx * p[:, 0] * k
    v = H * SS / 2 + sx * p[:, 1] * k
    dst = np.stack([u, v], axis=1).astype(np.float32)
    src = mesh.uv.astype(np.float32)
    depth = p[:, 2][mesh.tris].mean(axis=1)
    for ti in np.argsort(-depth):  # far to near
        idx = mesh.tris[ti]
        s3, d3 = src[idx], dst[idx]
        # Back faces (projected winding flipped against the photo's) are hidden.
        area_s = np.cross(s3[1] - s3[0], s3[2] - s3[0])
        area_d = np.cross(d3[1] - d3[0], d3[2] - d3[0])
        if area_s * area_d <= 0 or abs(area_d) < 1e-3:
            continue
        x0, y0 = np.floor(d3.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(d3.max(axis=0)).astype(int) + 2
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, out.shape[1]), min(y1, out.shape[0])
        if x1 <= x0 or y1 <= y0:
            continue
        m = cv2.getAffineTransform(s3, d3 - np.float32([x0, y0]))
        patch = cv2.warpAffine(
            mesh.texture, m, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_REFLECT,
        )  # fmt: skip
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        # Grown by half a pixel so neighbouring triangles leave no cracks.
        cv2.fillConvexPoly(mask, np.round((d3 - [x0, y0]) * 4).astype(np.int32), 1, cv2.LINE_8, 2)
        cv2.polylines(
            mask, [np.round((d3 - [x0, y0]) * 4).astype(np.int32)], True, 1, 2, cv2.LINE_8, 2
        )
        sel = mask.astype(bool)
        out[y0:y1, x0:x1][sel] = patch[sel]
    return out


def head_timeline(hold_s: float = 0.8, move_s: float = 0.4) -> tuple[list[dict], float]:
    """Return the holds ``[{start, end, yaw, pitch}]`` and the total duration."""
    targets = [(0.0, 0.0)]
    targets += [(y, 0.0) for y in (-30, -20, -10, 0, 10, 20, 30, 0)]
    targets += [(0.0, p) for p in (-20, -10, 0, 10, 20, 0)]
    holds = [{"start": 0.0, "end": 2.0, "yaw": 0.0, "pitch": 0.0}]
    t = 2.0
    for yaw, pitch in targets[1:]:
        t += move_s
        holds.append(
            {"start": round(t, 6), "end": round(t + hold_s, 6), "yaw": yaw, "pitch": pitch}
        )
        t += hold_s
    return holds, t


def angle_at(holds: list[dict], t: float) -> tuple[float, float]:
    """Linear moves between holds: the true (yaw, pitch) at time ``t``."""
    prev = holds[0]
    for h in holds:
        if t < h["start"]:
            f = (t - prev["end"]) / (h["start"] - prev["end"])
            return (
                prev["yaw"] + f * (h["yaw"] - prev["yaw"]),
                prev["pitch"] + f * (h["pitch"] - prev["pitch"]),
            )
        if t <= h["end"]:
            return float(h["yaw"]), float(h["pitch"])
        prev = h
    return float(prev["yaw"]), float(prev["pitch"])


def _writer(path: Path) -> cv2.VideoWriter:
    path.parent.mkdir(parents=True, exist_ok=True)
    vw = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), FPS, (W, H))
    if not vw.isOpened():
        raise RuntimeError(f"{path}: OpenCV cannot write mp4v here")
    return vw


def make_head_video(path: Path, *, seed: int, depth_scale: float = 1.0) -> dict:
    """Write the head-pose video; return its manifest entry."""
    rng = np.random.default_rng(seed)
    mesh = build_head_mesh(depth_scale)
    bg = cv2.GaussianBlur(mesh.texture, (0, 0), 12)
    cx, cy = mesh.pivot[:2]
    scale = 1.1
    m = np.float32(
        [
            [scale * SS, 0, W * SS / 2 - scale * SS * cx],
            [0, scale * SS, H * SS / 2 - scale * SS * cy],
        ]
    )
    background = cv2.warpAffine(bg, m, (W * SS, H * SS), borderMode=cv2.BORDER_REFLECT)
    background = (background * 0.8).astype(np.uint8)
    holds, dur = head_timeline()
    n = int(round(dur * FPS))
    truth = []
    vw = _writer(path)
    for i in range(n):
        t = i / FPS
        yaw, pitch = angle_at(holds, t)
        big = render_head(mesh, yaw, pitch, background, scale)
        frame = cv2.resize(big, (W, H), interpolation=cv2.INTER_AREA).astype(np.int16)
        frame += rng.normal(0.0, 2.0, frame.shape).round().astype(np.int16)
        vw.write(cv2.cvtColor(np.clip(frame, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR))
        truth.append([round(t, 6), round(yaw, 4), round(pitch, 4)])
    vw.release()
    return {
        "file": path.name,
        "fps": FPS,
        "frames": n,
        "size": [W, H],
        "calibration_s": 2.0,
        "convention": "yaw > 0: presenter turns to their own left (nose to image right); "
        "pitch > 0: head up; degrees, relative to facing the camera",
        "depth_scale": depth_scale,
        "holds": holds,
        "frames_truth": truth,
    }


def gesture_bursts() -> list[tuple[float, float, float]]:
    """The known bursts ``(start, end, swing_hz)``: 10 in 36 s, irregular gaps and lengths."""
    return [
        (2.0, 3.2, 2.0), (5.0, 6.0, 1.6), (8.5, 10.5, 2.4), (12.0, 12.9, 2.0),
        (15.5, 17.0, 1.8), (19.0, 20.5, 2.2), (22.5, 23.4, 2.0), (25.5, 27.5, 1.6),
        (29.5, 30.5, 2.4), (32.5, 34.0, 2.0),
    ]  # fmt: skip


def make_gesture_video(path: Path, *, seed: int) -> dict:
    """Write the gesture video; return its manifest entry."""
    from skimage import data

    rng = np.random.default_rng(seed)
    bg = cv2.resize(
        np.ascontiguousarray(data.astronaut()[:, :, :3]), (W, H), interpolation=cv2.INTER_AREA
    )
    bursts = gesture_bursts()
    dur = 36.0
    n = int(round(dur * FPS))
    rest = np.array([250.0, 205.0])  # the hand at rest, beside the body
    vw = _writer(path)
    for i in range(n):
        t = i / FPS
        pos = rest.copy()
        for start, end, hz in bursts:
            if start <= t < end:
                ph = 2 * math.pi * hz * (t - start)
                pos = rest + np.array([-45.0 * math.sin(ph), -30.0 * abs(math.sin(ph))])
        flicker = 1.0 + 0.01 * math.sin(2 * math.pi * 0.3 * t)
        frame = bg.astype(np.float32) * flicker
        cv2.ellipse(
            frame,
            (int(pos[0]), int(pos[1])),
            (13, 17),
            15.0,
            0,
            360,
            (224, 172, 140),
            -1,
            cv2.LINE_AA,
        )
        frame += rng.normal(0.0, 2.0, frame.shape)
        vw.write(cv2.cvtColor(np.clip(frame, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR))
    vw.release()
    return {
        "file": path.name,
        "fps": FPS,
        "frames": n,
        "size": [W, H],
        "duration_s": dur,
        "bursts": [{"start": s, "end": e, "swing_hz": hz} for s, e, hz in bursts],
        "gestures_per_min": len(bursts) / dur * 60.0,
    }


def main(argv: list[str] | None = None) -> int:
    """Write both videos and ``manifest.json``."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=OUT_DIR)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--depth-scale", type=float, default=1.0, help="stretch the mesh's depth")
    ap.add_argument("--only", choices=("head", "gestures"), default=None)
    args = ap.parse_args(argv)
    manifest_path = args.out / "manifest.json"
    manifest = json.loads(manifest_path.read_text()) if manifest_path.exists() else {}
    manifest["tool"] = "tools/make_test_video.py"
    manifest["seed"] = args.seed
    if args.only in (None, "head"):
        name = (
            "head_pose.mp4"
            if args.depth_scale == 1.0
            else f"head_pose_depth{args.depth_scale:g}.mp4"
        )
        entry = make_head_video(args.out / name, seed=args.seed, depth_scale=args.depth_scale)
        manifest[name.removesuffix(".mp4")] = entry
    if args.only in (None, "gestures"):
        manifest["gestures"] = make_gesture_video(args.out / "gestures.mp4", seed=args.seed + 1)
    args.out.mkdir(parents=True, exist_ok=True)
    manifest_path.write_text(json.dumps(manifest, indent=1) + "\n")
    for f in sorted(args.out.glob("*.mp4")):
        print(f"{f}: {f.stat().st_size / 1e6:.2f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
