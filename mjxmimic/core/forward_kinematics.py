"""Forward kinematics of a character's pose, in plain array code (numpy or jax.numpy).

The env needs, for the simulated body and the reference alike, only the body frames, centres of
mass and velocities (`Kin`). MJX's general kinematics (mj_kinematics, mj_comPos, mj_comVel) also
computes geoms, sites, inertias and motion subspaces, and it is the largest part of the compiled
training step: three copies of it (simulated body, reference, fresh reset) made most of the
step's compile time. This walks the kinematic tree once, level by level (all bodies of one depth
at once), with MuJoCo's conventions, and is tested against MuJoCo C on every character.

Conventions (MuJoCo's): a free joint's qpos is the body origin and orientation in the world, its
qvel the origin's world velocity then the angular velocity in the body frame; a ball joint's qvel
is the angular velocity in the body frame; a hinge turns about its axis in the parent-side
frame; joints rotate about their anchor (`jnt_pos`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.kinematics import ROOT_BODY, Kin

FREE, BALL, SLIDE, HINGE = 0, 1, 2, 3


class _Level(NamedTuple):
    """The bodies of one tree depth that carry joints of one type (or none)."""

    bodies: np.ndarray
    parents: np.ndarray
    joint_type: int  # -1: welded to its parent
    qposadr: np.ndarray
    dofadr: np.ndarray
    jnt_pos: np.ndarray  # (n, 3) anchor in the body frame
    jnt_axis: np.ndarray  # (n, 3)


class Tree(NamedTuple):
    """Static description of the kinematic tree, read once from an MjModel."""

    nbody: int
    levels: tuple[_Level, ...]
    body_pos: np.ndarray
    body_rot: np.ndarray  # (nbody, 3, 3) body_quat as matrices
    body_ipos: np.ndarray
    mass: np.ndarray  # (nbody,) the root subtree's masses, 0 elsewhere


def read_tree(model: Any) -> Tree:
    """The tree of `model`. Each body may carry at most one joint (every character here does);
    a model that breaks this is refused by name."""
    nbody = model.nbody
    depth = np.zeros(nbody, int)
    for b in range(1, nbody):
        depth[b] = depth[model.body_parentid[b]] + 1
        if model.body_jntnum[b] > 1:
            raise ValueError(f"body {model.body(b).name!r} has {model.body_jntnum[b]} joints; "
                             "forward kinematics here takes at most one per body")
        if model.body_jntnum[b] == 1 and model.jnt_type[model.body_jntadr[b]] == FREE and model.body_parentid[b] != 0:
            raise ValueError(f"body {model.body(b).name!r}: a free joint below another body")
    levels = []
    for d in range(1, depth.max() + 1):
        at_depth = np.flatnonzero(depth == d)
        types = np.where(model.body_jntnum[at_depth] == 1, model.jnt_type[model.body_jntadr[at_depth]], -1)
        for t in sorted(set(types.tolist())):
            bodies = at_depth[types == t]
            joints = model.body_jntadr[bodies] if t >= 0 else np.zeros(len(bodies), int)
            levels.append(_Level(
                bodies=bodies, parents=model.body_parentid[bodies], joint_type=t,
                qposadr=model.jnt_qposadr[joints], dofadr=model.jnt_dofadr[joints],
                jnt_pos=np.asarray(model.jnt_pos[joints], np.float32),
                jnt_axis=np.asarray(model.jnt_axis[joints], np.float32)))
    in_root = np.zeros(nbody, bool)
    for b in range(1, nbody):
        in_root[b] = b == ROOT_BODY or in_root[model.body_parentid[b]]
    return Tree(nbody=nbody, levels=tuple(levels),
                body_pos=np.asarray(model.body_pos, np.float32),
                body_rot=quat.to_matrix(np.asarray(model.body_quat, np.float64)).astype(np.float32),
                body_ipos=np.asarray(model.body_ipos, np.float32),
                mass=np.where(in_root, model.body_mass, 0.0).astype(np.float32))


def _set(xp: Any, a: Any, idx: np.ndarray, value: Any) -> Any:
    if xp is np:
        a = a.copy()
        a[idx] = value
        return a
    return a.at[idx].set(value)


def _apply(r: Any, v: Any, xp: Any) -> Any:
    """Rotation matrices (n, 3, 3) applied to vectors (n, 3) or (3,)."""
    return xp.einsum("nij,...nj->...ni", r, v) if v.ndim == 2 else xp.einsum("nij,j->ni", r, v)


def _axis_angle_matrix(axis: np.ndarray, angle: Any, xp: Any) -> Any:
    """Rodrigues: rotation by `angle` (n,) about unit `axis` (n, 3), as (n, 3, 3)."""
    k = np.zeros((len(axis), 3, 3), np.float32)  # the cross-product matrix of each axis
    k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    k = k - k.transpose(0, 2, 1)
    s, c = xp.sin(angle)[:, None, None], xp.cos(angle)[:, None, None]
    return np.eye(3, dtype=np.float32) + s * k + (1.0 - c) * (k @ k)


def kinematics(tree: Tree, qpos: Any, qvel: Any, xp: Any = np) -> Kin:
    """`Kin` of one pose (qpos, qvel); the same numbers as MuJoCo's kinematics and com velocity."""
    n = tree.nbody
    dtype = qpos.dtype
    xpos = xp.zeros((n, 3), dtype)
    xmat = xp.zeros((n, 3, 3), dtype) + xp.eye(3, dtype=dtype)
    omega = xp.zeros((n, 3), dtype)  # angular velocity, world frame
    vel = xp.zeros((n, 3), dtype)  # linear velocity of the body origin, world frame
    for lv in tree.levels:
        b, p = lv.bodies, lv.parents
        p_pos, p_rot, p_omega = xpos[p], xmat[p], omega[p]
        pos = p_pos + _apply(p_rot, tree.body_pos[b], xp)
        rot = p_rot @ tree.body_rot[b]
        w, v = p_omega, vel[p] + xp.cross(p_omega, pos - p_pos)
        if lv.joint_type == FREE:
            pos = qpos[lv.qposadr[:, None] + np.arange(3)]
            rot = quat.to_matrix(quat.normalize(qpos[lv.qposadr[:, None] + np.arange(3, 7)], xp), xp)
            v = qvel[lv.dofadr[:, None] + np.arange(3)]
            w = _apply(rot, qvel[lv.dofadr[:, None] + np.arange(3, 6)], xp)
        elif lv.joint_type in (BALL, HINGE):
            anchor = pos + _apply(rot, lv.jnt_pos, xp)
            if lv.joint_type == BALL:
                rot = rot @ quat.to_matrix(quat.normalize(qpos[lv.qposadr[:, None] + np.arange(4)], xp), xp)
                w_joint = _apply(rot, qvel[lv.dofadr[:, None] + np.arange(3)], xp)
            else:
                w_joint = _apply(rot, lv.jnt_axis, xp) * qvel[lv.dofadr][:, None]
                rot = rot @ _axis_angle_matrix(lv.jnt_axis, qpos[lv.qposadr], xp)
            pos = anchor - _apply(rot, lv.jnt_pos, xp)
            v = v + xp.cross(w_joint, pos - anchor)
            w = w + w_joint
        elif lv.joint_type == SLIDE:
            axis = _apply(rot, lv.jnt_axis, xp)
            pos = pos + axis * qpos[lv.qposadr][:, None]
            v = v + axis * qvel[lv.dofadr][:, None]
        xpos, xmat = _set(xp, xpos, b, pos), _set(xp, xmat, b, rot)
        omega, vel = _set(xp, omega, b, w), _set(xp, vel, b, v)
    offset = _apply(xmat, tree.body_ipos, xp)
    xipos = xpos + offset
    linvel = vel + xp.cross(omega, offset)
    com = xp.sum(tree.mass[:, None] * xipos, axis=0) / tree.mass.sum()
    return Kin(qpos=qpos, qvel=qvel, xipos=xipos, xmat=xmat, angvel=omega, linvel=linvel, com=com)
