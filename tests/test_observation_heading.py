"""env.observation_heading: the observation's heading frame from the yaw of the root's forward axis
(DeepMimic's) or from the twist of its rotation about the vertical, which stays steady where the
root faces the floor; the same on MJX and MuJoCo C."""

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from mjxmimic.core import quat
from mjxmimic.core.config import make_config
from mjxmimic.core.errors import UserError
from mjxmimic.core.kinematics import Kin, root_yaw
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.envs.mjx_env import ImitationEnv
from mjxmimic.motion.clip import load_clip_source


def _about(axis: int, angle: float) -> np.ndarray:
    return quat.from_rotvec(np.eye(3)[axis] * angle)


def _yaws(q: np.ndarray, kind: str) -> tuple[float, float]:
    """The heading of rotation q from the quaternion and from its matrix (as the observation reads it)."""
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, q)
    k = Kin(qpos=None, qvel=None, xipos=None, xmat=np.stack([np.eye(3), mat.reshape(3, 3)]), angvel=None,
            linvel=None, com=None)  # the world body, then the root
    return float(quat.heading(q, np, kind)), float(root_yaw(k, np, kind))


def _off(a: float, b: float) -> float:
    return abs(float(quat.wrap_angle(np.float64(a - b))))


def test_twist_is_the_forward_heading_upright_and_steady_face_down():
    yaw = 0.7
    upright = quat.mul(_about(2, yaw), _about(1, 0.1))  # turned, leaning 6 degrees
    for kind in ("forward", "twist"):
        from_quat, from_matrix = _yaws(upright, kind)
        assert _off(from_quat, yaw) < 1e-9 and _off(from_matrix, yaw) < 1e-9
    face_down = quat.mul(_about(2, yaw), _about(1, np.radians(88)))  # the forward axis near the floor
    nudged = quat.mul(face_down, _about(2, np.radians(3)))  # turned 3 degrees about its own spine
    assert _off(_yaws(face_down, "forward")[0], yaw) < 1e-9
    assert _off(_yaws(nudged, "forward")[0], yaw) > np.radians(45)  # the projection swings
    for q in (face_down, nudged):
        from_quat, from_matrix = _yaws(q, "twist")
        assert _off(from_quat, yaw) < np.radians(3.5) and _off(from_matrix, from_quat) < 1e-9
    jax_twist = quat.heading(jnp.asarray(nudged, jnp.float32), jnp, "twist")
    assert _off(float(jax_twist), _yaws(nudged, "twist")[0]) < 1e-5


def test_a_heading_that_is_neither_is_one_config_error():
    with pytest.raises(UserError, match="env.observation_heading"):
        make_config("cpu", {"env.observation_heading": "up"})


@pytest.fixture(scope="module")
def walk(character):
    return load_clip_source("slow_walk", character)


def _config(heading: str):
    return make_config("cpu", {"env.observation_heading": heading, "physics.backend": "jax",
                               "env.observations": "phase,root_height,bodies,reference_root"})


def test_mujoco_c_turns_the_observation_by_the_twist(character, walk):
    """The same tilted state read in both frames: the same numbers but for a turn about the vertical."""
    forward_env = CpuEnv(_config("forward"), character, [walk])
    twist_env = CpuEnv(_config("twist"), character, [walk])
    qpos, qvel = forward_env.reference(0.3)
    qpos = qpos.copy()
    qpos[3:7] = quat.mul(quat.mul(qpos[3:7], _about(1, 1.0)), _about(2, 0.35))  # bent over, turned
    a, b = forward_env.set_state(qpos, qvel, 0.3), twist_env.set_state(qpos, qvel, 0.3)
    np.testing.assert_allclose(a[:2], b[:2])  # phase, root height
    nbody = character.model.nbody - 1
    positions_a, positions_b = a[2:2 + 3 * nbody].reshape(-1, 3), b[2:2 + 3 * nbody].reshape(-1, 3)
    turn = _yaws(qpos[3:7], "forward")[0] - _yaws(qpos[3:7], "twist")[0]
    assert _off(turn, 0.0) > 0.05
    np.testing.assert_allclose(quat.rotate_yaw(positions_a, turn, np), positions_b, atol=1e-6)


@pytest.mark.slow
def test_mjx_and_mujoco_c_observe_alike_in_the_twist_frame(character, walk):
    """After three steps on MJX (a mismatch of frames would part them by 0.17)."""
    config = _config("twist")
    mjx_env, cpu_env = ImitationEnv(config, character, [walk]), CpuEnv(config, character, [walk])
    action = jnp.asarray(np.random.default_rng(0).normal(scale=0.2, size=character.action_size), jnp.float32)
    state = jax.jit(mjx_env.reset_at)(jax.random.PRNGKey(0), jnp.float32(0.3))
    for _ in range(3):
        state = jax.jit(mjx_env.transition)(state, action)
    qpos, qvel = (np.asarray(x, np.float64) for x in mjx_env.physics.qpos_qvel(state.pipeline_state))
    obs = cpu_env.set_state(qpos, qvel, float(state.info["time"]),
                            root_offset=np.asarray(state.info["root_offset"]))
    np.testing.assert_allclose(np.asarray(state.obs), obs, atol=1e-3, rtol=1e-3)
