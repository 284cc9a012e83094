"""Observation terms (DEEPMIMIC.md): small pure functions of the simulated kinematics and the
motion state, concatenated in the order that `env.observations` names them. numpy or jax.numpy
via `xp`; the same functions serve training and CPU playback.

The default, the released code's 227 numbers for the humanoid: phase; root height; for every body
its position relative to the root, its forward (x) and up (z) axes, linear and angular velocity,
all rotated into the heading frame (the rotation about the up axis that undoes the root's facing:
by default the yaw of its forward axis, DeepMimic's; `env.observation_heading=twist` the twist
of its rotation about the vertical, which stays steady where the root faces the floor).
`skill` adds a one-hot of the env's clip in a dataset, which a user switches at play time.
`reference_root` adds where the reference's root is, seen from the character's.
"""

from __future__ import annotations

from typing import Any, Callable, NamedTuple

from mjxmimic.core import quat
from mjxmimic.core.errors import UserError
from mjxmimic.core.kinematics import ROOT_BODY, Kin, root_yaw

DEFAULT = "phase,root_height,bodies"


def phase(k: Kin, clip_phase: Any, xp: Any) -> Any:
    return xp.reshape(clip_phase, (1,))


def root_height(k: Kin, clip_phase: Any, xp: Any) -> Any:
    return k.xipos[ROOT_BODY, 2:3]


def bodies(k: Kin, clip_phase: Any, xp: Any, heading: str = "forward") -> Any:
    yaw = -root_yaw(k, xp, heading)
    rest = slice(1, None)
    pos = quat.rotate_yaw(k.xipos[rest] - k.xipos[ROOT_BODY], yaw, xp)
    forward = quat.rotate_yaw(k.xmat[rest, :, 0], yaw, xp)
    up = quat.rotate_yaw(k.xmat[rest, :, 2], yaw, xp)
    lin = quat.rotate_yaw(k.linvel[rest], yaw, xp)
    ang = quat.rotate_yaw(k.angvel[rest], yaw, xp)
    return xp.concatenate([xp.reshape(x, (-1,)) for x in (pos, forward, up, lin, ang)])


def reference_root(k: Kin, ref_qpos: Any, xp: Any, heading: str = "forward") -> Any:
    """The reference root's horizontal offset from the character's, in the character's heading
    frame, and the heading difference as (sin, cos). The other terms show nothing of it, so
    without it a policy cannot steer back onto a reference it has drifted from within a cycle,
    which the paper form's world positions grade (experiments/README.md)."""
    yaw = quat.heading(k.qpos[3:7], xp, heading)
    offset = quat.rotate_yaw(ref_qpos[0:3] - k.qpos[0:3], -yaw, xp)[0:2]
    turn = quat.heading(ref_qpos[3:7], xp, heading) - yaw
    return xp.concatenate([offset, xp.stack([xp.sin(turn), xp.cos(turn)]).astype(offset.dtype)])


class Inputs(NamedTuple):
    """What the terms read: the kinematics, the clip phase, the heading frame
    (env.observation_heading), the skill selector's one-hot and the reference pose as the reward
    grades it (for reference_root)."""

    k: Kin
    clip_phase: Any
    xp: Any
    heading: str = "forward"
    skill_onehot: Any = None
    ref_qpos: Any = None


TERMS: dict[str, Callable[[Inputs], Any]] = {
    "phase": lambda i: phase(i.k, i.clip_phase, i.xp),
    "root_height": lambda i: root_height(i.k, i.clip_phase, i.xp),
    "bodies": lambda i: bodies(i.k, i.clip_phase, i.xp, i.heading),
    "skill": lambda i: i.skill_onehot,  # the skill selector (DEEPMIMIC.md, section 7): the clip's one-hot
    "reference_root": lambda i: reference_root(i.k, i.ref_qpos, i.xp, i.heading),
}
SIZES: dict[str, Callable[[int, int], int]] = {"phase": lambda nbody, nclips: 1,
                                               "root_height": lambda nbody, nclips: 1,
                                               "bodies": lambda nbody, nclips: 15 * (nbody - 1),
                                               "skill": lambda nbody, nclips: nclips,
                                               "reference_root": lambda nbody, nclips: 4}


def parse(names: str) -> tuple[str, ...]:
    """'phase,root_height,bodies' -> the term names, checked."""
    out = tuple(n.strip() for n in names.split(",") if n.strip())
    unknown = [n for n in out if n not in TERMS]
    if not out or unknown:
        raise UserError(f"config key 'env.observations': {names!r} must name terms among {', '.join(TERMS)}")
    twice = [n for n in out if out.count(n) > 1]
    if twice:
        raise UserError(f"config key 'env.observations': {twice[0]!r} is listed twice")
    return out


def observation_size(nbody: int, names: str = DEFAULT, nclips: int = 1) -> int:
    return sum(SIZES[n](nbody, nclips) for n in parse(names))


def observe(terms: tuple[str, ...], k: Kin, clip_phase: Any, xp: Any, skill_onehot: Any = None,
            ref_qpos: Any = None, heading: str = "forward") -> Any:
    """The terms in order (`Inputs` says what they read)."""
    inputs = Inputs(k, clip_phase, xp, heading, skill_onehot, ref_qpos)
    return xp.concatenate([TERMS[n](inputs) for n in terms])
