"""PPO for mjxmimic: one jitted train step assembled from Brax's PPO pieces used as a library.

Pieces taken from Brax (brax 0.14.2): `ppo.networks.make_ppo_networks` (policy/value MLPs, the
tanh-squashed Gaussian), `ppo.losses.compute_ppo_loss` (GAE, clipped surrogate, value and entropy
losses), `acting.generate_unroll` (the rollout scan), `acme.running_statistics` (observation
normaliser) and `gradients.gradient_update_fn`; optax adam after global-norm gradient clipping,
its rate following ppo.learning_rate_schedule.
Brax's `ppo.train` monolith, its pmap and its Episode/AutoReset wrappers are not used: the
environment resets itself (RSI draws a fresh start time on every reset).

One call of `Trainer.train_step(ts)` is one PPO iteration, all on device, no host sync:
  1. rollout: `ppo.unroll_length` steps of `ppo.num_envs` envs (samples = num_envs * unroll_length)
     with the stochastic policy; the env auto-resets inside its own `step`;
  2. observation normaliser update with the rollout's observations (before SGD, as Brax does);
  3. `ppo.num_epochs` epochs, each a fresh shuffle of whole env trajectories into
     `ppo.num_minibatches` minibatches, one adam step per minibatch; with ppo.max_kl, a step
     that takes the policy further than that KL from the gathering policy (on its minibatch) is
     undone and the iteration's later steps skipped (ppo/steps_undone: their share).
The input TrainState is donated. Timeouts (state.info["truncation"] = 1) are handled as in Brax:
the truncated transition is masked out of GAE (no false "failure" value target of 0); falls and
clip ends are terminations (value target 0 beyond them).

Several devices: with `jax.local_device_count() > 1` the env batch (and so the rollouts) is
sharded across a 1-D `Mesh` of the local devices (`NamedSharding` on the batch axis; each device
steps the physics of its own slice, `batched_env.PerDeviceEnv`), parameters, optimiser and normaliser state
are replicated, and XLA inserts the all-reduces (gradients, advantage and normaliser statistics
are global). Minibatch shuffling permutes within each device's shard and every minibatch takes an
equal slice from every device, so no trajectory crosses devices.

The networks, their initial action std and the policy function: mjxmimic.learn.networks.

Exported parameters (`export_params(ts)`, a plain pytree of float32 arrays) and the action:

    {"normalizer": {"mean": [obs], "std": [obs]},
     "policy": {"hidden_0": {"kernel": [obs, h0], "bias": [h0]}, ...,
                "hidden_L": {"kernel": [h_last, 2*act], "bias": [2*act]}}}

    z = (obs - mean) / std                     (no clipping)
    h = relu(z @ kernel_0 + bias_0) ... for every hidden layer; out = h @ kernel_L + bias_L
    loc, s = out[:act], out[act:]
    deterministic action = tanh(loc)           (the evaluation / playback policy)
    stochastic action    = tanh(loc + (softplus(s) + ppo.min_action_std) * N(0, 1))
The action is in [-1, 1]; the env turns it into PD targets (times env.action_scale).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, Callable

import flax
import jax
import jax.numpy as jnp
import numpy as np
import optax

from mjxmimic.core.compat import patch_all

patch_all()  # jax.device_put_replicated for brax; the jaxlib 0.10 CPU LAPACK deadlock

from brax.training import acting, gradients  # noqa: E402
from brax.training import types as brax_types  # noqa: E402
from brax.training.acme import running_statistics  # noqa: E402
from brax.training.agents.ppo import losses as ppo_losses  # noqa: E402
from brax.training.agents.ppo import networks as ppo_networks  # noqa: E402
from jax.sharding import Mesh, NamedSharding, PartitionSpec as P  # noqa: E402

from mjxmimic.core.config import Config, push_curriculum  # noqa: E402
from mjxmimic.core.errors import UserError  # noqa: E402
from mjxmimic.learn.batched_env import BATCH_AXIS, STEP_METRICS, BatchedEnv, PerDeviceEnv  # noqa: E402
from mjxmimic.learn.networks import init_output_layer, last_layer, make_networks, make_policy_fn  # noqa: E402
from mjxmimic.task.events import PUSH_SCALE  # noqa: E402


@flax.struct.dataclass
class TrainState:
    """Everything one iteration reads and writes. `env_state` is batched ([num_envs, ...])."""

    params: ppo_losses.PPONetworkParams  # .policy, .value: flax param dicts {"params": {...}}
    optimizer_state: optax.OptState
    normalizer: running_statistics.RunningStatisticsState
    env_state: Any  # brax.envs.base.State, batched
    key: jax.Array  # raw uint32[2] PRNG key
    env_steps: brax_types.UInt64  # samples consumed so far; int(ts.env_steps) on the host


def _strip_weak_type(tree):
    """Weak-typed scalars (e.g. the normaliser's std_eps) would make a restored state look new to
    jit; give every leaf a strong dtype (as Brax's train does) so train_step compiles once."""
    return jax.tree_util.tree_map(lambda x: jnp.asarray(x).astype(jnp.asarray(x).dtype), tree)


def schedule_values(config: Config) -> dict[str, np.ndarray]:
    """The numbers the run's schedules follow (learning rate, push curriculum). The train step
    takes them as an argument instead of building them into its program, so that runs that differ
    only in them (a sweep over the learning rate, another sample budget, a resume that changes
    them) share one compiled program and its entry in the compilation cache."""
    return {"total_samples": np.float32(config.run.total_samples),
            "learning_rate": np.float32(config.ppo.learning_rate),
            "learning_rate_final": np.float32(config.ppo.learning_rate_final),
            "push_ramp_samples": np.float32(config.env.push_ramp_samples),
            "push_start_samples": np.float32(config.env.push_start_samples),
            "push_stop_samples": np.float32(config.env.push_stop_samples)}


def learning_rate_at(config: Config, samples: jax.Array, values: dict | None = None) -> jax.Array:
    """The learning rate after `samples` samples (ppo.learning_rate_schedule over run.total_samples;
    the numbers from `values`, by default `schedule_values(config)`)."""
    v = schedule_values(config) if values is None else values
    start, final = v["learning_rate"], v["learning_rate_final"]
    progress = jnp.clip(jnp.asarray(samples, jnp.float32) / v["total_samples"], 0.0, 1.0)
    if config.ppo.learning_rate_schedule == "linear":
        return start + (final - start) * progress
    if config.ppo.learning_rate_schedule == "cosine":
        return final + 0.5 * (start - final) * (1.0 + jnp.cos(jnp.pi * progress))
    return jnp.asarray(start, jnp.float32)


def _std_half_frozen(action_size: int) -> optax.GradientTransformation:
    """Zero the updates of the std half of the policy's output layer (its kernel columns are 0 and
    its bias holds the initial std, so the std stays ppo.init_action_std in every state)."""

    def freeze(updates, params=None):
        layers = updates.policy["params"]
        last = last_layer(layers)
        kernel, bias = layers[last]["kernel"], layers[last]["bias"]
        frozen = {"kernel": kernel.at[:, action_size:].set(0.0), "bias": bias.at[action_size:].set(0.0)}
        policy = {**updates.policy, "params": {**layers, last: frozen}}
        return updates.replace(policy=policy)

    return optax.stateless(freeze)


def in_precision(fn: Callable, precision: str) -> Callable:
    """`fn` traced under `jax.default_matmul_precision(precision)`: the precision is fixed on each
    matrix product as it is traced, so it reaches the networks alone when only their calls are
    wrapped ("default" leaves `fn` as it is)."""
    if precision == "default":
        return fn

    @functools.wraps(fn)
    def traced_in_precision(*args, **kwargs):
        with jax.default_matmul_precision(precision):
            return fn(*args, **kwargs)

    return traced_in_precision


def make_optimizer(config: Config, learning_rate: float | jax.Array,
                   action_size: int = 0) -> optax.GradientTransformation:
    """Adam after global-norm clipping. The rate is a plain scale, so the optimiser state is the
    same for every schedule (and for checkpoints written before schedules existed)."""
    parts = [optax.clip_by_global_norm(config.ppo.max_grad_norm), optax.adam(learning_rate)]
    if config.ppo.std_mode == "fixed":
        parts.append(_std_half_frozen(action_size))
    return optax.chain(*parts)


def export_params(ts: TrainState) -> dict:
    """The policy as a plain pytree of arrays (layout in the module docstring)."""
    return {
        "normalizer": {"mean": ts.normalizer.mean, "std": ts.normalizer.std},
        "policy": dict(ts.params.policy["params"]),
    }


@dataclasses.dataclass
class Trainer:
    """Built by `make_trainer`. `train_step(ts)` is the jitted iteration (with the run's schedule
    values bound: `train_step.step(ts, values)` is the program itself); `init(seed)` a fresh state."""

    env: Any
    config: Config
    networks: ppo_networks.PPONetworks
    mesh: Mesh
    num_devices: int
    samples_per_iteration: int
    train_step: BoundSchedule = dataclasses.field(repr=False, default=None)
    # a TrainState's shapes and shardings: what compiles the step and the evaluator, running nothing
    abstract_state: Any = dataclasses.field(repr=False, default=None)
    _batched_env: BatchedEnv | PerDeviceEnv = dataclasses.field(repr=False, default=None)
    _state_sharding: Any = dataclasses.field(repr=False, default=None)
    _reset: Callable = dataclasses.field(repr=False, default=None)

    # ---- shardings -------------------------------------------------------------------------
    @property
    def replicated(self) -> NamedSharding:
        return NamedSharding(self.mesh, P())

    @property
    def batch_sharded(self) -> NamedSharding:
        return NamedSharding(self.mesh, P(BATCH_AXIS))

    def _constrain(self, x, spec):
        if self.num_devices == 1:
            return x
        return jax.lax.with_sharding_constraint(x, NamedSharding(self.mesh, spec))

    # ---- state -----------------------------------------------------------------------------
    def init_learner(self, key: jax.Array):
        """(params, optimizer_state, normalizer) for a fresh run."""
        cfg = self.config.ppo
        k_policy, k_value = jax.random.split(key)
        policy = self.networks.policy_network.init(k_policy)
        policy = init_output_layer(policy, self.env.action_size, cfg.init_action_std, cfg.min_action_std)
        value = self.networks.value_network.init(k_value)
        params = ppo_losses.PPONetworkParams(policy=policy, value=value)
        normalizer = running_statistics.init_state(
            jax.ShapeDtypeStruct((self.env.observation_size,), jnp.float32))
        optimizer = make_optimizer(self.config, cfg.learning_rate, self.env.action_size)
        return params, optimizer.init(params), normalizer

    def init(self, seed: int) -> TrainState:
        """A fresh TrainState, placed on the mesh (env batch sharded, the rest replicated)."""
        key = jax.random.PRNGKey(seed)
        key, k_learner, k_env = jax.random.split(key, 3)
        # one program, not one small compile per operation of the networks' init (seconds on a GPU)
        params, opt_state, normalizer = jax.jit(self.init_learner, out_shardings=self.replicated)(k_learner)
        ts = TrainState(params=params, optimizer_state=opt_state, normalizer=normalizer,
                        env_state=self.reset_envs(k_env), key=key,
                        env_steps=brax_types.UInt64(hi=0, lo=0))
        return self.place(ts)

    def reset_envs(self, key: jax.Array):
        """A fresh batch of env states (RSI), sharded over the mesh."""
        keys = jax.random.split(key, self.config.ppo.num_envs)
        return self._reset(jax.device_put(keys, self.batch_sharded))

    def step_envs(self, env_state: Any, action: jax.Array) -> Any:
        """One control step of the batch, each device stepping its own slice (jit it)."""
        return self._batched_env.step(env_state, action)

    def place(self, ts: TrainState) -> TrainState:
        """Put a TrainState (e.g. one restored from a checkpoint) on the mesh layout."""
        return jax.device_put(_strip_weak_type(ts), self.state_sharding(ts))

    def state_sharding(self, ts: TrainState) -> TrainState:
        """Env leaves with a leading env axis are sharded; the rest (such as warp's counters
        shared by all worlds) and the learner are replicated."""
        rep, bat, n = self.replicated, self.batch_sharded, self.config.ppo.num_envs
        tree = jax.tree_util.tree_map(lambda _: rep, ts)
        per_env = lambda x: bat if getattr(x, "ndim", 0) >= 1 and x.shape[0] == n else rep
        return tree.replace(env_state=jax.tree_util.tree_map(per_env, ts.env_state))

    def lower_train_step(self) -> jax.stages.Lowered:
        """`train_step` traced from the state's shapes alone."""
        return self.train_step.lower(self.abstract_state)

    def compile_train_step(self, lowered: jax.stages.Lowered | None = None
                           ) -> Callable[[TrainState], tuple[TrainState, dict]]:
        """`train_step` compiled ahead of time (from `lowered`, else traced here), so that it can
        compile in a thread while the reset and the evaluator compile."""
        return BoundSchedule((lowered or self.lower_train_step()).compile(), self.train_step.values)

    def lower_reset(self) -> jax.stages.Lowered:
        """The env reset traced from shapes alone."""
        keys = jax.eval_shape(lambda k: jax.random.split(k, self.config.ppo.num_envs), jax.random.PRNGKey(0))
        return self._reset.lower(jax.ShapeDtypeStruct(keys.shape, keys.dtype, sharding=self.batch_sharded))

    def compile_reset(self, lowered: jax.stages.Lowered | None = None) -> None:
        """The env reset compiled ahead of time (then used by `reset_envs`)."""
        self._reset = (lowered or self.lower_reset()).compile()

    # ---- policy ----------------------------------------------------------------------------
    def make_policy(self, params: dict, deterministic: bool = True) -> Callable:
        """fn(obs, key) -> action in [-1, 1] for `export_params`-style params (obs may be batched)."""
        return make_policy_fn(self.networks, params, deterministic)

    # ---- the iteration ---------------------------------------------------------------------
    def _shuffle_into_minibatches(self, x: jax.Array, key: jax.Array) -> jax.Array:
        """[B, ...] -> [M, B/M, ...]: permute within each device's shard, each minibatch takes
        an equal slice of every shard (stays sharded on the batch axis, no cross-device moves)."""
        d, m = self.num_devices, self.config.ppo.num_minibatches
        b = x.shape[0]
        rest = x.shape[1:]
        x = self._constrain(x.reshape((d, b // d) + rest), P(BATCH_AXIS))
        perms = jax.vmap(lambda k: jax.random.permutation(k, b // d))(jax.random.split(key, d))
        x = jax.vmap(lambda xi, p: xi[p])(x, perms)
        x = x.reshape((d, m, b // (d * m)) + rest)
        x = jnp.swapaxes(x, 0, 1).reshape((m, b // m) + rest)
        return self._constrain(x, P(None, BATCH_AXIS))

    def _curriculum(self, env_state: Any, samples: jax.Array, values: dict) -> tuple[Any, dict]:
        """The env states with this iteration's push curriculum factor (0 before
        env.push_start_samples, then rising over env.push_ramp_samples to 1, at once without a
        ramp, 0 again from env.push_stop_samples if set), and the factor as a metric; unchanged
        without a curriculum."""
        if not push_curriculum(self.config.env):
            return env_state, {}
        ramp, late = values["push_ramp_samples"], samples - values["push_start_samples"]
        ramped = jnp.clip(late / jnp.maximum(ramp, 1.0), 0.0, 1.0)
        scale = jnp.where(ramp > 0, ramped, (late >= 0).astype(jnp.float32))
        stop = values["push_stop_samples"]
        scale = jnp.where((stop > 0) & (samples >= stop), 0.0, scale)
        info = dict(env_state.info, **{PUSH_SCALE: jnp.full_like(env_state.info[PUSH_SCALE], scale)})
        return env_state.replace(info=info), {"curriculum/push_scale": scale}

    def _kl_from_behaviour(self, normalizer: Any, policy_params: Any, batch: Any) -> jax.Array:
        """Mean KL of `policy_params`' action distribution from the one that gathered `batch`."""
        dist = self.networks.parametric_action_distribution
        logits = self.networks.policy_network.apply(normalizer, policy_params, batch.observation)
        behaviour = dist.create_dist(batch.extras["policy_extras"]["distribution_params"])
        return jnp.mean(dist.create_dist(logits).kl_divergence(behaviour))

    def _train_step(self, ts: TrainState, values: dict) -> tuple[TrainState, dict]:
        cfg = self.config.ppo
        key, k_unroll, k_sgd = jax.random.split(ts.key, 3)
        samples = ts.env_steps.hi.astype(jnp.float32) * 2.0**32 + ts.env_steps.lo.astype(jnp.float32)
        env_state, curriculum = self._curriculum(ts.env_state, samples, values)
        policy = ppo_networks.make_inference_fn(self.networks)((ts.normalizer, ts.params.policy),
                                                               deterministic=False)
        policy = in_precision(policy, cfg.matmul_precision)
        env_state, data = acting.generate_unroll(
            self._batched_env, env_state, policy, k_unroll, cfg.unroll_length,
            extra_fields=("truncation", STEP_METRICS))
        # data leaves are time-major [T, B, ...].
        step_metrics = data.extras["state_extras"][STEP_METRICS]
        # physics/* are events (e.g. reset_nan: states that turned NaN or exploded and were reset):
        # counted per iteration, not averaged.
        metrics = {k: jnp.sum(v) if k.startswith("physics/") else jnp.mean(v) for k, v in step_metrics.items()}
        metrics["reward"] = jnp.mean(data.reward)
        done = 1.0 - data.discount
        metrics["done_rate"] = jnp.mean(done)
        if "fell" in step_metrics:
            fell = step_metrics["fell"]
            metrics["fall_rate"] = jnp.mean(fell)
            metrics["falls_per_episode_end"] = jnp.sum(fell) / jnp.maximum(jnp.sum(done), 1.0)
        metrics["truncation_rate"] = jnp.mean(data.extras["state_extras"]["truncation"])
        metrics.update(curriculum)

        data = data._replace(extras={
            "policy_extras": data.extras["policy_extras"],
            "state_extras": {"truncation": data.extras["state_extras"]["truncation"]},
        })
        data = jax.tree_util.tree_map(lambda x: jnp.swapaxes(x, 0, 1), data)  # [B, T, ...]

        normalizer = ts.normalizer
        if cfg.normalize_observations:
            normalizer = running_statistics.update(normalizer, data.observation)

        loss_fn = functools.partial(
            ppo_losses.compute_ppo_loss, ppo_network=self.networks, entropy_cost=cfg.entropy_cost,
            discounting=cfg.discounting, reward_scaling=cfg.reward_scaling, gae_lambda=cfg.gae_lambda,
            clipping_epsilon=cfg.clipping_epsilon, normalize_advantage=True)
        learning_rate = learning_rate_at(self.config, samples, values)
        metrics["ppo/learning_rate"] = learning_rate
        optimizer = make_optimizer(self.config, learning_rate, self.env.action_size)
        update = in_precision(gradients.gradient_update_fn(loss_fn, optimizer, pmap_axis_name=None,
                                                           has_aux=True), cfg.matmul_precision)

        kl_from_behaviour = in_precision(functools.partial(self._kl_from_behaviour, normalizer),
                                         cfg.matmul_precision)

        def minibatch_step(carry, batch):
            params, opt_state, k, stopped = carry
            k, k_loss = jax.random.split(k)
            (_, loss_metrics), new_params, new_opt_state = update(params, normalizer, batch, k_loss,
                                                                  optimizer_state=opt_state)
            if cfg.max_kl > 0:  # undo this step, and skip the rest, once the policy went too far
                stopped = stopped | (kl_from_behaviour(new_params.policy, batch) > cfg.max_kl)
                keep_old = lambda new, old: jax.tree_util.tree_map(lambda a, b: jnp.where(stopped, b, a), new, old)
                new_params, new_opt_state = keep_old(new_params, params), keep_old(new_opt_state, opt_state)
                loss_metrics = dict(loss_metrics, steps_undone=stopped.astype(jnp.float32))
            return (new_params, new_opt_state, k, stopped), loss_metrics

        def epoch(carry, _):
            params, opt_state, k, stopped = carry
            k, k_perm, k_grad = jax.random.split(k, 3)
            batches = jax.tree_util.tree_map(lambda x: self._shuffle_into_minibatches(x, k_perm), data)
            (params, opt_state, _, stopped), loss_metrics = jax.lax.scan(
                minibatch_step, (params, opt_state, k_grad, stopped), batches)
            return (params, opt_state, k, stopped), loss_metrics

        (params, opt_state, _, _), loss_metrics = jax.lax.scan(
            epoch, (ts.params, ts.optimizer_state, k_sgd, jnp.array(False)), None, length=cfg.num_epochs)
        for name, value in loss_metrics.items():
            metrics[f"ppo/{name}"] = jnp.mean(value)
        metrics["policy/std"] = metrics.pop("ppo/policy_dist_mean_std")

        new_ts = TrainState(params=params, optimizer_state=opt_state, normalizer=normalizer,
                            env_state=env_state, key=key,
                            env_steps=ts.env_steps + self.samples_per_iteration)
        return _strip_weak_type(new_ts), metrics


def make_trainer(env, config: Config, devices: list | None = None) -> Trainer:
    """A Trainer for `env` (the single, unbatched ImitationEnv API) and `config`, data-parallel
    over `devices` (default: every local device)."""
    cfg = config.ppo
    devices = list(devices or jax.local_devices())
    d = len(devices)
    if cfg.num_envs % d:
        raise UserError(f"config key 'ppo.num_envs': {cfg.num_envs} does not divide over the "
                        f"{d} local devices (use a multiple of {d})")
    if cfg.num_envs % (d * cfg.num_minibatches):
        raise UserError(f"config key 'ppo.num_minibatches': num_envs ({cfg.num_envs}) must divide into "
                        f"{cfg.num_minibatches} minibatches on each of {d} devices "
                        f"(num_envs % (devices * num_minibatches) == 0)")

    if d > 1:
        # Shardy, JAX's default partitioner, segfaults compiling the per-device env step on GPUs
        # (jax 0.11.2, two H100s); XLA's GSPMD partitions it. Process-wide: read when jit lowers.
        jax.config.update("jax_use_shardy_partitioner", False)
    networks = make_networks(env.observation_size, env.action_size, config)
    mesh = Mesh(np.array(devices), (BATCH_AXIS,))
    trainer = Trainer(env=env, config=config, networks=networks, mesh=mesh,
                      num_devices=d, samples_per_iteration=cfg.num_envs * cfg.unroll_length)
    trainer._batched_env = BatchedEnv(env)

    # Shardings of a TrainState, from shapes only (nothing runs).
    def abstract_init(key):
        params, opt_state, normalizer = trainer.init_learner(key)
        keys = jax.random.split(key, cfg.num_envs)
        return TrainState(params=params, optimizer_state=opt_state, normalizer=normalizer,
                          env_state=trainer._batched_env.reset(keys), key=key,
                          env_steps=brax_types.UInt64(hi=0, lo=0))

    abstract = jax.eval_shape(abstract_init, jax.random.PRNGKey(0))
    trainer._state_sharding = trainer.state_sharding(abstract)
    trainer.abstract_state = jax.tree_util.tree_map(
        lambda x, sharding: jax.ShapeDtypeStruct(x.shape, x.dtype, sharding=sharding), abstract,
        trainer._state_sharding)
    if d > 1:
        specs = jax.tree_util.tree_map(lambda sharding: sharding.spec, trainer._state_sharding.env_state)
        trainer._batched_env = PerDeviceEnv(trainer._batched_env, mesh, abstract.env_state, specs)
    trainer._reset = jax.jit(trainer._batched_env.reset, out_shardings=trainer._state_sharding.env_state)
    step = jax.jit(trainer._train_step, donate_argnums=0, out_shardings=(trainer._state_sharding, trainer.replicated))
    trainer.train_step = BoundSchedule(step, jax.device_put(schedule_values(config), trainer.replicated))
    return trainer


class BoundSchedule:
    """A train step, jitted or compiled, called as `step(ts)` with the run's schedule values."""

    def __init__(self, step: Any, values: dict):
        self.step, self.values = step, values

    def __call__(self, ts: TrainState) -> tuple[TrainState, dict]:
        return self.step(ts, self.values)

    def lower(self, ts: Any) -> jax.stages.Lowered:
        return self.step.lower(ts, self.values)

    def _cache_size(self) -> int:
        return self.step._cache_size()
