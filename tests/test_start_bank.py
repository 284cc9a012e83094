"""env.start_states: training episodes that start from given states, matched to the clip time of
the nearest reference pose and put onto that reference (mjxmimic.envs.start_bank)."""

import jax.numpy as jnp
import numpy as np
import pytest

from mjxmimic.core import quat
from mjxmimic.core.config import evaluation_config, make_config
from mjxmimic.core.errors import UserError
from mjxmimic.envs import start_bank
from mjxmimic.envs import starts
from mjxmimic.envs import step
from mjxmimic.motion import library as motion_lib
from mjxmimic.motion.clip import load_clip_source


@pytest.fixture(scope="module")
def clip(character):
    return load_clip_source("slow_walk", character)


def _turned(qpos, qvel, yaw, shift):
    """The state turned by `yaw` about the vertical through its root and moved by `shift`."""
    q, v = qpos.copy(), qvel.copy()
    q[0:2] += shift
    q[3:7] = quat.mul(quat.from_yaw(np.float32(yaw), np), q[3:7], np)
    v[0:3] = quat.rotate_yaw(v[0:3], np.float32(yaw), np)
    return q, v


def _bank_file(tmp_path, qpos, qvel):
    path = tmp_path / "states.npz"
    np.savez(path, qpos=np.asarray(qpos, np.float32), qvel=np.asarray(qvel, np.float32))
    return str(path)


def test_states_are_matched_to_their_clip_time_and_put_on_its_reference(character, clip, tmp_path):
    """Reference states turned and moved elsewhere come back as the reference at their own time."""
    lib = motion_lib.build_motion_lib([clip], character)
    dt, times = 1 / 30, (4, 11, 25)
    states = [motion_lib.sample(lib, 0, np.float32(k * dt), np) for k in times]
    moved = [_turned(q, v, yaw, shift) for (q, v), yaw, shift in
             zip(states, (1.0, -2.5, 3.0), ([3.0, -2.0], [0.0, 5.0], [-1.0, -1.0]), strict=True)]
    path = _bank_file(tmp_path, [q for q, _ in moved], [v for _, v in moved])
    config = make_config("cpu", {"env.start_states": path, "env.start_states_fraction": 0.5})
    scene, _ = step.build(config, character, [clip], np)
    bank = start_bank.build(config, character, scene, [clip], None, np)
    np.testing.assert_allclose(bank.time, [k * dt for k in times], atol=1e-5)
    assert list(bank.clip) == [0, 0, 0]
    for n, (q, v) in enumerate(states):
        np.testing.assert_allclose(bank.qpos[n, :3], q[:3], atol=1e-5)
        np.testing.assert_allclose(np.abs(np.dot(bank.qpos[n, 3:7], q[3:7])), 1.0, atol=1e-5)  # same rotation
        np.testing.assert_allclose(bank.qpos[n, 7:], q[7:], atol=1e-5)
        np.testing.assert_allclose(bank.qvel[n], v, atol=1e-4)


def test_a_share_of_resets_starts_from_the_bank_alike_on_numpy_and_jax(character, clip, tmp_path):
    lib = motion_lib.build_motion_lib([clip], character)
    q, v = motion_lib.sample(lib, 0, np.float32(0.5), np)
    q = q.copy()
    q[2] -= 0.3  # lower than any frame of the clip: not an RSI state
    path = _bank_file(tmp_path, [q], [v])
    config = make_config("cpu", {"env.start_states": path, "env.start_states_fraction": 0.5})
    scene, spec_np = step.build(config, character, [clip], np)
    spec_np = spec_np._replace(start_bank=start_bank.build(config, character, scene, [clip], None, np))
    spec_jax = step.build(config, character, [clip], jnp)[1]
    spec_jax = spec_jax._replace(start_bank=start_bank.build(config, character, scene, [clip], None, jnp))
    rsi_t, used = np.float32(0.1), []
    for seed in np.linspace(0.0, 1.0, 40, endpoint=False, dtype=np.float32):
        rsi_q, rsi_v = starts.start_state(spec_np, 0, rsi_t, seed, np)
        c, t, q_np, v_np = starts.from_bank(spec_np, 0, rsi_t, rsi_q, rsi_v, seed, np)
        c_j, t_j, q_j, _ = starts.from_bank(spec_jax, 0, jnp.float32(rsi_t), jnp.asarray(rsi_q), jnp.asarray(rsi_v),
                                          jnp.float32(seed), jnp)
        assert int(c_j) == int(c) and float(t_j) == pytest.approx(float(t)) and np.allclose(q_j, q_np, atol=1e-6)
        from_bank = float(t) != float(rsi_t)
        used.append(from_bank)
        np.testing.assert_allclose(q_np, spec_np.start_bank.qpos[0] if from_bank else rsi_q)
        assert float(t) == pytest.approx(float(spec_np.start_bank.time[0]) if from_bank else rsi_t)
    assert 0.25 < np.mean(used) < 0.75
    assert evaluation_config(config).env.start_states_fraction == 0.0  # graded from RSI only


@pytest.mark.parametrize("content, message", [
    (None, "no such file"),
    ({"qpos": np.zeros((2, 3))}, "no array 'qvel'"),
    ({"qpos": np.zeros((2, 3)), "qvel": np.zeros((2, 3))}, "must be"),
    ("not an npz", "not a readable .npz"),
])
def test_a_bad_start_states_file_is_one_line(character, clip, tmp_path, content, message):
    path = tmp_path / "states.npz"
    if isinstance(content, dict):
        np.savez(path, **content)
    elif isinstance(content, str):
        path.write_text(content)
    config = make_config("cpu", {"env.start_states": str(path), "env.start_states_fraction": 0.1})
    scene, _ = step.build(config, character, [clip], np)
    with pytest.raises(UserError, match=f"env.start_states=.*{message}"):
        start_bank.build(config, character, scene, [clip], None, np)


def test_a_fraction_needs_a_file():
    with pytest.raises(UserError, match="env.start_states_fraction.*needs env.start_states"):
        make_config("cpu", {"env.start_states_fraction": 0.2})
    with pytest.raises(UserError, match="env.start_states_fraction.*in \\[0, 1\\]"):
        make_config("cpu", {"env.start_states": "x.npz", "env.start_states_fraction": 1.5})
