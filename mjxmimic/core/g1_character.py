"""The Unitree G1 (29 hinges) as a character, built from the model in ../shared/robots/unitree_g1.

That model may not be copied into the repository (its NOTICE), so the character is made from it on
first use: MjSpec reads g1.xml, and this module adds what a character needs and the model lacks
(a floor, PD gains and torque limits, joint damping and rotor inertia, end effectors, body sets,
pose-error weights) and removes what would tie the file to its folder (the STL meshes, which are
visual only: the collision capsules and spheres are shown instead). The result is one
self-contained MJCF in the user's cache, rebuilt whenever its text would change, so that exported
policies can carry it.

Gains: each joint's motor (Unitree's 5020, 7520-14, 7520-22, 4010 actuators; two 5020s drive the
ankles and the waist's roll and pitch) gives its rotor inertia (armature) and effort limit; the PD
gains put every joint at a 10 Hz natural frequency with damping ratio 2 (kp = I w^2,
kd = 2 zeta I w), as mjlab's and BeyondMimic's G1 do. Self-collision is off, as for the humanoid.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import mujoco

from mjxmimic.core.errors import UserError

NAME = "g1"
CLIP_PREFIX = f"{NAME}_"
ENV_VAR = "MJXMIMIC_G1"  # g1.xml, or the folder that holds it
SHARED_PATH = Path("shared") / "robots" / "unitree_g1" / "g1.xml"

# motor: (armature kg m^2, effort limit N m)
MOTORS = {
    "5020": (0.003609725, 25.0),
    "2x5020": (2 * 0.003609725, 50.0),
    "7520_14": (0.010177520, 88.0),
    "7520_22": (0.025101925, 139.0),
    "4010": (0.00425, 5.0),
}
NATURAL_FREQUENCY = 10.0 * 2.0 * math.pi  # rad/s
DAMPING_RATIO = 2.0

# joint (without side and "_joint"): (motor, pose-error weight); weights follow DeepMimic's humanoid
# (hip 0.5, knee 0.3, ankle 0.2, chest 0.5, shoulder 0.3, elbow 0.2), wrists lightly.
LEG = {"hip_pitch": ("7520_14", 0.5), "hip_roll": ("7520_22", 0.5), "hip_yaw": ("7520_14", 0.5),
       "knee": ("7520_22", 0.3), "ankle_pitch": ("2x5020", 0.2), "ankle_roll": ("2x5020", 0.2)}
WAIST = {"waist_yaw": ("7520_14", 0.5), "waist_roll": ("2x5020", 0.5), "waist_pitch": ("2x5020", 0.5)}
ARM = {"shoulder_pitch": ("5020", 0.3), "shoulder_roll": ("5020", 0.3), "shoulder_yaw": ("5020", 0.3),
       "elbow": ("5020", 0.2), "wrist_roll": ("5020", 0.1), "wrist_pitch": ("4010", 0.1),
       "wrist_yaw": ("4010", 0.1)}
ROOT_WEIGHT = 1.0


def _joint_table() -> dict[str, tuple[str, float]]:
    """Every hinge by name -> (motor, pose-error weight); the clip order is the model's."""
    table = {f"left_{k}_joint": v for k, v in LEG.items()}
    table.update({f"right_{k}_joint": v for k, v in LEG.items()})
    table.update({f"{k}_joint": v for k, v in WAIST.items()})
    table.update({f"left_{k}_joint": v for k, v in ARM.items()})
    table.update({f"right_{k}_joint": v for k, v in ARM.items()})
    return table


BODY_SETS = {
    "feet": "left_ankle_roll_link right_ankle_roll_link",
    "hands": "left_wrist_roll_link left_wrist_pitch_link left_wrist_yaw_link "
             "right_wrist_roll_link right_wrist_pitch_link right_wrist_yaw_link",
    "torso": "pelvis waist_yaw_link waist_roll_link torso_link",
}
END_EFFECTORS = "left_ankle_roll_link right_ankle_roll_link left_wrist_yaw_link right_wrist_yaw_link"


def find_source() -> Path:
    """g1.xml: $MJXMIMIC_G1 (the file or its folder), else shared/robots/unitree_g1/g1.xml in the
    working directory or one of its parents."""
    setting = os.environ.get(ENV_VAR, "").strip()
    if setting:
        path = Path(setting).expanduser()
        path = path / "g1.xml" if path.is_dir() else path
        if not path.is_file():
            raise UserError(f"${ENV_VAR}={setting}: no g1.xml there")
        return path
    here = Path.cwd().resolve()
    for folder in (here, *here.parents):
        if (folder / SHARED_PATH).is_file():
            return folder / SHARED_PATH
    raise UserError(f"character {NAME!r}: the Unitree G1 model was not found (set ${ENV_VAR} to its g1.xml; "
                    f"looked for {SHARED_PATH} in {here} and its parents)")


def cache_path() -> Path:
    root = Path(os.environ.get("XDG_CACHE_HOME", "~/.cache")).expanduser()
    return root / "mjxmimic" / "characters" / f"{NAME}.xml"


def build_xml(source: Path) -> str:
    """The G1 character's MJCF text, self-contained."""
    spec = mujoco.MjSpec.from_file(str(source))
    spec.modelname = "unitree_g1_mjxmimic"
    spec.meshdir = ""
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER  # the PD law's implicit damping needs Euler
    spec.option.timestep = 1.0 / 240.0
    for geom in list(spec.geoms):
        if geom.type == mujoco.mjtGeom.mjGEOM_MESH:
            spec.delete(geom)
    for mesh in list(spec.meshes):
        spec.delete(mesh)
    for geom in spec.geoms:
        geom.group = 0
        geom.rgba = [0.62, 0.64, 0.68, 1.0]
        geom.contype, geom.conaffinity = 1, 0
    table = _joint_table()
    names = [j.name for j in spec.joints if j.type == mujoco.mjtJoint.mjJNT_HINGE]
    if sorted(names) != sorted(table):
        raise UserError(f"{source}: expected the 29 hinges of the G1 (29 DoF), found {len(names)}")
    for joint in spec.joints:
        if joint.type != mujoco.mjtJoint.mjJNT_HINGE:
            continue
        motor, weight = table[joint.name]
        armature, effort = MOTORS[motor]
        joint.armature = armature
        joint.damping = [2.0 * DAMPING_RATIO * armature * NATURAL_FREQUENCY, 0.0, 0.0]  # linear term only
        kp = armature * NATURAL_FREQUENCY**2
        _numeric(spec, f"joint/{joint.name}", [kp, effort, weight])
    _numeric(spec, "joint/root", [0.0, 0.0, ROOT_WEIGHT])
    _text(spec, "clip_joint_order", " ".join(names))
    _text(spec, "clip_prefix", CLIP_PREFIX)
    _text(spec, "end_effectors", END_EFFECTORS)
    for set_name, members in BODY_SETS.items():
        _text(spec, set_name, members)
    _add_floor(spec)
    return f"<!-- Made by mjxmimic.core.g1_character from {source.name} (see its NOTICE); rebuilt on use. -->\n" \
        + spec.to_xml()


def _numeric(spec: mujoco.MjSpec, name: str, data: list[float]) -> None:
    item = spec.add_numeric()
    item.name, item.data = name, data


def _text(spec: mujoco.MjSpec, name: str, data: str) -> None:
    item = spec.add_text()
    item.name, item.data = name, data


def _add_floor(spec: mujoco.MjSpec) -> None:
    texture = spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                               builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, width=512, height=512,
                               rgb1=[0.82, 0.82, 0.80], rgb2=[0.70, 0.70, 0.68])
    material = spec.add_material(name="grid", texrepeat=[1, 1], texuniform=True)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = texture.name
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                            material="grid", contype=0, conaffinity=1)
    spec.worldbody.add_light(name="sun", pos=[0, 0, 6], dir=[0, 0.2, -1],
                             type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)


def ensure_xml() -> Path:
    """The character's MJCF in the cache, written (atomically) when missing or out of date."""
    text = build_xml(find_source())
    path = cache_path()
    if path.is_file() and path.read_text(encoding="utf-8") == text:
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
    return path
