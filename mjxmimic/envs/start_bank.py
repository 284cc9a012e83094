"""Training episodes that start from given states (`env.start_states`), such as bodies knocked
down, which no frame of a getup clip resembles and RSI therefore never shows the policy (ASE, for
one, starts some of its episodes fallen).

Each state is matched once, when the env is built, to the clip and time whose reference pose is
nearest by the composite gate's own rule (`mjxmimic.envs.composite`), so that an expert trained
from such states learns to go on from where the gate will enter it; then turned about the
vertical and moved so that its root's heading and floor position are the reference's there
(`goals.align_reference`, with the state as the one turned): the imitation reward then grades it against that frame, as it grades an RSI start. A reset that draws
it (`mjxmimic.envs.starts.from_bank`) starts the clip at that time.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mjxmimic.core.character import Character
from mjxmimic.core.config import Config
from mjxmimic.core.errors import UserError
from mjxmimic.core.scene import Scene
from mjxmimic.envs import entry as entry_lib
from mjxmimic.envs import starts
from mjxmimic.envs import step as step_lib
from mjxmimic.motion import library as motion_lib
from mjxmimic.physics.cpu import CpuPhysics
from mjxmimic.task import goals

KEY = "env.start_states"


def read(path: str, nq: int, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """(qpos (N, nq), qvel (N, nv)) from the .npz at `path`, checked; one-line errors."""
    file = Path(path).expanduser()
    try:
        with np.load(file) as data:
            missing = [k for k in ("qpos", "qvel") if k not in data.files]
            if missing:
                raise UserError(f"{KEY}={path}: the file has no array {missing[0]!r} (it needs qpos and qvel)")
            qpos, qvel = np.asarray(data["qpos"], np.float32), np.asarray(data["qvel"], np.float32)
    except FileNotFoundError:
        raise UserError(f"{KEY}={path}: no such file") from None
    except UserError:
        raise
    except Exception as err:  # not an npz (zip) file, a truncated one
        raise UserError(f"{KEY}={path}: not a readable .npz file ({type(err).__name__}: {err})") from None
    if qpos.ndim != 2 or qpos.shape[1] != nq or qvel.ndim != 2 or qvel.shape[1] != nv or len(qpos) != len(qvel):
        raise UserError(f"{KEY}={path}: qpos {qpos.shape} and qvel {qvel.shape} must be (N, {nq}) and (N, {nv}) "
                        "for this character")
    if len(qpos) == 0 or not (np.isfinite(qpos).all() and np.isfinite(qvel).all()):
        raise UserError(f"{KEY}={path}: needs at least one state, all of them finite")
    return qpos, qvel


def build(config: Config, character: Character, scene: Scene, clips: list[Any], weights: Any, xp: Any
          ) -> step_lib.StartBank:
    """The bank of `config.env.start_states` for these clips, arrays in xp."""
    if config.terrain.kind != "none" or config.task.name == "throw":
        raise UserError(f"{KEY}: not available with a terrain or the throw task (their start states are placed)")
    qpos, qvel = read(config.env.start_states, scene.nq, scene.nv)
    spec = step_lib.make_spec(config, character, scene, clips, np, weights)
    physics = CpuPhysics(scene, spec.layout, 1, config.env.torque_limit)
    grid, _ = entry_lib.pose_grid(spec.lib, spec.control_dt, physics.kinematics)
    times, valid, feats = grid.times, grid.valid, grid.features
    limits = np.array([starts.start_time_range(spec, c, np) for c in range(len(clips))])
    valid = valid & (times < limits[:, None])  # as RSI: at least one control step of the clip left
    out_q, out_v = np.empty_like(qpos), np.empty_like(qvel)
    clip_of, time_of = np.zeros(len(qpos), np.int32), np.zeros(len(qpos), np.float32)
    for n, (q, v) in enumerate(zip(qpos, qvel, strict=True)):
        f = np.asarray(entry_lib.pose_features(physics.kinematics(q, v), np))
        d = np.where(valid, np.sum((feats - f) ** 2, axis=-1), np.inf)
        c, g = np.unravel_index(int(np.argmin(d)), d.shape)
        clip_of[n], time_of[n] = c, times[c, g]
        ref_qpos, _ = motion_lib.sample(spec.lib, int(c), times[c, g], np)
        out_q[n], out_v[n] = goals.align_reference(q, v, ref_qpos, np)
    return step_lib.StartBank(qpos=xp.asarray(out_q), qvel=xp.asarray(out_v), clip=xp.asarray(clip_of),
                              time=xp.asarray(time_of))
