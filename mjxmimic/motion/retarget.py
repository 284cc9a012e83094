"""A clip of one character -> a clip of another (`mjxmimic clips retarget`).

Matching skeletons (the same joints, by name and kind, in the same clip order): the paper's way,
the joint rotations copied and the root's position scaled by the ratio of the characters' standing
root heights.

Other skeletons (the humanoid's balls onto the G1's hinge chains, other proportions): inverse
kinematics, frame by frame. A retarget file (`retargets/SOURCE_to_TARGET.json`) pairs bodies: which
target body takes which source body's orientation, which its position, and with what weight. Each
target is calibrated at rest so that the rest pose maps onto the rest pose: orientations after
aligning the rest bone directions (the G1's bent elbow follows the humanoid's straight arm), and
positions with the rest offset between the two bodies carried in the source body's frame; source
positions are scaled by the ratio of leg lengths. A damped least-squares (Levenberg-Marquardt)
solve on MuJoCo's body Jacobians, warm-started from the previous frame, keeps hinges within their
range by projection. Our own solver rather than mink: the problem has only weighted pose targets
and box limits, which a short solve on MuJoCo's Jacobians handles, and it adds no dependency (mink brings
a QP solver). The clip is then put on the ground, and a report gives the end-effector error (to
the scaled source, relative to the root), foot skating, penetration and joint-limit hits.
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
from mjxmimic.motion.clip import Clip, lowest_points
from mjxmimic.motion.flight import flights

RETARGETS = Path(__file__).resolve().parent / "retargets"


@dataclasses.dataclass(frozen=True)
class Pair:
    target: str  # target body
    source: str  # source body
    weight: float
    bone: tuple[str, str] | None = None  # (target child, source child): rest bone directions to align


@dataclasses.dataclass(frozen=True)
class RetargetMap:
    path: Path
    orientations: tuple[Pair, ...]
    positions: tuple[Pair, ...]
    scale_chain: tuple[tuple[str, ...], tuple[str, ...]]  # (target bodies, source bodies), hip to ankle


@dataclasses.dataclass(frozen=True)
class Retargeted:
    clip: Clip
    report: dict


def _pairs(path: Path, data: dict, key: str) -> tuple[Pair, ...]:
    items = data.get(key)
    if not isinstance(items, dict) or not items:
        raise UserError(f"{path}: {key!r} must map target bodies to [source body, weight]")
    out = []
    for target, value in items.items():
        ok = isinstance(value, list) and len(value) in (2, 4) and isinstance(value[0], str) \
            and isinstance(value[1], (int, float)) and value[1] > 0 and all(isinstance(v, str) for v in value[2:])
        if not ok:
            raise UserError(f"{path}: {key}.{target}: expected [source body, weight > 0] or "
                            f"[source body, weight, target child, source child]")
        out.append(Pair(target, value[0], float(value[1]), tuple(value[2:]) if len(value) == 4 else None))
    return tuple(out)


def load_map(path: Path) -> RetargetMap:
    data = read_json(path, "retarget file")
    if not isinstance(data, dict):
        raise UserError(f"{path}: expected an object with 'orientations', 'positions' and 'scale_chain'")
    unknown = sorted(set(data) - {"comment", "orientations", "positions", "scale_chain"})
    if unknown:
        raise UserError(f"{path}: unknown key {unknown[0]!r}")
    chain = data.get("scale_chain")
    if not (isinstance(chain, dict) and all(isinstance(chain.get(k), list) and len(chain[k]) >= 2
                                            for k in ("target", "source"))):
        raise UserError(f"{path}: scale_chain must be {{'target': [bodies], 'source': [bodies]}}, hip to ankle")
    return RetargetMap(path, _pairs(path, data, "orientations"), _pairs(path, data, "positions"),
                       (tuple(chain["target"]), tuple(chain["source"])))


def find_map(source_name: str, target_name: str) -> RetargetMap:
    path = RETARGETS / f"{source_name}_to_{target_name}.json"
    if not path.is_file():
        known = ", ".join(p.stem for p in sorted(RETARGETS.glob("*.json")))
        raise UserError(f"no retarget file for {source_name} -> {target_name} (shipped: {known}); "
                        f"write one like {RETARGETS / 'humanoid_to_g1.json'} and pass --map")
    return load_map(path)


def matching(source: Character, target: Character) -> bool:
    """Whether the clip's joints can be copied as they are: the same names and kinds in clip order."""
    return [(j.name, j.kind) for j in source.joints] == [(j.name, j.kind) for j in target.joints]


def _rest(character: Character) -> mujoco.MjData:
    data = mujoco.MjData(character.model)
    mujoco.mj_kinematics(character.model, data)
    return data


def _standing_height(character: Character) -> float:
    """The root's height above the lowest point at rest."""
    model = character.model
    return float(model.qpos0[2] - lowest_points(character, model.qpos0[None])[0])


def _body(character: Character, name: str, where: str) -> int:
    bid = mujoco.mj_name2id(character.model, mujoco.mjtObj.mjOBJ_BODY, name)
    if bid < 0:
        raise UserError(f"{where}: {character.xml_path.stem} has no body {name!r}")
    return bid


def _chain_length(character: Character, names: tuple[str, ...], where: str) -> float:
    rest = _rest(character).xpos
    ids = [_body(character, n, where) for n in names]
    return float(sum(np.linalg.norm(rest[b] - rest[a]) for a, b in itertools.pairwise(ids)))


def retarget(clip: Clip, source: Character, target: Character, mapping: RetargetMap | None = None, *,
             iterations: int = 50) -> Retargeted:
    """The clip on `target`; `mapping` is needed unless the skeletons match."""
    if matching(source, target):
        scale = _standing_height(target) / _standing_height(source)
        qpos = clip.qpos.copy()
        qpos[:, 0:3] *= scale
        method, errors = "copy", {}
    else:
        if mapping is None:
            raise UserError(f"{source.xml_path.stem} -> {target.xml_path.stem}: the skeletons differ; "
                            f"a retarget file is needed")
        where = str(mapping.path)
        scale = _chain_length(target, mapping.scale_chain[0], where) / \
            _chain_length(source, mapping.scale_chain[1], where)
        goals = _goals(clip, source, target, mapping, scale, iterations)
        qpos = _solve(target, goals, iterations)
        errors = _end_effector_errors(target, qpos, goals)
        method = "ik"
    qpos, lowest, shift = quality.put_on_ground(target, qpos)
    out = Clip(name=clip.name, path=None, loop=clip.loop, durations=clip.durations.copy(), qpos=qpos)
    hits, samples = quality.joint_limit_hits(target, qpos)
    report = {
        "method": method, "frames": out.num_frames, "fps": round(out.fps, 9), "duration_s": round(out.duration, 9),
        "scale": scale, "map": None if mapping is None or method == "copy" else str(mapping.path),
        "end_effector_error_m": errors,
        "end_effector_error_mean_m": float(np.mean(list(errors.values()))) if errors else None,
        "foot_skating_m_per_s": quality.foot_skating(target, qpos, out.fps),
        "source_foot_skating_m_per_s": quality.foot_skating(source, clip.qpos, clip.fps),
        **quality.ground_report(lowest), "ground_shift_m": shift,
        "joint_limit_hits": hits, "joint_limit_hit_rate": hits / max(samples, 1),
        "airborne": [f.as_dict() for f in flights(target, out)],
    }
    return Retargeted(out, report)


@dataclasses.dataclass(frozen=True)
class _Goals:
    rot_bodies: np.ndarray  # (R,) target body ids
    rot: np.ndarray  # (F, R, 4) desired world orientations
    rot_weight: np.ndarray  # (R,)
    pos_bodies: np.ndarray  # (P,)
    pos: np.ndarray  # (F, P, 3) desired world positions
    pos_weight: np.ndarray  # (P,)
    pos_names: tuple[str, ...]
    root_qpos: np.ndarray  # (F, 7) a first guess for the root


def _goals(clip: Clip, source: Character, target: Character, mapping: RetargetMap, scale: float,
           iterations: int) -> _Goals:
    where = str(mapping.path)
    src_rest, tgt_rest = _rest(source), _rest(target)
    # row 0: the source at rest, whose goals pose the target in the source's rest posture
    src_pos, src_rot = quality.body_poses(source, np.concatenate([source.model.qpos0[None], clip.qpos]))
    turn = {}  # source body -> (F + 1, 4) its rotation from rest, in the world frame

    def from_rest(sb: int) -> np.ndarray:
        if sb not in turn:
            turn[sb] = quat.mul(src_rot[:, sb], quat.conj(src_rest.xquat[sb]))
        return turn[sb]

    rot_ids, rot, rot_w = [], [], []
    for pair in mapping.orientations:
        tb, sb = _body(target, pair.target, where), _body(source, pair.source, where)
        align = np.array([1.0, 0.0, 0.0, 0.0])
        if pair.bone is not None:
            tc, sc = _body(target, pair.bone[0], where), _body(source, pair.bone[1], where)
            align = quat.between(tgt_rest.xpos[tc] - tgt_rest.xpos[tb], src_rest.xpos[sc] - src_rest.xpos[sb])
        rot_ids.append(tb)
        rot.append(quat.mul(from_rest(sb), quat.mul(align, tgt_rest.xquat[tb])))
        rot_w.append(pair.weight)
    rot_ids_a, rot_a, rot_w_a = np.array(rot_ids), np.stack(rot, 1), np.array(rot_w)
    src_qpos = np.concatenate([src_rest.qpos[None], clip.qpos])
    root_qpos = np.concatenate([scale * src_qpos[:, 0:3], src_qpos[:, 3:7]], axis=1)
    calibration = _Goals(rot_ids_a, rot_a[:1], rot_w_a, np.zeros(0, int), np.zeros((1, 0, 3)), np.zeros(0), (),
                         root_qpos[:1])
    posed = _rest(target)
    posed.qpos[:] = _solve(target, calibration, iterations)[0]
    mujoco.mj_kinematics(target.model, posed)

    pos_ids, pos, pos_w = [], [], []
    for pair in mapping.positions:
        tb, sb = _body(target, pair.target, where), _body(source, pair.source, where)
        offset = np.broadcast_to(posed.xpos[tb] - scale * src_rest.xpos[sb], (len(src_pos), 3))
        pos_ids.append(tb)
        pos.append(scale * src_pos[:, sb] + quat.rotate(from_rest(sb), offset))
        pos_w.append(pair.weight)
    return _Goals(rot_ids_a, rot_a[1:], rot_w_a, np.array(pos_ids), np.stack(pos, 1)[1:], np.array(pos_w),
                  tuple(p.target for p in mapping.positions), root_qpos[1:])


def _solve(target: Character, goals: _Goals, iterations: int, damping: float = 1e-3) -> np.ndarray:
    """(F, nq): each frame's pose that best meets the goals (weighted least squares), hinges in range."""
    model, data = target.model, mujoco.MjData(target.model)
    limited = np.array([j for j in range(model.njnt)
                        if model.jnt_limited[j] and model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE], dtype=int)
    adr, low, high = model.jnt_qposadr[limited], model.jnt_range[limited, 0], model.jnt_range[limited, 1]
    frames = goals.rot.shape[0]
    out = np.zeros((frames, model.nq))
    q = model.qpos0.copy()
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    for f in range(frames):
        q[0:7] = goals.root_qpos[f] if f == 0 else q[0:7]
        for _ in range(iterations * (4 if f == 0 else 1)):
            data.qpos[:] = q
            mujoco.mj_kinematics(model, data)
            mujoco.mj_comPos(model, data)
            rows, residual = [], []
            for k, b in enumerate(goals.rot_bodies):
                mujoco.mj_jacBody(model, data, None, jacr, b)
                err = quat.to_rotvec(quat.mul(data.xquat[b], quat.conj(goals.rot[f, k])))
                rows.append(goals.rot_weight[k] * jacr.copy())
                residual.append(goals.rot_weight[k] * err)
            for k, b in enumerate(goals.pos_bodies):
                mujoco.mj_jacBody(model, data, jacp, None, b)
                rows.append(goals.pos_weight[k] * jacp.copy())
                residual.append(goals.pos_weight[k] * (data.xpos[b] - goals.pos[f, k]))
            jac, res = np.concatenate(rows), np.concatenate(residual)
            step = -np.linalg.solve(jac.T @ jac + damping * np.eye(model.nv), jac.T @ res)
            mujoco.mj_integratePos(model, q, step, 1.0)
            q[adr] = np.clip(q[adr], low, high)
            if np.max(np.abs(step)) < 1e-6:
                break
        out[f] = q
    return out


def _end_effector_errors(target: Character, qpos: np.ndarray, goals: _Goals) -> dict[str, float]:
    """Mean distance (m) of each position-matched end effector to its goal, both relative to the
    root (the root's own goal where it has one)."""
    positions, _ = quality.body_poses(target, qpos)
    roots = list(goals.pos_bodies)
    root_goal = goals.pos[:, roots.index(1)] if 1 in roots else goals.root_qpos[:, 0:3]
    errors = {}
    for k, b in enumerate(goals.pos_bodies):
        if b in target.end_effectors:
            miss = (positions[:, b] - positions[:, 1]) - (goals.pos[:, k] - root_goal)
            errors[goals.pos_names[k]] = float(np.mean(np.linalg.norm(miss, axis=1)))
    return errors
