"""The kinematic quantities that observation and reward read, for the simulated body and the
reference pose alike: computed by MuJoCo C (CPU playback, `kin_from_data`) or by the array code
of mjxmimic.core.forward_kinematics (the MJX env), which agree to float precision.
"""

from __future__ import annotations

from typing import Any, NamedTuple


class Kin(NamedTuple):
    qpos: Any  # (nq,)
    qvel: Any  # (nv,)
    xipos: Any  # (nbody, 3) body centres of mass, world
    xmat: Any  # (nbody, 3, 3) body frame orientations, world
    angvel: Any  # (nbody, 3) angular velocities, world frame
    linvel: Any  # (nbody, 3) linear velocities of the body centres of mass, world frame
    com: Any  # (3,) whole-character centre of mass (subtree_com of the root body)


ROOT_BODY = 1


def kin_from_data(d: Any, xp: Any) -> Kin:
    """A copy of the Kin in MuJoCo data whose kinematics and com velocities are current
    (mj_kinematics, mj_comPos, mj_comVel); MuJoCo's cvel is [angular; linear at the root's
    subtree com]."""
    xipos = xp.array(d.xipos)
    com = xp.array(d.subtree_com)[ROOT_BODY]
    cvel = xp.array(d.cvel)
    return Kin(
        qpos=xp.array(d.qpos),
        qvel=xp.array(d.qvel),
        xipos=xipos,
        xmat=xp.reshape(xp.array(d.xmat), (-1, 3, 3)),
        angvel=cvel[:, :3],
        linvel=cvel[:, 3:] + xp.cross(cvel[:, :3], xipos - com),
        com=com,
    )


def com_velocity(k: Kin, body_mass: Any, xp: Any) -> Any:
    return xp.sum(body_mass[:, None] * k.linvel, axis=0) / xp.sum(body_mass)


def root_yaw(k: Kin, xp: Any, heading: str = "forward") -> Any:
    """The root's heading: the yaw of its forward (x) axis on the ground (DeepMimic's), or with
    `heading="twist"` the twist about the vertical of its rotation (quat.heading says why)."""
    r = k.xmat[ROOT_BODY]
    if heading == "twist":
        return xp.arctan2(r[1, 0] - r[0, 1], r[0, 0] + r[1, 1])
    return xp.arctan2(r[1, 0], r[0, 0])
