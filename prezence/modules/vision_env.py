"""The vision module's own virtual environment: create it, find it, check it.

Head pose needs ``mediapipe==0.10.21``, the newest release whose wheel ships the FaceMesh and
Pose models (later ones fetch models at run time and cannot work offline). It needs
``numpy<2`` and ``opencv-python-headless<5``, which conflict with the main install (numpy 2,
OpenCV 5), so the vision module runs as a separate process in a venv of its own::

    python -m prezence.modules.vision_env install            # ~/.cache/prezence/vision-venv
    python -m prezence.modules.vision_env install --path DIR
    python -m prezence.modules.vision_env where              # print its python, exit 1 if absent
    python -m prezence.modules.vision_env check              # import mediapipe there

The venv holds a minimal, measured set (412 MB, no jax): ``mediapipe==0.10.21`` installed
``--no-deps``, then ``numpy<2``, ``opencv-python-headless<5``, ``protobuf>=4.25.3,<5``,
``absl-py``, ``attrs``, ``flatbuffers``, ``matplotlib``; and this checkout's ``prezence`` with
``--no-deps`` (editable when installed from a source tree), so that
``VENV/bin/python -m prezence.modules.vision`` runs there.

The location is, in order: an explicit path, ``$PREZENCE_VISION_VENV``, then
``~/.cache/prezence/vision-venv``.

This module imports only the standard library.
"""

from __future__ import annotations

import argparse
import logging
import os
import shutil
import subprocess
import sys
import venv
from collections.abc import Mapping
from pathlib import Path

log = logging.getLogger(__name__)

#: Environment variable that overrides the default venv location.
ENV_VAR = "PREZENCE_VISION_VENV"

#: Installed ``--no-deps``: its declared deps pull jax/jaxlib (330 MB), unused by ``solutions``.
MEDIAPIPE_PIN = "mediapipe==0.10.21"

#: The dependencies mediapipe's ``solutions`` API really needs (measured).
DEPENDENCIES = (
    "numpy<2",
    "opencv-python-headless<5",
    "protobuf>=4.25.3,<5",
    "absl-py",
    "attrs",
    "flatbuffers",
    "matplotlib",
)

#: Extra packages for ``tools/make_test_video.py`` (the test face photo ships in scikit-image).
TOOL_DEPENDENCIES = ("scikit-image",)

#: Written last by :func:`install`; its presence means the install finished.
MARKER = "prezence-vision-env.txt"

INSTALL_HINT = "python -m prezence.modules.vision_env install"


def default_path() -> Path:
    """Return the venv location: ``$PREZENCE_VISION_VENV`` or ``~/.cache/prezence/vision-venv``."""
    env = os.environ.get(ENV_VAR)
    if env:
        return Path(env).expanduser()
    return Path.home() / ".cache" / "prezence" / "vision-venv"


def venv_python(path: Path | None = None) -> Path:
    """Return the python executable inside the venv at ``path`` (it may not exist)."""
    root = Path(path) if path is not None else default_path()
    if os.name == "nt":
        return root / "Scripts" / "python.exe"
    return root / "bin" / "python"


def find_python(path: Path | None = None) -> Path | None:
    """Return the vision venv's python if a finished install is there, else ``None``.

    Cheap: checks the files only. Use :func:`check` to import mediapipe for real.
    """
    root = Path(path) if path is not None else default_path()
    py = venv_python(root)
    if py.exists() and (root / MARKER).exists():
        return py
    return None


def check(path: Path | None = None, *, timeout_s: float = 120.0) -> tuple[bool, str]:
    """Import mediapipe's FaceMesh and Pose and this package's vision module in the venv.

    Returns:
        ``(ok, detail)``: ``detail`` is the versions on success, or why it failed.
    """
    py = find_python(path)
    if py is None:
        root = Path(path) if path is not None else default_path()
        return False, f"no vision env at {root}; create it with: {INSTALL_HINT}"
    code = (
        "import mediapipe as mp, numpy, cv2, prezence.modules.vision as v;"
        "mp.solutions.face_mesh.FaceMesh; mp.solutions.pose.Pose;"
        "print(mp.__version__, numpy.__version__, cv2.__version__)"
    )
    proc = subprocess.run(
        [str(py), "-c", code],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
        env=child_env(),
    )
    if proc.returncode != 0:
        tail = proc.stderr.strip().splitlines()[-1:] or ["(no output)"]
        return False, f"{py}: import failed: {tail[0]}"
    mp_v, np_v, cv_v = proc.stdout.split()
    return True, f"mediapipe {mp_v}, numpy {np_v}, opencv {cv_v} ({py})"


def child_env(env: Mapping[str, str] | None = None) -> dict[str, str]:
    """The environment for a process of the vision env that must run *this* prezence.

    The env's own install of prezence may be another checkout's (an editable install points
    at the tree it was made from, and the default env is shared by every clone): a source
    tree this prezence runs from goes first on ``PYTHONPATH``. An installed prezence is not
    put on the path (its site-packages would bring this environment's numpy along).
    """
    out = dict(os.environ if env is None else env)
    root = _source_root()
    if root is not None:
        rest = out.get("PYTHONPATH")
        out["PYTHONPATH"] = str(root) + (os.pathsep + rest if rest else "")
    return out


def _source_root() -> Path | None:
    """Return the source tree this ``prezence`` was imported from, if it is one."""
    root = Path(__file__).resolve().parents[2]
    if (root / "pyproject.toml").exists() and (root / "prezence" / "__init__.py").exists():
        return root
    return None


def _pip(py: Path, *args: str) -> None:
    cmd = [str(py), "-m", "pip", "install", "--disable-pip-version-check", *args]
    log.info("running %s", " ".join(cmd))
    subprocess.run(cmd, check=True)


def _site_packages(py: Path) -> Path:
    out = subprocess.run(
        [str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    )
    return Path(out.stdout.strip())


def install(path: Path | None = None, *, tools: bool = False, clear: bool = False) -> Path:
    """Create (or complete) the vision venv and return its python.

    Args:
        path: where to create it (default: :func:`default_path`).
        tools: also install what ``tools/make_test_video.py`` needs (scikit-image).
        clear: delete an existing venv at ``path`` first.

    Raises:
        RuntimeError: this python's version has no mediapipe 0.10.21 wheel.
        subprocess.CalledProcessError: a pip step failed (its output is on the terminal).
    """
    if not (3, 9) <= sys.version_info[:2] <= (3, 12):
        raise RuntimeError(
            f"{MEDIAPIPE_PIN} has wheels for CPython 3.9 to 3.12 only, not "
            f"{sys.version_info.major}.{sys.version_info.minor}; run this with such a python"
        )
    root = Path(path) if path is not None else default_path()
    if clear and root.exists():
        shutil.rmtree(root)
    marker = root / MARKER
    if marker.exists():
        marker.unlink()
    py = venv_python(root)
    if not py.exists():
        log.info("creating venv at %s", root)
        venv.EnvBuilder(with_pip=True, clear=False).create(root)
    _pip(py, "--no-deps", MEDIAPIPE_PIN)
    _pip(py, *DEPENDENCIES)
    if tools:
        _pip(py, *TOOL_DEPENDENCIES)
    src = _source_root()
    if src is not None:
        _pip(py, "--no-deps", "-e", str(src))
    else:
        # An installed wheel has no source tree to point pip at: copy the pure-Python package.
        pkg = Path(__file__).resolve().parents[1]
        dest = _site_packages(py) / "prezence"
        if dest.exists():
            shutil.rmtree(dest)
        shutil.copytree(pkg, dest, ignore=shutil.ignore_patterns("__pycache__"))
    marker.write_text(f"{MEDIAPIPE_PIN}\n" + "\n".join(DEPENDENCIES) + "\n")
    return py


def build_parser() -> argparse.ArgumentParser:
    """Return the command-line parser of ``python -m prezence.modules.vision_env``."""
    p = argparse.ArgumentParser(
        prog="python -m prezence.modules.vision_env",
        description="Create or locate the separate venv that the vision module runs in.",
    )
    sub = p.add_subparsers(dest="cmd", required=True)
    i = sub.add_parser("install", help="create the venv with the pinned mediapipe set")
    i.add_argument("--path", type=Path, default=None, help="venv folder (default: %(default)s)")
    i.add_argument("--tools", action="store_true", help="also scikit-image, for the video tool")
    i.add_argument("--clear", action="store_true", help="delete an existing venv there first")
    w = sub.add_parser("where", help="print the venv's python; exit 1 if there is none")
    w.add_argument("--path", type=Path, default=None)
    c = sub.add_parser("check", help="import mediapipe in the venv")
    c.add_argument("--path", type=Path, default=None)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    args = build_parser().parse_args(argv)
    if args.cmd == "install":
        logging.basicConfig(level=logging.INFO, format="%(message)s")
        try:
            py = install(args.path, tools=args.tools, clear=args.clear)
        except (RuntimeError, subprocess.CalledProcessError) as e:
            print(f"error: vision env install failed: {e}", file=sys.stderr)
            return 2
        ok, detail = check(args.path)
        print(detail)
        if ok:
            print(py)
        return 0 if ok else 2
    if args.cmd == "where":
        found = find_python(args.path)
        if found is None:
            print(f"no vision env; create it with: {INSTALL_HINT}", file=sys.stderr)
            return 1
        print(found)
        return 0
    ok, detail = check(args.path)
    print(detail, file=sys.stdout if ok else sys.stderr)
    return 0 if ok else 2


if __name__ == "__main__":
    sys.exit(main())
