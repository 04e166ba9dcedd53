"""The NAO URDF is what the fact tables say, and its model folder is complete."""

from __future__ import annotations

import csv
import importlib.util
import math
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
import yourdfpy

from prezence.resources import assets_dir, urdf_path

ROOT = Path(__file__).resolve().parents[2]
MODEL_DIR = ROOT / "assets" / "nao_urdf"
REFERENCE = ROOT.parent / "shared" / "reference"


def _generator() -> ModuleType:
    path = ROOT / "tools" / "gen_nao_urdf.py"
    spec = importlib.util.spec_from_file_location("gen_nao_urdf", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, mod)  # dataclasses look their module up by name
    spec.loader.exec_module(mod)
    return mod


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def urdf() -> yourdfpy.URDF:
    return yourdfpy.URDF.load(str(urdf_path()), load_meshes=False, build_scene_graph=False)


def test_generator_check_passes_on_the_committed_urdf() -> None:
    out = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "gen_nao_urdf.py"), "--check"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 0, out.stdout + out.stderr


def test_generator_check_flags_an_edited_urdf(tmp_path: Path) -> None:
    gen = _generator()
    edited = tmp_path / "nao.urdf"
    text = urdf_path().read_text(encoding="utf-8")
    edited.write_text(text.replace('velocity="8.26797"', 'velocity="9.0"', 1), encoding="utf-8")
    problems = gen.check(urdf_path=edited, reference_dir=tmp_path / "absent")
    assert problems and "differs" in problems[0]


@pytest.mark.skipif(not REFERENCE.is_dir(), reason="reference facts folder not beside the checkout")
def test_asset_tables_are_copies_of_the_reference() -> None:
    copy = (MODEL_DIR / "nao_joints.csv").read_bytes()
    assert copy == (REFERENCE / "nao_joints.csv").read_bytes()
    assert _generator().check(reference_dir=REFERENCE) == []


def test_every_joint_of_the_table_is_in_the_urdf_with_its_numbers(urdf: yourdfpy.URDF) -> None:
    rows = _rows(MODEL_DIR / "nao_joints.csv")
    assert len(rows) == 26
    for r in rows:
        j = urdf.joint_map[r["joint"]]
        assert j.type == "revolute"
        assert (j.parent, j.child) == (r["parent_link"], r["child_link"])
        assert j.limit.lower == pytest.approx(float(r["lower_rad"]), abs=0)
        assert j.limit.upper == pytest.approx(float(r["upper_rad"]), abs=0)
        assert j.limit.velocity == pytest.approx(float(r["max_velocity_rad_s"]), abs=0)
        assert j.limit.effort == pytest.approx(float(r["max_effort_nm"]), abs=0)
        axis = [float(x) for x in r["axis_xyz"].split()]
        assert list(j.axis) == pytest.approx(axis)
        xyz = [float(x) for x in r["origin_xyz_m"].split()]
        assert list(j.origin[:3, 3]) == pytest.approx(xyz)


def test_masses_come_from_the_link_table_and_mirror_right(urdf: yourdfpy.URDF) -> None:
    for r in _rows(MODEL_DIR / "nao_links.csv"):
        link = urdf.link_map[r["link"]]
        assert link.inertial.mass == pytest.approx(float(r["mass_kg"]))
        com = [float(x) for x in r["com_xyz_m"].split()]
        assert list(link.inertial.origin[:3, 3]) == pytest.approx(com)
        mirror = "r_" + r["link"][2:] if r["link"].startswith("l_") else "R" + r["link"][1:]
        if r["link"][0] in "lL" and mirror in urdf.link_map:
            right = urdf.link_map[mirror].inertial
            assert right.mass == pytest.approx(float(r["mass_kg"]))
            assert list(right.origin[:3, 3]) == pytest.approx([com[0], -com[1], com[2]])


def test_total_mass_is_the_documented_v5_mass(urdf: yourdfpy.URDF) -> None:
    total = sum(link.inertial.mass for link in urdf.link_map.values() if link.inertial is not None)
    # nao_facts.md §6: the V5 URDF totals 5.305 kg (our grippers add 2 × 2 g)
    assert total == pytest.approx(5.305 + 0.004, abs=0.002)


def test_inertia_tensors_are_physical(urdf: yourdfpy.URDF) -> None:
    for link in urdf.link_map.values():
        if link.inertial is None:
            continue
        eig = sorted(float(x) for x in np.linalg.eigvalsh(link.inertial.inertia))
        assert eig[0] > 0, link.name
        assert eig[0] + eig[1] >= eig[2] * (1 - 1e-6), link.name


def test_shapes_are_primitives_only() -> None:
    text = urdf_path().read_text(encoding="utf-8")
    assert "<mesh" not in text
    for shape in ("<box", "<cylinder", "<sphere"):
        assert shape in text


def test_standing_height_matches_the_link_lengths(urdf: yourdfpy.URDF) -> None:
    # torso origin above the sole at the zero pose: HipOffsetZ + thigh + tibia + FootHeight
    urdf_scene = yourdfpy.URDF(robot=urdf.robot, build_scene_graph=True, load_meshes=False)
    tf = urdf_scene.get_transform("l_sole", "torso")
    assert tf[2, 3] == pytest.approx(-(0.085 + 0.100 + 0.1029 + 0.04519), abs=1e-9)
    assert math.isclose(tf[1, 3], 0.05, abs_tol=1e-9)


def test_model_folder_has_readme_license_changelog() -> None:
    files = ("README.md", "LICENSE", "CHANGELOG.md", "nao.urdf", "nao_joints.csv", "nao_links.csv")
    for name in files:
        assert (MODEL_DIR / name).is_file(), name
    readme = (MODEL_DIR / "README.md").read_text(encoding="utf-8")
    assert "Grade" in readme or "grade" in readme


def test_resources_find_the_checkout_assets() -> None:
    assert urdf_path() == assets_dir() / "nao_urdf" / "nao.urdf"
    assert urdf_path().is_file()
