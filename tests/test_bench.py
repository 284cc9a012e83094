"""`mjxmimic bench`'s three levels run and report consistent rows (correctness only; the speed
figures live in benchmarks/RESULTS.md)."""

import pytest

from mjxmimic.ops import bench
from mjxmimic.core.config import make_config
from mjxmimic.envs.mjx_env import make_env


@pytest.mark.slow
def test_the_three_levels_measure_the_same_settings():
    config = make_config("cpu", {"ppo.num_envs": 4, "ppo.num_minibatches": 2, "ppo.unroll_length": 4})
    env = make_env(config)
    rows = [bench.physics_only(env, 4, steps=2, repeats=1), bench.env_step(env, 4, steps=2, repeats=1),
            bench.train_loop(env, config, iterations=1)]
    assert [r.kind for r in rows] == ["physics_only", "env_step", "train_loop"]
    assert [r.control_steps for r in rows] == [2, 2, 4]
    for r in rows:
        assert (r.backend, r.num_envs, r.physics_hz, r.substeps, r.solver_iterations) == ("jax", 4, 120, 4, 4)
        assert r.samples_per_s > 0 and r.compile_s > 0
        assert r.physics_steps_per_s == r.samples_per_s * r.substeps
