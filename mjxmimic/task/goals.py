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

While a task steers the character, the imitation reward grades the pose, not where the clip
walks: the reference is turned about the vertical and moved so that its root stands where the
character's does, facing its way (`align_reference`).
"""

from __future__ import annotations

from typing import Any

from mjxmimic.core import quat
from mjxmimic.core.config import TaskConfig
from mjxmimic.core.kinematics import Kin, com_velocity, root_yaw

NAMES = ("heading",)
GOAL_SIZE = {"": 0, "heading": 3}
PLASTIC = 0.7548776662466927  # 1 / the plastic number: a well-spread additive recurrence
SPEED_TOLERANCE = 0.15  # a heading episode succeeds when its speed along the goal is within 15 % of v*


def clip_speed(lib: Any, clip: Any, xp: Any) -> Any:
    """The clip's average horizontal root speed over one cycle (m/s)."""
    shift = lib.cycle_shift[clip]
    return xp.sqrt(xp.sum(shift * shift)) / lib.duration[clip]


def heading_goal(task: TaskConfig, lib: Any, clip: Any, episode_time: Any, event_seed: Any, xp: Any) -> tuple[Any, Any]:
    """(world yaw of the commanded direction, commanded speed) at `episode_time`."""
    k = xp.floor(episode_time / task.resample_s)
    yaw = 2.0 * xp.pi * ((3.0 * event_seed + PLASTIC * (k + 1.0)) % 1.0)
    speed = xp.where(task.speed > 0, task.speed, clip_speed(lib, clip, xp))
    return yaw, xp.asarray(speed, xp.float32)


def goal_observation(k: Kin, yaw: Any, speed: Any, xp: Any) -> Any:
    relative = yaw - root_yaw(k, xp)
    return xp.stack([xp.cos(relative), xp.sin(relative), speed]).astype(xp.float32)


def speed_along(k: Kin, body_mass: Any, yaw: Any, xp: Any) -> Any:
    """The centre of mass velocity along the commanded direction (m/s)."""
    v = com_velocity(k, body_mass, xp)
    return v[0] * xp.cos(yaw) + v[1] * xp.sin(yaw)


def heading_reward(along: Any, speed: Any, xp: Any) -> Any:
    return xp.exp(-2.5 * xp.maximum(0.0, speed - along) ** 2)


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

def metrics_start(shape: Any, xp: Any) -> dict[str, Any]:
    zeros = xp.zeros(shape)
    return {"task_reward": zeros, "speed_along": zeros, "speed": zeros}


def metrics_add(acc: dict[str, Any], active: Any, metrics: dict[str, Any], xp: Any) -> dict[str, Any]:
    """Count one control step of the episodes still running (`active`)."""
    return {"task_reward": acc["task_reward"] + xp.where(active, metrics["reward/task"], 0.0),
            "speed_along": acc["speed_along"] + xp.where(active, metrics["task/speed_along"], 0.0),
            "speed": acc["speed"] + xp.where(active, metrics["task/speed"], 0.0)}


def metrics_summarize(acc: dict[str, Any], horizon: Any, failed: Any) -> dict[str, float]:
    """Per-episode sums (host arrays) -> task return (mean r_task per horizon step, 0 after a
    fall), the speed along the goal over the commanded speed, and the success rate: episodes that
    did not fall and held the commanded speed along the goal to within SPEED_TOLERANCE."""
    import numpy as np

    ratio = np.asarray(acc["speed_along"]) / np.maximum(np.asarray(acc["speed"]), 1e-6)
    ok = ~np.asarray(failed, bool) & (np.abs(ratio - 1.0) <= SPEED_TOLERANCE)
    return {"task_return": float((np.asarray(acc["task_reward"]) / np.asarray(horizon)).mean()),
            "speed_ratio": float(ratio.mean()), "success_rate": float(ok.mean())}
