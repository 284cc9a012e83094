"""mjxmimic.learn.ppo: the train step, the initial std, the exported policy, the multi-device path."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import numpy as np
import pytest

from mjxmimic.core.config import make_config
from mjxmimic.core.errors import UserError
from mjxmimic.learn.ppo import export_params, learning_rate_at, make_trainer
from standin_env import SeesPushScale, StandInEnv

REPO = Path(__file__).resolve().parent.parent
CONFIG = make_config("cpu", {"ppo.init_action_std": 0.3})


@pytest.fixture(scope="module")
def trainer():
    return make_trainer(StandInEnv(), CONFIG)


def _numpy_policy(params, obs, action_size):
    """The documented forward pass, written out in numpy."""
    h = (np.asarray(obs) - np.asarray(params["normalizer"]["mean"])) / np.asarray(params["normalizer"]["std"])
    layers = params["policy"]
    n = len(layers)
    for i in range(n):
        h = h @ np.asarray(layers[f"hidden_{i}"]["kernel"]) + np.asarray(layers[f"hidden_{i}"]["bias"])
        if i < n - 1:
            h = np.maximum(h, 0.0)
    return h[..., :action_size], h[..., action_size:]


def test_initial_std_and_exported_layout(trainer):
    ts = trainer.init(0)
    params = export_params(ts)
    env = trainer.env
    assert set(params) == {"normalizer", "policy"}
    assert params["normalizer"]["mean"].shape == (env.observation_size,)
    assert sorted(params["policy"]) == ["hidden_0", "hidden_1", "hidden_2"]
    assert params["policy"]["hidden_0"]["kernel"].shape == (env.observation_size, 64)
    assert params["policy"]["hidden_2"]["kernel"].shape == (64, 2 * env.action_size)

    obs = jax.random.normal(jax.random.PRNGKey(1), (16, env.observation_size)) * 3
    loc, s = _numpy_policy(params, obs, env.action_size)
    std = np.log1p(np.exp(s)) + CONFIG.ppo.min_action_std
    np.testing.assert_allclose(std, 0.3, rtol=1e-5)  # every state starts with ppo.init_action_std
    assert np.abs(loc).max() < 0.1  # small initial mean (0.01-scaled output layer)

    act = trainer.make_policy(params, deterministic=True)(obs, jax.random.PRNGKey(0))
    np.testing.assert_allclose(np.asarray(act), np.tanh(loc), atol=1e-6)
    noisy = trainer.make_policy(params, deterministic=False)(obs, jax.random.PRNGKey(0))
    assert np.all(np.abs(np.asarray(noisy)) <= 1.0)
    # tanh(loc + std * eps): the pre-tanh spread is the initial std
    pre = np.arctanh(np.clip(np.asarray(noisy), -0.999999, 0.999999)) - loc
    assert 0.2 < pre.std() < 0.4


def test_train_step_learns_without_recompiling(trainer):
    ts = trainer.init(0)
    rewards = []
    for _ in range(30):
        ts, metrics = trainer.train_step(ts)
        rewards.append(float(metrics["reward"]))
    assert trainer.train_step._cache_size() == 1  # one compilation for all iterations
    assert int(ts.env_steps) == 30 * CONFIG.ppo.num_envs * CONFIG.ppo.unroll_length
    for key in ("reward", "reward/track", "error/pose", "done_rate", "fall_rate", "ppo/policy_loss",
                "ppo/v_loss", "ppo/total_loss", "policy/std"):
        assert np.isfinite(float(metrics[key])), key
    assert np.mean(rewards[-5:]) > np.mean(rewards[:5]) + 0.3  # the stand-in is easy
    assert float(metrics["fall_rate"]) < float(np.mean(rewards[:1]))


@pytest.mark.parametrize("schedule, middle", [("constant", 1e-3), ("linear", 5.5e-4), ("cosine", 5.5e-4)])
def test_learning_rate_schedule(schedule, middle):
    config = make_config("cpu", {"ppo.learning_rate": 1e-3, "ppo.learning_rate_final": 1e-4,
                                 "ppo.learning_rate_schedule": schedule, "run.total_samples": 1000})
    rates = [float(learning_rate_at(config, s)) for s in (0, 250, 500, 1000, 5000)]
    assert rates[0] == pytest.approx(1e-3)
    assert rates[2] == pytest.approx(middle)
    assert rates[3] == pytest.approx(1e-3 if schedule == "constant" else 1e-4)
    assert rates[4] == pytest.approx(rates[3])  # held after run.total_samples
    if schedule == "cosine":
        assert rates[1] > 1e-4 + 0.75 * 9e-4  # slow start, unlike linear
    with pytest.raises(UserError, match="ppo.learning_rate_schedule"):
        make_config("cpu", {"ppo.learning_rate_schedule": "step"})


def _metrics_of_steps(trainer, steps: int, *keys: str) -> list[list[float]]:
    """Each key's metric over `steps` train steps from a fresh init."""
    ts = trainer.init(0)
    rows = []
    for _ in range(steps):
        ts, metrics = trainer.train_step(ts)
        rows.append([float(metrics[k]) for k in keys])
    return [list(column) for column in zip(*rows)]


def test_train_step_follows_the_schedule():
    config = make_config("cpu", {"ppo.learning_rate_schedule": "linear", "run.total_samples": 1024})
    trainer = make_trainer(StandInEnv(), config)
    rates, = _metrics_of_steps(trainer, 3, "ppo/learning_rate")
    assert rates == pytest.approx([1e-3, 1e-3 - 0.5 * (1e-3 - 3e-5), 3e-5], rel=1e-5)  # 512 samples per step
    assert trainer.train_step._cache_size() == 1


def test_runs_that_differ_only_in_their_schedules_share_one_program():
    """The learning rate's numbers, the sample budget and the push ramp are arguments of the
    train step, not constants in it: another value gives the same program text (so the
    compilation cache finds it), and the step follows the values it is given."""
    def text(overrides):
        trainer = make_trainer(StandInEnv(), make_config("cpu", overrides))
        return trainer.lower_train_step().as_text(), trainer
    base, _ = text({"ppo.learning_rate_schedule": "linear"})
    other, trainer = text({"ppo.learning_rate_schedule": "linear", "ppo.learning_rate": 5e-4,
                           "ppo.learning_rate_final": 5e-5, "run.total_samples": 1024})
    assert other == base
    step = trainer.compile_train_step()
    ts, _ = step(trainer.init(0))
    _, metrics = step(ts)  # after 512 of 1024 samples
    assert float(metrics["ppo/learning_rate"]) == pytest.approx(5e-4 - 0.5 * (5e-4 - 5e-5), rel=1e-5)
    assert text({"ppo.learning_rate_schedule": "cosine"})[0] != base  # the schedule's shape is the program's


@pytest.mark.parametrize("mode", ["learned", "fixed"])
def test_std_mode(mode):
    config = make_config("cpu", {"ppo.init_action_std": 0.3, "ppo.std_mode": mode})
    trainer = make_trainer(StandInEnv(), config)
    ts = trainer.init(0)
    for _ in range(10):
        ts, metrics = trainer.train_step(ts)
    obs = jax.random.normal(jax.random.PRNGKey(1), (16, trainer.env.observation_size)) * 3
    params = export_params(ts)
    loc, s = _numpy_policy(params, obs, trainer.env.action_size)
    std = np.log1p(np.exp(s)) + config.ppo.min_action_std
    if mode == "fixed":
        np.testing.assert_allclose(std, 0.3, rtol=1e-5)
        assert float(metrics["policy/std"]) == pytest.approx(0.3, rel=1e-4)
    else:
        assert np.abs(std - 0.3).max() > 1e-3
    assert np.abs(loc).max() > 0.1  # the mean learned in both modes


def test_min_action_std_floors_the_sampled_noise():
    """With the std half of the output driven to softplus(s) = 0, the training policy's pre-tanh
    noise is exactly ppo.min_action_std."""
    config = make_config("cpu", {"ppo.init_action_std": 0.3, "ppo.min_action_std": 0.05})
    trainer = make_trainer(StandInEnv(), config)
    params = export_params(trainer.init(0))
    last = params["policy"]["hidden_2"]
    act = trainer.env.action_size
    last["kernel"] = last["kernel"].at[:, act:].set(0.0)
    last["bias"] = last["bias"].at[act:].set(-40.0)
    obs = jax.random.normal(jax.random.PRNGKey(1), (4096, trainer.env.observation_size))
    loc, _ = _numpy_policy(params, obs, act)
    noisy = trainer.make_policy(params, deterministic=False)(obs, jax.random.PRNGKey(0))
    spread = np.std(np.arctanh(np.asarray(noisy)) - loc)
    assert spread == pytest.approx(0.05, rel=0.03)


@pytest.mark.parametrize("max_kl, undone", [(1e-9, 1.0), (1e9, 0.0)])
def test_max_kl_undoes_the_step_that_goes_too_far(max_kl, undone):
    """Below any KL a step can keep, every step of the iteration is undone: networks and optimiser
    stay as they were (the normaliser still learns the rollout); far above it, nothing is."""
    trainer = make_trainer(StandInEnv(), make_config("cpu", {"ppo.max_kl": max_kl}))
    ts = trainer.init(4)
    before = jax.tree_util.tree_map(np.asarray, (ts.params, ts.optimizer_state, ts.normalizer.mean))
    ts, metrics = trainer.train_step(ts)
    after = jax.tree_util.tree_map(np.asarray, (ts.params, ts.optimizer_state, ts.normalizer.mean))
    assert float(metrics["ppo/steps_undone"]) == undone
    same = [np.array_equal(a, b) for a, b in zip(jax.tree_util.tree_leaves(before[:2]),
                                                 jax.tree_util.tree_leaves(after[:2]))]
    assert all(same) == bool(undone)
    assert not np.array_equal(before[2], after[2])


@pytest.mark.parametrize("precision", ["default", "BF16_BF16_F32"])
def test_matmul_precision_reaches_the_network_products(precision):
    """Each product of the policy and value networks (rollout, loss, gradients) carries the
    chosen dot algorithm; "default" leaves every product as XLA would have it."""
    trainer = make_trainer(StandInEnv(), make_config("cpu", {"ppo.matmul_precision": precision}))
    jaxpr = str(jax.make_jaxpr(trainer._train_step)(trainer.abstract_state, trainer.train_step.values))
    tagged = jaxpr.count("precision=BF16_BF16_F32")
    if precision == "default":
        assert tagged == 0
    else:  # 3 layers x 2 networks: forward in the rollout, forward and two products backward in SGD
        assert tagged >= 3 * 2 * 3 and jaxpr.count("dot_general[") >= tagged


def test_donates_the_input_state(trainer):
    ts = trainer.init(1)
    leaf = ts.params.policy["params"]["hidden_0"]["kernel"]
    new, _ = trainer.train_step(ts)
    jax.block_until_ready(new)
    assert leaf.is_deleted()


def test_rsi_draws_fresh_start_times_on_every_reset(trainer):
    ts = trainer.init(2)
    t0 = np.asarray(ts.env_state.info["t"])
    assert len(np.unique(np.round(t0, 5))) == len(t0)
    ts2 = trainer.init(3)
    assert not np.allclose(np.asarray(ts2.env_state.info["t"]), t0)


def test_config_errors_are_one_line():
    with pytest.raises(UserError, match="init_action_std"):
        make_trainer(StandInEnv(), make_config("cpu", {"ppo.init_action_std": 0.0005}))


def _on_two_cpu_devices(script: str, timeout: int) -> str:
    """Run `script` in a fresh Python that sees two CPU devices; its stdout."""
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=2", JAX_PLATFORMS="cpu",
               PYTHONPATH=str(REPO))
    proc = subprocess.run([sys.executable, "-c", script], env=env, cwd=REPO, capture_output=True, text=True,
                          timeout=timeout)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc.stdout


@pytest.mark.slow
def test_two_devices_shard_the_batch_and_all_reduce():
    script = textwrap.dedent("""
        import sys
        sys.path.insert(0, "tests")
        import jax, numpy as np
        from mjxmimic.core.config import make_config
        from mjxmimic.core.errors import UserError
        from mjxmimic.learn.ppo import make_trainer
        from standin_env import StandInEnv
        assert jax.local_device_count() == 2
        try:
            make_trainer(StandInEnv(), make_config("cpu", {"ppo.num_envs": 33, "ppo.num_minibatches": 1}))
            raise SystemExit("no error for 33 envs on 2 devices")
        except UserError as err:
            assert "ppo.num_envs" in str(err) and "2 local devices" in str(err), err
        config = make_config("cpu")
        trainer = make_trainer(StandInEnv(), config)
        trainer.compile_reset()  # as the training loop does: the sharded reset, compiled ahead
        ts = trainer.init(0)
        leaf = ts.env_state.obs
        shards = leaf.addressable_shards
        assert len({s.device for s in shards}) == 2 and shards[0].data.shape[0] == 16, leaf.sharding
        hlo = trainer.train_step.lower(ts).compile().as_text()
        assert "all-reduce" in hlo
        rewards = []
        for _ in range(25):
            ts, m = trainer.train_step(ts)
            rewards.append(float(m["reward"]))
        assert trainer.train_step._cache_size() == 1
        kernel = ts.params.policy["params"]["hidden_0"]["kernel"]
        a, b = [np.asarray(s.data) for s in kernel.addressable_shards]
        np.testing.assert_array_equal(a, b)  # parameters stay replicated
        assert ts.env_state.obs.addressable_shards[0].data.shape[0] == 16  # batch stays sharded
        assert np.mean(rewards[-5:]) > np.mean(rewards[:5]) + 0.3, rewards
        # the KL stop reads the KL over both devices' slices: both undo the same steps
        stop = make_trainer(StandInEnv(), make_config("cpu", {"ppo.max_kl": 1e-9}))
        held = stop.init(1)
        before = np.asarray(held.params.policy["params"]["hidden_0"]["kernel"])
        held, m = stop.train_step(held)
        assert float(m["ppo/steps_undone"]) == 1.0
        for shard in held.params.policy["params"]["hidden_0"]["kernel"].addressable_shards:
            np.testing.assert_array_equal(np.asarray(shard.data), before)
        # with the whole batch as the one minibatch (the shuffle then changes nothing), the split
        # trains as one device would: the gradients, advantages and normaliser are global
        one_minibatch = make_config("cpu", {"ppo.num_minibatches": 1})
        split = make_trainer(StandInEnv(), one_minibatch)
        whole = make_trainer(StandInEnv(), one_minibatch, jax.local_devices()[:1])
        a, b = split.init(2), whole.init(2)
        for _ in range(3):
            (a, _), (b, _) = split.train_step(a), whole.train_step(b)
        for x, y in zip(jax.tree.leaves(jax.device_get(a.params)), jax.tree.leaves(jax.device_get(b.params))):
            np.testing.assert_allclose(x, y, atol=1e-5)
        assert not np.allclose(jax.device_get(a.params.policy["params"]["hidden_0"]["kernel"]),
                               jax.device_get(split.init(2).params.policy["params"]["hidden_0"]["kernel"]))
        print("OK", int(ts.env_steps))
    """)
    assert "OK 12800" in _on_two_cpu_devices(script, timeout=300)


@pytest.mark.slow
def test_two_devices_step_the_physics_of_their_own_slices_as_one_device_would():
    script = textwrap.dedent("""
        import jax, numpy as np
        from mjxmimic.core.config import make_config
        from mjxmimic.envs.mjx_env import make_env
        from mjxmimic.learn.ppo import make_trainer
        config = make_config("cpu", {"ppo.num_envs": 16, "ppo.num_minibatches": 2, "ppo.unroll_length": 4})
        env = make_env(config)
        split, whole = make_trainer(env, config), make_trainer(env, config, jax.local_devices()[:1])
        assert split.num_devices == 2 and whole.num_devices == 1
        assert not jax.config.jax_use_shardy_partitioner  # the partitioner that works on GPUs
        split.compile_reset()
        ts = split.init(0)
        a = ts.env_state
        b = jax.device_put(jax.device_get(a), jax.local_devices()[0])
        jaxpr = str(jax.make_jaxpr(split.step_envs)(a, np.zeros((16, env.action_size), np.float32)))
        assert "shard_map" in jaxpr  # each device steps its own slice
        for t in range(2):
            action = np.asarray(jax.random.uniform(jax.random.PRNGKey(t), (16, env.action_size), minval=-1, maxval=1))
            a = jax.jit(split.step_envs)(a, jax.device_put(action, split.batch_sharded))
            b = jax.jit(whole.step_envs)(b, action)
            assert {s.device for s in a.obs.addressable_shards} == set(jax.local_devices())
            np.testing.assert_allclose(np.asarray(a.pipeline_state.qpos), np.asarray(b.pipeline_state.qpos), atol=1e-4)
            np.testing.assert_allclose(np.asarray(a.reward), np.asarray(b.reward), atol=1e-4)
            np.testing.assert_allclose(np.asarray(a.obs), np.asarray(b.obs), atol=1e-2, rtol=1e-3)
            assert np.abs(np.asarray(a.obs)[8:]).max() > 0  # the second device's slice was written
        ts, metrics = split.train_step(ts)  # the fused iteration compiles around the per-device env
        assert np.isfinite(float(metrics["reward"]))
        print("OK", int(ts.env_steps))
    """)
    assert "OK 64" in _on_two_cpu_devices(script, timeout=600)


def test_the_push_curriculum_ramps_with_the_samples_trained():
    """env.push_ramp_samples: each iteration's rollout steps with (samples so far) / ramp, up to 1,
    and logs it; without it the metric is not there."""
    config = make_config("cpu", {"env.events": "push", "env.push_force_n": 100, "env.push_ramp_samples": 1024})  # 512 samples an iteration
    logged, seen = _metrics_of_steps(make_trainer(SeesPushScale(), config), 4, "curriculum/push_scale", "seen_scale")
    assert logged == seen == [0.0, 0.5, 1.0, 1.0]
    plain = make_trainer(StandInEnv(), make_config("cpu"))
    assert "curriculum/push_scale" not in plain.train_step(plain.init(0))[1]


@pytest.mark.parametrize("keys, expected", [
    ({"env.push_start_samples": 1024}, [0.0, 0.0, 1.0, 1.0]),  # no ramp: full pushes from the start sample on
    ({"env.push_start_samples": 512, "env.push_ramp_samples": 1024}, [0.0, 0.0, 0.5, 1.0]),
    ({"env.push_start_samples": 512, "env.push_stop_samples": 1536}, [0.0, 1.0, 1.0, 0.0]),
    ({"env.push_ramp_samples": 512, "env.push_stop_samples": 1024}, [0.0, 1.0, 0.0, 0.0]),
])
def test_pushes_can_start_late_and_stop_early(keys, expected):
    """env.push_start_samples: no pushes before it; the ramp, if any, starts there;
    env.push_stop_samples: none from it on."""
    config = make_config("cpu", {"env.events": "push", "env.push_force_n": 100, **keys})  # 512 samples an iteration
    seen, = _metrics_of_steps(make_trainer(SeesPushScale(), config), 4, "seen_scale")
    assert seen == expected
