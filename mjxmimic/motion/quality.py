"""What a made clip (imported or retargeted) is checked for: feet on the ground, foot skating,
penetration, joints at their limits. Shared by `clips import` and `clips retarget`."""

from __future__ import annotations

import mujoco
import numpy as np

from mjxmimic.core.character import Character
from mjxmimic.motion.clip import lowest_points

CONTACT_HEIGHT = 0.01  # m: a foot this close to the ground is taken to be planted (skating)
BELOW_GROUND = 0.005  # m: a frame whose lowest point is lower than this counts as below ground


def body_poses(character: Character, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, nbody, 3) world positions and (F, nbody, 4) orientations of every body at each pose."""
    model = character.model
    data = mujoco.MjData(model)
    xpos, xquat = np.zeros((len(qpos), model.nbody, 3)), np.zeros((len(qpos), model.nbody, 4))
    for f, q in enumerate(qpos):
        data.qpos[:] = q
        mujoco.mj_kinematics(model, data)
        xpos[f], xquat[f] = data.xpos, data.xquat
    return xpos, xquat


def put_on_ground(character: Character, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The clip moved up or down so that its lowest point is on the ground in all but 5 % of its
    frames (a few frames of a heel dipping do not lift the whole clip). Returns the qpos, each
    frame's lowest point after the move, and the move (m)."""
    lowest = lowest_points(character, qpos)
    shift = -float(np.percentile(lowest, 5))
    qpos = qpos.copy()
    qpos[:, 2] += shift
    return qpos, lowest + shift, shift


def foot_skating(character: Character, qpos: np.ndarray, fps: float) -> float | None:
    """Mean horizontal speed (m/s) of the feet while planted (both frames near the ground); None if
    the character names no feet or they never touch down."""
    positions, _ = body_poses(character, qpos)
    speeds = []
    for b in character.body_sets.get("feet", ()):
        height = lowest_points(character, qpos, (b,))
        speed = np.linalg.norm(np.diff(positions[:, b, :2], axis=0), axis=1) * fps
        planted = (height[1:] < CONTACT_HEIGHT) & (height[:-1] < CONTACT_HEIGHT)
        if planted.any():
            speeds.append(float(np.mean(speed[planted])))
    return float(np.mean(speeds)) if speeds else None


def joint_limit_hits(character: Character, qpos: np.ndarray, tolerance: float = 1e-4) -> tuple[int, int]:
    """(hinge samples at a limit, hinge samples in all) over the clip."""
    model, hits, samples = character.model, 0, 0
    for j in character.joints:
        jid = model.dof_jntid[j.dof_adr]
        if j.kind != "hinge" or not model.jnt_limited[jid]:
            continue
        low, high = model.jnt_range[jid]
        angle = qpos[:, j.qpos_adr]
        hits += int(np.sum((angle <= low + tolerance) | (angle >= high - tolerance)))
        samples += len(angle)
    return hits, samples


def ground_report(lowest: np.ndarray) -> dict:
    return {"penetration_max_m": float(max(0.0, -lowest.min())),
            "frames_below_ground": int(np.sum(lowest < -BELOW_GROUND))}
