"""A DeepMimic character file (characters/*.txt, JSON) -> an MJCF character for mjxmimic.

    python -m mjxmimic.core.deepmimic_character ../shared/deepmimic/characters/dog3d.txt \
        --name dog3d --out mjxmimic/core/characters/dog3d.xml

DeepMimic is y-up with x forward and z to the right; the MJCF is z-up with y left, so every
vector (x, y, z) becomes (x, -z, y) and a revolute joint about DeepMimic's local z becomes a hinge
about -y. Bodies keep DeepMimic's shapes and masses (MuJoCo derives the inertia from the shape, as
Bullet does); each joint's Kd is its MuJoCo damping and Kp, torque limit and pose-error weight go
to the <custom> block that `mjxmimic.core.character` reads. A box end effector (a foot) touches
the floor through four small spheres at its sole's corners, because MJX's box-plane contact keeps
fewer points than MuJoCo C's and training and CPU playback must agree.

The PD gains are not in the character file but in DeepMimic's controller files
(data/controllers/<name>_ctrl.txt); those of the two characters DeepMimic ships are below, or pass
`--ctrl FILE`.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from mjxmimic.core.errors import UserError, read_json

# (Kp, Kd) per joint from DeepMimic's data/controllers/*_ctrl.txt (MIT).
GAINS = {
    "humanoid3d": {"chest": (1000, 100), "neck": (100, 10), "hip": (500, 50), "knee": (500, 50),
                   "ankle": (400, 40), "shoulder": (400, 40), "elbow": (300, 30)},
    "dog3d": {"spine0": (500, 50), "spine1": (500, 50), "neck": (100, 10), "head": (50, 5),
              "shoulder": (200, 20), "forearm": (200, 20), "hand": (100, 10), "finger": (50, 5),
              "upper_leg": (300, 30), "leg": (200, 20), "foot": (150, 15), "toe": (80, 8),
              "tail0": (20, 2), "tail1": (10, 1)},
}
# Bodies whose contact with the ground is always a fall (the `torso` body set).
TORSO = {"humanoid3d": ("root", "chest", "neck"), "dog3d": ("root", "spine0", "spine1")}
SOLE_RADIUS = 0.01


def _v(x: float, y: float, z: float) -> tuple[float, float, float]:
    """DeepMimic's y-up vector in the MJCF's z-up frame."""
    return (x, -z, y)


def _fmt(values: Any) -> str:
    return " ".join(f"{float(v):.6g}" for v in values)


def _gains(name: str, joint: str, table: dict[str, tuple[float, float]]) -> tuple[float, float]:
    if joint in table:
        return table[joint]
    for side in ("left_", "right_"):
        if joint.startswith(side) and joint[len(side):] in table:
            return table[joint[len(side):]]
    raise UserError(f"{name}: no PD gains for joint {joint!r} (pass --ctrl with DeepMimic's controller file)")


def _rotation(where: str, item: dict) -> str:
    """A geom's quat attribute from DeepMimic's AttachTheta (one axis at most, as in its files)."""
    theta = [float(item.get(f"AttachTheta{a}", 0.0)) for a in "XYZ"]
    turned = [i for i, t in enumerate(theta) if t != 0.0]
    if not turned:
        return ""
    if len(turned) > 1:
        raise UserError(f"{where}: a rotation about more than one axis is not supported")
    axis = _v(*[1.0 if i == turned[0] else 0.0 for i in range(3)])
    half = theta[turned[0]] / 2
    return f' quat="{_fmt([math.cos(half)] + [math.sin(half) * a for a in axis])}"'


def _geom(where: str, body: dict, sole: bool) -> list[str]:
    """The geom line(s) of one body: its shape, plus sole spheres for a foot."""
    name, shape, mass = body["Name"], body["Shape"], float(body["Mass"])
    pos = _v(body["AttachX"], body["AttachY"], body["AttachZ"])
    p = [float(body[f"Param{i}"]) for i in range(3)]
    rot = _rotation(where, body)
    cls = ' class="foot"' if sole else ""
    if shape == "sphere":
        size = [p[0] / 2]
    elif shape == "capsule":
        size = [p[0] / 2, p[1] / 2]
    elif shape == "box":
        size = [p[0] / 2, p[2] / 2, p[1] / 2]
    else:
        raise UserError(f"{where}: shape {shape!r} is not supported (sphere, capsule, box)")
    lines = [f'<geom name="{name}"{cls} type="{shape}" size="{_fmt(size)}" pos="{_fmt(pos)}"{rot} mass="{mass:g}"/>']
    if sole:
        if shape != "box" or rot:
            raise UserError(f"{where}: a foot must be an unrotated box")
        hx, hy, hz = (s - SOLE_RADIUS for s in size)
        z = pos[2] - size[2] + SOLE_RADIUS
        for tag, (sx, sy) in {"heel_l": (-1, 1), "heel_r": (-1, -1), "toe_l": (1, 1), "toe_r": (1, -1)}.items():
            at = (pos[0] + sx * hx, pos[1] + sy * hy, z)
            lines.append(f'<geom name="{name}_{tag}" class="sole" pos="{_fmt(at)}"/>')
    return lines


def convert(data: dict, name: str, gains: dict[str, tuple[float, float]] | None = None,
            torso: tuple[str, ...] | None = None, clip_prefix: str | None = None,
            source: str = "") -> str:
    """The MJCF text of a DeepMimic character (parsed JSON)."""
    gains = GAINS.get(name) if gains is None else gains
    if gains is None:
        raise UserError(f"{name}: no built-in PD gains (known: {', '.join(GAINS)}); pass --ctrl")
    torso = TORSO.get(name, ("root",)) if torso is None else torso
    try:
        joints = data["Skeleton"]["Joints"]
        bodies = {int(b["ID"]): b for b in data["BodyDefs"]}
    except (KeyError, TypeError) as err:
        raise UserError(f"{source or name}: not a DeepMimic character file (missing {err})") from None
    if not joints or joints[0].get("Type") != "none" or int(joints[0].get("Parent", 0)) != -1:
        raise UserError(f"{source or name}: joint 0 must be the root (type none, parent -1)")
    children: dict[int, list[dict]] = {}
    for joint in joints[1:]:
        children.setdefault(int(joint["Parent"]), []).append(joint)
    effectors = [j["Name"] for j in joints if int(j.get("IsEndEffector", 0))]
    feet = [n for n in effectors if bodies[_id(joints, n)]["Shape"] == "box"]
    hands = [n for n in effectors if n not in feet]
    actuated = [j for j in joints[1:] if j["Type"] in ("spherical", "revolute")]
    custom = [f'<text name="clip_joint_order" data="{" ".join(j["Name"] for j in actuated)}"/>',
              f'<text name="clip_prefix" data="{clip_prefix if clip_prefix is not None else name + "_"}"/>',
              f'<text name="end_effectors" data="{" ".join(effectors)}"/>']
    for set_name, members in (("feet", feet), ("hands", hands), ("torso", list(torso))):
        if members:
            custom.append(f'<text name="{set_name}" data="{" ".join(members)}"/>')
    custom.append(f'<numeric name="joint/root" data="0 0 {float(joints[0].get("DiffWeight", 1)):g}"/>')
    for joint in actuated:
        kp, _ = _gains(name, joint["Name"], gains)
        custom.append(f'<numeric name="joint/{joint["Name"]}" data="{kp:g} {float(joint["TorqueLim"]):g} '
                      f'{float(joint["DiffWeight"]):g}"/>')

    def body_xml(joint: dict, depth: int) -> list[str]:
        pad = "  " * depth
        jname, jtype = joint["Name"], joint["Type"]
        where = f"{source or name}: joint {jname!r}"
        # The root's place is the clip's to set; its Attach values are not a position.
        pos = (0, 0, 1.0) if jtype == "none" else _v(joint["AttachX"], joint["AttachY"], joint["AttachZ"])
        if any(float(joint.get(f"AttachTheta{a}", 0.0)) for a in "XYZ"):
            raise UserError(f"{where}: rotated joint frames are not supported")
        lines = [f'{pad}<body name="{jname}" pos="{_fmt(pos)}">']
        inner = pad + "  "
        if jtype == "none":
            lines.append(f'{inner}<freejoint name="{jname}"/>')
            lines.append(f'{inner}<camera name="track" mode="trackcom" pos="0 -4 1.2" xyaxes="1 0 0 0 0.3 1"/>')
        elif jtype in ("spherical", "revolute"):
            _, kd = _gains(name, jname, gains)
            if jtype == "spherical":
                lines.append(f'{inner}<joint name="{jname}" type="ball" damping="{kd:g}"/>')
            else:
                lo, hi = float(joint["LimLow0"]), float(joint["LimHigh0"])
                lines.append(f'{inner}<joint name="{jname}" type="hinge" axis="0 -1 0" range="{lo:g} {hi:g}" '
                             f'damping="{kd:g}"/>')
        elif jtype != "fixed":
            raise UserError(f"{where}: joint type {jtype!r} is not supported (none, spherical, revolute, fixed)")
        body = bodies.get(int(joint["ID"]))
        if body is None:
            raise UserError(f"{where}: no BodyDefs entry with its ID")
        lines += [inner + g for g in _geom(f"{source or name}: body {body['Name']!r}", body, jname in feet)]
        for child in children.get(int(joint["ID"]), []):
            lines += body_xml(child, depth + 1)
        lines.append(f"{pad}</body>")
        return lines

    mass = sum(float(b["Mass"]) for b in bodies.values())
    header = (f"<!-- Made by mjxmimic.core.deepmimic_character from DeepMimic's {source or name} (MIT): "
              f"{len(bodies)} bodies, {mass:g} kg.\n     z-up: DeepMimic's (x, y, z) is (x, -z, y) here. "
              "Do not edit by hand: run the converter again. -->")
    return "\n".join([
        header,
        f'<mujoco model="deepmimic_{name}">',
        '  <compiler angle="radian" autolimits="true"/>',
        '  <option timestep="0.0041666667" integrator="Euler" solver="Newton" iterations="4" ls_iterations="8"/>',
        '  <size memory="1M"/>',
        "  <default>",
        '    <geom contype="1" conaffinity="0" condim="3" friction="0.9 0.005 0.0001" rgba="0.47 0.55 0.69 1"/>',
        '    <default class="foot">',
        '      <geom contype="0" conaffinity="0"/>',
        "    </default>",
        '    <default class="sole">',
        f'      <geom type="sphere" size="{SOLE_RADIUS:g}" mass="0"/>',
        "    </default>",
        "  </default>",
        "  <custom>",
        *["    " + line for line in custom],
        "  </custom>",
        "  <visual>",
        '    <headlight ambient="0.4 0.4 0.4" diffuse="0.6 0.6 0.6"/>',
        '    <global offwidth="640" offheight="480"/>',
        "  </visual>",
        "  <asset>",
        '    <texture name="grid" type="2d" builtin="checker" width="512" height="512" rgb1="0.82 0.82 0.80" '
        'rgb2="0.70 0.70 0.68"/>',
        '    <material name="grid" texture="grid" texrepeat="1 1" texuniform="true"/>',
        "  </asset>",
        "  <worldbody>",
        '    <geom name="floor" type="plane" size="0 0 0.05" material="grid" contype="0" conaffinity="1"/>',
        '    <light name="sun" pos="0 0 6" dir="0 0.2 -1" directional="true"/>',
        *body_xml(joints[0], 2),
        "  </worldbody>",
        "</mujoco>",
        "",
    ])


def _id(joints: list[dict], name: str) -> int:
    return next(int(j["ID"]) for j in joints if j["Name"] == name)


def ctrl_gains(path: Path) -> dict[str, tuple[float, float]]:
    """(Kp, Kd) by joint name from a DeepMimic controller file's PDControllers."""
    data = read_json(path, "controller file")
    try:
        return {c["Name"]: (float(c["Kp"]), float(c["Kd"])) for c in data["PDControllers"]}
    except (KeyError, TypeError, ValueError):
        raise UserError(f"{path}: expected PDControllers entries with Name, Kp and Kd") from None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m mjxmimic.core.deepmimic_character", description=__doc__.split("\n")[0])
    parser.add_argument("file", type=Path, help="DeepMimic character file (characters/NAME.txt)")
    parser.add_argument("--name", help="character name (default: the file's stem); picks built-in gains")
    parser.add_argument("--ctrl", type=Path, help="DeepMimic controller file with the PD gains")
    parser.add_argument("--out", type=Path, help="MJCF file to write (default: standard output)")
    args = parser.parse_args(argv)
    name = args.name or args.file.stem
    try:
        text = convert(read_json(args.file, "character file"), name,
                       gains=ctrl_gains(args.ctrl) if args.ctrl else None, source=args.file.name)
    except UserError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    if args.out is None:
        sys.stdout.write(text)
    else:
        tmp = args.out.with_suffix(".tmp")
        tmp.write_text(text)
        tmp.replace(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
