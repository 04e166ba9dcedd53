"""The vision env runs this checkout's vision code, not whichever prezence it has installed."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from prezence.modules import vision_env

REPO = Path(__file__).resolve().parents[2]


def test_a_vision_env_process_imports_this_checkouts_prezence(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # The shared default env may hold an editable install of another clone (or of a path
    # that is gone): a process started with child_env() still imports the prezence that
    # started it, from any working folder. (The module is pointed at this checkout's file so
    # the test means the same when the suite runs against an installed wheel.)
    monkeypatch.setattr(
        vision_env, "__file__", str(REPO / "prezence" / "modules" / "vision_env.py")
    )
    env = vision_env.child_env({"PATH": os.environ.get("PATH", ""), "PYTHONPATH": "/elsewhere"})
    assert env["PYTHONPATH"].split(os.pathsep) == [str(REPO), "/elsewhere"]
    code = "import prezence.modules.vision_env as v; print(v.__file__)"
    # -I would ignore PYTHONPATH: a bare interpreter (-S: no site-packages, so no install of
    # prezence at all) finds it through the path alone
    out = subprocess.run(
        [sys.executable, "-S", "-c", code],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    assert Path(out.strip()).resolve() == REPO / "prezence" / "modules" / "vision_env.py"


def test_an_installed_prezence_is_not_put_on_the_vision_envs_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A wheel's site-packages would bring this environment's numpy 2 into the vision env's
    # numpy<2 process: only a source tree goes on the path.
    site = tmp_path / "lib" / "python3.11" / "site-packages"
    (site / "prezence" / "modules").mkdir(parents=True)
    (site / "prezence" / "__init__.py").touch()
    monkeypatch.setattr(
        vision_env, "__file__", str(site / "prezence" / "modules" / "vision_env.py")
    )
    env = vision_env.child_env({"PATH": "/bin", "PYTHONPATH": "/elsewhere"})
    assert env["PYTHONPATH"] == "/elsewhere"
    assert "PYTHONPATH" not in vision_env.child_env({"PATH": "/bin"})
