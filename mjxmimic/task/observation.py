"""The policy's observation (DEEPMIMIC.md): one function for training and CPU playback.

phase; root height; for every body: position relative to the root, its forward (x) and up (z)
axes, linear and angular velocity, all rotated into the heading frame (the rotation about the up
axis that undoes the root's facing). 1 + 1 + 15 x (3 + 6 + 3 + 3) = 227 numbers for the humanoid.
"""

from __future__ import annotations

from typing import Any

from mjxmimic.core import quat
from mjxmimic.core.kinematics import ROOT_BODY, Kin, body_linvel, root_yaw


def observation_size(nbody: int) -> int:
    return 2 + 15 * (nbody - 1)


def observation(k: Kin, phase: Any, xp: Any) -> Any:
    yaw = -root_yaw(k, xp)
    bodies = slice(1, None)
    pos = quat.rotate_yaw(k.xipos[bodies] - k.xipos[ROOT_BODY], yaw, xp)
    forward = quat.rotate_yaw(k.xmat[bodies, :, 0], yaw, xp)
    up = quat.rotate_yaw(k.xmat[bodies, :, 2], yaw, xp)
    lin = quat.rotate_yaw(body_linvel(k, xp)[bodies], yaw, xp)
    ang = quat.rotate_yaw(k.cvel[bodies, :3], yaw, xp)
    parts = [xp.reshape(phase, (1,)), k.xipos[ROOT_BODY, 2:3]]
    parts += [xp.reshape(x, (-1,)) for x in (pos, forward, up, lin, ang)]
    return xp.concatenate(parts)
