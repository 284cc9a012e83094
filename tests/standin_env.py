"""A tiny stand-in with the ImitationEnv API (used by the PPO tests; no physics, trains in seconds).

A point in R^n tracks a looping reference trajectory ref(t) = 0.5 sin(2 pi t / T + phase_j).
Action a in [-1, 1]^n (after the policy's tanh) moves the point half way towards a:
x' = x + 0.5 (a - x). Reward exp(-20 mean((x' - ref(t'))^2)) in [0, 1]; the episode "falls"
(early termination) when mean |x' - ref(t')| > 0.25. RSI: reset at a uniformly random clip
time with x = ref(t). Auto-reset inside `step` with a fresh RSI draw, like the real env.
"""

from __future__ import annotations

from types import SimpleNamespace

import jax
import jax.numpy as jnp
from brax.envs.base import State

from mjxmimic.task.events import PUSH_SCALE


class StandInEnv:
    physics = SimpleNamespace(name="standin", simulator="stand-in (no physics)")  # what results name

    def __init__(self, n: int = 4, clip_duration: float = 2.0, control_dt: float = 1 / 30,
                 episode_steps: int = 120, looping: bool = True, fall_threshold: float = 0.25,
                 pad_observation_to: int = 0):
        self.n = n
        self.clip_duration = float(clip_duration)
        self.control_dt = float(control_dt)
        self.episode_steps = int(episode_steps)
        self.looping = looping
        self.fall_threshold = fall_threshold
        self._phase = jnp.linspace(0.0, 3.0, n)
        self._pad = max(0, pad_observation_to - (3 * n + 2))  # zeros, to mimic a larger observation
        self.max_eval_horizon = 600 if looping else int(round(self.clip_duration / self.control_dt))

    @property
    def observation_size(self) -> int:
        return 3 * self.n + 2 + self._pad

    @property
    def action_size(self) -> int:
        return self.n

    @property
    def backend(self) -> str:
        return "standin"

    @property
    def clip_durations(self):
        return jnp.asarray([self.clip_duration])

    @property
    def eval_start_limits(self):  # evaluation start times are drawn in [0, this) per clip
        return self.clip_durations

    def eval_horizon(self, t, clip=0):
        if self.looping:
            return 600 if isinstance(t, (int, float)) else jnp.full(jnp.shape(t), 600, jnp.int32)
        if isinstance(t, (int, float)):
            return int(round((self.clip_duration - t) / self.control_dt))
        return jnp.round((self.clip_duration - t) / self.control_dt).astype(jnp.int32)

    def _ref(self, t):
        return 0.5 * jnp.sin(2 * jnp.pi * t / self.clip_duration + self._phase)

    def _obs(self, x, t):
        w = 2 * jnp.pi * t / self.clip_duration
        return jnp.concatenate([x, self._ref(t), self._ref(t + self.control_dt),
                                jnp.array([jnp.sin(w), jnp.cos(w)]), jnp.zeros(self._pad)])

    def _metrics(self, reward, err, ee, fell):
        return {"reward": reward, "reward/imitation": reward, "reward/track": reward, "error/pose": err,
                "error/end_effector": ee, "fell": fell}

    def reset_at(self, rng, t, clip=0) -> State:
        t = jnp.asarray(t, jnp.float32)
        x = self._ref(t)
        zero = jnp.zeros(())
        info = {"t": t, "steps": jnp.zeros((), jnp.int32), "rng": rng, "truncation": zero, "failed": zero,
                "clip_end": zero}
        return State(pipeline_state=None, obs=self._obs(x, t), reward=zero, done=zero,
                     metrics=self._metrics(zero, zero, zero, zero), info=info | {"x": x})

    def reset(self, rng) -> State:
        rng, key = jax.random.split(rng)
        t = jax.random.uniform(key, (), maxval=self.clip_duration)
        return self.reset_at(rng, t)

    def transition(self, state: State, action, evaluation: bool = False) -> State:
        x, t = state.info["x"], state.info["t"]
        action = jnp.clip(action, -1.0, 1.0)
        x = x + 0.5 * (action - x)
        t = t + self.control_dt
        diff = x - self._ref(t)
        err = jnp.mean(jnp.abs(diff))
        fell = (err > self.fall_threshold).astype(jnp.float32)
        reward = jnp.exp(-20.0 * jnp.mean(diff**2)) * (1.0 - fell)
        steps = state.info["steps"] + 1
        limit = (steps >= self.episode_steps).astype(jnp.float32)
        clip_end = zero = jnp.zeros(())
        if not self.looping:
            clip_end = (t >= self.clip_duration - 1e-6).astype(jnp.float32)
        done = jnp.maximum(jnp.maximum(fell, limit), clip_end)
        truncation = limit * (1.0 - fell) * (1.0 - clip_end)
        info = {**state.info, "x": x, "t": t, "steps": steps, "truncation": truncation, "failed": fell,
                "clip_end": clip_end}
        del zero
        metrics = self._metrics(reward, err, 2 * err, fell)
        if evaluation:
            metrics["reward_paper"] = reward
        return state.replace(obs=self._obs(x, t), reward=reward, done=done, metrics=metrics, info=info)

    def select(self, pick, a: State, b: State) -> State:
        info = jax.tree_util.tree_map(lambda x, y: jnp.where(pick, x, y), a.info, b.info)
        return b.replace(obs=jnp.where(pick, a.obs, b.obs), info=info)

    def step(self, state: State, action) -> State:
        nxt = self.transition(state, action)
        rng, key = jax.random.split(nxt.info["rng"])
        fresh = self.reset(key)
        fresh = fresh.replace(info={**fresh.info, "rng": rng})
        nxt = nxt.replace(info={**nxt.info, "rng": rng})
        done = nxt.done > 0
        merged_info = jax.tree_util.tree_map(lambda a, b: jnp.where(done, a, b), fresh.info, nxt.info)
        # reward / done / metrics / truncation belong to the transition; obs and info to the new episode
        merged_info["truncation"] = nxt.info["truncation"]
        obs = jnp.where(done, fresh.obs, nxt.obs)
        return nxt.replace(obs=obs, info=merged_info)


class SeesPushScale(StandInEnv):
    """Keeps the push curriculum's factor in its info through restarts, as the real env does, and
    reports the factor that each step saw as a metric."""

    def reset_at(self, rng, t, clip=0):
        state = super().reset_at(rng, t, clip)
        return state.replace(info=state.info | {PUSH_SCALE: jnp.ones(())},
                             metrics=state.metrics | {"seen_scale": jnp.zeros(())})

    def step(self, state, action):
        out = super().step(state, action)
        return out.replace(info=out.info | {PUSH_SCALE: state.info[PUSH_SCALE]},
                           metrics=out.metrics | {"seen_scale": state.info[PUSH_SCALE]})
