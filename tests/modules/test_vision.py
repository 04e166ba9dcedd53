"""The vision module: the frame-difference gesture fallback, calibration, bad input.

The videos and their truth (``material_video/manifest.json``) come from
``tools/make_test_video.py``. These tests run in any env (OpenCV only); gestures from the body
are in ``test_vision_body.py``, head pose against rendered faces in ``test_vision_headpose.py``
(both need the vision env).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from prezence.modules.common import CUT_SHORT_STATUS
from prezence.modules.vision import (
    FileSource,
    GazeTracker,
    GestureDetector,
    HeadPose,
    HeadPoseEstimator,
    VisionInputError,
    VisionOptions,
    VisionUnavailable,
    mediapipe_available,
    run,
)

MATERIAL = Path(__file__).parent / "material_video"
MANIFEST: dict[str, Any] = json.loads((MATERIAL / "manifest.json").read_text())
GEST = MANIFEST["gestures"]
TOLERANCE_DEG = 5.0
MATCH_S = 0.5  # a detected burst start within this of a true start is a hit


def read_stream(path: Path) -> list[tuple[float, float]]:
    out = []
    for line in path.read_text().splitlines():
        t, v = line.split()
        out.append((float(t), float(v)))
    return out


def run_module(python: str | Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ)
    env.pop("PREZENCE_VISION_REEXEC", None)
    return subprocess.run(
        [str(python), "-m", "prezence.modules.vision", *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
        env=env,
    )


# --------------------------------------------------------------------------------------------
# Gestures (OpenCV only)


@pytest.fixture(scope="module")
def gesture_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, Path]:
    out = tmp_path_factory.mktemp("gestures")
    source = FileSource(MATERIAL / GEST["file"])
    try:
        summary = run(source, out, VisionOptions(head=False, fps=0, gesture_source="motion"))
    finally:
        source.close()
    return summary, out


def test_gesture_bursts_found_with_90_percent_recall(gesture_run: tuple[Any, Path]) -> None:
    summary, _ = gesture_run
    truth = [b["start"] for b in GEST["bursts"]]
    hits = [t for t in truth if any(abs(d - t) <= MATCH_S for d in summary.bursts)]
    assert len(hits) / len(truth) >= 0.9, (truth, summary.bursts)


def test_gesture_detector_finds_no_extra_bursts(gesture_run: tuple[Any, Path]) -> None:
    summary, _ = gesture_run
    truth = [b["start"] for b in GEST["bursts"]]
    false = [d for d in summary.bursts if all(abs(d - t) > MATCH_S for t in truth)]
    assert len(false) <= 1, (truth, summary.bursts)


def test_gesture_rate_stream_matches_the_true_rate(gesture_run: tuple[Any, Path]) -> None:
    summary, out = gesture_run
    rates = read_stream(out / "streams" / "cv_gestures_motion.txt")
    t_end, rate = rates[-1]
    window = VisionOptions().gesture_window_s
    n_true = sum(1 for b in GEST["bursts"] if t_end - window < b["start"] <= t_end)
    assert rate == pytest.approx(n_true / window * 60.0, abs=2.1)  # one burst in 30 s is 2/min


def test_gesture_rate_is_one_sample_per_second_from_10_s(gesture_run: tuple[Any, Path]) -> None:
    _, out = gesture_run
    times = [t for t, _ in read_stream(out / "streams" / "cv_gestures_motion.txt")]
    assert times == [float(i) for i in range(10, int(GEST["duration_s"]))]


def test_gesture_detector_counts_a_single_noise_spike_as_no_burst() -> None:
    import numpy as np

    det = GestureDetector()
    still = np.full((120, 160, 3), 100, np.uint8)
    spike = still.copy()
    spike[40:80, 40:80] = 220
    frames = [still] * 30 + [spike] + [still] * 30
    for i, f in enumerate(frames):
        det.update(i / 15.0, f)
    assert det.bursts == []


def test_gesture_rate_counts_only_the_window() -> None:
    det = GestureDetector(window_s=30.0, min_window_s=10.0)
    det.first_t = 0.0
    det.bursts = [1.0, 5.0, 40.0, 50.0]
    assert det.rate(60.0) == pytest.approx(2 / 30 * 60)
    assert det.rate(10.0) == pytest.approx(2 / 10 * 60)  # early: over the 10 s seen
    assert det.rate(20.0) == pytest.approx(2 / 20 * 60)


def test_a_calm_start_gives_no_gesture_rate_until_10_s_of_video() -> None:
    # Not "0 gestures per minute" at 1 s, which would make `gestureMore` fire at once.
    import numpy as np

    det = GestureDetector(window_s=30.0, min_window_s=10.0)
    still = np.full((120, 160, 3), 100, np.uint8)
    rates = {}
    for i in range(12 * 5):
        t = i / 5.0
        det.update(t, still)
        rates[t] = det.rate(t)
    assert all(r is None for t, r in rates.items() if t < 10.0)
    assert rates[10.0] == 0.0 and rates[11.8] == 0.0


def test_a_module_started_late_waits_for_its_own_10_s() -> None:
    # A camera module restarted at t = 100 s has seen none of the talk before it.
    det = GestureDetector(window_s=30.0, min_window_s=10.0)
    det.first_t = 100.0
    det.bursts = [103.0, 107.0, 125.0]
    assert det.rate(105.0) is None
    assert det.rate(110.0) == pytest.approx(2 / 10 * 60)
    assert det.rate(140.0) == pytest.approx(1 / 30 * 60)


def test_a_gesture_window_shorter_than_10_s_is_used_as_is(tmp_path: Path) -> None:
    source = FileSource(MATERIAL / GEST["file"])
    try:
        opts = VisionOptions(
            head=False, fps=0, gesture_window_s=5.0, duration_s=8.0, gesture_source="motion"
        )
        run(source, tmp_path, opts)
    finally:
        source.close()
    times = [t for t, _ in read_stream(tmp_path / "streams" / "cv_gestures_motion.txt")]
    assert times == [5.0, 6.0, 7.0, 8.0]


def test_run_touches_the_launchers_heartbeat_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    beat = tmp_path / ".vision.alive"
    monkeypatch.setenv("PREZENCE_HEARTBEAT", str(beat))
    source = FileSource(MATERIAL / GEST["file"])
    try:
        run(
            source,
            tmp_path / "s",
            VisionOptions(head=False, fps=0, duration_s=2.0, gesture_source="motion"),
        )
    finally:
        source.close()
    assert beat.exists()


# --------------------------------------------------------------------------------------------
# Calibration and facing (pure)


def pose(yaw: float, pitch: float) -> HeadPose:
    return HeadPose(yaw, pitch, (0, 0, 10, 10))


def test_calibration_uses_the_median_of_the_first_seconds_and_releases_them() -> None:
    g = GazeTracker(calibrate_s=1.0)
    got = []
    for i, (y, p) in enumerate([(10, -5), (12, -6), (11, -4), (50, 50), (11, -20)]):
        got += g.update(i * 0.4, pose(y, p))
    # Frames at 0, 0.4, 0.8 and 1.2 s calibrate (median 11.5, -4.5); all come out relative.
    assert g.offset == (11.5, -4.5)
    assert [round(v, 2) for _, _, v in got] == [-0.5, -1.5, 0.5, 54.5, -15.5]


def test_configured_audience_direction_skips_calibration() -> None:
    g = GazeTracker(calibrate_s=3.0, audience=(5.0, -10.0))
    assert g.update(0.0, pose(5.0, -25.0)) == [(0.0, 0.0, -15.0)]


def test_facing_fraction_counts_frames_without_a_face_as_away() -> None:
    g = GazeTracker(calibrate_s=0.0, facing_window_s=5.0, tolerance=(20.0, 15.0))
    for i, p in enumerate([pose(0, 0), None, pose(30, 0), pose(0, -20), pose(5, 5)]):
        g.update(float(i), p)
    assert g.facing(4.0) == pytest.approx(2 / 5)


# --------------------------------------------------------------------------------------------
# Head pose without mediapipe (main env)


@pytest.mark.skipif(mediapipe_available(), reason="mediapipe is importable in this python")
def test_forcing_body_gestures_without_mediapipe_fails_naming_the_install_command(
    tmp_path: Path,
) -> None:
    source = FileSource(MATERIAL / GEST["file"])
    try:
        with pytest.raises(VisionUnavailable, match="vision_env install"):
            run(source, tmp_path, VisionOptions(head=False, gesture_source="body"))
    finally:
        source.close()


@pytest.mark.skipif(mediapipe_available(), reason="mediapipe is importable in this python")
def test_head_pose_without_mediapipe_names_the_install_command() -> None:
    with pytest.raises(VisionUnavailable, match="python -m prezence.modules.vision_env install"):
        HeadPoseEstimator()


@pytest.mark.skipif(mediapipe_available(), reason="mediapipe is importable in this python")
def test_cli_without_mediapipe_still_writes_the_gesture_rate(tmp_path: Path) -> None:
    proc = run_module(
        sys.executable,
        *("--video", str(MATERIAL / GEST["file"]), "--out", str(tmp_path)),
        *("--no-reexec", "--duration", "12"),
    )
    assert proc.returncode == 0, proc.stderr
    assert "python -m prezence.modules.vision_env install" in proc.stderr
    assert "gesture rate from the frame difference (fallback" in proc.stderr
    times = [t for t, _ in read_stream(tmp_path / "streams" / "cv_gestures_motion.txt")]
    assert times == [10.0, 11.0, 12.0]  # none before 10 s of video
    source = read_stream(tmp_path / "streams" / "cv_gestures_source.txt")
    assert source == [(10.0, 2.0), (11.0, 2.0), (12.0, 2.0)]  # 2: frame difference
    assert read_stream(tmp_path / "streams" / "cv_headGaze.txt") == []
    # the session folder says why head pose is missing and where the gesture rate came from,
    # so the report does not take the empty head streams for a camera that saw no face
    status = json.loads((tmp_path / "vision.json").read_text())
    assert status["gesture_source"] == "motion"
    assert set(status["off"]) == {"cv_headGaze", "cv_headYaw", "cv_facingAudience", "cv_gestures"}
    assert all("vision_env install" in why for why in status["off"].values())
    # session 23: the fallback's rate is its own metric, which no default rule judges (it was
    # written as cv_gestures and cued "use your hands more" on a video with no one in it)
    assert read_stream(tmp_path / "streams" / "cv_gestures.txt") == []
    assert "cv_gestures_motion, too unreliable to advise on" in status["off"]["cv_gestures"]


def test_cli_no_head_records_that_head_pose_was_turned_off(tmp_path: Path) -> None:
    proc = run_module(
        sys.executable,
        *("--video", str(MATERIAL / GEST["file"]), "--out", str(tmp_path)),
        *("--no-reexec", "--duration", "11", "--no-head", "--gesture-source", "motion"),
    )
    assert proc.returncode == 0, proc.stderr
    status = json.loads((tmp_path / "vision.json").read_text())
    assert status == {
        "format": 1,
        "off": {
            **dict.fromkeys(
                ("cv_headGaze", "cv_headYaw", "cv_facingAudience"),
                "head pose was turned off (--no-head)",
            ),
            "cv_gestures": "--gesture-source motion was asked for; the frame-difference "
            "fallback's rate is in cv_gestures_motion, too unreliable to advise on (it misses "
            "most gestures, counts other motion, and cannot tell no one in view from no "
            "gestures)",
        },
        "gesture_source": "motion",
    }


# --------------------------------------------------------------------------------------------
# Bad input


@pytest.fixture
def bad_files(tmp_path: Path) -> dict[str, Path]:
    empty = tmp_path / "empty.mp4"
    empty.write_bytes(b"")
    text = tmp_path / "notes.mp4"
    text.write_text("not a video at all\n" * 100)
    truncated = tmp_path / "truncated.mp4"
    data = (MATERIAL / GEST["file"]).read_bytes()
    truncated.write_bytes(data[: len(data) // 2])
    return {"empty": empty, "text": text, "truncated": truncated, "missing": tmp_path / "no.mp4"}


@pytest.mark.parametrize("kind", ["empty", "text", "truncated", "missing"])
def test_bad_video_raises_naming_the_file(bad_files: dict[str, Path], kind: str) -> None:
    path = bad_files[kind]
    with pytest.raises(VisionInputError, match=str(path)):
        FileSource(path)


def test_cli_bad_video_exits_2_naming_the_file(bad_files: dict[str, Path], tmp_path: Path) -> None:
    path = bad_files["truncated"]
    proc = run_module(sys.executable, "--video", str(path), "--out", str(tmp_path), "--no-head")
    assert proc.returncode == 2
    assert f"error: {path}:" in proc.stderr


def _faststart_copy(src: Path, dst: Path) -> None:
    """``src`` remuxed with its index first (as phones and ffmpeg's +faststart write it), so
    that a copy cut short still opens."""
    import av

    with av.open(str(src)) as i, av.open(str(dst), "w", options={"movflags": "+faststart"}) as o:
        stream = o.add_stream_from_template(i.streams.video[0])
        for packet in i.demux(i.streams.video[0]):
            if packet.dts is None:
                continue
            packet.stream = stream
            o.mux(packet)


def test_a_video_that_breaks_off_is_measured_up_to_there_and_says_so(tmp_path: Path) -> None:
    # A phone that died mid-talk: the video opens and ends early. The module measured what it
    # read but said "error: ..." and exited 2, so `up` stopped the talk as a bad input and
    # `rehearse` reported the vision metrics "not measured: the vision module could not run".
    pytest.importorskip("av", reason="the copy is remuxed with PyAV (the speech extra)")
    whole = tmp_path / "whole.mp4"
    _faststart_copy(MATERIAL / GEST["file"], whole)
    cut = tmp_path / "cut.mp4"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    out = tmp_path / "s"
    args = ["--video", str(cut), "--out", str(out), "--no-head", "--gesture-source", "motion"]
    proc = run_module(sys.executable, *args, "--no-reexec")
    assert proc.returncode == CUT_SHORT_STATUS, proc.stderr
    assert f"warning: {cut}: the video ended after " in proc.stderr
    assert "the streams hold what was read" in proc.stderr and "error:" not in proc.stderr
    rates = read_stream(out / "streams" / "cv_gestures_motion.txt")
    assert rates and 0.3 * GEST["duration_s"] < rates[-1][0] < 0.7 * GEST["duration_s"]


class _FakeCapture:
    """A camera that has delivered ``n`` frames before the analysis asks for one."""

    def __init__(self, n: int) -> None:
        self.left = n

    def isOpened(self) -> bool:  # noqa: N802 - cv2's name
        return True

    def get(self, prop: int) -> float:
        return 30.0

    def read(self) -> tuple[bool, Any]:
        import numpy as np

        if self.left == 0:
            return False, None
        self.left -= 1
        return True, np.zeros((24, 32, 3), np.uint8)

    def release(self) -> None:
        pass


def test_live_frames_the_analysis_missed_are_counted_and_reported(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    from prezence.modules.vision import CameraSource

    cam = CameraSource(0, t0=0.0, capture=_FakeCapture(12))
    cam._thread.join()  # the camera ran ahead: all 12 frames arrived before the first analysis
    with caplog.at_level("WARNING"):
        summary = run(cam, tmp_path, VisionOptions(head=False, fps=0, gesture_source="motion"))
    cam.close()
    assert summary.analysed == 1
    assert cam.stats.not_analysed == 11
    assert "11 of 12 frames were not analysed" in caplog.text


def test_a_variable_frame_rate_video_keeps_its_own_frame_times() -> None:
    # Session 17: a webcam that stalls (or a phone) records a variable frame rate. The times
    # were frame index / the container's average rate, so every frame after a stall came too
    # early against the sound (4.6 s mid-talk on a 48 s video with a 6 s stall).
    # stall_vfr.mp4: 6 s of testsrc at 15 fps with the frames of 2..4 s dropped, their times kept:
    #   ffmpeg -f lavfi -i testsrc=size=64x48:rate=15:duration=6 \
    #       -vf "select='not(between(t,2,4))'" -fps_mode passthrough -c:v libx264 \
    #       -pix_fmt yuv420p -g 15 stall_vfr.mp4
    source = FileSource(MATERIAL / "stall_vfr.mp4")
    try:
        ts = [t for t, _ in source.frames()]
    finally:
        source.close()
    want = [i / 15.0 for i in range(90) if not 2.0 <= i / 15.0 <= 4.0]
    assert len(ts) == len(want)
    assert ts == pytest.approx(want, abs=1e-3)


def test_a_sound_only_mp4_is_named_as_such_not_as_a_broken_video() -> None:
    # Session 17: a voice memo saved as .mp4 (sound only) was reported as "cannot be read as
    # a video (wrong format, or a truncated file)", in vision.log and in the report, for a
    # good file. sound_only.mp4: ffmpeg -f lavfi -i "sine=frequency=220:duration=1" -c:a aac
    path = MATERIAL / "sound_only.mp4"
    with pytest.raises(VisionInputError, match="no video stream") as e:
        FileSource(path)
    assert str(path) in str(e.value)


def test_a_face_found_late_is_calibrated_on_seconds_of_it_not_its_first_three_frames() -> None:
    # Session 17: in a portrait video FaceMesh found no face for 9.5 s; the first three faces
    # then, mid head turn at -28 deg, became the audience direction, and every later yaw read
    # 28 deg off (facing 0). Now the median of calibrate_s seconds from the first face is used.
    g = GazeTracker(calibrate_s=3.0)
    fps = 8.0
    out = []
    for i in range(int(20 * fps)):
        t = i / fps
        if t < 9.5:
            pose = None
        elif t < 10.0:
            pose = HeadPose(-28.0, -12.0, (0, 0, 1, 1))  # turning, as the face is first found
        else:
            pose = HeadPose(1.0, 2.0, (0, 0, 1, 1))  # then facing the audience
        out += g.update(t, pose)
    assert g.offset == pytest.approx((1.0, 2.0))
    later = [(y, p) for t, y, p in out if t >= 10.0]
    assert later and all(y == pytest.approx(0.0) and p == pytest.approx(0.0) for y, p in later)


def test_mirrored_reaches_the_module_from_rehearse_and_up() -> None:
    # `prezence rehearse talk.mp4 --vision-args "--mirrored"` and `prezence up ... --vision-args`
    # both check the words with the module's parser and append them to its command line.
    from prezence.modules.vision import build_parser
    from prezence.rehearse import module_args, module_commands

    words = module_args("--vision-args", "vision", "--mirrored")
    assert words == ["--mirrored"]
    cmds = module_commands(Path("talk.mp4"), Path("s"), extra={"vision": words})
    assert cmds["vision"][-1] == "--mirrored"
    assert build_parser().parse_args(["--video", "x.mp4", "--out", "s", "--mirrored"]).mirrored
    assert not build_parser().parse_args(["--video", "x.mp4", "--out", "s"]).mirrored
