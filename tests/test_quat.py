"""Quaternion math properties, in numpy and jax.numpy."""

import jax.numpy as jnp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from mjxmimic.core import quat

vec3 = arrays(np.float64, 3, elements=st.floats(-3.0, 3.0))
quat4 = arrays(np.float64, 4, elements=st.floats(-1.0, 1.0)).filter(lambda q: np.linalg.norm(q) > 0.1)


@given(quat4)
@settings(max_examples=60, deadline=None)
def test_q_times_inverse_is_identity(q):
    q = quat.normalize(q)
    np.testing.assert_allclose(quat.mul(q, quat.conj(q)), [1, 0, 0, 0], atol=1e-12)


@given(vec3)
@settings(max_examples=60, deadline=None)
def test_log_of_exp_is_identity(r):
    if np.linalg.norm(r) >= np.pi:  # the map is one-to-one on the open ball of radius pi
        r = r / np.linalg.norm(r) * 3.0
    np.testing.assert_allclose(quat.to_rotvec(quat.from_rotvec(r)), r, atol=1e-9)


@given(quat4, quat4)
@settings(max_examples=60, deadline=None)
def test_slerp_endpoints_and_midpoint(a, b):
    a, b = quat.normalize(a), quat.normalize(b)
    same = lambda x, y: min(np.abs(x - y).max(), np.abs(x + y).max())
    assert same(quat.slerp(a, b, np.array([0.0])), a) < 1e-9
    assert same(quat.slerp(a, b, np.array([1.0])), b) < 1e-9
    mid = quat.slerp(a, b, np.array([0.5]))
    np.testing.assert_allclose(quat.angle_between(a, mid), quat.angle_between(mid, b), atol=1e-6)


@given(quat4, vec3)
@settings(max_examples=60, deadline=None)
def test_rotate_matches_matrix_and_jax(q, v):
    import mujoco

    q = quat.normalize(q)
    mat = np.zeros(9)
    mujoco.mju_quat2Mat(mat, q)
    np.testing.assert_allclose(quat.rotate(q, v), mat.reshape(3, 3) @ v, atol=1e-9)
    np.testing.assert_allclose(np.asarray(quat.rotate(jnp.asarray(q), jnp.asarray(v), jnp)),
                               quat.rotate(q, v), atol=1e-5)


def test_heading_of_yaw_rotation():
    for yaw in np.linspace(-3.0, 3.0, 7):
        assert abs(quat.heading(quat.from_yaw(np.array(yaw))) - yaw) < 1e-9
