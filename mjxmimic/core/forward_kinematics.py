"""Forward kinematics of a character's pose, in plain array code (numpy or jax.numpy).

The env needs, for the simulated body and the reference alike, only the body frames, centres of
mass and velocities (`Kin`). MJX's general kinematics (mj_kinematics, mj_comPos, mj_comVel) also
computes geoms, sites, inertias and motion subspaces, and compiles several times slower, three
times over in each training step (simulated body, reference, fresh reset; benchmarks/startup.py
times both). This walks the kinematic tree once, level by level
(the bodies of one depth with the same joint types at once), with MuJoCo's conventions, and is
tested against MuJoCo C on every character and on joints anchored off the body origin.

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


class _Joint(NamedTuple):
    """The k-th joint of every body of a level (they share its type)."""

    kind: int
    qposadr: np.ndarray
    dofadr: np.ndarray
    pos: np.ndarray  # (n, 3) anchor in the body frame
    axis: np.ndarray  # (n, 3)


class _Level(NamedTuple):
    """The bodies of one tree depth that carry the same sequence of joint types (maybe none)."""

    bodies: np.ndarray
    parents: np.ndarray
    joints: tuple[_Joint, ...]


class Tree(NamedTuple):
    """Static description of the kinematic tree, read once from an MjModel."""

    nbody: int
    levels: tuple[_Level, ...]
    body_pos: np.ndarray
    body_rot: np.ndarray  # (nbody, 3, 3) body_quat as matrices
    body_ipos: np.ndarray
    mass: np.ndarray  # (nbody,) the root subtree's masses, 0 elsewhere


def read_tree(model: Any, nbody: int = 0) -> Tree:
    """The tree of `model`'s first `nbody` bodies (all by default: a scene's extra bodies, such as
    a thrown ball, come after the character's), read once (MuJoCo's compiler allows a free joint
    only on a child of the world, where it sets the body's frame)."""
    nbody = nbody or model.nbody
    depth = np.zeros(nbody, int)
    kinds = [()] * nbody
    for b in range(1, nbody):
        depth[b] = depth[model.body_parentid[b]] + 1
        first = model.body_jntadr[b]
        kinds[b] = tuple(int(model.jnt_type[j]) for j in range(first, first + model.body_jntnum[b]))
    levels = []
    for d in range(1, depth.max() + 1):
        at_depth = [b for b in range(1, nbody) if depth[b] == d]
        for signature in sorted({kinds[b] for b in at_depth}):
            bodies = np.array([b for b in at_depth if kinds[b] == signature])
            joints = []
            for k, kind in enumerate(signature):
                ids = model.body_jntadr[bodies] + k
                joints.append(_Joint(kind=kind, qposadr=model.jnt_qposadr[ids], dofadr=model.jnt_dofadr[ids],
                                     pos=np.asarray(model.jnt_pos[ids], np.float32),
                                     axis=np.asarray(model.jnt_axis[ids], np.float32)))
            levels.append(_Level(bodies=bodies, parents=model.body_parentid[bodies], joints=tuple(joints)))
    in_root = np.zeros(nbody, bool)
    for b in range(1, nbody):
        in_root[b] = b == ROOT_BODY or in_root[model.body_parentid[b]]
    return Tree(nbody=nbody, levels=tuple(levels),
                body_pos=np.asarray(model.body_pos[:nbody], np.float32),
                body_rot=quat.to_matrix(np.asarray(model.body_quat[:nbody], np.float64)).astype(np.float32),
                body_ipos=np.asarray(model.body_ipos[:nbody], np.float32),
                mass=np.where(in_root, model.body_mass[:nbody], 0.0).astype(np.float32))


def _set(xp: Any, a: Any, idx: np.ndarray, value: Any) -> Any:
    if xp is np:
        a = a.copy()
        a[idx] = value
        return a
    return a.at[idx].set(value)


def _apply(r: Any, v: Any, xp: Any) -> Any:
    """Rotation matrices (n, 3, 3) applied to vectors (n, 3) or (3,)."""
    return xp.einsum("nij,...nj->...ni", r, v) if v.ndim == 2 else xp.einsum("nij,j->ni", r, v)


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
        turns = []  # each rotating joint: (joint, its anchor, a hinge's world axis)
        slide = 0.0
        for j in lv.joints:
            if j.kind == FREE:
                pos = qpos[j.qposadr[:, None] + np.arange(3)]
                rot = quat.to_matrix(quat.normalize(qpos[j.qposadr[:, None] + np.arange(3, 7)], xp), xp)
                continue
            if j.kind == SLIDE:
                axis = _apply(rot, j.axis, xp)
                pos = pos + axis * qpos[j.qposadr][:, None]
                slide = slide + axis * qvel[j.dofadr][:, None]
                continue
            anchor = pos + _apply(rot, j.pos, xp)
            if j.kind == HINGE:
                turns.append((j, anchor, _apply(rot, j.axis, xp)))
                rot = rot @ quat.to_matrix(quat.from_rotvec(j.axis * qpos[j.qposadr][:, None], xp), xp)
            else:  # BALL
                turns.append((j, anchor, None))
                rot = rot @ quat.to_matrix(quat.normalize(qpos[j.qposadr[:, None] + np.arange(4)], xp), xp)
            pos = anchor - _apply(rot, j.pos, xp)
        if lv.joints and lv.joints[0].kind == FREE:
            j = lv.joints[0]
            v = qvel[j.dofadr[:, None] + np.arange(3)]
            w = _apply(rot, qvel[j.dofadr[:, None] + np.arange(3, 6)], xp)
        else:
            w, v = p_omega, vel[p] + xp.cross(p_omega, pos - p_pos) + slide
            for j, anchor, axis in turns:
                if j.kind == HINGE:
                    turn = axis * qvel[j.dofadr][:, None]
                else:  # a ball's dofs turn about the body's final axes
                    turn = _apply(rot, qvel[j.dofadr[:, None] + np.arange(3)], xp)
                w = w + turn
                v = v + xp.cross(turn, pos - anchor)
        xpos, xmat = _set(xp, xpos, b, pos), _set(xp, xmat, b, rot)
        omega, vel = _set(xp, omega, b, w), _set(xp, vel, b, v)
    offset = _apply(xmat, tree.body_ipos, xp)
    xipos = xpos + offset
    linvel = vel + xp.cross(omega, offset)
    com = xp.sum(tree.mass[:, None] * xipos, axis=0) / tree.mass.sum()
    return Kin(qpos=qpos, qvel=qvel, xipos=xipos, xmat=xmat, angvel=omega, linvel=linvel, com=com)
