"""mjxmimic.core.compat: the jax.device_put_replicated replacement, and Brax's own PPO running on it."""

import functools
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.sharding import NamedSharding

from mjxmimic.core import compat

REPO = Path(__file__).resolve().parent.parent


def test_replacement_stacks_one_slice_per_device():
    devices = jax.local_devices()
    tree = {"a": jnp.arange(6.0).reshape(2, 3), "b": 1.5, "c": np.int32(7)}
    out = compat.device_put_replicated(tree, devices)
    n = len(devices)
    assert out["a"].shape == (n, 2, 3)
    assert out["b"].shape == (n,) and out["c"].shape == (n,)
    np.testing.assert_array_equal(np.asarray(out["a"]), np.stack([np.arange(6.0).reshape(2, 3)] * n))
    np.testing.assert_array_equal(np.asarray(out["b"]), [1.5] * n)
    assert out["a"].dtype == jnp.float32 and out["c"].dtype == jnp.int32
    assert isinstance(out["a"].sharding, NamedSharding)
    assert tuple(out["a"].sharding.spec) == ("replica",)
    assert [s.device for s in out["a"].addressable_shards] == devices
    for shard in out["a"].addressable_shards:
        assert shard.data.shape == (1, 2, 3)


def test_patch_installs_only_when_missing(monkeypatch):
    monkeypatch.delattr(jax, "device_put_replicated", raising=False)
    assert compat.patch_jax_for_brax() is True
    assert jax.device_put_replicated is compat.device_put_replicated
    assert compat.patch_jax_for_brax() is False  # idempotent

    sentinel = object()
    monkeypatch.setattr(jax, "device_put_replicated", sentinel, raising=False)
    assert compat.patch_jax_for_brax() is False
    assert jax.device_put_replicated is sentinel  # JAX's own function is never replaced


def test_replacement_on_two_devices():
    script = textwrap.dedent("""
        import jax, numpy as np
        from mjxmimic.core.compat import device_put_replicated
        devs = jax.local_devices()
        assert len(devs) == 2, devs
        out = device_put_replicated({"w": np.arange(4.0)}, devs)["w"]
        assert out.shape == (2, 4)
        shards = out.addressable_shards
        assert {s.device for s in shards} == set(devs)
        for s in shards:
            np.testing.assert_array_equal(np.asarray(s.data), [np.arange(4.0)])
        # what brax's pmap'ed code does with it: map over the device axis
        y = jax.pmap(lambda x: x.sum())(out)
        np.testing.assert_allclose(np.asarray(y), [6.0, 6.0])
        print("OK")
    """)
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2", JAX_PLATFORMS="cpu",
               PYTHONPATH=str(REPO))
    proc = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "OK" in proc.stdout


def test_brax_ppo_train_runs_with_the_patch():
    compat.patch_jax_for_brax()
    import brax.envs
    from brax.training.agents.ppo import networks as ppo_networks
    from brax.training.agents.ppo import train as ppo

    env = brax.envs.get_environment("fast")
    steps = []
    factory = functools.partial(ppo_networks.make_ppo_networks, policy_hidden_layer_sizes=(8,),
                                value_hidden_layer_sizes=(8,))
    _, params, metrics = ppo.train(
        env, num_timesteps=512, episode_length=16, num_envs=8, batch_size=8, num_minibatches=2,
        unroll_length=8, num_updates_per_batch=1, num_evals=2, num_eval_envs=4, seed=0,
        network_factory=factory, progress_fn=lambda step, m: steps.append(step))
    assert steps[-1] >= 512
    assert np.isfinite(float(metrics["eval/episode_reward"]))


@pytest.mark.parametrize("left_side", [True, False])
@pytest.mark.parametrize("lower", [True, False])
@pytest.mark.parametrize("transpose_a", [True, False])
@pytest.mark.parametrize("unit_diagonal", [True, False])
def test_small_triangular_solve_matches_the_definition(left_side, lower, transpose_a, unit_diagonal):
    rng = np.random.default_rng(0)
    tri = np.tril(rng.normal(size=(3, 6, 6))) + 4 * np.eye(6)
    a = tri if lower else np.swapaxes(tri, -1, -2)
    # garbage in the unreferenced triangle must be ignored, as LAPACK does
    junk = np.triu(rng.normal(size=(3, 6, 6)), 1)
    a_junk = a + (junk if lower else np.swapaxes(junk, -1, -2))
    b = rng.normal(size=(3, 6, 2) if left_side else (3, 2, 6))
    x = np.asarray(compat._triangular_solve_small(
        jnp.asarray(a_junk, jnp.float32), jnp.asarray(b, jnp.float32), left_side=left_side, lower=lower,
        transpose_a=transpose_a, conjugate_a=False, unit_diagonal=unit_diagonal))
    a_eff = np.where(np.eye(6, dtype=bool), 1.0, a) if unit_diagonal else a
    op = np.swapaxes(a_eff, -1, -2) if transpose_a else a_eff
    np.testing.assert_allclose(op @ x if left_side else x @ op, b, atol=2e-5)


def test_lapack_deadlock_patch_removes_lapack_and_stays_correct():
    import jaxlib

    patched = compat.patch_jax_cpu_lapack_deadlock()
    assert patched == (tuple(int(p) for p in jaxlib.__version__.split(".")[:2]) < (0, 11))
    rng = np.random.default_rng(1)
    k = rng.normal(size=(8, 34, 34)).astype(np.float32)
    a = k @ np.swapaxes(k, -1, -2) + 34 * np.eye(34, dtype=np.float32)
    b = rng.normal(size=(8, 34)).astype(np.float32)

    def solve(a, b):
        return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(a), b)

    f = jax.jit(jax.vmap(solve))
    if patched:
        assert "lapack" not in f.lower(a, b).as_text()
    x = np.asarray(f(a, b))
    np.testing.assert_allclose(np.einsum("bij,bj->bi", a, x), b, atol=1e-3)
    np.testing.assert_allclose(np.asarray(jnp.linalg.cholesky(a)), np.linalg.cholesky(a), rtol=1e-4, atol=1e-4)
    not_pd = -np.eye(3, dtype=np.float32)
    assert np.isnan(np.asarray(jnp.linalg.cholesky(not_pd))).any()  # as LAPACK: NaN, not garbage
