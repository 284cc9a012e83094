"""The env batched for training: vmapped over the envs, and on several devices each device
stepping its own slice of the batch."""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from jax.sharding import Mesh, PartitionSpec as P

BATCH_AXIS = "batch"  # the mesh axis the env batch is split on
STEP_METRICS = "_step_metrics"  # info key under which the batched env exposes state.metrics


class BatchedEnv:
    """vmap of the single env; copies each step's `state.metrics` into info so that Brax's
    `generate_unroll` records them (it only records `info` fields)."""

    def __init__(self, env):
        self.env = env

    @staticmethod
    def _expose(state):
        info = dict(state.info)
        info.setdefault("truncation", jnp.zeros_like(state.done))
        info[STEP_METRICS] = dict(state.metrics)
        return state.replace(info=info)

    def reset(self, keys):
        return self._expose(jax.vmap(self.env.reset)(keys))

    def step(self, state, action):
        inner = state.replace(info={k: v for k, v in state.info.items() if k != STEP_METRICS})
        return self._expose(jax.vmap(self.env.step)(inner, action))


class PerDeviceEnv:
    """The batched env run by each device on its own slice of the batch (`shard_map`).

    Under plain jit sharding XLA must split the physics itself, and it cannot split MuJoCo Warp's
    kernels (foreign calls): it gathers the whole batch onto every device and steps it there.
    Here each device steps its slice, with its own contact pool and CUDA graphs. `state_specs`
    says which env leaves are per env (split) and which all worlds share (warp's counters: each
    device keeps its own). Empty leaves (MJX fields of size 0) stay outside the shard_map and are
    made again around it: under Shardy (jax 0.11.2, GPU), outputs that mixed them with others
    crashed the compiler; whether GSPMD, used now, needs this was not tried."""

    def __init__(self, env: BatchedEnv, mesh: Mesh, abstract_state: Any, state_specs: Any):
        leaves, self._tree = jax.tree_util.tree_flatten(abstract_state)
        specs = self._tree.flatten_up_to(state_specs)
        self._shapes = [(x.shape, x.dtype) for x in leaves]
        self._kept = [x.size > 0 for x in leaves]
        d = mesh.devices.size
        self._local_shapes = [((x.shape[0] // d,) + x.shape[1:] if spec == P(BATCH_AXIS) else x.shape, x.dtype)
                              for x, spec in zip(leaves, specs)]
        kept_specs = [spec for spec, kept in zip(specs, self._kept) if kept]
        batch = P(BATCH_AXIS)
        self._reset = jax.shard_map(lambda keys: self._strip(env.reset(keys)), mesh=mesh, in_specs=batch,
                                    out_specs=kept_specs, check_vma=False)
        self._step = jax.shard_map(
            lambda kept, action: self._strip(env.step(self._fill(kept, self._local_shapes), action)),
            mesh=mesh, in_specs=(kept_specs, batch), out_specs=kept_specs, check_vma=False)

    def _strip(self, state: Any) -> list:
        return [x for x, kept in zip(jax.tree_util.tree_leaves(state), self._kept) if kept]

    def _fill(self, kept_leaves: list, shapes: list) -> Any:
        it = iter(kept_leaves)
        return self._tree.unflatten([next(it) if kept else jnp.zeros(shape, dtype)
                                     for kept, (shape, dtype) in zip(self._kept, shapes)])

    def reset(self, keys: jax.Array) -> Any:
        return self._fill(self._reset(keys), self._shapes)

    def step(self, state: Any, action: jax.Array) -> Any:
        return self._fill(self._step(self._strip(state), action), self._shapes)
