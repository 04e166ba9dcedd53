"""Screenshot a report page in headless Chromium, to check it as a person would see it.

Usage::

    python tools/screenshot_report.py SESSION/report/report.html -o shot.png [--width 1200]
        [--height 3000] [--chromium PATH]

Chromium (``apt-get install chromium``) is run as
``chromium --headless --screenshot=OUT --window-size=W,H file://PAGE``; the page is
self-contained, so no network is involved. Exits 2 when Chromium is not installed.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_chromium(explicit: str | None = None) -> str | None:
    """The Chromium executable, or None."""
    if explicit:
        return explicit if shutil.which(explicit) or Path(explicit).is_file() else None
    for name in CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    return None


def screenshot(
    page: Path,
    out: Path,
    *,
    width: int = 1200,
    height: int = 3000,
    chromium: str | None = None,
    timeout_s: float = 120.0,
) -> Path:
    """Render ``page`` to the PNG ``out``; raises FileNotFoundError without Chromium.

    Raises:
        FileNotFoundError: no Chromium, or ``page`` does not exist.
        subprocess.CalledProcessError: Chromium failed (its stderr is in the exception).
    """
    exe = find_chromium(chromium)
    if exe is None:
        raise FileNotFoundError("chromium not found: apt-get install chromium")
    page = page.resolve()
    if not page.is_file():
        raise FileNotFoundError(f"no such page: {page}")
    out = out.resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="prezence-chromium-") as profile:
        cmd = [
            exe,
            "--headless",
            "--no-sandbox",  # containers and CI run as root, where the sandbox cannot start
            "--disable-gpu",
            "--hide-scrollbars",
            "--no-first-run",
            f"--user-data-dir={profile}",
            f"--screenshot={out}",
            f"--window-size={width},{height}",
            page.as_uri(),
        ]
        subprocess.run(cmd, check=True, capture_output=True, text=True, timeout=timeout_s)
    if not out.is_file():
        raise FileNotFoundError(f"chromium wrote no screenshot to {out}")
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("page", type=Path, help="report.html")
    p.add_argument("-o", "--out", type=Path, default=Path("report.png"))
    p.add_argument("--width", type=int, default=1200)
    p.add_argument("--height", type=int, default=3000)
    p.add_argument("--chromium", help="path of the Chromium executable")
    args = p.parse_args(argv)
    try:
        out = screenshot(
            args.page, args.out, width=args.width, height=args.height, chromium=args.chromium
        )
    except FileNotFoundError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except subprocess.CalledProcessError as e:
        print(f"error: chromium failed ({e.returncode}): {e.stderr[-2000:]}", file=sys.stderr)
        return 1
    print(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
