"""Gesture renders: the video suffix is checked before rendering; MP4, GIF and AVI are written."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

pytest.importorskip("pybullet")
cv2 = pytest.importorskip("cv2")

import sim.render as render  # noqa: E402
from prezence.errors import BackendUnavailable, ConfigError  # noqa: E402


def _frames(n: int = 6) -> list[np.ndarray]:
    out = []
    for k in range(n):
        img = np.full((48, 64, 3), 255, dtype=np.uint8)
        img[:, 8 * k : 8 * k + 8] = (200, 40, 20)  # a bar that moves: no two frames alike
        out.append(img)
    return out


def test_an_unsupported_suffix_fails_before_anything_is_rendered(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def no_sim(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("rendering started")

    monkeypatch.setattr(render, "NaoSim", no_sim)
    with pytest.raises(ConfigError, match=r"x\.mov: .*'\.mov'.*\.mp4, \.gif, \.avi"):
        render.render_gesture("encourage", tmp_path / "x.png", tmp_path / "x.mov")
    with pytest.raises(ConfigError, match="without a suffix"):
        render.render_gesture("encourage", tmp_path / "x.png", tmp_path / "x")
    assert not (tmp_path / "x.png").exists()


def test_gif_is_an_animation_with_every_frame(tmp_path: Path) -> None:
    from PIL import Image

    out = tmp_path / "sub" / "clip.GIF"
    assert render.write_video(out, _frames(), fps=25) == "gif"
    with Image.open(out) as im:
        assert im.n_frames == 6
        assert im.info["duration"] == 40 and im.info["loop"] == 0


def test_gif_without_pillow_says_what_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "PIL", None)
    monkeypatch.setitem(sys.modules, "PIL.Image", None)
    with pytest.raises(BackendUnavailable, match="GIF needs Pillow"):
        render.check_video_path(tmp_path / "clip.gif")


@pytest.mark.parametrize("suffix", [".mp4", ".avi"])
def test_opencv_videos_hold_every_frame(tmp_path: Path, suffix: str) -> None:
    out = tmp_path / f"clip{suffix}"
    codec = render.write_video(out, _frames(), fps=25)
    assert codec in render.VIDEO_CODECS[suffix]
    cap = cv2.VideoCapture(str(out))
    try:
        assert int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) == 6
    finally:
        cap.release()


class _Unopened:
    """What cv2.VideoWriter gives for a codec it cannot open."""

    def isOpened(self) -> bool:  # noqa: N802 (OpenCV's name)
        return False

    def release(self) -> None:
        pass


def test_mp4_prefers_h264_and_falls_back(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    asked: list[str] = []
    real = cv2.VideoWriter

    def writer(path: str, fourcc: int, fps: float, size: tuple[int, int]) -> Any:
        name = "".join(chr((fourcc >> 8 * i) & 0xFF) for i in range(4))
        asked.append(name)
        if name == "avc1":  # as in an OpenCV build without an H.264 encoder
            return _Unopened()
        return real(path, fourcc, fps, size)

    monkeypatch.setattr(cv2, "VideoWriter", writer)
    assert render.write_video(tmp_path / "clip.mp4", _frames(), fps=25) == "mp4v"
    assert asked == ["avc1", "mp4v"]


def test_render_writes_a_sheet_and_a_gif(tmp_path: Path) -> None:
    result = render.render_gesture(
        "encourage", tmp_path / "e.png", tmp_path / "e.gif", fps=10, size=(96, 96)
    )
    assert result["video_codec"] == "gif"
    assert (tmp_path / "e.png").stat().st_size > 0
    assert result["video_frames"] >= 10 * result["planned_s"]


def test_render_plays_a_gesture_of_a_library_of_your_own(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from prezence.cli import main

    mine = tmp_path / "mine.toml"
    mine.write_text(
        "format = 1\n[gestures.wave]\n[[gestures.wave.keyframes]]\n"
        "pose = { RShoulderPitch = -40.0, RHand = 1.0 }\nhold = 0.2\n"
    )
    out = tmp_path / "w.png"
    argv = ["gestures", "render", "wave", "--out", str(out), "--video", str(tmp_path / "w.gif")]
    assert main([*argv, "--library", str(mine)]) == 0
    assert out.stat().st_size > 0 and (tmp_path / "w.gif").stat().st_size > 0
    assert main(argv) == 2  # the built-in library has no 'wave'
    assert "unknown gesture 'wave'" in capsys.readouterr().err


def test_a_contact_sheet_opencv_cannot_write_fails_before_rendering_with_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from prezence.cli import main

    def no_sim(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("rendering started")

    monkeypatch.setattr(render, "NaoSim", no_sim)
    for out, said in (("sheet", "as a file without a suffix"), ("sheet.txt", "as '.txt'")):
        assert main(["gestures", "render", "look_up", "--out", str(tmp_path / out)]) == 2
        err = capsys.readouterr().err
        assert f"error: {tmp_path / out}: cannot write the contact sheet {said}" in err
        assert "use .png or .jpg" in err
    assert not list(tmp_path.iterdir())


def test_a_parameter_out_of_range_is_rendered_and_titled_as_played(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    titles: list[str] = []
    sheet = render.contact_sheet

    def spy(images: Any, labels: Any, title: str) -> Any:
        titles.append(title)
        return sheet(images, labels, title)

    monkeypatch.setattr(render, "contact_sheet", spy)
    with caplog.at_level("WARNING", logger="sim.render"):
        result = render.render_gesture(
            "time_left", tmp_path / "t.png", None, params={"minutes": 20}, size=(64, 64)
        )
    assert "minutes = 20 is outside 1..5: rendered at 5" in caplog.text
    assert titles == [
        f"time_left {{'minutes': 5}}: {result['planned_s']:.2f} s planned at 60% speed"
    ]


CLASP = """format = 1
[gestures.articulate]
description = "Hands clasped in front."
[[gestures.articulate.keyframes]]
pose = { LShoulderPitch = -5.0, LShoulderRoll = -10.0, LElbowYaw = -40.0, LElbowRoll = -82.0, \
RShoulderPitch = -5.0, RShoulderRoll = 10.0, RElbowYaw = 40.0, RElbowRoll = 82.0 }
hold = 0.3
"""
#: two 4 s holds and back: 12 s at the default speed, more than a talk allows
LONG = (
    'format = 1\n[gestures.summary]\ndescription = "long"\n'
    "[[gestures.summary.keyframes]]\npose = { HeadPitch = 15.0 }\nhold = 5\n"
    "[[gestures.summary.keyframes]]\npose = { HeadPitch = -5.0 }\nhold = 5\n"
)


@pytest.mark.parametrize(
    ("text", "name", "says"),
    [
        (CLASP, "articulate", "self-collision: "),
        (LONG, "summary", "takes "),
    ],
    ids=["self-collision", "too-long"],
)
def test_render_says_when_the_gesture_it_draws_fails_the_check(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, name: str, says: str
) -> None:
    # session 23's walkthrough: the contact sheet showed forearms passing through each other
    # (and a 13.8 s gesture) without a word, while a position-limit error was refused
    from prezence.cli import main

    mine = tmp_path / "mine.toml"
    mine.write_text(text)
    out = tmp_path / "g.png"
    argv = ["gestures", "render", name, "--out", str(out), "--video", str(tmp_path / "g.gif")]
    assert main([*argv, "--library", str(mine)]) == 0
    assert out.stat().st_size > 0  # drawn as planned
    err = capsys.readouterr().err
    assert (
        f"warning: {mine}:2: gesture '{name}' fails `prezence gestures check {mine}`: {says}"
        in (err)
    ), err
    assert "a talk refuses it" in err
    assert main(argv) == 0  # a built-in gesture passes: no word
    assert "fails `prezence gestures check" not in capsys.readouterr().err
