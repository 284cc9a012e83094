"""The character: an MJCF model plus everything derived from it by name.

Joint order, qpos/qvel addresses, PD gains, torque limits, pose-error weights, end effectors and
body sets for fall contacts are read from the MJCF (joint attributes and its <custom> block) here
and nowhere else, so no index list is typed twice.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from pathlib import Path

import mujoco
import numpy as np

from mjxmimic.core import g1_character
from mjxmimic.core.errors import UserError

XML_DIR = Path(__file__).resolve().parent / "characters"
DEFAULT_XML = XML_DIR / "humanoid.xml"

BALL, HINGE = "ball", "hinge"
_FREE, _BALL, _HINGE = (int(mujoco.mjtJoint.mjJNT_FREE), int(mujoco.mjtJoint.mjJNT_BALL),
                        int(mujoco.mjtJoint.mjJNT_HINGE))


@dataclasses.dataclass(frozen=True)
class Joint:
    """One actuated joint (ball or hinge) in clip order."""

    name: str
    kind: str  # BALL or HINGE
    body: int
    qpos_adr: int
    dof_adr: int
    kp: float
    kd: float
    torque_limit: float
    weight: float  # pose-error weight, normalised over root + joints

    @property
    def qpos_width(self) -> int:
        return 4 if self.kind == BALL else 1

    @property
    def dof_width(self) -> int:
        return 3 if self.kind == BALL else 1


@dataclasses.dataclass(frozen=True)
class Character:
    """A character model and its layout, all derived from the MJCF by name."""

    xml_path: Path
    model: mujoco.MjModel
    joints: tuple[Joint, ...]  # actuated joints in clip (DeepMimic id) order
    root_weight: float
    body_names: tuple[str, ...]  # bodies 1..nbody-1 (world excluded)
    end_effectors: tuple[int, ...]  # body ids
    body_sets: dict[str, tuple[int, ...]]  # named body-id sets (feet, hands, torso, ...)
    clip_prefix: str = ""  # DeepMimic's file-name prefix of this character's clips ("humanoid3d_")

    @property
    def nq(self) -> int:
        return self.model.nq

    @property
    def nv(self) -> int:
        return self.model.nv

    @property
    def action_size(self) -> int:
        return sum(j.dof_width for j in self.joints)

    @property
    def clip_width(self) -> int:
        """Numbers per clip frame: duration, root pos, root quat, then each joint."""
        return 1 + 3 + 4 + sum(j.qpos_width for j in self.joints)

    @property
    def mass(self) -> float:
        return float(self.model.body_subtreemass[1])

    def sha256(self) -> str:
        return hashlib.sha256(self.xml_path.read_bytes()).hexdigest()

    def fall_bodies(self, spec: str) -> tuple[int, ...]:
        """Body ids for a fall-contact spec.

        `spec` is a named set ("torso"), or "all", or "all-<set>[-<set>...]" for every body except
        those sets (e.g. "all-feet", "all-feet-hands").
        """
        parts = spec.split("-")
        if parts[0] == "all":
            excluded: set[int] = set()
            for name in parts[1:]:
                excluded |= set(self._body_set(name, spec))
            return tuple(b for b in range(1, self.model.nbody) if b not in excluded)
        if len(parts) == 1:
            return self._body_set(spec, spec)
        raise ValueError(f"fall-contact set {spec!r}: expected a set name or 'all-<set>-...'")

    def _body_set(self, name: str, spec: str) -> tuple[int, ...]:
        if name not in self.body_sets:
            known = ", ".join(sorted(self.body_sets))
            raise ValueError(f"fall-contact set {spec!r}: unknown body set {name!r} (known: {known})")
        return self.body_sets[name]


# Fall-contact body sets by clip name (DEEPMIMIC.md, "Episodes"); anything else: all but the feet.
FALL_CONTACT_BY_CLIP = {"cartwheel": "all-feet-hands", "crawl": "torso", "roll": "torso", "getup": "torso"}


def default_fall_contact(clip_name: str) -> str:
    for key, spec in FALL_CONTACT_BY_CLIP.items():
        if key in clip_name:
            return spec
    return "all-feet"


def character_names() -> list[str]:
    """The characters known by name: those the package ships (humanoid, dog3d) and those built on
    use from a model outside it (g1)."""
    return sorted([p.stem for p in XML_DIR.glob("*.xml")] + [g1_character.NAME])


@functools.lru_cache(maxsize=1)
def character_prefixes() -> dict[str, str]:
    """Each shipped character's clip file-name prefix, by name (those that have one)."""
    out = {g1_character.NAME: g1_character.CLIP_PREFIX}
    for path in XML_DIR.glob("*.xml"):
        model = mujoco.MjModel.from_xml_path(str(path))
        if _has_text(model, "clip_prefix"):
            out[path.stem] = _custom_text(model, "clip_prefix")
    return dict(sorted(out.items()))


def character_for_clip(path: Path, default: str | None = "humanoid") -> str | None:
    """The character a clip file is for, by the file-name prefix of the shipped characters
    (dog3d_* move the dog); clips without one, such as the project's own: `default`."""
    return next((name for name, prefix in character_prefixes().items() if path.stem.startswith(prefix)),
                default)


def resolve_xml(xml: str | Path) -> Path:
    """A character's MJCF: a path, a file name in the package's characters/ folder, or a NAME
    (`humanoid`, `dog3d`, `g1`)."""
    path = Path(xml)
    if path.is_file():
        return path
    if (XML_DIR / path).is_file():
        return XML_DIR / path
    if (XML_DIR / f"{xml}.xml").is_file():
        return XML_DIR / f"{xml}.xml"
    if str(xml) == g1_character.NAME:
        return g1_character.ensure_xml()
    raise UserError(f"unknown character {str(xml)!r}: not a file, and not one of {', '.join(character_names())}")


def physics_model(character: Character, physics_hz: int, solver_iterations: int,
                  ls_iterations: int) -> mujoco.MjModel:
    """A copy of the character's model at the given physics rate and solver settings."""
    model = character.model.__copy__()
    model.opt.timestep = 1.0 / physics_hz
    model.opt.iterations = solver_iterations
    model.opt.ls_iterations = ls_iterations
    return model


def _custom_text(model: mujoco.MjModel, name: str) -> str:
    idx = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, name)
    if idx < 0:
        raise ValueError(f"{name!r} missing from the model's <custom> block (a character's MJCF names its "
                         f"joints, gains and end effectors there, as mjxmimic/core/characters/humanoid.xml does; "
                         f"the Unitree G1 is --character g1)")
    adr, size = model.text_adr[idx], model.text_size[idx]
    return bytes(model.text_data[adr : adr + size]).decode().rstrip("\x00")


def _custom_numeric(model: mujoco.MjModel, name: str) -> np.ndarray:
    idx = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_NUMERIC, name)
    if idx < 0:
        raise ValueError(f"{name!r} missing from the model's <custom> block")
    adr, size = model.numeric_adr[idx], model.numeric_size[idx]
    return np.asarray(model.numeric_data[adr : adr + size], dtype=np.float64)


def _body_ids(model: mujoco.MjModel, names: str) -> tuple[int, ...]:
    ids = []
    for name in names.split():
        idx = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)
        if idx < 0:
            raise ValueError(f"body {name!r} named in <custom> does not exist")
        ids.append(idx)
    return tuple(ids)


def load_character(xml_path: str | Path = DEFAULT_XML) -> Character:
    """Load an MJCF character and derive its layout by name; a file that is not one (MuJoCo cannot
    read it, or it lacks the character's <custom> block) is a one-line UserError naming it."""
    xml_path = Path(xml_path)
    if not xml_path.is_file():
        raise UserError(f"{xml_path}: character file not found")
    try:
        return _load_character(xml_path)
    except ValueError as err:  # MuJoCo's own parse and compile errors are ValueErrors too
        why = " ".join(str(err).split()).removeprefix(f"{xml_path}: ")
        raise UserError(f"character {xml_path}: {why}") from None


def _load_character(xml_path: Path) -> Character:
    model = mujoco.MjModel.from_xml_path(str(xml_path))
    if model.njnt == 0 or int(model.jnt_type[0]) != _FREE:
        raise ValueError(f"{xml_path}: the first joint must be the root's free joint")

    raw = []
    for name in _custom_text(model, "clip_joint_order").split():
        jid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if jid < 0:
            raise ValueError(f"{xml_path}: joint {name!r} in clip_joint_order does not exist")
        jtype = int(model.jnt_type[jid])
        if jtype not in (_BALL, _HINGE):
            raise ValueError(f"{xml_path}: joint {name!r} must be a ball or hinge joint")
        kp, limit, weight = _custom_numeric(model, f"joint/{name}")
        dof = model.jnt_dofadr[jid]
        raw.append((name, BALL if jtype == _BALL else HINGE, jid, kp, limit, weight, dof))
    root_weight = float(_custom_numeric(model, "joint/root")[2])
    total = root_weight + sum(r[5] for r in raw)
    joints = tuple(
        Joint(
            name=name,
            kind=kind,
            body=int(model.jnt_bodyid[jid]),
            qpos_adr=int(model.jnt_qposadr[jid]),
            dof_adr=int(dof),
            kp=float(kp),
            kd=float(model.dof_damping[dof]),
            torque_limit=float(limit),
            weight=float(weight / total),
        )
        for name, kind, jid, kp, limit, weight, dof in raw
    )
    n_actuated = sum(1 for j in range(model.njnt) if int(model.jnt_type[j]) != _FREE)
    if n_actuated != len(joints):
        raise ValueError(f"{xml_path}: clip_joint_order names {len(joints)} of {n_actuated} joints")

    body_sets = {}
    for i in range(model.ntext):
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_TEXT, i)
        if name in ("clip_joint_order", "end_effectors", "clip_prefix"):
            continue
        body_sets[name] = _body_ids(model, _custom_text(model, name))
    body_names = tuple(mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, model.nbody))
    return Character(
        xml_path=xml_path,
        model=model,
        joints=joints,
        root_weight=root_weight / total,
        body_names=body_names,
        end_effectors=_body_ids(model, _custom_text(model, "end_effectors")),
        body_sets=body_sets,
        clip_prefix=_custom_text(model, "clip_prefix") if _has_text(model, "clip_prefix") else "",
    )


def _has_text(model: mujoco.MjModel, name: str) -> bool:
    return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, name) >= 0
