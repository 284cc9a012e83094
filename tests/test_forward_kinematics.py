"""The env's own forward kinematics against MuJoCo C (mj_kinematics, mj_comPos, mj_comVel), on
every character, in numpy and in jax.numpy."""

from __future__ import annotations

from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest

from mjxmimic.core import forward_kinematics, quat
from mjxmimic.core.character import load_character, resolve_xml
from mjxmimic.core.scene import build_scene
from test_env import c_kin

G1_DIR = Path(__file__).resolve().parents[2] / "shared" / "robots" / "unitree_g1"
FIELDS = ("xipos", "xmat", "angvel", "linvel", "com")


def random_pose(model: mujoco.MjModel, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Any orientation for free and ball joints, hinges over +-2 rad, fast velocities."""
    qpos = model.qpos0.copy()
    for j in range(model.njnt):
        a, kind = model.jnt_qposadr[j], model.jnt_type[j]
        if kind == mujoco.mjtJoint.mjJNT_FREE:
            qpos[a:a + 3] = rng.normal(0, 1, 3)
            qpos[a + 3:a + 7] = quat.normalize(rng.normal(size=4))
        elif kind == mujoco.mjtJoint.mjJNT_BALL:
            qpos[a:a + 4] = quat.normalize(rng.normal(size=4))
        else:
            qpos[a] = rng.uniform(-2, 2)
    return qpos, rng.normal(0, 2, model.nv)


@pytest.fixture(params=["humanoid", "dog3d", "g1"])
def model(request, monkeypatch, tmp_path) -> mujoco.MjModel:
    if request.param == "g1":
        if not (G1_DIR / "g1.xml").is_file():
            pytest.skip("../shared/robots/unitree_g1 is not present")
        monkeypatch.setenv("MJXMIMIC_G1", str(G1_DIR))
        monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    return build_scene(load_character(resolve_xml(request.param)), 240, 4, 4).model


def test_matches_mujoco_on_random_poses(model):
    tree = forward_kinematics.read_tree(model)
    rng = np.random.default_rng(0)
    fk_jax = jax.jit(lambda q, v: forward_kinematics.kinematics(tree, q, v, jnp))
    for _ in range(10):
        qpos, qvel = random_pose(model, rng)
        want = c_kin(model, qpos, qvel)
        got_np = forward_kinematics.kinematics(tree, qpos, qvel, np)
        got_jax = fk_jax(jnp.asarray(qpos, jnp.float32), jnp.asarray(qvel, jnp.float32))
        for name in FIELDS:  # body 0 (the world) is never read
            w = getattr(want, name)[1:] if name != "com" else want.com
            for got, atol in ((got_np, 1e-6), (got_jax, 2e-4)):
                g = np.asarray(getattr(got, name))
                g = g[1:] if name != "com" else g
                np.testing.assert_allclose(g, w, atol=atol * max(1.0, np.abs(w).max()), err_msg=name)


def test_to_matrix_rotates_as_rotate_does():
    rng = np.random.default_rng(1)
    q, v = quat.normalize(rng.normal(size=(5, 4))), rng.normal(size=(5, 3))
    np.testing.assert_allclose(np.einsum("nij,nj->ni", quat.to_matrix(q), v), quat.rotate(q, v), atol=1e-12)


def test_matches_mujoco_on_joints_anchored_off_the_origin():
    """Several joints per body, anchors off the body origin, slides, bodies turned in their
    parent, a welded body: the cases the characters here do not have."""
    model = mujoco.MjModel.from_xml_string("""
        <mujoco><worldbody><body name="root" pos="0 0 1"><freejoint/><geom size="0.1"/>
          <body name="a" pos="0.2 0 0" quat="0.9 0.1 0.3 0"><joint type="hinge" axis="1 0 0" pos="0.05 0 0"/>
            <joint type="hinge" axis="0 0.6 0.8" pos="0 0.1 0"/><geom size="0.1" pos="0 0 -0.2"/>
            <body name="b" pos="0 0 -0.4"><joint type="ball" pos="0 0 0.1"/><joint type="slide" axis="0 0 1"/>
              <geom size="0.05" pos="0.1 0 0"/>
              <body name="welded" pos="0.1 0.1 0"><geom size="0.05"/></body></body></body>
          <body name="c" pos="-0.2 0 0"><joint type="slide" axis="1 0 0"/><joint type="hinge" axis="0 1 0" pos="0 0 0.1"/>
            <geom size="0.1" pos="0 0.1 0"/></body></body></worldbody></mujoco>""")
    tree = forward_kinematics.read_tree(model)
    rng = np.random.default_rng(2)
    for _ in range(10):
        qpos, qvel = random_pose(model, rng)
        want, got = c_kin(model, qpos, qvel), forward_kinematics.kinematics(tree, qpos, qvel, np)
        for name in FIELDS:
            w, g = getattr(want, name), np.asarray(getattr(got, name))
            np.testing.assert_allclose(g if name == "com" else g[1:], w if name == "com" else w[1:], atol=1e-6,
                                       err_msg=name)
