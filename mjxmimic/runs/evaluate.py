"""Normalised return (NR) exactly as /work/shared/docs/EVALUATION.md defines it, on MJX.

`run.eval_episodes` episodes (64 by default), vmapped; episode i starts at clip time
t_i ~ U[0, clip duration) from the reference state (RSI), runs the deterministic policy (tanh of
the mean) through `env.transition(..., evaluation=True)` (no auto-reset, none of the training-only
terminations) and is counted by `mjxmimic.task.nr`, the rule the CPU player shares: NR under the
training reward (`nr`, the released five-term form unless the run says otherwise) and under the
paper's four-term reward (`nr_paper`; discounted, `nr_paper_discounted`) from the same episodes,
fall rate, survival, errors. With a task, both NRs grade the imitation reward alone, and the
task's return and success rate (mjxmimic.task.goals) are reported beside them.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from mjxmimic.core import terrain as terrain_lib
from mjxmimic.core.config import Config
from mjxmimic.task import goals
from mjxmimic.task import nr as nr_rule


def start_times(key: jax.Array, num_episodes: int, clip_duration: float) -> jax.Array:
    """Episode start times, uniform over the clip, from the first of three keys split from `key`
    (CPU playback replays the same starts from the same seed)."""
    k_time = jax.random.split(key, 3)[0]
    return jax.random.uniform(k_time, (num_episodes,), minval=0.0, maxval=clip_duration)


def rollout(env, policy_fn: Callable, key: jax.Array, num_episodes: int, clip: int = 0,
            t0: jax.Array | None = None) -> dict:
    """Per-episode sums (traceable; jit it). policy_fn(obs, key) -> action, batched over episodes.
    The episodes start at the evaluation's draw from `key`, or at `t0` (num_episodes clip times)
    where given, to look at particular starts."""
    _, k_reset, k_policy = jax.random.split(key, 3)
    if t0 is None:
        t0 = start_times(key, num_episodes, env.eval_start_limits[clip])
    state = jax.vmap(lambda k, t: env.reset_at(k, t, clip))(jax.random.split(k_reset, num_episodes), t0)
    horizon = jax.vmap(lambda t: env.eval_horizon(t, clip))(t0)
    transition = jax.vmap(lambda s, a: env.transition(s, a, evaluation=True))

    task, on_terrain = task_of(env), _on_terrain(env)
    course = terrain_lib.course_start(state.pipeline_state.qpos[:, 0], jnp) if on_terrain else {}

    def body(carry, k):
        state, acc, task_acc, course = carry
        action = policy_fn(state.obs, jax.random.fold_in(k_policy, k))
        nxt = transition(state, action)
        m = nxt.metrics
        if task:
            task_acc = goals.metrics_add(task_acc, acc["alive"] & (k < horizon), m, jnp)
        if on_terrain:
            course = terrain_lib.course_add(course, acc["alive"] & (k < horizon) & ~(nxt.info["failed"] > 0),
                                            m["terrain/x"], jnp)
        acc = nr_rule.add_step(acc, k, horizon, m["reward/imitation"], m["reward_paper"], nxt.info["failed"] > 0,
                               nxt.info["clip_end"] > 0, m["error/pose"], m["error/end_effector"], jnp)
        # An episode that is over keeps its last state (finite, and cheap to step).
        state = jax.vmap(env.select)(acc["alive"], nxt, state)
        return (state, acc, task_acc, course), None

    def running(carry):  # until the longest horizon, or sooner once every episode has ended
        k, (_, acc, _, _) = carry
        return (k < env.max_eval_horizon) & jnp.any(acc["alive"] & (k < horizon))

    def step(carry):
        k, inner = carry
        return k + 1, body(inner, k)[0]

    start = (state, nr_rule.start((num_episodes,), jnp), goals.metrics_start(task, (num_episodes,), jnp), course)
    steps_run, (_, acc, task_acc, course) = jax.lax.while_loop(running, step, (jnp.zeros((), jnp.int32), start))
    acc["horizon"] = horizon
    acc["steps_run"] = steps_run
    acc["start_time"] = t0
    if task:
        acc["task"] = task_acc
    if on_terrain:
        acc["course"] = course
    return acc


def _on_terrain(env) -> bool:
    spec = getattr(env, "spec", None)
    return getattr(spec, "terrain", None) is not None


def task_of(env) -> str:
    """The env's task name ("" for none, and for envs without tasks such as the test stand-in)."""
    return env.config.task.name if "reward/task" in getattr(env, "metric_keys", ()) else ""


def summarize(acc: dict, control_dt: float, task: str = "", course_length: float = 0.0) -> dict:
    """Per-episode sums (host arrays) -> the EVALUATION.md numbers (and the task's, and on a
    terrain the course's: distance before a fall, success)."""
    sums = {k: v for k, v in acc.items() if k in nr_rule.FIELDS}
    result = nr_rule.summarize(sums, acc["horizon"], control_dt)
    result["steps_run"] = int(acc["steps_run"])  # control steps the batch ran (to its last episode's end)
    if task:
        result.update(goals.metrics_summarize(task, acc["task"], acc["horizon"], acc["failed"]))
    if "course" in acc:
        result.update(terrain_lib.course_summarize(acc["course"], course_length))
    return result


def _finish(result: dict, env, seconds: float, samples: int | None, train_seconds: float | None) -> dict:
    result["simulator"] = env.physics.simulator
    result["eval_seconds"] = seconds
    if samples is not None:
        result["samples"] = int(samples)
    if train_seconds is not None:
        result["train_seconds"] = float(train_seconds)
    return result


PER_CLIP_FIELDS = ("nr", "nr_paper", "nr_paper_discounted", "fall_rate")


def per_clip(env, run_clip: Callable[[jax.Array], dict]) -> dict:
    """One clip: its evaluation. A dataset: every clip's own (the episodes of clip c start on clip
    c, so a skill selector reads c), its NR fields as clip/<name>/<field>, and every figure
    averaged over the clips by their weights."""
    count = len(env.clip_durations)
    results = [run_clip(jnp.asarray(c, jnp.int32)) for c in range(count)]
    if count == 1:
        return results[0]
    weights = np.asarray(env.spec.lib.clip_weight, np.float64)
    out = {key: float(sum(w * r[key] for w, r in zip(weights, results)))
           for key, value in results[0].items() if isinstance(value, (int, float)) and not isinstance(value, bool)}
    out["episodes"] = sum(r["episodes"] for r in results)
    out["steps_run"] = sum(r["steps_run"] for r in results)
    for clip, r in zip(env.clips, results):
        out.update({f"clip/{clip.name}/{key}": r[key] for key in PER_CLIP_FIELDS})
    return out


def evaluate(env, policy_fn: Callable, config: Config, seed: int = 0, *, episodes: int | None = None,
             grid: float | None = None, samples: int | None = None, train_seconds: float | None = None) -> dict:
    """NR and friends for a fixed `policy_fn(obs, key) -> action` (compiles on every call; for
    repeated evaluations of changing parameters use `Evaluator`), with the runs of start times
    that fell (`fall_windows`). `grid` (seconds): a start every `grid` over each clip instead of
    the seeded draw of `episodes`."""
    n = int(episodes or config.run.eval_episodes)
    start = time.time()
    drawn = jax.jit(lambda key, clip: rollout(env, policy_fn, key, n, clip))
    key, task = jax.random.PRNGKey(seed), task_of(env)

    def run_clip(clip: jax.Array) -> dict:
        if grid is None:
            acc = drawn(key, clip)
        else:
            t0 = jnp.asarray(nr_rule.grid_starts(env.eval_start_limits[int(clip)], grid), jnp.float32)
            acc = jax.jit(lambda k: rollout(env, policy_fn, k, len(t0), clip, t0))(key)
        acc = jax.device_get(acc)
        out = summarize(acc, env.control_dt, task, config.terrain.length_m)
        out["fall_windows"] = nr_rule.fall_windows(np.asarray(acc["start_time"]).tolist(),
                                                   np.asarray(acc["failed"]).tolist())
        return out

    result = per_clip(env, run_clip)
    if grid is not None:
        result["grid_s"] = grid
    return _finish(result, env, time.time() - start, samples, train_seconds)


class Evaluator:
    """Compiled once; `evaluator(params, seed)` for any params of the same structure.

    make_policy(params, deterministic) -> fn(obs, key) -> action (e.g. Trainer.make_policy).
    With run.eval_stochastic the training policy is graded too, on the same start times, as
    `stochastic_*` fields: a deterministic NR far below it means the mean action has drifted from
    what training optimises.
    """

    STOCHASTIC_FIELDS = ("nr", "nr_paper", "fall_rate", "pose_error_rad")

    def __init__(self, env, config: Config, make_policy: Callable[[Any, bool], Callable],
                 episodes: int | None = None):
        self.env = env
        self.course_length = config.terrain.length_m
        self.num_episodes = int(episodes or config.run.eval_episodes)
        self.stochastic = config.run.eval_stochastic
        self._run = jax.jit(
            lambda params, key, deterministic, clip: rollout(env, make_policy(params, deterministic), key,
                                                             self.num_episodes, clip), static_argnums=2)
        self._compiled: dict[bool, Callable] = {}

    def lower(self, params: Any) -> dict[bool, jax.stages.Lowered]:
        """The rollouts traced for parameters shaped like `params` (arrays or their shapes)."""
        key, clip = jax.random.PRNGKey(0), jnp.zeros((), jnp.int32)
        return {deterministic: self._run.lower(params, key, deterministic, clip)
                for deterministic in ((True, False) if self.stochastic else (True,))}

    def compile(self, params: Any, lowered: dict[bool, jax.stages.Lowered] | None = None) -> None:
        """Compile ahead of time (from `lowered`, else traced here), so that the first evaluation
        does not wait for it (the training loop runs this in a thread)."""
        for deterministic, program in (lowered or self.lower(params)).items():
            self._compiled[deterministic] = program.compile()

    def _episodes(self, params: Any, key: jax.Array, deterministic: bool, clip: jax.Array) -> dict:
        compiled = self._compiled.get(deterministic)
        if compiled is not None:
            return compiled(params, key, clip)
        return self._run(params, key, deterministic, clip)

    def __call__(self, params: Any, seed: int = 0, *, samples: int | None = None,
                 train_seconds: float | None = None) -> dict:
        start = time.time()
        key = jax.random.PRNGKey(seed)
        task, dt = task_of(self.env), self.env.control_dt

        def graded(deterministic: bool) -> dict:
            return per_clip(self.env, lambda c: summarize(
                jax.device_get(self._episodes(params, key, deterministic, c)), dt, task, self.course_length))

        result = graded(True)
        if self.stochastic:
            noisy = graded(False)
            result.update({f"stochastic_{k}": noisy[k] for k in self.STOCHASTIC_FIELDS})
        return _finish(result, self.env, time.time() - start, samples, train_seconds)
