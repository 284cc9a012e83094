"""The `reference_root` observation term: where the reference's root is, seen from the character's
(its offset in the character's heading frame, the heading difference), the same on MJX and
MuJoCo C, and carried by an exported policy."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic.core import quat
from mjxmimic.core.config import make_config
from mjxmimic.core.kinematics import Kin
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.envs.mjx_env import ImitationEnv
from mjxmimic.motion.clip import load_clip_source
from mjxmimic.portable import policy_file
from mjxmimic.task.observation import DEFAULT, observation_size, reference_root

OBSERVED = DEFAULT + ",reference_root"


def _root_only(qpos):
    """A Kin of which the term reads only qpos."""
    return Kin(qpos=qpos, qvel=None, xipos=None, xmat=None, angvel=None, linvel=None, com=None)


def test_the_offset_is_in_the_characters_heading_frame():
    # the character at (1, 2) facing +y; the reference 0.5 m to its front and turned 30 degrees to its left
    sim, ref = np.zeros(7), np.zeros(7)
    sim[0:3], sim[3:7] = [1.0, 2.0, 0.9], quat.from_yaw(np.float64(np.pi / 2))
    ref[0:3], ref[3:7] = [1.0, 2.5, 0.8], quat.from_yaw(np.float64(np.pi / 2 + np.pi / 6))
    expected = [0.5, 0.0, 0.5, np.sqrt(3) / 2]
    np.testing.assert_allclose(reference_root(_root_only(sim), ref, np), expected, atol=1e-12)
    np.testing.assert_allclose(reference_root(_root_only(jnp.asarray(sim, jnp.float32)),
                                              jnp.asarray(ref, jnp.float32), jnp), expected, atol=1e-6)


@pytest.fixture(scope="module")
def config():
    return make_config("cpu", {"env.action_mode": "residual", "env.observations": OBSERVED,
                               "physics.backend": "jax"})


@pytest.fixture(scope="module")
def walk(character):
    return load_clip_source("slow_walk", character)


def test_mujoco_c_reads_a_character_put_off_its_reference(config, character, walk):
    env = CpuEnv(config, character, [walk])
    assert env.observation_size == observation_size(character.model.nbody, DEFAULT) + 4
    np.testing.assert_allclose(env.reset_at(0.3)[-4:], [0.0, 0.0, 0.0, 1.0], atol=1e-6)
    qpos, qvel = env.reference(0.3)
    qpos = qpos.copy()
    qpos[0] -= 0.4  # 0.4 m behind the reference along world x
    obs = env.set_state(qpos, qvel, 0.3)
    yaw = quat.heading(qpos[3:7])
    np.testing.assert_allclose(obs[-4:-2], [0.4 * np.cos(yaw), -0.4 * np.sin(yaw)], atol=1e-6)
    np.testing.assert_allclose(obs[-2:], [0.0, 1.0], atol=1e-6)


def test_mjx_and_mujoco_c_observe_the_same_state_alike(config, character, walk):
    """After a step on MJX, MuJoCo C set to the same state, clip time and root offset reads the
    same term (the two simulators' steps differ a little; the observation must not)."""
    mjx_env, cpu_env = ImitationEnv(config, character, [walk]), CpuEnv(config, character, [walk])
    action = jnp.asarray(np.random.default_rng(0).normal(scale=0.2, size=character.action_size), jnp.float32)
    state = jax.jit(mjx_env.reset_at)(jax.random.PRNGKey(0), jnp.float32(0.3))
    for _ in range(3):
        state = jax.jit(mjx_env.transition)(state, action)
    assert float(state.done) == 0.0
    qpos, qvel = (np.asarray(x, np.float64) for x in mjx_env.physics.qpos_qvel(state.pipeline_state))
    obs = cpu_env.set_state(qpos, qvel, float(state.info["time"]), root_offset=np.asarray(state.info["root_offset"]))
    term = np.asarray(state.obs[-4:])
    assert np.abs(term[:2]).max() > 1e-3  # the character has left its reference
    np.testing.assert_allclose(term, obs[-4:], atol=1e-4)


def test_an_exported_policy_lays_the_term_out(config, character, walk):
    size = observation_size(character.model.nbody, OBSERVED)
    params = {"normalizer": {"mean": np.zeros(size, np.float32), "std": np.ones(size, np.float32)},
              "policy": {"hidden_0": {"kernel": np.zeros((size, 2 * character.action_size), np.float32),
                                      "bias": np.zeros(2 * character.action_size, np.float32)}}}
    pf = policy_file.make_policy_file(config, character, walk, params)
    layout = pf.manifest["observation"]["layout"]
    assert layout[-1]["name"] == "reference_root" and sum(p["size"] for p in layout) == size


def test_the_gpu_preset_observes_the_reference_root_and_its_tasks_do_not():
    assert make_config("gpu").env.observations == OBSERVED
    assert make_config("gpu").reward.kind == "paper"
    for task in ("heading", "strike", "throw"):
        told = make_config("gpu", {"task.name": task})
        assert (told.env.observations, told.reward.kind) == (DEFAULT, "released")
    asked = make_config("gpu", {"task.name": "heading", "reward.kind": "paper", "env.observations": OBSERVED})
    assert (asked.env.observations, asked.reward.kind) == (OBSERVED, "paper")
