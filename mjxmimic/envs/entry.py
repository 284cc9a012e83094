"""Nearest-pose entry: the time of a clip whose reference pose is nearest the character's, over a
grid of control-step times. The composite's gate enters a new expert there; the skill selector
does with env.skill_switch_entry=nearest. Written once for numpy and jax.numpy."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core.kinematics import ROOT_BODY, Kin
from mjxmimic.motion import library as motion_lib
from mjxmimic.task import observation as obs_terms

VELOCITY_WEIGHT = 0.1  # seconds: body velocities count as the positions they reach in 0.1 s


class Entry(NamedTuple):
    """Each clip's reference on a grid of control-step times (arrays in the step's xp)."""

    times: Any  # (C, G) grid times
    features: Any  # (C, G, D) the reference's pose features there
    valid: Any  # (C, G) bool: grid points within the clip


def pose_features(k: Kin, xp: Any) -> Any:
    """What nearest-pose matching compares: each body's position, x and z axes and (scaled)
    linear velocity relative to the root, in the heading frame (the observation's 'bodies')."""
    nb = k.xipos.shape[0] - 1
    parts = xp.reshape(obs_terms.bodies(k, None, xp), (5, nb, 3))
    return xp.concatenate([xp.reshape(parts[:3], (-1,)), VELOCITY_WEIGHT * xp.reshape(parts[3], (-1,))])


def pose_grid(lib: motion_lib.MotionLib, control_dt: float,
              kinematics: Callable[[Any, Any], Kin]) -> tuple[Entry, np.ndarray]:
    """The entry grid of every clip of `lib` (numpy; `kinematics` a numpy one) and the reference's
    root height at each grid point (C, G)."""
    count = len(lib.duration)
    grids = [np.arange(max(1, int(np.ceil(float(lib.duration[e]) / control_dt - 1e-6)))) * control_dt
             for e in range(count)]
    g = max(len(x) for x in grids)
    times = np.zeros((count, g), np.float32)
    valid = np.zeros((count, g), bool)
    heights = np.zeros((count, g), np.float32)
    feats = None
    for e, grid in enumerate(grids):
        for i, t in enumerate(grid):
            k = kinematics(*motion_lib.sample(lib, e, np.float32(t), np))
            f = np.asarray(pose_features(k, np), np.float32)
            if feats is None:
                feats = np.zeros((count, g, f.shape[0]), np.float32)
            times[e, i], valid[e, i], feats[e, i], heights[e, i] = t, True, f, k.xipos[ROOT_BODY, 2]
    return Entry(times=times, features=feats, valid=valid), heights


def of_clip(entry: Entry, clip: Any) -> Entry:
    """The grid of clip number `clip` alone (`nearest_times` of it is a scalar)."""
    return Entry(*(a[clip] for a in entry))


def nearest_times(entry: Entry, k: Kin, xp: Any) -> Any:
    """(C,) where each clip would start now: its grid time of the reference pose nearest `k`'s (a
    scalar for one clip's grid, `of_clip`)."""
    d = xp.sum((entry.features - pose_features(k, xp)) ** 2, axis=-1)
    best = xp.argmin(xp.where(entry.valid, d, xp.inf), axis=-1)
    return xp.take_along_axis(entry.times, best[..., None], axis=-1)[..., 0]


def to_xp(entry: Entry, xp: Any) -> Entry:
    return Entry(*(xp.asarray(a) for a in entry))
