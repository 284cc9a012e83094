"""Motion library: one or many clips as flat frame arrays, and the reference pose at any time.

`MotionLib` is a NamedTuple of arrays, so it is a JAX pytree as it stands and also works with
numpy: the environment samples it with jax.numpy, CPU playback with numpy (`xp` argument).
Layout follows MimicKit: all clips' frames concatenated, plus per-clip start, length and loop mode.
Cyclic clips continue across cycles: each new cycle is the first one moved by the clip's net
root displacement and heading change, applied k times for cycle k. An episode may also move the
reference root horizontally under the character at each new cycle (`sync_root_offset`).
"""

from __future__ import annotations

from typing import Any, NamedTuple, Sequence

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.character import Character
from mjxmimic.core.layout import Layout, make_layout


class MotionLib(NamedTuple):
    layout: Layout
    qpos: np.ndarray  # (F, nq) all clips' frames
    qvel: np.ndarray  # (F, nv) finite-difference velocity of each frame's segment
    times: np.ndarray  # (F,) frame start time within its clip
    frame_clip: np.ndarray  # (F,) clip index of each frame
    clip_start: np.ndarray  # (C,) index of each clip's first frame
    clip_frames: np.ndarray  # (C,)
    duration: np.ndarray  # (C,) seconds
    loop: np.ndarray  # (C,) bool
    cycle_yaw: np.ndarray  # (C,) heading change over one cycle
    cycle_origin: np.ndarray  # (C, 2) first frame's root xy
    cycle_shift: np.ndarray  # (C, 2) last minus first root xy


def _segment_velocity(layout: Layout, q0: np.ndarray, q1: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """qvel that takes q0 to q1 in dt: world linear root velocity, local angular velocities."""
    dt = dt[..., None]
    scalars = (q1[..., layout.q_scalar] - q0[..., layout.q_scalar]) / dt
    a, b = q0[..., layout.q_quat], q1[..., layout.q_quat]
    ang = quat.to_rotvec(quat.mul(quat.conj(a), b)) / dt[..., None]
    flat = np.concatenate([scalars, ang.reshape(*ang.shape[:-2], -1)], axis=-1)
    return flat[..., layout.v_perm]


def build_motion_lib(clips: Sequence[Any], character: Character) -> MotionLib:
    """Concatenate clips (mjxmimic.motion.clip.Clip) into one library, computing velocities."""
    layout = make_layout(character)
    qpos, qvel, times, frame_clip = [], [], [], []
    starts, counts, durations, loops, yaws, origins, shifts = [], [], [], [], [], [], []
    start = 0
    for c, clip in enumerate(clips):
        q = np.asarray(clip.qpos, dtype=np.float64)
        dur = np.asarray(clip.durations, dtype=np.float64)[:-1]
        vel = _segment_velocity(layout, q[:-1], q[1:], dur)
        first_yaw, last_yaw = quat.heading(q[0, 3:7]), quat.heading(q[-1, 3:7])
        yaw = float(quat.wrap_angle(last_yaw - first_yaw)) if clip.loop else 0.0
        if clip.loop:  # the last frame starts the next cycle: its velocity is the first's, turned
            last = vel[0].copy()
            last[0:3] = quat.rotate_yaw(vel[0, 0:3], np.asarray(yaw))
        else:
            last = vel[-1]
        qpos.append(q)
        qvel.append(np.concatenate([vel, last[None]], axis=0))
        times.append(np.concatenate([[0.0], np.cumsum(dur)]))
        frame_clip.append(np.full(len(q), c))
        starts.append(start)
        counts.append(len(q))
        durations.append(dur.sum())
        loops.append(bool(clip.loop))
        yaws.append(yaw)
        origins.append(q[0, 0:2])
        shifts.append(q[-1, 0:2] - q[0, 0:2] if clip.loop else np.zeros(2))
        start += len(q)
    f32 = np.float32
    return MotionLib(
        layout=layout,
        qpos=np.concatenate(qpos).astype(f32),
        qvel=np.concatenate(qvel).astype(f32),
        times=np.concatenate(times).astype(f32),
        frame_clip=np.concatenate(frame_clip).astype(np.int32),
        clip_start=np.array(starts, dtype=np.int32),
        clip_frames=np.array(counts, dtype=np.int32),
        duration=np.array(durations, dtype=f32),
        loop=np.array(loops),
        cycle_yaw=np.array(yaws, dtype=f32),
        cycle_origin=np.array(origins, dtype=f32),
        cycle_shift=np.array(shifts, dtype=f32),
    )


def _cycle_translation(shift: Any, yaw: Any, k: Any, xp: Any) -> Any:
    """sum_{i<k} R(i yaw) shift, in closed form (a geometric series of plane rotations)."""
    small = xp.abs(yaw) < 1e-6
    safe = xp.where(small, 1.0, yaw)
    # (1 - e^{ik yaw}) / (1 - e^{i yaw}) as a complex factor a + ib
    num_re, num_im = 1.0 - xp.cos(k * safe), -xp.sin(k * safe)
    den_re, den_im = 1.0 - xp.cos(safe), -xp.sin(safe)
    den = den_re * den_re + den_im * den_im
    a = (num_re * den_re + num_im * den_im) / den
    b = (num_im * den_re - num_re * den_im) / den
    a, b = xp.where(small, k, a), xp.where(small, 0.0, b)
    return xp.stack([a * shift[..., 0] - b * shift[..., 1], b * shift[..., 0] + a * shift[..., 1]], axis=-1)


def phase(lib: MotionLib, clip: Any, t: Any, xp: Any = np) -> Any:
    """Clip phase in [0, 1): time over duration, wrapped for cyclic clips."""
    dur = lib.duration[clip]
    p = t / dur
    return xp.where(lib.loop[clip], p - xp.floor(p), xp.clip(p, 0.0, 1.0))


def sample(lib: MotionLib, clip: Any, t: Any, xp: Any = np) -> tuple[Any, Any]:
    """Reference (qpos, qvel) of `clip` at time `t` (scalars; vmap for batches)."""
    dur = lib.duration[clip]
    loop = lib.loop[clip]
    cycle = xp.where(loop, xp.floor(t / dur), 0.0)
    tau = xp.clip(t - cycle * dur, 0.0, dur)

    in_clip = lib.frame_clip == clip
    n = lib.clip_frames[clip]
    local = xp.sum(in_clip & (lib.times <= tau)) - 1
    local = xp.clip(local, 0, n - 2)
    i0 = lib.clip_start[clip] + local
    t0, t1 = lib.times[i0], lib.times[i0 + 1]
    alpha = xp.clip((tau - t0) / xp.maximum(t1 - t0, 1e-9), 0.0, 1.0)

    q0, q1 = lib.qpos[i0], lib.qpos[i0 + 1]
    lay = lib.layout
    scalars = (1.0 - alpha) * q0[lay.q_scalar] + alpha * q1[lay.q_scalar]
    quats = quat.slerp(q0[lay.q_quat], q1[lay.q_quat], xp.full((len(lay.q_quat), 1), alpha), xp)
    qpos = xp.concatenate([scalars, xp.reshape(quats, (-1,))])[lay.q_perm]
    qvel = (1.0 - alpha) * lib.qvel[i0] + alpha * lib.qvel[i0 + 1]

    # Move cycle k by the k-fold cycle transform: turn about the first frame's root, then shift.
    yaw = lib.cycle_yaw[clip] * cycle
    origin = lib.cycle_origin[clip]
    xy = quat.rotate_yaw(xp.concatenate([qpos[0:2] - origin, xp.zeros(1)]), yaw, xp)[:2]
    xy = xy + origin + _cycle_translation(lib.cycle_shift[clip], lib.cycle_yaw[clip], cycle, xp)
    root_quat = quat.mul(quat.from_yaw(yaw, xp), qpos[3:7], xp)
    qpos = xp.concatenate([xy, qpos[2:3], root_quat, qpos[7:]])
    qvel = xp.concatenate([quat.rotate_yaw(qvel[0:3], yaw, xp), qvel[3:]])
    return qpos, qvel


def sync_root_offset(lib: MotionLib, clip: Any, t_prev: Any, t: Any, offset: Any, sim_xy: Any,
                     ref_xy: Any, xp: Any = np) -> Any:
    """The horizontal offset added to the reference root from time t on.

    DeepMimic's released code (sync_char_root_pos, on by default) moves a cyclic reference's root
    horizontally to the simulated root whenever a new cycle starts, so that the character's
    harmless drift over many cycles does not pile up in the root-position error. `ref_xy` is the
    unshifted reference root at t; between cycle starts the offset is kept.
    """
    dur = lib.duration[clip]
    new_cycle = lib.loop[clip] & (xp.floor(t / dur) > xp.floor(t_prev / dur))
    return xp.where(new_cycle, sim_xy - ref_xy, offset)


def shift_root(qpos: Any, offset: Any, xp: Any = np) -> Any:
    """qpos with its root moved horizontally by offset (2,)."""
    return xp.concatenate([qpos[0:2] + offset, qpos[2:]])
