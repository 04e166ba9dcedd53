"""The product installs and runs on a real NAO alone: importing it pulls in no simulator.

``prezence.modules`` is left out: the input modules are separate programs (one process each)
with their own optional dependencies (OpenCV, pocketsphinx, mediapipe in its own venv).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path


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


def test_no_file_of_the_product_imports_the_sandbox() -> None:
    """Not even inside a function: the sandbox is reached by entry-point strings only."""
    import ast
    from pathlib import Path

    import prezence

    root = Path(prezence.__file__).parent
    found = []
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            for name in names:
                if name == "sim" or name.startswith("sim."):
                    found.append(f"{path.relative_to(root.parent)}:{node.lineno}: {name}")
    assert len(list(root.rglob("*.py"))) > 40  # the walk saw the product
    assert found == []


def test_a_replay_of_a_folder_with_foreign_streams_imports_no_camera_code(tmp_path: Path) -> None:
    """Session 22: replay's check for streams no rule reads imported the vision module to
    know its streams: OpenCV (which a replay does not need, and the core install lacks) and
    17 MB more peak memory on the peers' workload. Session 24 took two more out of a replay's
    start, held here: the NAOqi client (for one constant) and ``numpy.ma`` (``np.percentile``)."""
    folder = tmp_path / "load"
    (folder / "streams").mkdir(parents=True)
    (folder / "streams" / "speech_speed.txt").write_text("1 150\n2 150\n")
    (folder / "streams" / "gesture_rate.txt").write_text("1 3\n2 3\n")
    code = textwrap.dedent(
        f"""
        import sys
        from prezence.cli import main
        status = main(["replay", {str(folder)!r}, "--out", {str(tmp_path / "r")!r},
                       "--no-report", "--allocated", "10"])
        heavy = {{"cv2", "prezence.modules.vision", "numpy.ma", "prezence.backends.naoqi"}}
        print(status, sorted(heavy & set(sys.modules)))
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().splitlines()[-1] == "0 []", out.stdout + out.stderr
    assert "gesture_rate.txt" in out.stdout + out.stderr  # the check ran
