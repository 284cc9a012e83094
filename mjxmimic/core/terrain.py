"""Terrain courses (DEEPMIMIC.md, "Beyond one clip": dense gaps, a winding balance beam, stairs,
mixed obstacles) as a pure description, a height function written once for numpy and jax.numpy,
and the heightmap observation.

The description is a set of axis-aligned boxes, each standing on the pit floor (`-depth_m`) with
its top at some height: the flat ground of a course is a box whose top is z = 0, a gap is where
no box is, a stair step is a box whose top is higher. The scene builds the same boxes as MuJoCo
box geoms (box-sphere, box-capsule and box-box collisions are exact in MJX impl='jax', impl='warp'
and MuJoCo C; the floor plane drops to the pit floor), and the height function reads them, so the
physics, the heightmap and the start placement share one source of truth.

Per-env variety with one model: `lanes` courses side by side along y (lane l centred at
y = l * lane_width_m), each drawn from (seed, l); an env starts on the lane that its event seed
picks, on the flat start pad (x in [0.5, START_PAD_M - 0.5]) facing +x, so it never starts over a
gap or inside a step. A course runs from x = 0 to x = length_m (its end, where success is
counted); a flat pad lies before and after it. Every walkable surface is at z >= 0, so the root
below -fall_margin_m means the character fell into a gap or off the beam.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.config import TERRAINS
from mjxmimic.core.errors import UserError

START_PAD_M = 2.0  # flat ground before x = 0, where episodes start
END_PAD_M = 40.0  # flat ground after the course's end, long enough that a character that crossed it
# keeps going on flat ground for the rest of its episode instead of walking off into the pit


class Terrain(NamedTuple):
    """boxes: (N, 5) rows of (centre x, centre y, half length x, half width y, top z)."""

    boxes: Any
    depth: float  # the pit floor is at z = -depth
    lanes: int
    lane_width: float
    length: float


def _box(x0: float, x1: float, y0: float, y1: float, top: float) -> tuple[float, ...]:
    return (0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (x1 - x0), 0.5 * (y1 - y0), top)


def _ground(x0: float, x1: float, half: float) -> tuple[float, ...]:
    return _box(x0, x1, -half, half, 0.0)


def _gaps(rng: np.random.Generator, difficulty: float, length: float, half: float) -> list[tuple[float, ...]]:
    """Platforms 1-2 m long with gaps of 0.2 + 0.8 d (up to +-20 %) between them."""
    boxes, x = [], 0.0
    while x < length:
        run = rng.uniform(1.0, 2.0)
        boxes.append(_ground(x, x + run, half))
        x += run + (0.2 + 0.8 * difficulty) * rng.uniform(0.8, 1.2)
    boxes.append(_ground(min(x, length), max(x, length) + END_PAD_M, half))
    return boxes


def _beam(rng: np.random.Generator, difficulty: float, length: float, half: float) -> list[tuple[float, ...]]:
    """A beam 0.5 - 0.3 d wide in 1 m segments whose centre line winds sideways (a random walk
    of steps up to 0.25 d m, kept within the lane), each segment overlapping the next by its width."""
    width = 0.5 - 0.3 * difficulty
    boxes, y, x = [], 0.0, 0.0
    while x < length:
        boxes.append(_box(x - 0.5 * width, x + 1.0 + 0.5 * width, y - 0.5 * width, y + 0.5 * width, 0.0))
        y = float(np.clip(y + rng.uniform(-1.0, 1.0) * 0.25 * difficulty, -half + width, half - width))
        x += 1.0
    boxes.append(_ground(min(x, length), max(x, length) + END_PAD_M, half))
    return boxes


def _stairs(rng: np.random.Generator, difficulty: float, length: float, half: float) -> list[tuple[float, ...]]:
    """Flights of 4-8 steps up (rise 0.05 + 0.15 d, tread 0.3-0.4 m), a 3-tread landing, as many
    down, 3 treads flat. A flight is nested boxes (step k's box spans from the k-th tread up to
    the k-th tread down), so the height is their maximum and the geom count is one per step.
    The n-th step up is n mm narrower on each side than the ground under it, so that no two
    boxes share a side face (coplanar faces flicker in renders)."""
    boxes, x = [_ground(0.0, 1.0, half)], 1.0
    while x < length:
        steps, rise, tread = int(rng.integers(4, 9)), 0.05 + 0.15 * difficulty, rng.uniform(0.3, 0.4)
        span = (2 * steps + 2) * tread  # up, landing (the top step's tread + 2 more), down
        boxes.append(_ground(x, x + span + 3 * tread, half))
        for k in range(steps):
            side = half - 1e-3 * (k + 1)
            boxes.append(_box(x + k * tread, x + span - k * tread, -side, side, rise * (k + 1)))
        x += span + 3 * tread
    boxes.append(_ground(min(x, length), max(x, length) + END_PAD_M, half))
    return boxes


def _mixed(rng: np.random.Generator, difficulty: float, length: float, half: float) -> list[tuple[float, ...]]:
    """Segments of flat ground, gaps, and blocks to step onto (0.1 + 0.3 d high) or over."""
    boxes, x = [], 0.0
    while x < length:
        kind, run = rng.integers(3), rng.uniform(0.8, 1.6)
        if kind == 0:
            boxes.append(_ground(x, x + run, half))
        elif kind == 1:
            boxes.append(_ground(x, x + run, half))
            run += (0.2 + 0.6 * difficulty) * rng.uniform(0.8, 1.2)  # a gap after the ground
        else:
            boxes.append(_box(x, x + run, -half, half, (0.1 + 0.3 * difficulty) * rng.uniform(0.5, 1.0)))
        x += run
    boxes.append(_ground(min(x, length), max(x, length) + END_PAD_M, half))
    return boxes


_GENERATORS = {"gaps": _gaps, "beam": _beam, "stairs": _stairs, "mixed": _mixed}


def generate(kind: str, seed: int = 0, difficulty: float = 0.5, lanes: int = 4, length: float = 20.0,
             lane_width: float = 3.0, depth: float = 2.0) -> Terrain:
    """`lanes` courses of `kind`, lane l drawn from (seed, l), as one set of boxes."""
    if kind not in _GENERATORS:
        raise UserError(f"config key 'terrain.kind': {kind!r} must be 'none' or one of {', '.join(TERRAINS)}")
    half = 0.5 * lane_width
    rows = []
    for lane in range(lanes):
        rng = np.random.default_rng([seed, lane])
        lane_boxes = [_box(-START_PAD_M, 0.0, -half, half, 0.0)] + _GENERATORS[kind](rng, difficulty, length, half)
        rows += [(cx, cy + lane * lane_width, hx, hy, top) for cx, cy, hx, hy, top in lane_boxes]
    return Terrain(boxes=np.array(rows, np.float32), depth=depth, lanes=lanes, lane_width=lane_width,
                   length=length)


def from_config(cfg: Any) -> Terrain | None:
    """The terrain of a `TerrainConfig`, None for kind 'none'."""
    if cfg.kind == "none":
        return None
    return generate(cfg.kind, cfg.seed, cfg.difficulty, cfg.lanes, cfg.length_m, cfg.lane_width_m, cfg.depth_m)


def height(boxes: Any, depth: float, xy: Any, xp: Any) -> Any:
    """Terrain height at points xy (..., 2): the highest box top over the point, else -depth.

    `boxes` must be concrete (a host array): the loop over them unrolls into one elementwise
    kernel. XLA's GPU compiler took minutes over the same maximum written as a reduction across a
    (points, boxes) array once a course had about a hundred boxes."""
    xy = xp.asarray(xy)
    h = xp.full(xy.shape[:-1], -depth, xy.dtype)
    for cx, cy, hx, hy, top in np.asarray(boxes, np.float64).tolist():
        inside = (xp.abs(xy[..., 0] - cx) <= hx) & (xp.abs(xy[..., 1] - cy) <= hy)
        h = xp.where(inside & (h < top), xp.asarray(top, xy.dtype), h)
    return h


def grid_offsets(rows: int, cols: int, spacing: float, forward: float) -> np.ndarray:
    """(rows * cols, 2) points of the heightmap in the heading frame: `rows` along the facing
    (x, nearest first), `cols` across it (y, left to right as seen from above), centred `forward`
    m ahead of the root."""
    x = (np.arange(rows) - 0.5 * (rows - 1)) * spacing + forward
    y = (np.arange(cols) - 0.5 * (cols - 1)) * spacing
    gx, gy = np.meshgrid(x, y, indexing="ij")
    return np.stack([gx.ravel(), gy.ravel()], axis=-1).astype(np.float32)


def heightmap(boxes: Any, depth: float, offsets: Any, root_pos: Any, yaw: Any, xp: Any) -> Any:
    """(rows * cols,) terrain heights relative to the root's height at the grid points `offsets`,
    turned by the root's heading `yaw` and placed at the root."""
    c, s = xp.cos(yaw), xp.sin(yaw)
    world = xp.stack([root_pos[0] + c * offsets[:, 0] - s * offsets[:, 1],
                      root_pos[1] + s * offsets[:, 0] + c * offsets[:, 1]], axis=-1)
    return (height(boxes, depth, world, xp) - root_pos[2]).astype(xp.float32)


def start_pose(terrain: Terrain, qpos: Any, qvel: Any, event_seed: Any, xp: Any) -> tuple[Any, Any]:
    """The reference state placed on the course: turned to face +x, its root moved to the start
    pad of the lane that the event seed picks (x uniform in [0.5 - pad, -0.5]) and lifted by the
    terrain height there (0 on the pad)."""
    lane = xp.floor(event_seed * terrain.lanes)
    u = (event_seed * terrain.lanes) % 1.0
    x = -START_PAD_M + 0.5 + u * (START_PAD_M - 1.0)
    y = lane * terrain.lane_width
    lift = height(terrain.boxes, terrain.depth, xp.stack([x, y]), xp)
    turn = -quat.heading(qpos[3:7], xp)
    root = xp.stack([x, y, qpos[2] + lift]).astype(qpos.dtype)
    qpos = xp.concatenate([root, quat.mul(quat.from_yaw(turn, xp), qpos[3:7], xp), qpos[7:]])
    # the free joint's linear velocity is in the world frame and turns; its angular velocity is in
    # the root's own frame, which turns with the root
    return qpos, xp.concatenate([quat.rotate_yaw(qvel[0:3], turn, xp), qvel[3:]])



# ---- course metrics of evaluation episodes (issue 16): distance before a fall, success -------

def course_start(start_x: Any, xp: Any) -> dict[str, Any]:
    """Per episode: the root's x at the start, and the furthest x reached so far."""
    start_x = xp.asarray(start_x, xp.float32)
    return {"start_x": start_x, "reach_x": start_x}


def course_add(acc: dict[str, Any], active: Any, root_x: Any, xp: Any) -> dict[str, Any]:
    """Count one control step of the episodes still running without a fall (`active`)."""
    return {**acc, "reach_x": xp.where(active, xp.maximum(acc["reach_x"], root_x), acc["reach_x"])}


def course_summarize(acc: dict[str, Any], length: float) -> dict[str, float]:
    """Per-episode values (host arrays) -> distance travelled along the course (+x) before a fall
    or the horizon's end (m), and success = the root reached the course's end (x = length)."""
    reach = np.asarray(acc["reach_x"], np.float64)
    return {"course_distance_m": float((reach - np.asarray(acc["start_x"], np.float64)).mean()),
            "course_success_rate": float((reach >= length).mean())}
