"""Numeric arrays derived once from a Character: where quaternions, angles and velocities sit in
qpos/qvel, PD gains and limits, pose-error weights, action slots, end effectors and masses.

Group order everywhere: "quaternion groups" are the root then each ball joint (clip order);
"scalar groups" are root x, y, z then each hinge (clip order). numpy only (CPU playback uses it).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core.character import BALL, Character


class Layout(NamedTuple):
    q_quat: np.ndarray  # (K, 4) qpos addresses of the root and ball-joint quaternions
    q_scalar: np.ndarray  # (S,) qpos addresses of the root position and hinge angles
    q_perm: np.ndarray  # (nq,) concat(scalars, quats.flat)[q_perm] == qpos
    v_ang: np.ndarray  # (K, 3) qvel addresses of root and ball angular velocities (local frames)
    v_scalar: np.ndarray  # (S,) qvel addresses of the root linear velocity and hinge rates
    v_perm: np.ndarray  # (nv,) concat(scalars, ang.flat)[v_perm] == qvel
    quat_weight: np.ndarray  # (K,) pose-error weights (root first), normalised with hinge_weight
    hinge_weight: np.ndarray  # (H,)
    ball_kp: np.ndarray  # (B,) B = K - 1
    ball_kd: np.ndarray  # (B,) the joint's MuJoCo damping
    ball_limit: np.ndarray  # (B,) torque-norm limit, N m
    hinge_kp: np.ndarray  # (H,)
    hinge_kd: np.ndarray  # (H,)
    hinge_limit: np.ndarray  # (H,)
    hinge_low: np.ndarray  # (H,) joint range
    hinge_high: np.ndarray  # (H,)
    action_ball: np.ndarray  # (B, 3) action slots of each ball joint's exponential map
    action_hinge: np.ndarray  # (H,) action slot of each hinge angle
    end_effectors: np.ndarray  # (E,) body ids
    body_mass: np.ndarray  # (nbody,)


def make_layout(character: Character) -> Layout:
    model = character.model
    q_quat, v_ang, quat_weight = [[3, 4, 5, 6]], [[3, 4, 5]], [character.root_weight]
    q_scalar, v_scalar = [0, 1, 2], [0, 1, 2]
    ball_kp, ball_kd, ball_limit, action_ball = [], [], [], []
    hinge_weight, hinge_kp, hinge_kd, hinge_limit, hinge_low, hinge_high, action_hinge = [], [], [], [], [], [], []
    slot = 0
    for j in character.joints:
        if j.kind == BALL:
            q_quat.append(list(range(j.qpos_adr, j.qpos_adr + 4)))
            v_ang.append(list(range(j.dof_adr, j.dof_adr + 3)))
            quat_weight.append(j.weight)
            ball_kp.append(j.kp)
            ball_kd.append(j.kd)
            ball_limit.append(j.torque_limit)
            action_ball.append([slot, slot + 1, slot + 2])
            slot += 3
        else:
            jid = model.dof_jntid[j.dof_adr]
            q_scalar.append(j.qpos_adr)
            v_scalar.append(j.dof_adr)
            hinge_weight.append(j.weight)
            hinge_kp.append(j.kp)
            hinge_kd.append(j.kd)
            hinge_limit.append(j.torque_limit)
            hinge_low.append(model.jnt_range[jid, 0])
            hinge_high.append(model.jnt_range[jid, 1])
            action_hinge.append(slot)
            slot += 1
    q_quat_a, v_ang_a = np.array(q_quat), np.array(v_ang)
    f32 = np.float32
    return Layout(
        q_quat=q_quat_a,
        q_scalar=np.array(q_scalar, dtype=int),
        q_perm=np.argsort(np.concatenate([q_scalar, q_quat_a.ravel()])),
        v_ang=v_ang_a,
        v_scalar=np.array(v_scalar, dtype=int),
        v_perm=np.argsort(np.concatenate([v_scalar, v_ang_a.ravel()])),
        quat_weight=np.array(quat_weight, dtype=f32),
        hinge_weight=np.array(hinge_weight, dtype=f32),
        ball_kp=np.array(ball_kp, dtype=f32),
        ball_kd=np.array(ball_kd, dtype=f32),
        ball_limit=np.array(ball_limit, dtype=f32),
        hinge_kp=np.array(hinge_kp, dtype=f32),
        hinge_kd=np.array(hinge_kd, dtype=f32),
        hinge_limit=np.array(hinge_limit, dtype=f32),
        hinge_low=np.array(hinge_low, dtype=f32),
        hinge_high=np.array(hinge_high, dtype=f32),
        action_ball=np.array(action_ball, dtype=int).reshape(-1, 3),  # (0, 3) for a character of hinges
        action_hinge=np.array(action_hinge, dtype=int),
        end_effectors=np.array(character.end_effectors),
        body_mass=model.body_mass.astype(f32),
    )


def join_qpos(layout: Layout, scalars: Any, quats: Any, xp: Any = np) -> Any:
    """qpos from its scalar groups (S,) and quaternion groups (K, 4)."""
    return xp.concatenate([scalars, xp.reshape(quats, (-1,))])[layout.q_perm]
