"""The product installs and runs on a real NAO alone: importing it pulls in no simulator.

``prezence.modules`` is left out: the input modules are separate programs (one process each)
with their own optional dependencies (OpenCV, pocketsphinx, mediapipe in its own venv).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap


def test_prezence_imports_no_simulator_or_robot_sdk() -> None:
    code = textwrap.dedent(
        """
        import importlib, pkgutil, sys
        import prezence
        skip = {"prezence.__main__"}
        for m in pkgutil.walk_packages(prezence.__path__, "prezence."):
            if m.name not in skip and not m.name.startswith("prezence.modules."):
                importlib.import_module(m.name)
        heavy = {"pybullet", "gymnasium", "qi", "sim", "cv2", "matplotlib"}
        print(sorted(heavy & {k.split(".")[0] for k in sys.modules}))
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]", out.stdout + out.stderr
