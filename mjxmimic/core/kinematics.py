"""The kinematic quantities that observation and reward read, taken from MuJoCo data.

`mjx.Data` and `mujoco.MjData` name these fields alike, so one constructor serves the training
environment and CPU playback; both compute them with MuJoCo's own kinematics (mj_kinematics,
mj_comPos, mj_comVel), for the simulated body and the reference pose alike.
"""

from __future__ import annotations

from typing import Any, NamedTuple


class Kin(NamedTuple):
    qpos: Any  # (nq,)
    qvel: Any  # (nv,)
    xipos: Any  # (nbody, 3) body centres of mass, world
    xmat: Any  # (nbody, 3, 3) body frame orientations, world
    cvel: Any  # (nbody, 6) [angular; linear at subtree_com[root]] world-oriented velocities
    com: Any  # (3,) whole-character centre of mass (subtree_com of the root body)


ROOT_BODY = 1


def kin_from_data(d: Any, xp: Any) -> Kin:
    """Read a Kin from mjx.Data or mujoco.MjData whose kinematics and com velocities are current."""
    return Kin(
        qpos=xp.asarray(d.qpos),
        qvel=xp.asarray(d.qvel),
        xipos=xp.asarray(d.xipos),
        xmat=xp.reshape(xp.asarray(d.xmat), (-1, 3, 3)),
        cvel=xp.asarray(d.cvel),
        com=xp.asarray(d.subtree_com)[ROOT_BODY],
    )


def body_linvel(k: Kin, xp: Any) -> Any:
    """Linear velocity of each body's centre of mass (nbody, 3), world frame."""
    ang, lin = k.cvel[:, :3], k.cvel[:, 3:]
    return lin + xp.cross(ang, k.xipos - k.com)


def com_velocity(k: Kin, body_mass: Any, xp: Any) -> Any:
    return xp.sum(body_mass[:, None] * body_linvel(k, xp), axis=0) / xp.sum(body_mass)


def root_yaw(k: Kin, xp: Any) -> Any:
    """Heading of the root body's forward (x) axis."""
    r = k.xmat[ROOT_BODY]
    return xp.arctan2(r[1, 0], r[0, 0])
