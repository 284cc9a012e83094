"""The skill selector's switches, written once for numpy and jax.numpy: when a clip may hand over to
another, where the next one starts, and the random switches of training (env.skill_switch_s).

Between two cyclic clips a switch comes at once, at the same phase or (env.skill_switch_entry=
nearest) at the next clip's reference pose nearest the character's. Into or out of a one-off clip
(a getup, a kick) it waits for the playing clip's cycle, or the one-off itself, to end, and the next
clip starts from its beginning. The reference root is moved under the character either way (as at
a new cycle: the old clip's offset would leave a faster clip's reference metres away), and with
env.skill_switch_settle_s it follows the character for that long (mjxmimic.envs.step).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from mjxmimic.core import forward_kinematics
from mjxmimic.core.config import Config
from mjxmimic.core.kinematics import Kin
from mjxmimic.core.scene import Scene
from mjxmimic.envs import entry as entry_lib
from mjxmimic.motion import library as motion_lib
from mjxmimic.physics import randomise

if TYPE_CHECKING:
    from mjxmimic.envs.step import Motion, Spec

SKILL_SWITCH_DRAWS = 1 << 24  # where the skill switches' draws start in the event seed's stream, two per step


def entry_grid(config: Config, scene: Scene, lib: motion_lib.MotionLib, xp: Any) -> entry_lib.Entry | None:
    """The clips' nearest-pose entry grid (`lib` in numpy) with env.skill_switch_entry=nearest."""
    if config.env.skill_switch_entry != "nearest":
        return None
    tree = forward_kinematics.read_tree(scene.model, scene.nbody)
    grid, _ = entry_lib.pose_grid(lib, 1.0 / config.env.control_hz,
                                  lambda q, v: forward_kinematics.kinematics(tree, q, v, np))
    return entry_lib.to_xp(grid, xp)


def root_under(spec: Spec, clip: Any, t: Any, qpos: Any, xp: Any) -> Any:
    """The root offset (2,) that puts clip `clip`'s reference at time t under the character."""
    ref_qpos, _ = motion_lib.sample(spec.lib, clip, t, xp)
    return qpos[0:2] - ref_qpos[0:2]


def switched(spec: Spec, motion: Motion, clip: Any, qpos: Any, sim: Kin, xp: Any) -> Motion:
    """The motion state following clip number `clip` from here on (the module docstring says where
    it starts); `sim` is the character's kinematics now."""
    lib = spec.lib
    if spec.switch_entry is not None:
        cyclic = entry_lib.nearest_times(entry_lib.of_clip(spec.switch_entry, clip), sim, xp)
    else:
        cyclic = motion_lib.phase(lib, motion.clip, motion.time, xp) * lib.duration[clip]
    t = xp.where(lib.loop[motion.clip] & lib.loop[clip], cyclic, 0.0).astype(xp.float32)
    offset = root_under(spec, clip, t, qpos, xp).astype(xp.asarray(motion.root_offset).dtype)
    settle = xp.asarray(round(spec.config.env.skill_switch_settle_s / spec.control_dt))
    settle = settle.astype(xp.asarray(motion.settle).dtype)
    return motion._replace(clip=xp.asarray(clip).astype(xp.asarray(motion.clip).dtype), time=t, root_offset=offset,
                           settle=settle)


def may_switch(spec: Spec, clip: Any, to: Any, t_before: Any, t_after: Any, xp: Any,
               finish_cycle: bool = False) -> Any:
    """Whether clip number `clip`, gone from t_before to t_after, may hand over to clip `to` now;
    with `finish_cycle` a cyclic clip is left only where its cycle ends, as a one-off clip is."""
    ended = motion_lib.ended(spec.lib, clip, t_after, xp)
    return _may_switch(spec.lib, clip, to, t_before, t_after, ended, xp, finish_cycle)


def _may_switch(lib: motion_lib.MotionLib, clip: Any, to: Any, t_before: Any, t_after: Any, ended: Any,
                xp: Any, finish_cycle: bool = False) -> Any:
    wrapped = motion_lib.cycle_index(lib, clip, t_after, xp) > motion_lib.cycle_index(lib, clip, t_before, xp)
    return (lib.loop[clip] & lib.loop[to] & (not finish_cycle)) | wrapped | ended


def maybe_switch_skill(spec: Spec, motion: Motion, t_before: Any, qpos: Any, stopped: Any, xp: Any,
                       sim: Kin) -> Motion:
    """env.skill_switch_s: the episode goes on with another clip of the dataset (uniformly drawn),
    so that the selector learns the switches a user makes at play time, about every skill_switch_s
    seconds: between cyclic clips with probability control_dt / skill_switch_s at each step; into a
    one-off clip with probability cycle / skill_switch_s where a cycle ends; out of a one-off clip
    always, at its end (the episode goes on)."""
    lib, every = spec.lib, spec.config.env.skill_switch_s
    count = lib.duration.shape[0]
    u = randomise.uniform(motion.event_seed, 2, xp, first=SKILL_SWITCH_DRAWS + 2 * motion.steps)
    other = (motion.clip + 1 + xp.floor(u[1] * (count - 1)).astype(xp.asarray(motion.clip).dtype)) % count
    ended = motion_lib.ended(lib, motion.clip, motion.time, xp)
    chance = xp.where(lib.loop[motion.clip] & lib.loop[other], spec.control_dt / every,
                      xp.minimum(1.0, lib.duration[motion.clip] / every))
    chance = xp.where(ended, 1.0, chance)
    flip = (u[0] < chance) & _may_switch(lib, motion.clip, other, t_before, motion.time, ended, xp) & ~stopped
    moved = switched(spec, motion, other, qpos, sim, xp)
    return motion._replace(clip=xp.where(flip, moved.clip, motion.clip), time=xp.where(flip, moved.time, motion.time),
                           root_offset=xp.where(flip, moved.root_offset, motion.root_offset),
                           settle=xp.where(flip, moved.settle, motion.settle))
