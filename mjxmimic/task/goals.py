"""Tasks (DEEPMIMIC.md, "Beyond one clip"): a goal that the character chases while it imitates,
r = task.imitation_weight * r_imitation + task.task_weight * r_task (0.7 and 0.3 in the paper),
the goal appended to the observation in the character's heading frame.

heading: move in a commanded direction at a commanded speed v*;
    r_task = exp(-2.5 max(0, v* - v . d*)^2), v the centre of mass velocity, d* the direction
    (going faster than v* is not penalised). v* is `task.speed`, or the clip's own average speed
    (cycle displacement / duration) when that is 0. The direction is drawn afresh every
    `task.resample_s` of the episode, uniformly around the circle, from the episode's event seed
    and the goal's index by an additive recurrence, so that the step needs no random numbers and
    MJX and the CPU env set the same goals. Observation: cos and sin of the direction relative to
    the character's facing, and v*.

strike: hit a target with a body (the right foot for the spinkick). At reset the target is placed
    `task.target_min_m` to `task.target_max_m` from the root in any direction, at
    `task.target_height_m`, again from the episode's event seed; a hit is the striking body's centre
    within `task.target_radius_m` of the target's (a choice: DEEPMIMIC.md does not say how a hit
    is detected). r_task = 1 once the target has been hit, else exp(-4 d^2), d the distance between
    the two (the form that the paper gives, as we read it; DEEPMIMIC.md states only the 0.7 / 0.3
    mix). Observation: the target relative to the root in the heading frame, and whether it has
    been hit. The target and the hit flag are the episode's goal state (`Motion.goal`). With
    `task.target_each_cycle` a looping clip gets a new target, placed the same way around the
    character, at each new cycle of its clip (a travelling spinkick leaves a fixed target
    behind); success is then the share of targets shown that were hit.

throw: throw a ball onto a target on the floor (the pitch clip). The ball (mjxmimic.core.scene, a
    free body after the character) is carried by overwriting its position and velocity with the
    hand's at the end of every control step that starts before `task.release_s` of clip time (a
    kinematic carry: the same on MJX-JAX, MJX-Warp and MuJoCo C, no constraint to toggle); from
    then on it flies freely, so it leaves the hand with the hand's velocity at the first control
    step boundary at or after `task.release_s` (mjxmimic.envs.step.released). The
    target is placed as strike's, on the floor. It lands when it first comes within
    LAND_TOLERANCE_M of resting on the floor after release; where it landed is taken to be where the
    ballistic prediction of the step before put it (the ball touches nothing but the floor, so the
    flight is ballistic, and 1/30 s of rolling after the touch does not count). r_task =
    exp(-k max(0, d - target radius)^2) (k: `task.throw_shape`), d the distance from the target of where the
    ball would land if it flew freely from now on (held: if let go now), and after landing of
    where it landed: a shaped choice, DEEPMIMIC.md states only the 0.7 / 0.3 mix and that success is
    the ball landing on the target. Success (a hit): it landed within `task.target_radius_m`.
    Observation: the target and the ball relative to the root and the ball's velocity, all in the
    heading frame, then whether the ball has been let go and whether it has landed. Goal state:
    (target x, y, landed, d).

While a task steers the character, the imitation reward grades the pose, not where the clip
walks: the reference is turned about the vertical and moved so that its root stands where the
character's does, facing its way (`align_reference`).
"""

from __future__ import annotations

from typing import Any

from mjxmimic.core import quat
from mjxmimic.core.config import TaskConfig
from mjxmimic.core.kinematics import ROOT_BODY, Kin, com_velocity
from mjxmimic.motion import library as motion_lib

GOAL_SIZE = {"": 0, "heading": 3, "strike": 4, "throw": 11}
# per-step metrics of each task (summed over an evaluation episode's running steps)
METRICS = {"": (), "heading": ("reward/task", "task/speed_along", "task/speed"),
           "strike": ("reward/task", "task/hit", "task/distance", "task/new_hit", "task/new_target",
                      "task/whole_cycle_hit"),
           "throw": ("reward/task", "task/hit", "task/distance")}
PLASTIC = 0.7548776662466927  # 1 / the plastic number: a well-spread additive recurrence
SPEED_TOLERANCE = 0.15  # a heading episode succeeds when its speed along the goal is within 15 % of v*
GRAVITY = 9.81  # m/s^2, MuJoCo's default, which the scene keeps
HOLD_OFFSET = (0.0, 0.0, -0.08)  # throw: the ball's centre in the hand body's frame (beyond the wrist)
LAND_TOLERANCE_M = 0.01  # throw: the ball has landed once its centre is this close to its radius


def clip_speed(lib: Any, clip: Any, xp: Any) -> Any:
    """The clip's average horizontal root speed over one cycle (m/s)."""
    shift = lib.cycle_shift[clip]
    return xp.sqrt(xp.sum(shift * shift)) / lib.duration[clip]


def heading_goal(task: TaskConfig, lib: Any, clip: Any, episode_time: Any, event_seed: Any, xp: Any) -> tuple[Any, Any]:
    """(world yaw of the commanded direction, commanded speed) at `episode_time`."""
    k = xp.floor(episode_time / task.resample_s)
    yaw = 2.0 * xp.pi * ((3.0 * event_seed + PLASTIC * (k + 1.0)) % 1.0)
    speed = task.speed if task.speed > 0 else clip_speed(lib, clip, xp)
    return yaw, xp.asarray(speed, xp.float32)


def goal_observation(frame_yaw: Any, yaw: Any, speed: Any, xp: Any) -> Any:
    """The commanded direction relative to the observation's heading frame (its yaw `frame_yaw`),
    and the commanded speed."""
    relative = yaw - frame_yaw
    return xp.stack([xp.cos(relative), xp.sin(relative), speed]).astype(xp.float32)


def speed_along(k: Kin, body_mass: Any, yaw: Any, xp: Any) -> Any:
    """The centre of mass velocity along the commanded direction (m/s)."""
    v = com_velocity(k, body_mass, xp)
    return v[0] * xp.cos(yaw) + v[1] * xp.sin(yaw)


def heading_reward(along: Any, speed: Any, xp: Any) -> Any:
    return xp.exp(-2.5 * xp.maximum(0.0, speed - along) ** 2)


def place_target(task: TaskConfig, root_qpos: Any, event_seed: Any, xp: Any, index: Any = 0) -> Any:
    """The strike goal state (target x, y, z, hit = 0) around the root `root_qpos`: the episode's
    `index`-th target (0 at reset)."""
    event_seed = xp.asarray(event_seed, xp.float32)
    n = xp.asarray(index, xp.float32) + 1.0
    angle = 2.0 * xp.pi * ((5.0 * event_seed + PLASTIC * n) % 1.0)
    u = (7.0 * event_seed + PLASTIC * PLASTIC * n) % 1.0
    distance = task.target_min_m + (task.target_max_m - task.target_min_m) * u
    return xp.stack([root_qpos[0] + distance * xp.cos(angle), root_qpos[1] + distance * xp.sin(angle),
                     xp.asarray(task.target_height_m, angle.dtype), xp.zeros_like(angle)]).astype(xp.float32)


def strike(task: TaskConfig, k: Kin, body: int, goal: Any, xp: Any) -> tuple[Any, Any, Any]:
    """(r_task, the goal state after the step, the distance between striking body and target)."""
    distance = xp.sqrt(xp.sum((k.xipos[body] - goal[:3]) ** 2))
    hit = (goal[3] > 0) | (distance < task.target_radius_m)
    r_task = xp.where(hit, 1.0, xp.exp(-4.0 * distance**2))
    return r_task, xp.concatenate([goal[:3], hit.astype(goal.dtype)[None]]), distance


def renew_target(task: TaskConfig, lib: Any, clip: Any, time_before: Any, time_after: Any, root_qpos: Any,
                 event_seed: Any, goal: Any, xp: Any) -> tuple[Any, Any, Any]:
    """(the strike goal state after a step from clip time `time_before` to `time_after`, whether
    it is a new target, whether the target it replaces had a whole cycle): with
    `task.target_each_cycle`, a looping clip's new cycle places the target anew (its index is the
    cycle's), else `goal` stays. An episode starts in cycle 0 (RSI draws a time within the clip),
    so the targets placed at later cycles' starts are the ones shown for a whole kick."""
    if not task.target_each_cycle:
        no = xp.zeros((), bool)
        return goal, no, no
    cycle_before = motion_lib.cycle_index(lib, clip, time_before, xp)
    cycle = motion_lib.cycle_index(lib, clip, time_after, xp)
    new = cycle > cycle_before
    return xp.where(new, place_target(task, root_qpos, event_seed, xp, cycle), goal), new, new & (cycle_before >= 1)


def ball_in_hand(k: Kin, hand: int, xp: Any) -> tuple[Any, Any]:
    """The held ball's free-joint (qpos (7,), qvel (6,)): at HOLD_OFFSET in the hand's frame, moving
    with the hand (orientation the world's, so its angular velocity is the hand's in world axes)."""
    r = xp.einsum("ij,j->i", k.xmat[hand], xp.asarray(HOLD_OFFSET, k.xipos.dtype))
    w = k.angvel[hand]
    v = k.linvel[hand] + xp.cross(w, r)
    return xp.concatenate([k.xipos[hand] + r, xp.asarray([1.0, 0.0, 0.0, 0.0], r.dtype)]), xp.concatenate([v, w])


def landing_point(pos: Any, vel: Any, radius: float, xp: Any) -> Any:
    """Where (x, y) a ball at `pos` moving at `vel` comes down to `radius` above the floor in free
    flight (straight down from where it is if it is already there)."""
    height = xp.maximum(pos[2] - radius, 0.0)
    fall = (vel[2] + xp.sqrt(vel[2] ** 2 + 2.0 * GRAVITY * height)) / GRAVITY
    return pos[:2] + vel[:2] * fall


def throw_start(task: TaskConfig, root_qpos: Any, event_seed: Any, xp: Any) -> Any:
    """The throw goal state at reset: (target x, y, landed = 0, d = the target's distance from the
    root), the target placed as strike's (`place_target`) on the floor."""
    target = place_target(task, root_qpos, event_seed, xp)
    d = xp.sqrt(xp.sum((target[:2] - root_qpos[:2]) ** 2))
    return xp.stack([target[0], target[1], xp.zeros_like(d), d]).astype(xp.float32)


def throw(task: TaskConfig, ball_pos: Any, ball_vel: Any, released: Any, radius: float, goal: Any,
          xp: Any) -> tuple[Any, Any, Any, Any]:
    """(r_task, the goal state after the step, d, hit) from the ball's state after the step (the
    module docstring)."""
    landed_before = goal[2] > 0
    touched = released & (ball_pos[2] <= radius + LAND_TOLERANCE_M)
    predicted = xp.sqrt(xp.sum((landing_point(ball_pos, ball_vel, radius, xp) - goal[:2]) ** 2))
    d = xp.where(landed_before | touched, goal[3], predicted)
    landed = landed_before | touched
    hit = landed & (d <= task.target_radius_m)
    r_task = xp.exp(-task.throw_shape * xp.maximum(0.0, d - task.target_radius_m) ** 2)
    state = xp.stack([goal[0], goal[1], landed.astype(goal.dtype), d.astype(goal.dtype)])
    return r_task, state, d, hit


def throw_observation(k: Kin, goal: Any, ball_pos: Any, ball_vel: Any, released: Any, frame_yaw: Any,
                      xp: Any) -> Any:
    """The target (on the floor) and the ball relative to the root, the ball's velocity, all in the
    heading frame (yaw `frame_yaw`); whether the ball has been let go, whether it has landed."""
    root, turn = k.xipos[ROOT_BODY], -frame_yaw
    target = xp.concatenate([goal[:2], xp.zeros_like(goal[:1])]) - root
    parts = [quat.rotate_yaw(target, turn, xp), quat.rotate_yaw(ball_pos - root, turn, xp),
             quat.rotate_yaw(ball_vel, turn, xp), xp.stack([xp.asarray(released, goal.dtype), goal[2]])]
    return xp.concatenate(parts).astype(xp.float32)


def target_observation(k: Kin, goal: Any, frame_yaw: Any, xp: Any) -> Any:
    """The target relative to the root in the heading frame (yaw `frame_yaw`), and the hit flag."""
    relative = quat.rotate_yaw(goal[:3] - k.xipos[ROOT_BODY], -frame_yaw, xp)
    return xp.concatenate([relative, goal[3:4]]).astype(xp.float32)


def align_reference(ref_qpos: Any, ref_qvel: Any, sim_qpos: Any, xp: Any) -> tuple[Any, Any]:
    """The reference turned about the vertical through its root to face the character's way and
    moved horizontally to the character's root (its height, tilt and joints unchanged)."""
    turn = quat.heading(sim_qpos[3:7], xp) - quat.heading(ref_qpos[3:7], xp)
    q_turn = quat.from_yaw(turn, xp)
    root = xp.concatenate([sim_qpos[0:2], ref_qpos[2:3], quat.mul(q_turn, ref_qpos[3:7], xp), ref_qpos[7:]])
    # the free joint's linear velocity is in the world frame and turns; its angular velocity is in
    # the root's own frame, which turns with the root
    return root, xp.concatenate([quat.rotate_yaw(ref_qvel[0:3], turn, xp), ref_qvel[3:]])


# ---- task metrics of evaluation episodes (EVALUATION.md, "Task success") ------------------------

def metrics_start(task: str, shape: Any, xp: Any) -> dict[str, Any]:
    return {key: xp.zeros(shape) for key in METRICS[task]}


def metrics_add(acc: dict[str, Any], active: Any, metrics: dict[str, Any], xp: Any) -> dict[str, Any]:
    """Count one control step of the episodes still running (`active`)."""
    return {key: acc[key] + xp.where(active, metrics[key], 0.0) for key in acc}


def metrics_summarize(task: str, acc: dict[str, Any], horizon: Any, failed: Any) -> dict[str, float]:
    """Per-episode sums (host arrays) -> the task's return (mean r_task per horizon step, 0 after
    a fall) and success rate. heading: success = no fall and the speed along the goal within
    SPEED_TOLERANCE of v* (also reported: that speed over v*); strike: the share of targets shown
    that were hit (one per episode, or one per cycle with `task.target_each_cycle`; the last target
    of an episode counts too), and with a target per cycle also the share hit of those shown for
    a whole cycle (`whole_cycle_success_rate`); throw: the ball landed on the target."""
    import numpy as np

    acc = {k: np.asarray(v, np.float64) for k, v in acc.items()}
    out = {"task_return": float((acc["reward/task"] / np.asarray(horizon)).mean())}
    if task == "heading":
        ratio = acc["task/speed_along"] / np.maximum(acc["task/speed"], 1e-6)
        ok = ~np.asarray(failed, bool) & (np.abs(ratio - 1.0) <= SPEED_TOLERANCE)
        out["speed_ratio"] = float(ratio.mean())
        out["success_rate"] = float(ok.mean())
    elif task == "strike":  # the reset's target and one per new cycle
        targets = len(acc["task/new_target"]) + acc["task/new_target"].sum()
        out["success_rate"] = float(acc["task/new_hit"].sum() / targets)
        out["targets_per_episode"] = float(targets / len(acc["task/new_target"]))
        # the targets retired at a new cycle, less each episode's first (the reset's, shown from a
        # random phase); the last target of an episode is never retired
        whole = np.maximum(acc["task/new_target"] - 1.0, 0.0).sum()
        if whole > 0:
            out["whole_cycle_success_rate"] = float(acc["task/whole_cycle_hit"].sum() / whole)
    else:
        out["success_rate"] = float((acc["task/hit"] > 0).mean())
    return out
