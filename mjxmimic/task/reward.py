"""Imitation reward terms (DEEPMIMIC.md). Each term is a pure error function E(sim, ref) of the
simulated and the reference kinematics; a reward list gives each term a weight and a scale, and
r = sum weight * exp(-scale * E). The released code's five terms and the paper's four are two
lists; `reward.weights` re-weights (or, with 0, drops) terms of the chosen list.

released (default): 0.5 exp(-2 E_pose) + 0.05 exp(-0.1 E_vel) + 0.15 exp(-10 E_ee)
                    + 0.2 exp(-5 E_root) + 0.1 exp(-10 E_com); E_pose and E_vel weigh each joint
                    by its DiffWeight (normalised), E_ee is in each root's heading frame, E_com on
                    COM velocity
paper:              0.65 exp(-2 E_pose) + 0.1 exp(-0.1 E_vel) + 0.15 exp(-40 E_ee)
                    + 0.1 exp(-10 E_com), as the paper writes them: plain sums over the joints (no
                    weights), end effectors and COM at their world positions (the reference's root
                    moved as the reward moves it, reward.sync_root_position)
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

from mjxmimic.core import quat
from mjxmimic.core.errors import UserError
from mjxmimic.core.kinematics import ROOT_BODY, Kin, com_velocity, root_yaw
from mjxmimic.core.layout import Layout


class Term(NamedTuple):
    name: str  # logged as reward/<name>
    error: Callable[[Layout, Kin, Kin, Any], Any]
    weight: float
    scale: float


def joint_angles(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> tuple[Any, Any]:
    """Per-joint rotation angle between sim and reference (quaternion groups, hinges)."""
    quat_angle = quat.angle_between(sim.qpos[layout.q_quat], ref.qpos[layout.q_quat], xp)
    hinge_angle = xp.abs(sim.qpos[layout.q_scalar[3:]] - ref.qpos[layout.q_scalar[3:]])
    return quat_angle, hinge_angle


def end_effectors(layout: Layout, k: Kin, xp: Any) -> Any:
    """End effectors relative to the root in its heading frame, with height above the ground."""
    ee = k.xipos[layout.end_effectors]
    rel = quat.rotate_yaw(ee - k.xipos[ROOT_BODY], -root_yaw(k, xp), xp)
    return xp.concatenate([rel[:, :2], ee[:, 2:]], axis=-1)


def _pose_sum(layout: Layout, sim: Kin, ref: Kin, xp: Any, quat_weight: Any, hinge_weight: Any) -> Any:
    quat_angle, hinge_angle = joint_angles(layout, sim, ref, xp)
    return xp.sum(quat_weight * quat_angle**2) + xp.sum(hinge_weight * hinge_angle**2)


def joint_velocity_errors(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> tuple[Any, Any]:
    """Per-joint squared angular-velocity error between sim and reference (quaternion groups, hinges)."""
    ang = xp.sum((sim.qvel[layout.v_ang] - ref.qvel[layout.v_ang]) ** 2, axis=-1)
    hv = layout.v_scalar[3:]
    return ang, (sim.qvel[hv] - ref.qvel[hv]) ** 2


def _velocity_sum(layout: Layout, sim: Kin, ref: Kin, xp: Any, quat_weight: Any, hinge_weight: Any) -> Any:
    ang, hinge = joint_velocity_errors(layout, sim, ref, xp)
    return xp.sum(quat_weight * ang) + xp.sum(hinge_weight * hinge)


def pose_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    return _pose_sum(layout, sim, ref, xp, layout.quat_weight, layout.hinge_weight)


def velocity_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    return _velocity_sum(layout, sim, ref, xp, layout.quat_weight, layout.hinge_weight)


def plain_pose_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    return _pose_sum(layout, sim, ref, xp, 1.0, 1.0)


def plain_velocity_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    return _velocity_sum(layout, sim, ref, xp, 1.0, 1.0)


def end_effector_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    return xp.sum((end_effectors(layout, sim, xp) - end_effectors(layout, ref, xp)) ** 2)


def world_end_effector_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    return xp.sum((sim.xipos[layout.end_effectors] - ref.xipos[layout.end_effectors]) ** 2)


def root_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    root_angle = quat.angle_between(sim.qpos[3:7], ref.qpos[3:7], xp)
    return (xp.sum((sim.qpos[0:3] - ref.qpos[0:3]) ** 2) + 0.1 * root_angle**2
            + 0.01 * xp.sum((sim.qvel[0:3] - ref.qvel[0:3]) ** 2)
            + 0.001 * xp.sum((sim.qvel[3:6] - ref.qvel[3:6]) ** 2))


def com_velocity_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    dv = com_velocity(sim, layout.body_mass, xp) - com_velocity(ref, layout.body_mass, xp)
    return 0.1 * xp.sum(dv**2)


def com_position_error(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> Any:
    return xp.sum((sim.com - ref.com) ** 2)


LISTS: dict[str, tuple[Term, ...]] = {
    "released": (Term("pose", pose_error, 0.5, 2.0), Term("velocity", velocity_error, 0.05, 0.1),
                 Term("end_effector", end_effector_error, 0.15, 10.0), Term("root", root_error, 0.2, 5.0),
                 Term("com", com_velocity_error, 0.1, 10.0)),
    "paper": (Term("pose", plain_pose_error, 0.65, 2.0), Term("velocity", plain_velocity_error, 0.1, 0.1),
              Term("end_effector", world_end_effector_error, 0.15, 40.0),
              Term("com", com_position_error, 0.1, 10.0)),
}


def parse_weights(text: str) -> dict[str, float]:
    """'pose=0.6,root=0' -> {'pose': 0.6, 'root': 0.0} (reward.weights)."""
    out = {}
    for item in (p.strip() for p in text.split(",")):
        if not item:
            continue
        name, _, value = item.partition("=")
        if name.strip() in out:
            raise UserError(f"config key 'reward.weights': {name.strip()!r} is given twice")
        try:
            out[name.strip()] = float(value)
        except ValueError:
            raise UserError(f"config key 'reward.weights': {item!r} is not term=weight") from None
    return out


def terms(kind: str, weights: str = "") -> tuple[Term, ...]:
    """The reward list `kind` with `weights` applied; zero-weight terms dropped."""
    if kind not in LISTS:
        raise UserError(f"config key 'reward.kind': {kind!r} is not one of {', '.join(LISTS)}")
    base = LISTS[kind]
    override = parse_weights(weights)
    unknown = sorted(set(override) - {t.name for t in base})
    if unknown:
        raise UserError(f"config key 'reward.weights': no term {unknown[0]!r} in the {kind} reward "
                        f"(terms: {', '.join(t.name for t in base)})")
    out = tuple(t._replace(weight=override.get(t.name, t.weight)) for t in base)
    return tuple(t for t in out if t.weight != 0.0)


def tracking_errors(layout: Layout, sim: Kin, ref: Kin, xp: Any) -> dict[str, Any]:
    """Human-readable errors: mean joint angle (rad, the pose weights) and end-effector distance (m)."""
    quat_angle, hinge_angle = joint_angles(layout, sim, ref, xp)
    total = xp.sum(layout.quat_weight) + xp.sum(layout.hinge_weight)
    angle = (xp.sum(layout.quat_weight * quat_angle) + xp.sum(layout.hinge_weight * hinge_angle)) / total
    gap = end_effectors(layout, sim, xp) - end_effectors(layout, ref, xp)
    return {"error/pose": angle, "error/end_effector": xp.mean(xp.sqrt(xp.sum(gap**2, axis=-1)))}


def reward(terms_: tuple[Term, ...], layout: Layout, sim: Kin, ref: Kin, xp: Any) -> tuple[Any, dict[str, Any]]:
    """Total reward and a metrics dict: reward/<term> (each in [0, 1]) and error/*."""
    metrics = tracking_errors(layout, sim, ref, xp)
    total = 0.0
    for t in terms_:
        r = xp.exp(-t.scale * t.error(layout, sim, ref, xp))
        metrics[f"reward/{t.name}"] = r
        total = total + t.weight * r
    return total, metrics
