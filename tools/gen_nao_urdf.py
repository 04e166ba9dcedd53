#!/usr/bin/env python3
"""Generate ``assets/nao_urdf/nao.urdf`` from the project's NAO fact tables.

Inputs (both in ``assets/nao_urdf/``, so the product never needs the reference folder):

* ``nao_joints.csv``: a verbatim copy of ``reference/nao_joints.csv`` (frames, axes, position,
  velocity and effort limits of the 26 joints).
* ``nao_links.csv``: masses, centres of mass and inertia tensors of the left/centre links,
  transcribed from ``reference/nao_facts.md`` section 6. Right-side links are mirrored here
  (CoM y and the ixy/iyz products change sign; masses are equal), as the facts prescribe.

The shapes (boxes, cylinders, spheres) and colours are this project's own design, written below;
no mesh or geometry is copied from any other model.

Usage::

    python tools/gen_nao_urdf.py            # write assets/nao_urdf/nao.urdf
    python tools/gen_nao_urdf.py --check    # exit 1 if the URDF differs from what the tables give

``--check`` also compares the two CSV copies with ``../shared/reference`` (the reference facts
beside the checkout) when that folder exists, and says so when it does not.
"""

from __future__ import annotations

import argparse
import csv
import difflib
import math
import re
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ASSET_DIR = ROOT / "assets" / "nao_urdf"
JOINTS_CSV = ASSET_DIR / "nao_joints.csv"
LINKS_CSV = ASSET_DIR / "nao_links.csv"
URDF_PATH = ASSET_DIR / "nao.urdf"
REFERENCE_DIR = ROOT.parent / "shared" / "reference"

#: FootHeight: the V5 doc value (45.19 mm, nao_facts.md section 2); the ROS URDF keeps V3.2's 45.11.
FOOT_HEIGHT_M = "0.04519"
#: l_gripper/r_gripper carry NAO's 8 finger links in the source model (2e-6 kg each). We have
#: no finger links, so the gripper gets a token mass for a well-conditioned physics link.
GRIPPER_MASS_KG = 0.002
HALF_PI = f"{math.pi / 2:.6f}"
#: Pure frames (base_link, soles) get a negligible inertial: PyBullet gives a link without one
#: a default mass of 1 kg, which would hang a kilogram under each ankle.
FRAME_INERTIAL_MASS = "1e-06"

# ----------------------------------------------------------------------------------------------
# Colours: left limbs blue, right limbs orange, so the two sides read apart in renders.
MATERIALS: dict[str, str] = {
    "shell": "0.93 0.93 0.91 1",
    "joint_grey": "0.55 0.56 0.60 1",
    "face": "0.12 0.13 0.16 1",
    "eye": "0.30 0.75 1.00 1",
    "left_arm": "0.20 0.45 0.90 1",
    "left_hand": "0.10 0.25 0.60 1",
    "right_arm": "0.95 0.45 0.15 1",
    "right_hand": "0.65 0.25 0.05 1",
    "left_leg": "0.55 0.68 0.90 1",
    "right_leg": "0.95 0.70 0.55 1",
}


@dataclass(frozen=True)
class Shape:
    """One primitive: kind box|cylinder|sphere, size (box: x y z; cylinder: radius length;
    sphere: radius), pose in the link frame, material, and whether it also collides."""

    kind: str
    size: str
    xyz: str
    rpy: str
    material: str
    collide: bool = True


def _cyl_x(radius: float, length: float, x: float, y: float, material: str) -> Shape:
    """A cylinder lying along the link's x axis (URDF cylinders lie along z)."""
    return Shape("cylinder", f"{radius} {length}", f"{x} {y} 0", f"0 {HALF_PI} 0", material)


def _cyl_z(radius: float, length: float, z: float, material: str) -> Shape:
    return Shape("cylinder", f"{radius} {length}", f"0 0 {z}", "0 0 0", material)


def _ball(radius: float, material: str, xyz: str = "0 0 0", collide: bool = False) -> Shape:
    return Shape("sphere", f"{radius}", xyz, "0 0 0", material, collide)


def _shapes(side: str) -> dict[str, list[Shape]]:
    """Primitive shapes of one side's limbs (side 'L' or 'R'); y offsets mirror."""
    s = 1.0 if side == "L" else -1.0
    arm, hand, leg = (
        ("left_arm", "left_hand", "left_leg")
        if side == "L"
        else (
            "right_arm",
            "right_hand",
            "right_leg",
        )
    )
    w = "l" if side == "L" else "r"
    # Sizes follow NAO's outline (574 mm tall, chunky upper arms, short forearms, long feet);
    # the cylinders stop short of each joint so neighbours never overlap at the zero pose.
    return {
        f"{side}Shoulder": [_ball(0.029, "joint_grey")],
        f"{side}Bicep": [_cyl_x(0.025, 0.075, 0.055, s * 0.008, arm)],
        f"{side}Elbow": [_ball(0.021, "joint_grey")],
        f"{side}ForeArm": [_cyl_x(0.022, 0.036, 0.032, 0.0, arm)],
        f"{w}_wrist": [Shape("box", "0.052 0.024 0.044", "0.034 0 -0.004", "0 0 0", hand)],
        # The finger paddle: LHand turns it about the hand's x axis by the opening fraction
        # (1 rad when fully open), a visual stand-in for NAO's three coupled fingers.
        f"{w}_gripper": [Shape("box", "0.034 0.008 0.040", "0.014 0 0.018", "0 0 0", hand)],
        f"{side}Pelvis": [_ball(0.022, "joint_grey")],
        f"{side}Hip": [],
        f"{side}Thigh": [_cyl_z(0.032, 0.070, -0.050, leg)],
        f"{side}Tibia": [_cyl_z(0.030, 0.072, -0.052, leg)],
        f"{side}AnklePitch": [_ball(0.018, "joint_grey")],
        f"{w}_ankle": [Shape("box", "0.160 0.080 0.024", "0.020 0 -0.03319", "0 0 0", leg)],
    }


def shapes_by_link() -> dict[str, list[Shape]]:
    """Every link's primitives (links missing here have none)."""
    out: dict[str, list[Shape]] = {
        "torso": [
            Shape("box", "0.090 0.130 0.120", "-0.008 0 0.050", "0 0 0", "shell"),
            Shape("box", "0.075 0.100 0.060", "-0.008 0 -0.030", "0 0 0", "shell"),
        ],
        "Neck": [_cyl_z(0.018, 0.020, -0.012, "joint_grey")],
        "Head": [
            Shape("sphere", "0.062", "-0.005 0 0.062", "0 0 0", "shell"),
            Shape("box", "0.040 0.100 0.036", "0.040 0 0.064", "0 0 0", "face", collide=False),
            _ball(0.010, "eye", "0.058 0.025 0.066"),
            _ball(0.010, "eye", "0.058 -0.025 0.066"),
        ],
    }
    out.update(_shapes("L"))
    out.update(_shapes("R"))
    return out


# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class JointRow:
    name: str
    parent: str
    child: str
    axis: str
    xyz: str
    rpy: str
    lower: str
    upper: str
    velocity: str
    effort: str


@dataclass(frozen=True)
class Inertial:
    mass: str
    com: str
    ixx: str
    iyy: str
    izz: str
    ixy: str
    ixz: str
    iyz: str


def read_joints(path: Path = JOINTS_CSV) -> list[JointRow]:
    with path.open(newline="", encoding="utf-8") as f:
        return [
            JointRow(
                r["joint"],
                r["parent_link"],
                r["child_link"],
                r["axis_xyz"],
                r["origin_xyz_m"],
                r["origin_rpy"],
                r["lower_rad"],
                r["upper_rad"],
                r["max_velocity_rad_s"],
                r["max_effort_nm"],
            )
            for r in csv.DictReader(f)
        ]


def _neg(v: str) -> str:
    """Negate a number written as text without reformatting it."""
    if v.startswith("-"):
        return v[1:]
    return v if float(v) == 0.0 else "-" + v


def read_links(path: Path = LINKS_CSV) -> dict[str, Inertial]:
    """Inertials of all links: the table's rows plus the mirrored right side."""
    out: dict[str, Inertial] = {}
    with path.open(newline="", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            link = r["link"]
            x, y, z = r["com_xyz_m"].split()
            out[link] = Inertial(
                r["mass_kg"],
                r["com_xyz_m"],
                r["ixx"],
                r["iyy"],
                r["izz"],
                r["ixy"],
                r["ixz"],
                r["iyz"],
            )
            mirror = _mirror_name(link)
            if mirror != link:
                out[mirror] = Inertial(
                    r["mass_kg"],
                    f"{x} {_neg(y)} {z}",
                    r["ixx"],
                    r["iyy"],
                    r["izz"],
                    _neg(r["ixy"]),
                    r["ixz"],
                    _neg(r["iyz"]),
                )
    return out


def _mirror_name(link: str) -> str:
    if link.startswith("l_"):
        return "r_" + link[2:]
    if link.startswith("L"):
        return "R" + link[1:]
    return link


def _gripper_inertial() -> Inertial:
    m = GRIPPER_MASS_KG
    a, b, c = 0.034, 0.008, 0.040  # the paddle box
    return Inertial(
        f"{m}",
        "0.014 0 0.018",
        f"{m * (b * b + c * c) / 12:.4g}",
        f"{m * (a * a + c * c) / 12:.4g}",
        f"{m * (a * a + b * b) / 12:.4g}",
        "0",
        "0",
        "0",
    )


def _frame_inertial() -> Inertial:
    return Inertial(FRAME_INERTIAL_MASS, "0 0 0", "1e-09", "1e-09", "1e-09", "0", "0", "0")


# ----------------------------------------------------------------------------------------------
def _shape_xml(tag: str, sh: Shape) -> list[str]:
    if sh.kind == "box":
        geom = f'<box size="{sh.size}"/>'
    elif sh.kind == "cylinder":
        radius, length = sh.size.split()
        geom = f'<cylinder radius="{radius}" length="{length}"/>'
    else:
        geom = f'<sphere radius="{sh.size}"/>'
    lines = [
        f"    <{tag}>",
        f'      <origin xyz="{sh.xyz}" rpy="{sh.rpy}"/>',
        f"      <geometry>{geom}</geometry>",
    ]
    if tag == "visual":
        lines.append(f'      <material name="{sh.material}"/>')
    lines.append(f"    </{tag}>")
    return lines


def _link_xml(name: str, inertial: Inertial | None, shapes: list[Shape]) -> list[str]:
    if inertial is None and not shapes:
        return [f'  <link name="{name}"/>']
    lines = [f'  <link name="{name}">']
    if inertial is not None:
        i = inertial
        lines += [
            "    <inertial>",
            f'      <origin xyz="{i.com}" rpy="0 0 0"/>',
            f'      <mass value="{i.mass}"/>',
            f'      <inertia ixx="{i.ixx}" ixy="{i.ixy}" ixz="{i.ixz}"'
            f' iyy="{i.iyy}" iyz="{i.iyz}" izz="{i.izz}"/>',
            "    </inertial>",
        ]
    for sh in shapes:
        lines += _shape_xml("visual", sh)
    for sh in shapes:
        if sh.collide:
            lines += _shape_xml("collision", sh)
    lines.append("  </link>")
    return lines


def generate(joints: list[JointRow], inertials: dict[str, Inertial]) -> str:
    """The URDF text for the given tables (deterministic: same tables, same bytes)."""
    shapes = shapes_by_link()
    out = [
        '<?xml version="1.0" encoding="utf-8"?>',
        "<!-- GENERATED by tools/gen_nao_urdf.py from nao_joints.csv and nao_links.csv:"
        " do not edit.",
        "     Prezence's own NAO H25 (V5/V6) model with primitive shapes; see README.md. -->",
        '<robot name="nao">',
    ]
    for mat, rgba in MATERIALS.items():
        out.append(f'  <material name="{mat}"><color rgba="{rgba}"/></material>')
    # base_link -(fixed)-> torso, as in the ROS/qibullet model, so frame names match.
    out += _link_xml("base_link", _frame_inertial(), [])
    out += [
        '  <joint name="base_link_fixedjoint" type="fixed">',
        '    <parent link="base_link"/>',
        '    <child link="torso"/>',
        '    <origin xyz="0 0 0" rpy="0 0 0"/>',
        "  </joint>",
    ]
    out += _link_xml("torso", inertials["torso"], shapes["torso"])
    for j in joints:
        child_inertial = inertials.get(j.child)
        if child_inertial is None and j.child.endswith("_gripper"):
            child_inertial = _gripper_inertial()
        if child_inertial is None:
            raise ValueError(f"no mass/inertia for link {j.child!r} (joint {j.name})")
        out += _link_xml(j.child, child_inertial, shapes.get(j.child, []))
        out += [
            f'  <joint name="{j.name}" type="revolute">',
            f'    <parent link="{j.parent}"/>',
            f'    <child link="{j.child}"/>',
            f'    <origin xyz="{j.xyz}" rpy="{j.rpy}"/>',
            f'    <axis xyz="{j.axis}"/>',
            f'    <limit lower="{j.lower}" upper="{j.upper}"'
            f' effort="{j.effort}" velocity="{j.velocity}"/>',
            "  </joint>",
        ]
        if j.name == "RHipYawPitch":
            out.insert(len(out) - 1, '    <mimic joint="LHipYawPitch" multiplier="1" offset="0"/>')
    for side, ankle in (("l", "l_ankle"), ("r", "r_ankle")):
        out += _link_xml(f"{side}_sole", _frame_inertial(), [])
        out += [
            f'  <joint name="{side.upper()}Sole_fixedjoint" type="fixed">',
            f'    <parent link="{ankle}"/>',
            f'    <child link="{side}_sole"/>',
            f'    <origin xyz="0 0 -{FOOT_HEIGHT_M}" rpy="0 0 0"/>',
            "  </joint>",
        ]
    out.append("</robot>")
    return "\n".join(out) + "\n"


# ----------------------------------------------------------------------------------------------
def _facts_inertials(facts_md: Path) -> dict[str, tuple[str, ...]]:
    """Mass/CoM/inertia rows parsed from nao_facts.md section 6 (ASCII minus signs)."""
    rows: dict[str, list[str]] = {}
    for line in facts_md.read_text(encoding="utf-8").splitlines():
        if not line.startswith("| "):
            continue
        cells = [c.strip().replace("\u2212", "-") for c in line.strip().strip("|").split("|")]
        link = cells[0].split(" ")[0]
        if len(cells) == 5 and re.fullmatch(r"[0-9.]+", cells[2]):
            rows.setdefault(link, []).extend([cells[2], cells[3]])
        elif len(cells) == 7 and re.fullmatch(r"[0-9.e-]+", cells[1]) and link in rows:
            rows[link].extend(cells[1:])
    return {k: tuple(v) for k, v in rows.items() if len(v) == 8}


def _links_rows(path: Path) -> dict[str, tuple[str, ...]]:
    with path.open(newline="", encoding="utf-8") as f:
        return {
            r["link"]: (
                r["mass_kg"],
                r["com_xyz_m"],
                r["ixx"],
                r["iyy"],
                r["izz"],
                r["ixy"],
                r["ixz"],
                r["iyz"],
            )
            for r in csv.DictReader(f)
        }


def check(urdf_path: Path = URDF_PATH, reference_dir: Path = REFERENCE_DIR) -> list[str]:
    """Problems found (empty when the URDF is what the tables give)."""
    problems: list[str] = []
    want = generate(read_joints(), read_links())
    have = urdf_path.read_text(encoding="utf-8") if urdf_path.exists() else ""
    if have != want:
        diff = difflib.unified_diff(
            have.splitlines(),
            want.splitlines(),
            "nao.urdf (on disk)",
            "nao.urdf (from tables)",
            lineterm="",
            n=1,
        )
        problems.append(
            "nao.urdf differs from the tables; run tools/gen_nao_urdf.py\n"
            + "\n".join(list(diff)[:40])
        )
    ref_csv = reference_dir / "nao_joints.csv"
    if ref_csv.exists() and ref_csv.read_bytes() != JOINTS_CSV.read_bytes():
        problems.append(f"{JOINTS_CSV} is not a copy of {ref_csv}")
    facts = reference_dir / "nao_facts.md"
    if facts.exists():
        ref = _facts_inertials(facts)
        mine = _links_rows(LINKS_CSV)
        if ref != mine:
            bad = sorted(k for k in set(ref) | set(mine) if ref.get(k) != mine.get(k))
            problems.append(f"{LINKS_CSV} disagrees with {facts} section 6 for: {', '.join(bad)}")
    return problems


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--check", action="store_true", help="compare instead of writing; exit 1 on a difference"
    )
    parser.add_argument(
        "--reference", type=Path, default=REFERENCE_DIR, help="reference facts folder"
    )
    args = parser.parse_args(argv)
    if args.check:
        problems = check(reference_dir=args.reference)
        if not args.reference.exists():
            print(
                f"note: {args.reference} not found; checked the URDF against the asset copies only"
            )
        for p in problems:
            print(p, file=sys.stderr)
        if not problems:
            print(f"ok: {URDF_PATH.relative_to(ROOT)} matches the joint and link tables")
        return 1 if problems else 0
    URDF_PATH.write_text(generate(read_joints(), read_links()), encoding="utf-8")
    print(f"wrote {URDF_PATH.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
