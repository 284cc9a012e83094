"""Motion library: one or many clips as flat frame arrays, and the reference pose at any time.

`MotionLib` is a NamedTuple of arrays, so it is a JAX pytree as it stands and also works with
numpy: the environment samples it with jax.numpy, CPU playback with numpy (`xp` argument).
Layout follows MimicKit: all clips' frames concatenated, plus per-clip start, length and loop mode.
Looking a pose up costs the same for 1 clip or 100: each clip has a table of the frame in force at
every point of a uniform time grid (step no longer than its shortest frame), so the frame holding a
time is one of a few table entries (`_frame_index`), not a scan over all frames. Clips are drawn by
weight with `draw_clip`.
Cyclic clips continue across cycles: each new cycle is the first one moved by the clip's net
root displacement and heading change, applied k times for cycle k. An episode may also move the
reference root horizontally under the character at each new cycle (`sync_root_offset`).
"""

from __future__ import annotations

from typing import Any, NamedTuple, Sequence

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.character import Character
from mjxmimic.core.errors import UserError
from mjxmimic.core.layout import Layout, join_qpos, make_layout

# Grid cells per frame at most, so a clip with a few very short frames does not get a huge table;
# times inside frames shorter than the grid step are then looked up to within one step (see
# `_frame_index`). A fixed-rate clip gets one cell per frame.
MAX_CELLS_PER_FRAME = 64
_BELOW_ONE = float(np.nextafter(np.float32(1.0), np.float32(0.0)))  # largest float32 below 1


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
    grid_frame: np.ndarray  # (G,) int32 clip-local frame in force at each grid time, all clips
    grid_start: np.ndarray  # (C,) index of each clip's first grid entry
    grid_size: np.ndarray  # (C,) grid entries per clip
    grid_step: np.ndarray  # (C,) grid step in seconds
    clip_weight: np.ndarray  # (C,) sampling weights, summing to 1
    clip_cdf: np.ndarray  # (C,) running sum of clip_weight; 1.0 exactly from the last weighted clip on


def _segment_velocity(layout: Layout, q0: np.ndarray, q1: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """qvel that takes q0 to q1 in dt: world linear root velocity, local angular velocities."""
    dt = dt[..., None]
    scalars = (q1[..., layout.q_scalar] - q0[..., layout.q_scalar]) / dt
    a, b = q0[..., layout.q_quat], q1[..., layout.q_quat]
    ang = quat.to_rotvec(quat.mul(quat.conj(a), b)) / dt[..., None]
    flat = np.concatenate([scalars, ang.reshape(*ang.shape[:-2], -1)], axis=-1)
    return flat[..., layout.v_perm]


def _check_durations(name: str, dur: np.ndarray) -> None:
    """Frame durations a library can use: finite, >= 0, a positive total."""
    bad = np.flatnonzero(~np.isfinite(dur) | (dur < 0))
    if bad.size:
        raise UserError(f"clip {name}: frame {int(bad[0])} (0-based) has duration {dur[bad[0]]:g}; "
                        "durations must be finite and >= 0")
    if not dur.sum() > 0:
        raise UserError(f"clip {name}: its frames last 0 s in total")


def _fill_from_neighbours(vel: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """vel with each invalid row replaced by the nearest valid one before it (after it at the start).

    A 0-duration frame is a jump: its finite-difference velocity would be infinite, so it takes the
    velocity of the segment beside it instead.
    """
    idx = np.where(valid, np.arange(len(valid)), -1)
    idx = np.maximum.accumulate(idx)
    idx[idx < 0] = np.flatnonzero(valid)[0]
    return vel[idx]


def _time_grid(times: np.ndarray, duration: np.float32) -> tuple[np.float32, np.ndarray]:
    """(step, frame in force at each k * step) for one clip's float32 frame start times.

    The step is no longer than the shortest gap between distinct frame times (equal times, from
    0-duration frames, are one boundary), bounded below by the mean frame over MAX_CELLS_PER_FRAME.
    Built in float64 from the float32 values that `sample` compares against, so it is exact.
    """
    t = times.astype(np.float64)
    gaps = np.diff(np.unique(t))
    mean = float(duration) / max(len(t) - 1, 1)
    step = max(float(gaps.min()) if gaps.size else mean, mean / MAX_CELLS_PER_FRAME)
    step32 = np.float32(step)
    if float(step32) > step:  # rounding up could put two boundaries in one cell
        step32 = np.nextafter(step32, np.float32(0.0))
    cells = int(np.floor(float(duration) / float(step32))) + 2  # covers k + 1 for tau = duration
    grid = np.arange(cells) * float(step32)  # exact: k * (a float32) fits in a float64
    return step32, (np.searchsorted(t, grid, side="right") - 1).astype(np.int32)


def _clip_weights(weights: Sequence[float] | None, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Normalised weights and their running sum, checked; raises UserError."""
    if weights is None:
        w = np.ones(count)
    else:
        try:
            w = np.asarray(weights, dtype=np.float64)
        except (TypeError, ValueError):
            raise UserError(f"clip weights must be numbers, got {weights!r}") from None
    if w.shape != (count,):
        raise UserError(f"clip weights: expected one weight per clip ({count}), got {w.size}")
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise UserError(f"clip weights must be finite and >= 0, got {w.tolist()}")
    if not w.sum() > 0:
        raise UserError("clip weights are all 0: at least one clip needs a positive weight")
    w = w / w.sum()
    cdf = np.cumsum(w)
    cdf[np.flatnonzero(w > 0)[-1]:] = 1.0  # so u < 1 never lands past the last weighted clip
    return w.astype(np.float32), cdf.astype(np.float32)


def _frame_velocities(seg: np.ndarray, loop: bool, yaw: float, velocity: str) -> np.ndarray:
    """(F, nv) velocity at each frame from the F - 1 segments' `seg`. forward: each frame the
    velocity of the segment it starts (blended between frames, they lead the slerped pose by half a
    frame); central: the mean of the segments on either side. A cyclic clip's last frame is the
    next cycle's first, turned by the cycle's yaw (the root's linear velocity is in world axes)."""
    def turned(v: np.ndarray, angle: float) -> np.ndarray:
        v = v.copy()
        v[0:3] = quat.rotate_yaw(v[0:3], np.asarray(angle))
        return v

    if velocity == "forward":
        first = seg[0]
        inner = seg[1:]
    elif velocity == "central":
        first = 0.5 * (turned(seg[-1], -yaw) + seg[0]) if loop else seg[0]
        inner = 0.5 * (seg[:-1] + seg[1:])
    else:
        raise ValueError(f"reference velocity {velocity!r}: expected forward or central")
    last = turned(first, yaw) if loop else seg[-1]
    return np.concatenate([first[None], inner, last[None]], axis=0)


def build_motion_lib(clips: Sequence[Any], character: Character,
                     weights: Sequence[float] | None = None, velocity: str = "forward") -> MotionLib:
    """Concatenate clips (mjxmimic.motion.clip.Clip) into one library, computing velocities.

    `weights` (one per clip, default uniform) set how often `draw_clip` picks each clip;
    `velocity` (config key clip.velocity) how frames give the reference its velocities.
    """
    if len(clips) == 0:
        raise UserError("a motion library needs at least one clip")
    clip_weight, clip_cdf = _clip_weights(weights, len(clips))
    layout = make_layout(character)
    qpos, qvel, times, frame_clip = [], [], [], []
    starts, counts, durations, loops, yaws, origins, shifts = [], [], [], [], [], [], []
    grids, grid_starts, grid_sizes, grid_steps = [], [], [], []
    start = grid_at = 0
    for c, clip in enumerate(clips):
        q = np.asarray(clip.qpos, dtype=np.float64)
        dur = np.asarray(clip.durations, dtype=np.float64)[:-1]
        _check_durations(clip.name, dur)
        moving = dur > 0
        vel = _segment_velocity(layout, q[:-1], q[1:], np.where(moving, dur, 1.0))
        vel = _fill_from_neighbours(vel, moving)
        first_yaw, last_yaw = quat.heading(q[0, 3:7]), quat.heading(q[-1, 3:7])
        yaw = float(quat.wrap_angle(last_yaw - first_yaw)) if clip.loop else 0.0
        clip_times = np.concatenate([[0.0], np.cumsum(dur)]).astype(np.float32)
        step, grid = _time_grid(clip_times, np.float32(dur.sum()))
        qpos.append(q)
        qvel.append(_frame_velocities(vel, bool(clip.loop), yaw, velocity))
        times.append(clip_times)
        frame_clip.append(np.full(len(q), c))
        starts.append(start)
        counts.append(len(q))
        durations.append(dur.sum())
        loops.append(bool(clip.loop))
        yaws.append(yaw)
        origins.append(q[0, 0:2])
        shifts.append(q[-1, 0:2] - q[0, 0:2] if clip.loop else np.zeros(2))
        grids.append(grid)
        grid_starts.append(grid_at)
        grid_sizes.append(len(grid))
        grid_steps.append(step)
        start += len(q)
        grid_at += len(grid)
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
        grid_frame=np.concatenate(grids),
        grid_start=np.array(grid_starts, dtype=np.int32),
        grid_size=np.array(grid_sizes, dtype=np.int32),
        grid_step=np.array(grid_steps, dtype=f32),
        clip_weight=clip_weight,
        clip_cdf=clip_cdf,
    )


def draw_clip(lib: MotionLib, u: Any, xp: Any = np) -> Any:
    """The clip index that a uniform number u in [0, 1) picks, in proportion to the clip weights.

    Takes u rather than a key so that numpy and jax.numpy callers share it (vmap over u for many).
    """
    u = xp.clip(u, 0.0, _BELOW_ONE)
    return xp.searchsorted(lib.clip_cdf, u, side="right")


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


END_TOLERANCE_S = 1e-4  # a clip time this close to a one-off clip's end counts as its end


def ended(lib: MotionLib, clip: Any, t: Any, xp: Any = np) -> Any:
    """A clip that does not loop has reached its end at time t."""
    return ~lib.loop[clip] & (t >= lib.duration[clip] - END_TOLERANCE_S)


def cycle_index(lib: MotionLib, clip: Any, t: Any, xp: Any = np) -> Any:
    """Which cycle of a cyclic clip time `t` falls in (0, 1, ...); 0 for a clip that does not loop."""
    return xp.where(lib.loop[clip], xp.floor(t / lib.duration[clip]), 0.0)


def _frame_index(lib: MotionLib, clip: Any, tau: Any, xp: Any) -> Any:
    """The last clip-local frame starting at or before tau (0 <= tau <= duration), in constant time.

    A grid cell (k step, (k+1) step] holds at most one distinct frame time, so for tau in cell k
    the answer is grid entry k or k + 1: the later one if its frame has started. The float k may
    be one off either way, hence entries k-1 .. k+2, of which the last started one is the answer.
    Where a clip has frames shorter than its step (see MAX_CELLS_PER_FRAME) a time inside them may
    resolve to an earlier frame, i.e. the pose at most one step back.
    """
    size = lib.grid_size[clip]
    k = xp.floor(tau / lib.grid_step[clip])
    cells = xp.clip(k + xp.arange(-1.0, 3.0), 0, size - 1).astype(xp.int32)
    frames = lib.grid_frame[lib.grid_start[clip] + cells]
    started = lib.times[lib.clip_start[clip] + frames] <= tau
    return xp.max(xp.where(started, frames, 0))


def sample(lib: MotionLib, clip: Any, t: Any, xp: Any = np) -> tuple[Any, Any]:
    """Reference (qpos, qvel) of `clip` at time `t` (scalars; vmap for batches)."""
    dur = lib.duration[clip]
    cycle = cycle_index(lib, clip, t, xp)
    tau = xp.clip(t - cycle * dur, 0.0, dur)

    n = lib.clip_frames[clip]
    local = xp.clip(_frame_index(lib, clip, tau, xp), 0, n - 2)
    i0 = lib.clip_start[clip] + local
    t0, t1 = lib.times[i0], lib.times[i0 + 1]
    alpha = xp.clip((tau - t0) / xp.maximum(t1 - t0, 1e-9), 0.0, 1.0)

    q0, q1 = lib.qpos[i0], lib.qpos[i0 + 1]
    lay = lib.layout
    scalars = (1.0 - alpha) * q0[lay.q_scalar] + alpha * q1[lay.q_scalar]
    quats = quat.slerp(q0[lay.q_quat], q1[lay.q_quat], xp.full((len(lay.q_quat), 1), alpha), xp)
    qpos = join_qpos(lay, scalars, quats, xp)
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
    new_cycle = cycle_index(lib, clip, t, xp) > cycle_index(lib, clip, t_prev, xp)
    return xp.where(new_cycle, sim_xy - ref_xy, offset)


def shift_root(qpos: Any, offset: Any, xp: Any = np) -> Any:
    """qpos with its root moved horizontally by offset (2,)."""
    return xp.concatenate([qpos[0:2] + offset, qpos[2:]])
