"""The Table 6 push test: the force search, the push's direction, and real pushed trials on MJX."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic.core import quat
from mjxmimic.core.kinematics import ROOT_BODY
from mjxmimic.task import push_protocol as protocol


@pytest.mark.parametrize("threshold", [0.0, 37.0, 437.0, 1234.0])
def test_search_finds_the_largest_survived_force_to_the_resolution(threshold):
    calls = []

    def rate(force):
        calls.append(force)
        return 0.95 if force <= threshold else 0.5

    force, tried = protocol.largest_survived_force(rate)
    assert threshold - protocol.RESOLUTION_N <= force <= threshold
    assert [f for f, _ in tried] == calls and len(calls) < 20


def test_search_edges():
    assert protocol.largest_survived_force(lambda f: 0.8)[0] == 0.0  # falls even unpushed
    assert protocol.largest_survived_force(lambda f: 1.0, max_force=800.0)[0] == 800.0
    # 29 of 32 survive: 0.906 >= 90 %; 28 of 32 do not
    assert protocol.largest_survived_force(lambda f: 29 / 32 if f < 500 else 28 / 32)[0] >= 490


def test_protocol_timing():
    lead, push, total = protocol.steps(1 / 30)
    assert (lead, push, total) == (30, 6, 186)
    assert protocol.start_time_range(3.0, True) == 3.0
    assert protocol.start_time_range(2.0, False) == pytest.approx(0.8)
    assert protocol.start_time_range(1.0, False) == 0.0


@pytest.mark.parametrize("direction", ["forward", "sideways"])
def test_wrench_pushes_the_root_along_its_facing(direction):
    yaw = 0.7
    qpos = np.zeros(7 + 3)
    qpos[3:7] = quat.from_yaw(np.asarray(yaw))
    w = protocol.wrench(qpos, 300.0, protocol.DIRECTIONS[direction], 1.0, 5, np)
    expected = yaw + (0.0 if direction == "forward" else 0.5 * math.pi)
    np.testing.assert_allclose(w[ROOT_BODY, :3], [300 * math.cos(expected), 300 * math.sin(expected), 0], atol=1e-3)
    assert np.all(np.delete(w, ROOT_BODY, axis=0) == 0) and np.all(w[:, 3:] == 0)
    assert np.all(protocol.wrench(qpos, 300.0, 0.0, 0.0, 5, np) == 0)


@pytest.mark.slow
def test_pushed_trials_on_mjx(residual_env):
    """A real push through the env: a strong forward push speeds the root up along its facing,
    and knocks every trial down where an unpushed trial set does not fall more."""
    from mjxmimic.runs.push_eval import make_trials

    env = residual_env
    state = jax.jit(env.reset_at)(jax.random.PRNGKey(0), 0.5)
    qpos = env.physics.qpos_qvel(state.pipeline_state)[0]
    transition = jax.jit(lambda s, f: env.transition(s, jnp.zeros(env.action_size), True, f))
    quiet = transition(state, None)
    push = transition(state, protocol.wrench(qpos, 2000.0, 0.0, 1.0, env.model.nbody, jnp))
    dv = np.asarray(env.physics.qpos_qvel(push.pipeline_state)[1][:2] - env.physics.qpos_qvel(quiet.pipeline_state)[1][:2])
    yaw = float(quat.heading(np.asarray(qpos[3:7])))
    assert np.linalg.norm(dv) > 0.5  # 2000 N for 1/30 s on ~45 kg: about 1.5 m/s
    assert np.dot(dv / np.linalg.norm(dv), [math.cos(yaw), math.sin(yaw)]) > 0.95

    trials = make_trials(env, lambda obs, key: jnp.zeros(obs.shape[:-1] + (env.action_size,)), 4)
    key = jax.random.PRNGKey(1)
    unpushed = float(trials(key, jnp.float32(0.0), jnp.float32(0.0)))
    knocked = float(trials(key, jnp.float32(4000.0), jnp.float32(0.0)))
    assert knocked == 0.0 and unpushed >= knocked
    assert trials._cache_size() == 1  # force and direction are traced: one compilation per search


def test_pushed_trials_on_mujoco_c(character):
    """The CPU runner: a strong push knocks every trial down, in the direction pushed."""
    from mjxmimic.core.config import make_config
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.portable.push_playback import survival_rate

    env = CpuEnv(make_config("cpu", {"env.action_mode": "residual"}), character,
                 load_clip_source("slow_walk", character))
    zero = lambda obs: np.zeros(character.action_size)  # noqa: E731 (PD towards the reference)
    starts = np.array([0.1, 0.6])
    assert survival_rate(env, zero, 4000.0, 0.0, starts) == 0.0
    assert survival_rate(env, zero, 0.0, 0.0, starts) >= 0.0
    env.reset_at(0.5)
    yaw = float(quat.heading(env.data.qpos[3:7].copy()))
    before = env.data.qvel[:2].copy()
    env.step(zero(None), external_force=protocol.wrench(env.data.qpos, 2000.0, 0.5 * math.pi, 1.0,
                                                        env.model.nbody, np))
    dv = env.data.qvel[:2] - before
    assert np.dot(dv / np.linalg.norm(dv), [-math.sin(yaw), math.cos(yaw)]) > 0.9  # to its left



def test_trials_in_forked_workers_give_the_same_rates(character):
    """The CPU push test's trials spread over processes: the same survival rates as one after
    another (each trial depends on its start time alone)."""
    from mjxmimic.core.config import make_config
    from mjxmimic.envs.cpu_env import CpuEnv
    from mjxmimic.motion.clip import load_clip_source
    from mjxmimic.portable import push_playback

    env = CpuEnv(make_config("cpu", {"env.action_mode": "residual"}), character,
                 load_clip_source("slow_walk", character))
    zero = lambda obs: np.zeros(character.action_size)  # noqa: E731
    starts = np.array([0.1, 0.4, 0.6, 0.9])
    alone = [push_playback.survival_rate(env, zero, force, 0.0, starts) for force in (0.0, 150.0, 4000.0)]
    with push_playback.trial_pool(env, zero, 2) as pool:
        assert pool is not None
        forked = [push_playback.survival_rate(env, zero, force, 0.0, starts, pool) for force in (0.0, 150.0, 4000.0)]
    assert forked == alone and alone[-1] == 0.0
