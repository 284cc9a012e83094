"""A BVH recording -> a clip for one of our characters (`mjxmimic clips import`).

The source skeleton is mapped onto the character by a mapping file (`skeletons/*.json`, picked by
the joint names it needs, or given; for the humanoid, else guessed: `skeleton_guess`): which source
joint drives which character body, the source's up and forward axes, and the leg whose length sets
the scale. Each mapped body takes its
source joint's world orientation; where a body has one mapped child (a thigh, a forearm), the
rest-pose bone directions of the two skeletons are aligned first, so that a leg that rests
splayed in the capture still stands straight on the character. A rest pose that does not stand
(LAFAN1's joints each have a frame of their own, so its bones lie in a heap at rest) gives way to
the recording's frame whose bones point most nearly as the character's do at rest. Hinges keep
the twist about their axis (the rest passes on to the child) within their range; the root is
scaled by the leg lengths' ratio; the clip is resampled, moved to the origin and put on the ground.
"""

from __future__ import annotations

import dataclasses
import itertools
from pathlib import Path

import mujoco
import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.character import Character
from mjxmimic.core.errors import UserError, read_json
from mjxmimic.motion import quality
from mjxmimic.motion.bvh import Bvh
from mjxmimic.motion.clip import Clip
from mjxmimic.motion.flight import flights

SKELETONS = Path(__file__).resolve().parent / "skeletons"
AXIS_NAMES = {"x": 0, "y": 1, "z": 2}


@dataclasses.dataclass(frozen=True)
class Mapping:
    path: Path | None  # None: guessed from the joint names (skeleton_guess)
    up: np.ndarray  # (3,) the source's up axis, in source coordinates
    forward: np.ndarray  # (3,) the direction the source skeleton faces at rest
    bodies: dict[str, str]  # character body -> source joint
    scale_chain: tuple[str, ...]  # character bodies from hip to ankle
    root_anchor: tuple[str, ...]  # bodies whose mean position places the root (the hip joints)

    @property
    def label(self) -> str:
        return self.path.name if self.path is not None else "guessed from the joint names"

    def as_file(self, character_name: str) -> dict:
        """The mapping in the format of skeletons/*.json, to save and edit."""
        return {"up": _axis_text(self.up), "forward": _axis_text(self.forward),
                "characters": {character_name: {"bodies": dict(self.bodies), "scale_chain": list(self.scale_chain),
                                                "root_anchor": list(self.root_anchor)}}}


def _axis(text: object, where: str) -> np.ndarray:
    if not isinstance(text, str) or len(text) != 2 or text[0] not in "+-" or text[1] not in AXIS_NAMES:
        raise UserError(f"{where}: {text!r} is not an axis like '+y' or '-z'")
    out = np.zeros(3)
    out[AXIS_NAMES[text[1]]] = 1.0 if text[0] == "+" else -1.0
    return out


def _axis_text(axis: np.ndarray) -> str:
    k = int(np.argmax(np.abs(axis)))
    return ("+" if axis[k] > 0 else "-") + "xyz"[k]


def load_mapping(path: Path, character_name: str) -> Mapping:
    data = read_json(path, "mapping file")
    if not isinstance(data, dict) or not isinstance(data.get("characters"), dict):
        raise UserError(f"{path}: expected an object with 'up', 'forward' and 'characters'")
    target = data["characters"].get(character_name)
    if not isinstance(target, dict) or not isinstance(target.get("bodies"), dict):
        known = ", ".join(sorted(data["characters"])) or "none"
        raise UserError(f"{path}: no mapping for character {character_name!r} (it maps: {known})")
    up, forward = _axis(data.get("up"), f"{path}: up"), _axis(data.get("forward"), f"{path}: forward")
    if abs(float(up @ forward)) > 0:
        raise UserError(f"{path}: up and forward must be different axes")
    chain = target.get("scale_chain")
    if not isinstance(chain, list) or len(chain) < 2 or any(b not in target["bodies"] for b in chain):
        raise UserError(f"{path}: {character_name}.scale_chain must list two or more mapped bodies (hip to ankle)")
    anchor = target.get("root_anchor")
    if not isinstance(anchor, list) or not anchor or any(b not in target["bodies"] for b in anchor):
        raise UserError(f"{path}: {character_name}.root_anchor must list mapped bodies (the hip joints)")
    return Mapping(path, up, forward, {str(k): str(v) for k, v in target["bodies"].items()}, tuple(chain),
                   tuple(anchor))


def mapped_characters() -> set[str]:
    """The characters that a shipped mapping moves, or that a guess can (the humanoid)."""
    from mjxmimic.motion import skeleton_guess

    names = {skeleton_guess.CHARACTER}
    for path in SKELETONS.glob("*.json"):
        data = read_json(path, "mapping file")
        names |= set(data.get("characters", {})) if isinstance(data, dict) else set()
    return names


def find_mapping(bvh: Bvh, character_name: str) -> Mapping:
    """The shipped mapping whose source joints the file has, all of them; else, for the humanoid,
    one guessed from the joint names and the rest pose."""
    from mjxmimic.motion import skeleton_guess

    names = set(bvh.names)
    tried = []
    for path in sorted(SKELETONS.glob("*.json")):
        mapping = load_mapping(path, character_name)
        missing = [j for j in mapping.bodies.values() if j not in names]
        if not missing:
            return mapping
        tried.append(f"{path.stem} (no {missing[0]})")
    if character_name == skeleton_guess.CHARACTER:
        try:
            return skeleton_guess.guess_mapping(bvh)
        except skeleton_guess.NoGuess as why:
            tried.append(f"a guess from the joint names ({why})")
    raise UserError(f"{bvh.path}: no skeleton mapping fits its joints (tried {', '.join(tried)}); "
                    f"write one like {SKELETONS / 'cmu_max.json'} and pass --mapping")


def _source_to_world(mapping: Mapping) -> np.ndarray:
    """(3, 3) rotation from the source's coordinates to the character's (z up, facing +x)."""
    left = np.cross(mapping.up, mapping.forward)
    return np.stack([mapping.forward, left, mapping.up])  # rows: world x, y, z in source terms


def _matrix_quat(m: np.ndarray) -> np.ndarray:
    out = np.zeros(4)
    mujoco.mju_mat2Quat(out, np.ascontiguousarray(m, dtype=np.float64).reshape(-1))
    return out



@dataclasses.dataclass(frozen=True)
class Imported:
    clip: Clip
    report: dict


def import_bvh(bvh: Bvh, character: Character, mapping: Mapping, *, start: float = 0.0, end: float | None = None,
               fps: float = 60.0, loop: bool = False, name: str = "clip") -> Imported:
    model = character.model
    body_id = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, n) for n in mapping.bodies}
    for body, bid in body_id.items():
        if bid < 0:
            raise UserError(f"{mapping.path or mapping.label}: the character has no body {body!r}")
    for joint in mapping.bodies.values():
        if joint not in bvh.names:
            raise UserError(f"{bvh.path}: no joint {joint!r}, which {mapping.label} maps")
    if model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE or model.jnt_bodyid[0] != 1:
        raise UserError(f"{character.xml_path}: the character's first body needs a free joint")
    root = model.body(1).name
    if mapping.bodies.get(root) is None:
        raise UserError(f"{mapping.path or mapping.label}: the character's root body {root!r} is not mapped")
    if fps <= 0:
        raise UserError(f"--fps {fps:g}: must be positive")

    length = (bvh.num_frames - 1) * bvh.frame_time
    stop = length if end is None else end
    if not 0 <= start < stop <= length + 1e-9:
        raise UserError(f"{bvh.path}: --start {start:g} --end {stop:g} s is not within its {length:.3f} s")
    first, last = int(np.floor(start / bvh.frame_time)), int(np.ceil(stop / bvh.frame_time - 1e-9))
    all_pos, all_rot = bvh.forward_kinematics()
    src_pos = all_pos[first:last + 1]
    times = np.arange(first, last + 1) * bvh.frame_time

    to_world = _source_to_world(mapping)
    q_world = _matrix_quat(to_world)
    rest = bvh.rest_positions()
    joint_of = {b: bvh.index(j) for b, j in mapping.bodies.items()}

    # the character at rest (every joint at zero) for bone directions and frames
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    rest_xpos, rest_xquat = data.xpos.copy(), data.xquat.copy()

    def mapped_parent(b: int) -> int | None:
        p = int(model.body_parentid[b])
        while p > 0 and model.body(p).name not in mapping.bodies:
            p = int(model.body_parentid[p])
        return p if p > 0 else None

    children: dict[int, list[int]] = {body_id[b]: [] for b in mapping.bodies}
    for b in mapping.bodies:
        parent = mapped_parent(body_id[b])
        if parent is not None:
            children[parent].append(body_id[b])

    # desired world orientation of each mapped body, frame by frame: the source joint's turn from
    # the calibration posture, applied to the body at rest (its bone first aligned with the source's)
    bones = [(bid, children[bid][0], joint_of[b], joint_of[model.body(children[bid][0]).name])
             for b, bid in body_id.items() if len(children[bid]) == 1]  # (body, child, their joints)
    leg = [(joint_of[a], joint_of[b]) for a, b in itertools.pairwise(mapping.scale_chain)]
    spine = [(joint_of[root], joint_of[model.body(c).name]) for c in children[body_id[root]]
             if model.body(c).name not in mapping.root_anchor]
    world_rot = quat.mul(quat.mul(q_world, all_rot), quat.conj(q_world))  # every frame, the character's axes
    if rest_stands(rest, mapping.up, down=leg, up=spine):
        cal = _Calibration(np.tile([1.0, 0.0, 0.0, 0.0], (len(bvh.joints), 1)), rest @ to_world.T,
                           np.array([1.0, 0.0, 0.0, 0.0]), {"calibration": "rest pose"})
    else:
        cal = _frame_calibration(bvh, mapping, all_pos @ to_world.T, world_rot, joint_of, bones, rest_xpos, body_id)
    src_in_world = world_rot[first:last + 1]
    desired: dict[int, np.ndarray] = {}
    bone_of = {body: (child, jb, jc) for body, child, jb, jc in bones}
    for b, bid in body_id.items():
        align = np.array([1.0, 0.0, 0.0, 0.0])
        if bid in bone_of:
            child, jb, jc = bone_of[bid]
            target_bone = quat.rotate(cal.heading, rest_xpos[child] - rest_xpos[bid])
            source_bone = cal.pos[jc] - cal.pos[jb]
            if np.linalg.norm(target_bone) > 1e-6 and np.linalg.norm(source_bone) > 1e-6:
                align = quat.between(target_bone, source_bone)
        j = joint_of[b]
        turn = quat.mul(src_in_world[:, j], quat.conj(cal.rot[j]))
        desired[bid] = quat.mul(turn, quat.mul(align, quat.mul(cal.heading, rest_xquat[bid])))

    # joint by joint from the root: each takes what its parent left over
    frames = len(times)
    qpos = np.tile(model.qpos0, (frames, 1))
    world = np.zeros((frames, model.nbody, 4))
    world[:, 0, 0] = 1.0
    limit_hits, hinge_samples = 0, 0
    for b in range(1, model.nbody):
        parent_frame = quat.mul(world[:, model.body_parentid[b]], model.body_quat[b])
        joints = [j for j in range(model.njnt) if model.jnt_bodyid[j] == b]
        if not joints:
            world[:, b] = parent_frame
            continue
        if len(joints) > 1:
            raise UserError(f"{character.xml_path}: body {model.body(b).name!r} has more than one joint")
        j, adr = joints[0], model.jnt_qposadr[joints[0]]
        want = desired.get(b)
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            qpos[:, adr + 3:adr + 7] = want
            local = want
        elif want is None:
            local = np.tile([1.0, 0.0, 0.0, 0.0], (frames, 1))  # an unmapped joint stays at zero
            if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
                qpos[:, adr] = 0.0
        elif model.jnt_type[j] == mujoco.mjtJoint.mjJNT_BALL:
            local = quat.normalize(quat.mul(quat.conj(parent_frame), want))
            qpos[:, adr:adr + 4] = local
        elif model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
            full = quat.mul(quat.conj(parent_frame), want)
            axis = model.jnt_axis[j]
            angle = 2 * np.arctan2(full[:, 1:] @ axis, full[:, 0])
            angle = (angle + np.pi) % (2 * np.pi) - np.pi
            if model.jnt_limited[j]:
                low, high = model.jnt_range[j]
                clipped = np.clip(angle, low, high)
                limit_hits += int(np.sum(np.abs(clipped - angle) > 1e-6))
                angle = clipped
            hinge_samples += frames
            qpos[:, adr] = angle
            local = np.concatenate([np.cos(angle / 2)[:, None], np.sin(angle / 2)[:, None] * axis], axis=1)
        else:
            raise UserError(f"{character.xml_path}: joint {model.joint(j).name!r} is neither free, ball nor hinge")
        world[:, b] = quat.mul(parent_frame, local)

    # root position: the anchor (the hips' mean) where the source's is, scaled by the legs' ratio
    chain = [body_id[b] for b in mapping.scale_chain]
    target_leg = sum(np.linalg.norm(rest_xpos[c] - rest_xpos[p]) for p, c in zip(chain, chain[1:]))
    source_leg = sum(np.linalg.norm(rest[joint_of[model.body(c).name]] - rest[joint_of[model.body(p).name]])
                     for p, c in zip(chain, chain[1:]))
    scale = float(target_leg / source_leg)
    anchor_src = np.mean([src_pos[:, joint_of[b]] for b in mapping.root_anchor], axis=0) @ to_world.T * scale
    anchor_offset = np.mean([rest_xpos[body_id[b]] - rest_xpos[1] for b in mapping.root_anchor], axis=0)
    qpos[:, 0:3] = anchor_src - quat.rotate(qpos[:, 3:7], np.broadcast_to(anchor_offset, (frames, 3)))

    qpos = _resample(model, qpos, times - times[0], fps, stop - start)
    qpos[:, 0:2] -= qpos[0, 0:2]
    qpos, lowest, ground_shift = quality.put_on_ground(character, qpos)

    durations = np.full(qpos.shape[0], 1.0 / fps)
    clip = Clip(name=name, path=None, loop=loop, durations=durations, qpos=qpos)
    report = _report(character, mapping, clip, bvh, src_pos, times - times[0], scale, to_world, joint_of, lowest)
    report.update(ground_shift_m=ground_shift, joint_limit_hits=limit_hits,
                  joint_limit_hit_rate=limit_hits / max(hinge_samples, 1), source_frames=frames, **cal.report,
                  source_fps=1.0 / bvh.frame_time, start_s=start, end_s=stop)
    return Imported(clip, report)


def rest_stands(rest: np.ndarray, axis: np.ndarray, *, down: list[tuple[int, int]],
                up: list[tuple[int, int]]) -> bool:
    """Whether a rest pose (joint positions, every channel zero) stands along `axis`: the bones
    (joint index pairs) of `down` (legs) point down it and those of `up` (the spine) up, within 37
    degrees."""
    def along(pairs: list[tuple[int, int]], sign: float) -> bool:
        return all(sign * float((rest[c] - rest[p]) @ axis) >= 0.8 * float(np.linalg.norm(rest[c] - rest[p]))
                   for p, c in pairs)

    return along(down, -1.0) and along(up, 1.0)


@dataclasses.dataclass(frozen=True)
class _Calibration:
    """The source posture that the character's rest pose is matched with: the file's rest pose
    where it stands, else a frame of the recording (`_frame_calibration`)."""
    rot: np.ndarray  # (J, 4) the source joints' world rotations there, in the character's axes
    pos: np.ndarray  # (J, 3) their positions
    heading: np.ndarray  # (4,) the turn about up from the character's rest facing to the source's
    report: dict


def _frame_calibration(bvh: Bvh, mapping: Mapping, pos: np.ndarray, rot: np.ndarray, joint_of: dict[str, int],
                       bones: list[tuple[int, int, int, int]], rest_xpos: np.ndarray,
                       body_id: dict[str, int]) -> _Calibration:
    """For a rest pose that does not stand (LAFAN1's bones all lie along x at rest, each joint's
    frame its own): the recording's frame (`pos`, `rot`: every frame's joints in the character's
    axes) whose bones point most nearly as the character's do at rest, turned to face as the
    source does there."""
    right, left = mapping.root_anchor[0], mapping.root_anchor[-1]
    target_side = rest_xpos[body_id[left]] - rest_xpos[body_id[right]]
    source_side = pos[:, joint_of[left]] - pos[:, joint_of[right]]
    # (one anchor, right == left: both sides are zero vectors, and arctan2(0, 0) = 0 leaves no turn)
    yaw = np.arctan2(source_side[:, 1], source_side[:, 0]) - np.arctan2(target_side[1], target_side[0])
    heading = quat.from_yaw(yaw)  # (F, 4)
    target = np.stack([rest_xpos[c] - rest_xpos[b] for b, c, _, _ in bones])  # (B, 3)
    source = np.stack([pos[:, jc] - pos[:, jb] for _, _, jb, jc in bones], axis=1)  # (F, B, 3)
    turned = quat.rotate(np.repeat(heading[:, None], len(bones), axis=1), np.broadcast_to(target, source.shape))
    cos = np.sum(turned * source, axis=-1) / np.maximum(
        np.linalg.norm(turned, axis=-1) * np.linalg.norm(source, axis=-1), 1e-12)
    error = np.mean(np.arccos(np.clip(cos, -1.0, 1.0)), axis=1)  # (F,)
    f = int(np.argmin(error))
    return _Calibration(rot[f], pos[f], heading[f], {"calibration": {
        "frame": f, "time_s": f * bvh.frame_time, "bone_angle_rad": float(error[f])}})


def _resample(model: mujoco.MjModel, qpos: np.ndarray, times: np.ndarray, fps: float, length: float) -> np.ndarray:
    """qpos at 0, 1/fps, ... up to `length`: positions and angles linearly, quaternions by slerp."""
    count = int(np.floor(length * fps + 1e-6)) + 1
    out_times = np.minimum(np.arange(count) / fps, times[-1])
    i = np.clip(np.searchsorted(times, out_times, side="right") - 1, 0, len(times) - 2)
    w = ((out_times - times[i]) / (times[i + 1] - times[i]))[:, None]
    out = (1 - w) * qpos[i] + w * qpos[i + 1]
    for j in range(model.njnt):
        adr = model.jnt_qposadr[j]
        if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            adr += 3
        elif model.jnt_type[j] != mujoco.mjtJoint.mjJNT_BALL:
            continue
        a, b = qpos[i, adr:adr + 4], qpos[i + 1, adr:adr + 4]
        b = np.where(np.sum(a * b, axis=1, keepdims=True) < 0, -b, b)
        out[:, adr:adr + 4] = quat.normalize(quat.slerp(a, b, w))
    return out


def _report(character: Character, mapping: Mapping, clip: Clip, bvh: Bvh, src_pos: np.ndarray, src_times: np.ndarray,
            scale: float, to_world: np.ndarray, joint_of: dict[str, int], lowest: np.ndarray) -> dict:
    """End-effector error against the scaled source (both relative to the root anchor), foot skating,
    penetration."""
    model = character.model
    positions, _ = quality.body_poses(character, clip.qpos)
    times = np.arange(clip.num_frames) / clip.fps
    anchor_src = np.mean([src_pos[:, joint_of[b]] for b in mapping.root_anchor], axis=0)
    anchor_tgt = np.mean([positions[:, model.body(b).id] for b in mapping.root_anchor], axis=0)
    errors = {}
    for b in character.end_effectors:
        name = model.body(b).name
        if name not in joint_of:
            continue
        rel_src = (src_pos[:, joint_of[name]] - anchor_src) @ to_world.T * scale
        rel_src = np.stack([np.interp(times, src_times, rel_src[:, k]) for k in range(3)], axis=1)
        rel_tgt = positions[:, b] - anchor_tgt
        errors[name] = float(np.mean(np.linalg.norm(rel_tgt - rel_src, axis=1)))
    skating = quality.foot_skating(character, clip.qpos, clip.fps)
    return {
        "frames": clip.num_frames, "fps": round(clip.fps, 9), "duration_s": round(clip.duration, 9), "scale": scale,
        "mapping": str(mapping.path or mapping.label),
        "end_effector_error_m": errors,
        "end_effector_error_mean_m": float(np.mean(list(errors.values()))) if errors else None,
        "foot_skating_m_per_s": skating,
        **quality.ground_report(lowest),
        "airborne": [f.as_dict() for f in flights(character, clip)],
    }
