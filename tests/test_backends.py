"""The physics seam: backend selection, fall contacts through contact sensors on all three
backends, and warp-vs-JAX parity where warp-lang is installed (CPU or GPU; skipped otherwise).
The GPU run of the same comparison is benchmarks/results/backend_parity_h200.json."""

import importlib.util
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import pytest
from mujoco import mjx

from mjxmimic.core.config import make_config
from mjxmimic.core.errors import UserError
from mjxmimic.core.scene import build_scene, fall_mask
from mjxmimic.physics.mjx import resolve_backend

HAS_WARP = importlib.util.find_spec("warp") is not None


def test_auto_picks_jax_without_a_gpu_and_unknown_names_are_one_line_errors():
    if jax.default_backend() != "gpu":
        assert resolve_backend("auto") == "jax"
    assert resolve_backend("jax") == "jax"
    with pytest.raises(UserError, match="physics.backend"):
        resolve_backend("bullet")
    with pytest.raises(UserError, match="physics.backend"):
        make_config("cpu", {"physics.backend": "bullet"})


def test_contact_sensors_watch_every_geom_that_can_touch_the_floor(character):
    scene = build_scene(character, 240, 4, 4)
    m = scene.model
    assert m.nsensor == len(scene.contact_geoms) > 10
    assert set(m.geom_bodyid[scene.contact_geoms]) >= set(character.fall_bodies("all-feet"))
    feet = fall_mask(scene, character, "all-feet")
    assert 0 < feet.sum() < len(feet)  # the feet's geoms are watched but are no fall


def _lying(character, scene):
    d = mujoco.MjData(scene.model)
    d.qpos[2] = 0.08
    d.qpos[3:7] = [np.cos(np.pi / 4), 0.0, np.sin(np.pi / 4), 0.0]  # face down
    return d


@pytest.mark.parametrize("impl", ["jax", pytest.param("warp", marks=[
    pytest.mark.slow, pytest.mark.skipif(not HAS_WARP, reason="warp-lang not installed")])])
def test_contact_sensors_agree_with_mujoco_c(character, impl):
    scene = build_scene(character, 240, 4, 4)
    d = _lying(character, scene)
    mujoco.mj_forward(scene.model, d)
    c_found = d.sensordata[scene.contact_adr] > 0
    assert c_found.any() and (c_found & fall_mask(scene, character, "all-feet")).any()
    kw = {"naconmax": 64, "njmax": 256} if impl == "warp" else {}
    sys_ = mjx.put_model(scene.model, impl=impl)
    dx = mjx.make_data(scene.model, impl=impl, **kw).replace(qpos=jnp.asarray(d.qpos))
    out = jax.jit(lambda x: mjx.forward(sys_, x))(dx)
    np.testing.assert_array_equal(np.asarray(out.sensordata)[scene.contact_adr] > 0, c_found)


@pytest.mark.slow
@pytest.mark.skipif(not HAS_WARP, reason="warp-lang not installed")
def test_warp_and_jax_take_the_same_control_step_with_a_converged_solve():
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
    from backend_parity import compare

    config = make_config("cpu", {"env.solver_iterations": 30, "env.ls_iterations": 30})
    out = compare(config, envs=4, steps=2, action_scale=0.1)
    first = out["per_step"][0]
    assert first["alive"] == 4 and first["fall_agreement"] == 1.0
    assert first["reward_max_abs"] < 1e-3 and first["obs_max_abs"] < 1e-2, first
    assert out["summary"]["nan_warp"] == 0
