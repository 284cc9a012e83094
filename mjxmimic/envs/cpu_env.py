"""The control step (`mjxmimic.envs.step`) on MuJoCo's C simulator with numpy: one character,
its clip (or a dataset's clips, one of which drives the episode: the skill), one episode at a
time. No JAX on this path, so an exported policy plays wherever numpy and mujoco do (the viewer, rendering, sim-to-sim NR).

Time is kept in float32 as on MJX, so that both sample the same reference. With a converged
contact solve one control step agrees with MJX to < 1e-3 in every observation entry, on the
ground and in the air (tests/test_export_playback.py). At the gpu preset's 4 Newton iterations
MJX-Warp's solve is converged and MuJoCo C's is not, so playback lets MuJoCo C's run on
(mjxmimic.core.config.playback_config).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from mjxmimic.core.character import Character
from mjxmimic.core import terrain as terrain_lib
from mjxmimic.core.config import Config
from mjxmimic.envs import skill_switch
from mjxmimic.envs import starts
from mjxmimic.envs import step as step_lib
from mjxmimic.motion import library as motion_lib
from mjxmimic.physics.cpu import CpuPhysics
from mjxmimic.task import goals
from mjxmimic.task import nr as nr_rule
from mjxmimic.task import termination


ROUTE_VIA_S = 1.0  # how long a routed switch plays the skill it passes through


class Step(NamedTuple):
    obs: np.ndarray
    reward: float
    done: bool
    fell: bool
    failed: bool  # a termination term fired (a fall, or a state the simulator lost)
    truncated: bool  # the env's time limit, not a failure
    clip_end: bool
    metrics: dict[str, float]


class CpuEnv:
    """One character on MuJoCo's CPU simulator, on one clip or on a dataset's clips (`clip` a list,
    with `weights`), of which `self.motion.clip` is the one playing."""

    def __init__(self, config: Config, character: Character, clip: Any, weights: Any = None):
        env = config.env
        self.config = config
        self.character = character
        self.clips = list(clip) if isinstance(clip, (list, tuple)) else [clip]
        self.clip = self.clips[0]
        self.scene, self.spec = step_lib.build(config, character, self.clips, np, weights)
        self.model = self.scene.model
        self.observation_size, self.action_size = self.spec.observation_size, self.spec.action_size
        self.substeps = env.physics_hz // env.control_hz
        self.physics = CpuPhysics(self.scene, self.spec.layout, self.substeps, env.torque_limit)
        self.data = self.physics.data
        self.control_dt = self.spec.control_dt
        self.max_steps = self.spec.max_steps
        self.max_eval_horizon = starts.max_eval_horizon(self.spec)
        self.clip_durations = self.spec.lib.duration
        self.eval_start_limits = starts.eval_start_limits(self.spec, np)
        self.clip_duration = float(self.spec.lib.duration[0])
        self.terminations = termination.evaluation_list(env.early_termination, config.terrain.kind != "none")
        self.motion = step_lib.Motion(clip=0, time=np.float32(0.0), steps=0, root_offset=np.zeros(2), event_seed=0.0,
                                      goal=np.zeros(4, np.float32))
        self.requested: int | None = None
        self.resume_clip: int | None = None
        # (from, to) -> the skill a switch passes through first (mjxmimic.portable.skills.best_routes)
        self.routes: dict[tuple[int, int], int] = {}
        self.then: tuple[int, int] | None = None  # a routed switch's target, control steps left before it
        # clips that a switch leaves only where their cycle ends, as a one-off clip (a backflip lands)
        self.finish_cycle: set[int] = set()

    @property
    def time(self) -> float:
        return float(self.motion.time)

    def reference(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Reference (qpos, qvel) at clip time t as the reward sees it (step.graded_reference)."""
        qpos, qvel = motion_lib.sample(self.spec.lib, self.motion.clip, np.float32(t), np)
        return step_lib.graded_reference(self.spec, qpos, qvel, self.data.qpos, self.motion.root_offset, np)

    def set_state(self, qpos: Any, qvel: Any, t: float, steps: int = 0, root_offset: Any = (0.0, 0.0),
                  event_seed: float = 0.0, clip: int = 0) -> np.ndarray:
        """Put the character in (qpos, qvel) at time t of clip number `clip` (the throw task's ball in
        its hand unless qpos has the ball's too); returns the observation."""
        self.physics.init(*step_lib.with_ball(self.spec, self.physics, np.asarray(qpos), np.asarray(qvel)))
        self.requested = self.resume_clip = self.then = None  # the skill selector's pending switch (switch)
        self.motion = step_lib.Motion(clip=int(clip), time=np.float32(t), steps=int(steps),
                                      root_offset=np.array(root_offset, dtype=np.float64),
                                      event_seed=float(event_seed),
                                      goal=step_lib.initial_goal(self.spec, qpos, event_seed, np))
        return self._observe(self.motion)

    def _observe(self, motion: step_lib.Motion) -> np.ndarray:
        qpos, qvel, ball_q, ball_v = step_lib.split_ball(self.spec, self.data.qpos, self.data.qvel)
        return step_lib.observe(self.spec, self.physics, self.physics.kinematics(qpos, qvel), motion, (ball_q, ball_v))

    def reset_at(self, t: float, event_seed: float = 0.0, clip: int = 0) -> np.ndarray:
        """The reference state at time t of clip number `clip` (RSI); returns the observation.
        `event_seed` in [0, 1) varies the episode's events and goals."""
        qpos, qvel = starts.start_state(self.spec, clip, np.float32(t), np.float32(event_seed), np)
        return self.set_state(qpos, qvel, t, event_seed=event_seed, clip=clip)

    def switch(self, clip: int) -> np.ndarray:
        """Ask for clip number `clip` from here on (the skill selector): between cyclic clips at
        once; into or out of a one-off clip (a getup, a kick) where the playing clip's cycle ends
        (mjxmimic.envs.skill_switch, as training switches). A one-off clip hands back to the skill
        played before it at its end unless another was asked for. With `routes`, a switch passes
        through another skill for ROUTE_VIA_S first; out of a clip of `finish_cycle` it waits for
        that clip's cycle to end. Returns the observation, whose skill one-hot names the clip now
        followed."""
        via = self.routes.get((int(self.motion.clip), int(clip)))
        self.then = None if via is None else (int(clip), max(1, round(ROUTE_VIA_S / self.control_dt)))
        self.requested = int(clip) if via is None else via
        self._maybe_switch(float(self.motion.time))
        return self._observe(self.motion)

    def _maybe_switch(self, t_before: float) -> bool:
        motion, lib = self.motion, self.spec.lib
        if self.then is not None and self.requested is None:  # on a routed switch's way
            target, left = self.then
            self.then = None if left <= 1 else (target, left - 1)
            if self.then is None:
                self.requested = target
        if self.requested is None and self.resume_clip is not None and motion_lib.ended(lib, motion.clip, motion.time):
            self.requested = self.resume_clip
        if self.requested is None or self.requested == motion.clip:
            self.requested = None
            return False
        if not skill_switch.may_switch(self.spec, motion.clip, self.requested, np.float32(t_before), motion.time, np,
                                       finish_cycle=motion.clip in self.finish_cycle):
            return False
        self.resume_clip = motion.clip if not lib.loop[self.requested] and lib.loop[motion.clip] else None
        qpos, qvel, _, _ = step_lib.split_ball(self.spec, self.data.qpos, self.data.qvel)
        moved = skill_switch.switched(self.spec, motion, self.requested, qpos, self.physics.kinematics(qpos, qvel), np)
        self.motion = moved._replace(clip=int(moved.clip), time=np.float32(moved.time))
        self.requested = None
        return True

    def step(self, action: Any, external_force: Any = None, grade_paper: bool = False) -> Step:
        t_before = float(self.motion.time)
        out = step_lib.control_step(self.spec, self.physics, self.data, self.motion,
                                    np.asarray(action, np.float64), self.terminations, external_force, grade_paper)
        self.motion = out.motion._replace(time=np.float32(out.motion.time), steps=int(out.motion.steps))
        failed, timeout = bool(out.failed), bool(out.truncation) and not bool(out.failed)
        obs, clip_end, done = np.asarray(out.obs), bool(out.clip_end), bool(out.done)
        if not failed and self._maybe_switch(t_before):
            obs, done, clip_end = self._observe(self.motion), timeout, False
        metrics = {k: float(v) for k, v in out.metrics.items()}
        return Step(obs=obs, reward=float(out.reward), done=done, fell=bool(metrics["fell"]), failed=failed,
                    truncated=timeout, clip_end=clip_end, metrics=metrics)

    def eval_horizon(self, t: float, clip: int = 0) -> int:
        return int(starts.eval_horizon(self.spec, clip, np.float32(t), np))

    def start_times(self, n: int, seed: int, clip: int = 0) -> np.ndarray:
        """n start times ~ U[0, clip duration) from a seeded numpy generator (the interval that
        MJX evaluation draws from, starts.eval_start_limits; its own times come from JAX's generator,
        see export)."""
        duration = float(self.eval_start_limits[clip])
        return np.random.default_rng(seed).uniform(0.0, duration, size=n).astype(np.float32)

    def episode(self, policy: Callable[[np.ndarray], np.ndarray], t0: float,
                on_step: Callable[[CpuEnv, Step], Any] | None = None, event_seed: float = 0.0,
                clip: int = 0) -> dict[str, Any]:
        """One evaluation episode of clip number `clip` from its reference state at t0, counted by
        `mjxmimic.task.nr`. on_step(env, step) after every step (a viewer); returning False ends
        the episode there."""
        obs = self.reset_at(t0, event_seed, clip)
        horizon = self.eval_horizon(t0, clip)
        acc = nr_rule.start((), np)
        task_acc = goals.metrics_start(self.config.task.name, (), np) if self.config.task.name else None
        course = None if self.spec.terrain is None else terrain_lib.course_start(self.data.qpos[0], np)
        for k in range(horizon):
            s = self.step(policy(obs), grade_paper=True)
            m = s.metrics
            if task_acc is not None:
                task_acc = goals.metrics_add(task_acc, True, m, np)
            if course is not None:
                course = terrain_lib.course_add(course, not s.failed, m["terrain/x"], np)
            acc = nr_rule.add_step(acc, k, horizon, m["reward/imitation"], m["reward_paper"], s.failed, s.clip_end,
                                   m["error/pose"], m["error/end_effector"], np)
            if (on_step is not None and on_step(self, s) is False) or not acc["alive"]:
                break
            obs = s.obs
        out = {k: float(acc[k]) for k in nr_rule.FIELDS}
        out.update(start_time=float(t0), horizon=horizon, nr=out["reward"] / horizon)
        if task_acc is not None:
            out["task"] = {k: float(v) for k, v in task_acc.items()}
        if course is not None:
            out["course"] = {k: float(v) for k, v in course.items()}
        return out
