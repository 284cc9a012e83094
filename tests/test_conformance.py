"""The same checks on every environment: the MJX env (MJX-JAX here), the CPU env (MuJoCo C) and
the stand-in that the PPO tests train on. Each is driven through a small adapter that resets to a
clip time and steps with an action."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic.envs.cpu_env import CpuEnv
from standin_env import StandInEnv


class Jitted:
    """An env with the Brax-style API (reset_at/transition), jitted, one episode."""

    def __init__(self, env, reset_at=None, evaluate=None):
        self.env = env
        self._reset = reset_at or jax.jit(env.reset_at)
        self._step = evaluate or jax.jit(lambda s, a: env.transition(s, a, evaluation=True))
        self.state = None

    def reset_at(self, t):
        self.state = self._reset(jax.random.PRNGKey(0), jnp.float32(t))
        return np.asarray(self.state.obs)

    def step(self, action):
        self.state = self._step(self.state, jnp.asarray(action, jnp.float32))
        s = self.state
        return (np.asarray(s.obs), float(s.reward), bool(s.done), bool(s.info["failed"]),
                float(s.metrics["reward_paper"]))


class Cpu:
    def __init__(self, env):
        self.env = env

    def reset_at(self, t):
        return self.env.reset_at(t)

    def step(self, action):
        s = self.env.step(action, grade_paper=True)
        return s.obs, s.reward, s.done, s.failed, s.metrics["reward_paper"]


@pytest.fixture(scope="module", params=["mjx", "cpu", "standin"])
def adapter(request, residual_env, env_fns):
    if request.param == "mjx":
        return Jitted(residual_env, env_fns.reset_at, env_fns.evaluate)
    if request.param == "cpu":
        return Cpu(CpuEnv(residual_env.config, residual_env.character, residual_env.clips[0]))
    return Jitted(StandInEnv())


def test_reset_and_steps_give_finite_observations_and_rewards_in_range(adapter):
    env = adapter.env
    rng = np.random.default_rng(0)
    obs = adapter.reset_at(0.3)
    assert obs.shape == (env.observation_size,) and np.all(np.isfinite(obs))
    for _ in range(6):
        obs, reward, done, failed, paper = adapter.step(rng.uniform(-0.2, 0.2, env.action_size))
        assert obs.shape == (env.observation_size,) and np.all(np.isfinite(obs))
        assert 0.0 <= reward <= 1.0 and 0.0 <= paper <= 1.0
        if failed:
            assert done and reward == 0.0 and paper == 0.0
            break


def test_evaluation_horizon_is_positive_and_bounded(adapter):
    env = adapter.env
    for t in (0.0, 0.5, float(np.asarray(env.clip_durations)[0]) * 0.9):
        h = int(env.eval_horizon(t))
        assert 1 <= h <= env.max_eval_horizon
