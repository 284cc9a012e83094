"""Normalised return (NR) exactly as /work/shared/docs/EVALUATION.md defines it.

- `run.eval_episodes` episodes (64 by default), vmapped; episode i starts at clip time
  t_i ~ U[0, clip_duration) from the reference state (`env.reset_at`, i.e. RSI).
- Deterministic policy (the mean action, tanh(loc)); no pushes; `env.transition` (no auto-reset,
  and none of the training-only env.pose_termination_m).
- Horizon H_i = env.eval_horizon(t_i) steps: 600 (20 s at 30 Hz) for a looping clip, to the
  clip's end otherwise. The rollout is one fixed-length `lax.scan` of env.max_eval_horizon steps;
  steps at or past H_i are masked.
- Per step reward r_t in [0, 1] is the env's imitation reward. An episode ends at its horizon
  or at its first `done` that is not a timeout (info["truncation"]; the env's own time limit does
  not cut an evaluation short). A fall (state.metrics["fell"]), or a non-timeout `done` more than
  one step before the horizon's end (the env's NaN/exploding-state guard; the one step of slack
  absorbs rounding of a non-looping clip's end), is a failure: every remaining step counts 0.
- NR = mean over episodes of sum_t(r_t) / H_i   (H_i >= 1).

Reported beside NR: fall rate (fraction of episodes that ended by a failure), mean survival
time (s; steps actually run, up to and including the failing step, times control_dt, averaged
over episodes), mean pose error (rad, the reward's weighting; "error/pose") and mean
end-effector error (m, "error/end_effector"), both pooled over all survived steps (steps run
before any failure, the failing step excluded), the number of episodes, and (when the caller
passes them) the training samples and wall-clock of the run.
"""

from __future__ import annotations

import time
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from mjxmimic.core.config import Config


def start_times(key: jax.Array, num_episodes: int, clip_duration: float) -> jax.Array:
    """Episode start times, uniform over the clip, from the first of three keys split from `key`
    (CPU playback replays the same starts from the same seed)."""
    k_time = jax.random.split(key, 3)[0]
    return jax.random.uniform(k_time, (num_episodes,), minval=0.0, maxval=clip_duration)


def _rollout(env, policy_fn: Callable, key: jax.Array, num_episodes: int) -> dict:
    """Per-episode sums (traceable; jit it). policy_fn(obs, key) -> action, batched over episodes."""
    _, k_reset, k_policy = jax.random.split(key, 3)
    t0 = start_times(key, num_episodes, env.clip_duration)
    state = jax.vmap(env.reset_at)(jax.random.split(k_reset, num_episodes), t0)
    horizon = jnp.maximum(jnp.broadcast_to(jnp.asarray(env.eval_horizon(t0), jnp.int32), (num_episodes,)), 1)
    horizon = jnp.minimum(horizon, env.max_eval_horizon)
    zeros = jnp.zeros((num_episodes,))
    alive0 = jnp.ones((num_episodes,), bool)

    def body(carry, k):
        state, alive, acc = carry
        key = jax.random.fold_in(k_policy, k)
        action = policy_fn(state.obs, key)
        nxt = jax.vmap(lambda s, a: env.transition(s, a, pose_termination=False))(state, action)
        active = alive & (k < horizon)
        fell = nxt.metrics["fell"] > 0
        done = nxt.done > 0
        truncation = nxt.info.get("truncation", jnp.zeros_like(nxt.done)) > 0
        # A done that is neither a timeout nor the horizon's end is a failure (ET, or the env's
        # NaN/exploding-state guard); one step of slack absorbs rounding of the clip's end.
        early = done & ~truncation & (k + 2 < horizon)
        failed = active & (fell | early)
        survived = active & ~failed
        acc = {
            "reward": acc["reward"] + jnp.where(active, nxt.reward, 0.0),
            "steps": acc["steps"] + active,
            "failed": acc["failed"] | failed,
            "ok_steps": acc["ok_steps"] + survived,
            "pose": acc["pose"] + jnp.where(survived, nxt.metrics["error/pose"], 0.0),
            "ee": acc["ee"] + jnp.where(survived, nxt.metrics["error/end_effector"], 0.0),
        }
        # Keep the carried state finite and fixed once an episode is over.
        state = jax.tree_util.tree_map(
            lambda new, old: jnp.where(jnp.reshape(active, active.shape + (1,) * (new.ndim - 1)), new, old),
            nxt, state)
        # Timeouts do not end an evaluation episode (the horizon does); everything else does.
        return (state, alive & ~(done & ~truncation), acc), None

    acc0 = {"reward": zeros, "steps": zeros.astype(jnp.int32), "failed": ~alive0,
            "ok_steps": zeros.astype(jnp.int32), "pose": zeros, "ee": zeros}
    (_, _, acc), _ = jax.lax.scan(body, (state, alive0, acc0), jnp.arange(env.max_eval_horizon))
    acc["horizon"] = horizon
    acc["start_time"] = t0
    return acc


def summarize(acc: dict, control_dt: float) -> dict:
    """Per-episode sums (host arrays) -> the EVALUATION.md numbers."""
    acc = {k: np.asarray(v) for k, v in acc.items()}
    ok = max(int(acc["ok_steps"].sum()), 1)
    per_episode = acc["reward"] / acc["horizon"]
    return {
        "nr": float(per_episode.mean()),
        "nr_std": float(per_episode.std()),
        "fall_rate": float(acc["failed"].mean()),
        "survival_s": float(acc["steps"].mean() * control_dt),
        "pose_error_rad": float(acc["pose"].sum() / ok),
        "end_effector_error_m": float(acc["ee"].sum() / ok),
        "mean_horizon_steps": float(acc["horizon"].mean()),
        "episodes": int(len(per_episode)),
    }


def _finish(result: dict, seconds: float, samples: int | None, train_seconds: float | None) -> dict:
    result["eval_seconds"] = seconds
    if samples is not None:
        result["samples"] = int(samples)
    if train_seconds is not None:
        result["train_seconds"] = float(train_seconds)
    return result


def evaluate(env, policy_fn: Callable, config: Config, seed: int = 0, *, episodes: int | None = None,
             samples: int | None = None, train_seconds: float | None = None) -> dict:
    """NR and friends for a fixed `policy_fn(obs, key) -> action` (compiles on every call; for
    repeated evaluations of changing parameters use `Evaluator`)."""
    n = int(episodes or config.run.eval_episodes)
    start = time.time()
    acc = jax.jit(lambda key: _rollout(env, policy_fn, key, n))(jax.random.PRNGKey(seed))
    acc = jax.device_get(acc)
    return _finish(summarize(acc, env.control_dt), time.time() - start, samples, train_seconds)


class Evaluator:
    """Compiled once; `evaluator(params, seed)` for any params of the same structure.

    make_policy(params, deterministic) -> fn(obs, key) -> action (e.g. Trainer.make_policy).
    """

    def __init__(self, env, config: Config, make_policy: Callable[[Any, bool], Callable],
                 episodes: int | None = None):
        self.env = env
        self.num_episodes = int(episodes or config.run.eval_episodes)
        self._run = jax.jit(
            lambda params, key: _rollout(env, make_policy(params, True), key, self.num_episodes))

    def __call__(self, params: Any, seed: int = 0, *, samples: int | None = None,
                 train_seconds: float | None = None) -> dict:
        start = time.time()
        acc = jax.device_get(self._run(params, jax.random.PRNGKey(seed)))
        return _finish(summarize(acc, self.env.control_dt), time.time() - start, samples, train_seconds)
