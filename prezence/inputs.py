"""Pre-flight checks of a live talk's inputs: ``prezence up`` fails in a second, not mid-talk.

Everything ``up`` is told to listen to, and the robot it is told to use, is looked at before a
session folder is made or a module started: the module that reads each input can be imported
(its extra is installed); files exist, are regular, non-empty files, and the module's own
reader opens them (the checks ``prezence rehearse`` meets when its modules start: an audio
track that decodes, a video with frames); a microphone or camera is there; the robot's address
is well formed, and something answers on its port. Each problem is one :class:`InputError`
line that names the option and says what to do.
"""

from __future__ import annotations

import importlib
import os
import socket
import stat
import sys
from pathlib import Path
from urllib.parse import urlsplit

from prezence.errors import PrezenceError

#: NAOqi's port when an address gives none.
NAOQI_PORT = 9559
#: How long a TCP connection to the robot may take in the pre-flight check, seconds.
ROBOT_CONNECT_TIMEOUT_S = 3.0


class InputError(PrezenceError, ValueError):
    """An input of ``up`` cannot be used; the message names the option and what to do."""


def check_media_file(option: str, value: str) -> Path:
    """``value`` is an existing, readable, non-empty regular file (not a FIFO or a device).

    Raises:
        InputError: it is not (``--audio nothere.wav: no such file``).
    """
    path = Path(value)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        raise InputError(f"{option} {value}: no such file") from None
    except OSError as e:
        raise InputError(f"{option} {value}: cannot be read ({e.strerror or e})") from None
    if stat.S_ISDIR(st.st_mode):
        raise InputError(f"{option} {value}: is a folder; give a media file")
    if not stat.S_ISREG(st.st_mode):
        raise InputError(f"{option} {value}: not a regular file (a FIFO or a device?)")
    if st.st_size == 0:
        raise InputError(f"{option} {value}: the file is empty")
    if not os.access(path, os.R_OK):
        raise InputError(f"{option} {value}: no permission to read it")
    return path


#: Per input module, the libraries it cannot start without, with what each is, and the extra
#: that installs them.
MODULE_NEEDS: dict[str, tuple[tuple[str, str], ...]] = {
    "speech": (("pocketsphinx", "pocketsphinx"), ("av", "PyAV")),
    "vision": (("cv2", "OpenCV"),),
}


def check_module_extra(option: str, value: str, module: str) -> None:
    """The libraries the ``module`` input module needs can be imported here.

    Raises:
        InputError: one is missing (``--video cam: the vision module needs OpenCV (cv2):
            pip install "prezence[vision]"``).
    """
    for name, what in MODULE_NEEDS[module]:
        try:
            importlib.import_module(name)
        except ImportError:
            lib = what if what == name else f"{what} ({name})"
            raise InputError(
                f"{option} {value}: the {module} module needs {lib}: "
                f'pip install "prezence[{module}]"'
            ) from None


def check_recording(option: str, value: str, module: str) -> Path:
    """``value`` is a media file the ``module`` input module can read: the module's own reader
    opens it and decodes its first audio block (speech) or video frame (vision).

    Raises:
        InputError: the module's extra is missing, or the file is not one it can read (the
            module's own message: ``--audio random.wav: random.wav: not an audio or video
            file the decoder can read (…)``).
    """
    path = check_media_file(option, value)
    check_module_extra(option, value, module)
    from prezence.modules.common import ModuleInputError

    try:
        if module == "speech":
            from prezence.modules.audio_io import decode_file

            blocks = decode_file(path)  # what the module's FileSource reads first
            try:
                next(blocks, None)
            finally:
                blocks.close()
        else:
            from prezence.modules.vision import open_video

            cap = open_video(path)
            try:
                ok, _ = cap.read()
            finally:
                cap.release()
            if not ok:
                raise ModuleInputError(path, "no video frame could be decoded (truncated?)")
    except ModuleInputError as e:
        raise InputError(f"{option} {value}: {e.reason}") from None
    return path


def check_microphone(device: str | None = None) -> None:
    """A capture device is there (PortAudio through ``sounddevice``).

    Raises:
        InputError: no input device, or the sound library is missing.
    """
    try:
        import sounddevice as sd
    except (ImportError, OSError) as e:
        raise InputError(
            f"--audio mic: the sound library cannot be loaded ({e}); install "
            "prezence[speech] and the PortAudio library (libportaudio2)"
        ) from None
    try:
        dev = sd.query_devices(device, kind="input") if device else sd.query_devices(kind="input")
    except Exception as e:  # PortAudio errors are plain Exceptions
        raise InputError(
            f"--audio mic: no microphone found ({str(e).strip() or type(e).__name__}); plug "
            "one in, or give an audio file"
        ) from None
    if not dev or int(dev.get("max_input_channels", 0)) < 1:
        raise InputError("--audio mic: no microphone found; plug one in, or give an audio file")


def check_camera(value: str) -> None:
    """``cam`` or ``cam:N``: ``/dev/videoN`` is there (on Linux; elsewhere not checked)."""
    _, _, idx = value.partition(":")
    if idx and not idx.isdigit():
        raise InputError(f"--video {value}: want cam or cam:N (N a camera number)")
    n = int(idx or 0)
    if sys.platform.startswith("linux") and not Path(f"/dev/video{n}").exists():
        raise InputError(f"--video {value}: no camera /dev/video{n}; plug one in or give a file")


def robot_address(url: str) -> tuple[str, int]:
    """``(host, port)`` of ``tcp://HOST:PORT``, ``HOST:PORT`` or ``HOST``.

    Raises:
        InputError: not such an address.
    """
    text = url.strip()
    parts = urlsplit(text if "://" in text else f"tcp://{text}")
    if parts.scheme not in ("tcp", "tcps") or not parts.hostname:
        raise InputError(f"--robot {url}: want a NAOqi address like tcp://HOST:9559")
    try:
        port = parts.port or NAOQI_PORT
    except ValueError:
        raise InputError(f"--robot {url}: the port is not a number from 1 to 65535") from None
    return parts.hostname, port


def check_robot(url: str, *, timeout_s: float = ROBOT_CONNECT_TIMEOUT_S) -> None:
    """Something accepts a TCP connection at the robot's address within ``timeout_s``.

    A port that accepts but never speaks NAOqi is caught later, by the backend's own connect
    timeout, still before the talk starts.

    Raises:
        InputError: bad address, unknown host, refused, or no answer in time.
    """
    host, port = robot_address(url)
    try:
        with socket.create_connection((host, port), timeout=timeout_s):
            pass
    except socket.gaierror:
        raise InputError(f"--robot {url}: unknown host {host}") from None
    except TimeoutError:
        raise InputError(
            f"--robot {url}: no answer from {host}:{port} within {timeout_s:g} s (robot off, "
            "wrong address, or a firewall?)"
        ) from None
    except ConnectionRefusedError:
        raise InputError(
            f"--robot {url}: nothing listens on {host}:{port} (is NAOqi running? the virtual "
            "NAO: prezence sim serve)"
        ) from None
    except OSError as e:
        raise InputError(f"--robot {url}: cannot reach {host}:{port} ({e.strerror or e})") from None


def check_up_inputs(
    *,
    audio: str | None,
    video: str | None,
    backend: str,
    robot: str | None,
    device: str | None = None,
) -> None:
    """Every check above that applies to ``prezence up``'s options; the first problem raised.

    Raises:
        InputError: a file, device or robot cannot be used, or ``--robot`` is given without
            ``--backend naoqi`` (it would be ignored).
    """
    if robot and backend != "naoqi":
        raise InputError(
            f"--robot is only used with --backend naoqi (the backend is {backend}); add "
            "--backend naoqi, or leave --robot out"
        )
    if backend == "naoqi" and not robot:
        raise InputError("--backend naoqi needs --robot tcp://HOST:9559")
    if audio is not None:
        if audio == "mic":
            check_module_extra("--audio", audio, "speech")
            check_microphone(device)
        else:
            check_recording("--audio", audio, "speech")
    if video is not None:
        if video.startswith("cam"):
            check_module_extra("--video", video, "vision")
            check_camera(video)
        else:
            check_recording("--video", video, "vision")
    if robot and backend == "naoqi":
        check_robot(robot)
