"""Sim-to-sim NR: EVALUATION.md's protocol on MuJoCo's CPU simulator (`mjxmimic.envs.cpu_env`),
counted by the rule MJX evaluation shares (`mjxmimic.task.nr`). Start times: the MJX evaluation's
own (carried in the exported file), or a seeded draw. No JAX (a test checks).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from mjxmimic.core.terrain import course_summarize
from mjxmimic.envs.cpu_env import CpuEnv, Step
from mjxmimic.task import goals
from mjxmimic.task import nr as nr_rule


def summarize(episodes: list[dict[str, Any]], control_dt: float) -> dict[str, Any]:
    """Per-episode sums -> the EVALUATION.md numbers (as MJX evaluation names them)."""
    acc = {k: np.array([e[k] for e in episodes]) for k in nr_rule.FIELDS}
    return nr_rule.summarize(acc, np.array([e["horizon"] for e in episodes]), control_dt)


def evaluate(env: CpuEnv, policy: Callable[[np.ndarray], np.ndarray], starts: Any,
             progress: Callable[[int, dict], Any] | None = None,
             on_step: Callable[[CpuEnv, Step], Any] | None = None, clip: int = 0) -> dict[str, Any]:
    """Sim-to-sim NR: one episode of clip number `clip` per start time on the CPU simulator.
    on_step(env, step) after every step (a viewer); returning False ends that episode."""
    t_start = time.perf_counter()
    episodes = []
    for i, t0 in enumerate(np.asarray(starts, np.float32)):
        # each episode its own goals (a task's), the same in every playback
        episodes.append(env.episode(policy, float(t0), on_step=on_step, event_seed=(i * goals.PLASTIC) % 1.0,
                                    clip=clip))
        if progress is not None:
            progress(i, episodes[-1])
    wall = time.perf_counter() - t_start
    out = summarize(episodes, env.control_dt)
    if episodes and "task" in episodes[0]:
        task = {k: np.array([e["task"][k] for e in episodes]) for k in episodes[0]["task"]}
        out.update(goals.metrics_summarize(env.config.task.name, task, np.array([e["horizon"] for e in episodes]),
                                           np.array([e["failed"] for e in episodes])))
    if episodes and "course" in episodes[0]:
        course = {k: np.array([e["course"][k] for e in episodes]) for k in episodes[0]["course"]}
        out.update(course_summarize(course, env.config.terrain.length_m))
    steps = int(sum(e["steps"] for e in episodes))
    start_times = [e["start_time"] for e in episodes]
    out.update(control_steps=steps, eval_seconds=wall, steps_per_s=steps / wall if wall > 0 else None,
               start_times=start_times, per_episode_nr=[e["nr"] for e in episodes],
               fall_windows=nr_rule.fall_windows(start_times, [bool(e["failed"]) for e in episodes]))
    return out

