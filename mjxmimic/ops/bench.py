"""Throughput and stability measurements (EVALUATION.md, "Samples per second").

physics_only: the backend's PD substeps and physics steps, no policy, reward or resets (the limit).
env_step:     the full environment step (PD, physics, kinematics, observation, reward, resets).
train_loop:   the whole PPO iteration (rollout, GAE, updates) as training runs it.
tracking:     how well plain PD tracking of the reference (residual action 0) survives at a physics
              rate and solver setting: the stability and quality side of the physics-rate choice.
Compile time and steady state are timed apart; the steady-state figure is the median of repeats.
"""

from __future__ import annotations

import dataclasses
import platform
import statistics
import time
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from mjxmimic.core.config import Config, apply_overrides
from mjxmimic.physics.pd import action_to_targets
from mjxmimic.envs.mjx_env import ImitationEnv


def environment_info() -> dict[str, Any]:
    import brax
    import mujoco

    dev = jax.devices()[0]
    return {
        "device": f"{dev.platform}:{dev.device_kind}",
        "device_count": jax.device_count(),
        "jax": jax.__version__,
        "mujoco": mujoco.__version__,
        "brax": brax.__version__,
        "python": platform.python_version(),
        "date": time.strftime("%Y-%m-%d"),
    }


def peak_memory_bytes() -> int | None:
    stats = jax.devices()[0].memory_stats() or {}
    return stats.get("peak_bytes_in_use")


def _time(fn: Callable[[Any], Any], arg: Any, repeats: int) -> tuple[float, list[float], Any]:
    """Compile+first call time, then steady-state times of `repeats` calls."""
    start = time.perf_counter()
    out = jax.block_until_ready(fn(arg))
    compile_s = time.perf_counter() - start
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        out = jax.block_until_ready(fn(out))
        times.append(time.perf_counter() - start)
    return compile_s, times, out


@dataclasses.dataclass
class Measurement:
    kind: str
    backend: str  # physics backend: warp or jax
    num_envs: int
    physics_hz: int
    substeps: int
    solver_iterations: int
    ls_iterations: int
    control_steps: int
    compile_s: float
    median_s: float
    samples_per_s: float
    physics_steps_per_s: float
    peak_memory_bytes: int | None


def _measurement(kind: str, env: ImitationEnv, num_envs: int, steps: int, compile_s: float,
                 times: list[float]) -> Measurement:
    med = statistics.median(times)
    sps = num_envs * steps / med
    cfg = env.config.env
    return Measurement(kind, env.backend_name, num_envs, cfg.physics_hz, env.physics.substeps,
                       cfg.solver_iterations, cfg.ls_iterations, steps, compile_s, med, sps,
                       sps * env.physics.substeps, peak_memory_bytes())


def steps_for(num_envs: int) -> int:
    """Control steps per timed call: about 262 k samples (32 steps at 8192 envs, 4 at 65536), so
    that every env count is timed over a similar amount of work and the large ones take seconds."""
    return max(4, min(32, 2**18 // num_envs))


def solver_label(row: dict) -> str:
    """"4x4": Newton x line-search iterations of a Measurement row."""
    return f"{row['solver_iterations']}x{row['ls_iterations']}"


def physics_only(env: ImitationEnv, num_envs: int, steps: int | None = None, repeats: int = 5) -> Measurement:
    """The backend's PD substepping and physics (`env.physics.step`) for `steps` control steps
    (default `steps_for`), targets fixed at the start pose: no policy, reward or resets."""
    steps = steps or steps_for(num_envs)
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), num_envs))
    cfg = env.config.env
    zero = jnp.zeros(env.action_size)

    def one_env(data):
        targets = action_to_targets(env.spec.layout, zero, data.qpos, cfg.action_mode, cfg.action_scale, jnp)
        return jax.lax.scan(lambda d, _: (env.physics.step(d, targets).state, None), data, None, length=steps)[0]

    fn = jax.jit(jax.vmap(one_env), donate_argnums=0)
    compile_s, times, _ = _time(fn, states.pipeline_state, repeats)
    return _measurement("physics_only", env, num_envs, steps, compile_s, times)


def env_step(env: ImitationEnv, num_envs: int, steps: int | None = None, repeats: int = 5) -> Measurement:
    """The whole environment step (with resets) for `steps` control steps (default `steps_for`),
    zero actions."""
    steps = steps or steps_for(num_envs)
    states = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(0), num_envs))
    zero = jnp.zeros((num_envs, env.action_size))
    vstep = jax.vmap(env.step)

    def run(state):
        return jax.lax.scan(lambda s, _: (vstep(s, zero), None), state, None, length=steps)[0]

    compile_s, times, _ = _time(jax.jit(run, donate_argnums=0), states, repeats)
    return _measurement("env_step", env, num_envs, steps, compile_s, times)


def tracking(env: ImitationEnv, num_envs: int, seconds: float = 4.0, seed: int = 0) -> dict[str, float]:
    """PD tracking of the reference with residual action 0 from RSI starts, no resets: survival,
    reward while upright, and how many states exploded (NaN or joint speed over the guard)."""
    if env.config.env.action_mode != "residual":
        raise ValueError("tracking needs env.action_mode = residual")
    steps = int(round(seconds * env.config.env.control_hz))
    zero = jnp.zeros((num_envs, env.action_size))
    vtrans = jax.vmap(env.transition)

    def run(key):
        state = jax.vmap(env.reset)(jax.random.split(key, num_envs))

        def body(carry, _):
            state, alive, bad = carry
            nxt = vtrans(state, zero)
            exploded = nxt.metrics["physics/reset_nan"] > 0
            reward = jnp.where(alive, nxt.reward, 0.0)
            return (nxt, alive & (nxt.done == 0), bad | (alive & exploded)), (reward, alive)

        (_, alive, bad), (rewards, alive_t) = jax.lax.scan(body, (state, jnp.ones(num_envs, bool),
                                                                   jnp.zeros(num_envs, bool)), None, length=steps)
        return rewards, alive_t, bad

    rewards, alive_t, bad = jax.jit(run)(jax.random.PRNGKey(seed))
    alive_t = np.asarray(alive_t)
    alive_steps = alive_t.sum(axis=0)
    return {
        "seconds": seconds,
        "survival_s": float(alive_steps.mean() / env.config.env.control_hz),
        "survived_fraction": float((alive_steps == steps).mean()),
        "reward_while_alive": float(np.asarray(rewards).sum() / max(alive_t.sum(), 1)),
        "exploded_fraction": float(np.asarray(bad).mean()),
    }


def with_settings(config: Config, physics_hz: int, iterations: int, ls_iterations: int) -> Config:
    return apply_overrides(config, {"env.physics_hz": physics_hz, "env.solver_iterations": iterations,
                                    "env.ls_iterations": ls_iterations})


def train_loop(env: ImitationEnv, config: Config, iterations: int | None = None) -> Measurement:
    """Samples/s of the full PPO iteration (rollout, reward, resets, GAE, updates), steady state;
    5 timed iterations by default, 3 once one iteration holds a million samples."""
    from mjxmimic.learn.ppo import make_trainer

    if iterations is None:
        iterations = 3 if config.ppo.num_envs * config.ppo.unroll_length >= 2**20 else 5
    trainer = make_trainer(env, config)
    step = lambda out: trainer.train_step(out[0])  # (state, metrics) -> (state, metrics)
    compile_s, times, _ = _time(step, (trainer.init(0), None), iterations)
    return _measurement("train_loop", env, config.ppo.num_envs, config.ppo.unroll_length, compile_s, times)
