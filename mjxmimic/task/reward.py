"""The imitation reward (DEEPMIMIC.md): every term a function of the simulated and the reference
kinematics, both computed by MuJoCo's own kinematics. numpy or jax.numpy via `xp`.

released (default): 0.5 exp(-2 E_pose) + 0.05 exp(-0.1 E_vel) + 0.15 exp(-10 E_ee)
                    + 0.2 exp(-5 E_root) + 0.1 exp(-10 E_com), E_com on COM velocity
paper:              0.65 exp(-2 E_pose) + 0.1 exp(-0.1 E_vel) + 0.15 exp(-40 E_ee)
                    + 0.1 exp(-10 E_com), E_com on COM position
"""

from __future__ import annotations

from typing import Any

from mjxmimic.core import quat
from mjxmimic.core.kinematics import ROOT_BODY, Kin, com_velocity, root_yaw
from mjxmimic.core.layout import Layout

# term: (weight, scale) in r = sum weight * exp(-scale * E)
RELEASED = {"pose": (0.5, 2.0), "velocity": (0.05, 0.1), "end_effector": (0.15, 10.0),
            "root": (0.2, 5.0), "com": (0.1, 10.0)}
PAPER = {"pose": (0.65, 2.0), "velocity": (0.1, 0.1), "end_effector": (0.15, 40.0), "com": (0.1, 10.0)}
KINDS = {"released": RELEASED, "paper": PAPER}


def _joint_angles(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> tuple[Any, Any]:
    """Per-joint rotation angle between sim and reference (quaternion groups, hinges)."""
    qs, qr = sim.qpos[layout.q_quat], ref.qpos[layout.q_quat]
    quat_angle = quat.angle_between(qs, qr, xp)
    hinge_angle = xp.abs(sim.qpos[layout.q_scalar[3:]] - ref.qpos[layout.q_scalar[3:]])
    return quat_angle, hinge_angle


def _end_effectors(layout: Layout, k: Kin, xp: Any) -> Any:
    """End effectors relative to the root in its heading frame, with height above the ground."""
    ee = k.xipos[layout.end_effectors]
    rel = quat.rotate_yaw(ee - k.xipos[ROOT_BODY], -root_yaw(k, xp), xp)
    return xp.concatenate([rel[:, :2], ee[:, 2:]], axis=-1)


def errors(layout: Layout, sim: Kin, ref: Kin, kind: str, xp: Any) -> dict[str, Any]:
    """The error E of each term, plus human-readable pose and end-effector errors."""
    quat_angle, hinge_angle = _joint_angles(layout, sim, ref, xp)
    e_pose = xp.sum(layout.quat_weight * quat_angle**2) + xp.sum(layout.hinge_weight * hinge_angle**2)

    ang_s, ang_r = sim.qvel[layout.v_ang], ref.qvel[layout.v_ang]
    hv = layout.v_scalar[3:]
    e_vel = xp.sum(layout.quat_weight * xp.sum((ang_s - ang_r) ** 2, axis=-1))
    e_vel = e_vel + xp.sum(layout.hinge_weight * (sim.qvel[hv] - ref.qvel[hv]) ** 2)

    ee_dist2 = xp.sum((_end_effectors(layout, sim, xp) - _end_effectors(layout, ref, xp)) ** 2, axis=-1)
    e_ee = xp.sum(ee_dist2)

    e_root = (
        xp.sum((sim.qpos[0:3] - ref.qpos[0:3]) ** 2)
        + 0.1 * quat_angle[0] ** 2
        + 0.01 * xp.sum((sim.qvel[0:3] - ref.qvel[0:3]) ** 2)
        + 0.001 * xp.sum((sim.qvel[3:6] - ref.qvel[3:6]) ** 2)
    )
    if kind == "paper":
        e_com = xp.sum((sim.com - ref.com) ** 2)
    else:
        dv = com_velocity(sim, layout.body_mass, xp) - com_velocity(ref, layout.body_mass, xp)
        e_com = 0.1 * xp.sum(dv**2)

    angle_weights = xp.sum(layout.quat_weight) + xp.sum(layout.hinge_weight)
    mean_angle = (xp.sum(layout.quat_weight * quat_angle) + xp.sum(layout.hinge_weight * hinge_angle))
    return {
        "pose": e_pose,
        "velocity": e_vel,
        "end_effector": e_ee,
        "root": e_root,
        "com": e_com,
        "pose_angle": mean_angle / angle_weights,
        "end_effector_distance": xp.mean(xp.sqrt(ee_dist2)),
    }


def reward(layout: Layout, sim: Kin, ref: Kin, kind: str, xp: Any) -> tuple[Any, dict[str, Any]]:
    """Total reward in [0, 1] and a metrics dict: reward/<term> (each in [0, 1]) and error/*."""
    e = errors(layout, sim, ref, kind, xp)
    metrics = {}
    total = 0.0
    for term, (weight, scale) in KINDS[kind].items():
        r = xp.exp(-scale * e[term])
        metrics[f"reward/{term}"] = r
        total = total + weight * r
    metrics["error/pose"] = e["pose_angle"]
    metrics["error/end_effector"] = e["end_effector_distance"]
    return total, metrics
