"""The one place where mjxmimic papers over version skew between Brax and JAX.

brax 0.14.2 (the newest release) was written against a JAX that still had
`jax.device_put_replicated`; JAX removed it in 0.10 (the CPU machines run jax 0.10.x, the GPU
machine 0.11.2). `patch_jax_for_brax()` installs a faithful replacement, built on
`jax.device_put` with a `NamedSharding` over the given devices, but only when JAX lacks the
function, so on an older JAX nothing changes. A second, unrelated JAX problem, a deadlock of
batched LAPACK calls on jaxlib 0.10.x CPU that hangs MJX training, is fixed by
`patch_jax_cpu_lapack_deadlock()` (see its docstring). `patch_all()` applies both;
`mjxmimic.learn.ppo` calls it at import.

Semantics of the old function (and of the replacement): `device_put_replicated(x, devices)` maps
over the pytree `x`; each leaf of shape S becomes one array of shape (len(devices), *S) whose
slice i lives on devices[i] (all slices equal), i.e. the layout that `jax.pmap` expects for a
replicated argument. Dtypes are kept; weak types are not (the old function kept them; Brax
strips weak types from its training state anyway).

What else was checked in brax 0.14.2 against jax 0.10.2 (a scan of every `jax.<attr>` and
`jnp.<attr>` that brax references outside its tests, plus `brax.training.agents.ppo.train.train`
run end to end on the 'fast' env in tests/test_compat.py):
- `jax.device_put_replicated` is the only missing attribute that brax calls. It is used by
  `brax/training/pmap.py` (`bcast_local_devices`) and by the ppo, apg and sac `train` functions.
- `jax.device_put_sharded` is also gone from JAX; brax 0.14.2 does not call it, so it is not patched.
- Removed aliases such as `jax.tree_map` / `jax.tree_leaves` are not used by brax 0.14.2 (it uses
  `jax.tree_util.*` and `jax.tree.*`).
- `jax.pmap` still exists (recent JAX implements it on top of `shard_map`); brax's
  `_unpmap` reads `addressable_shards[0]`, which works with arrays placed by the replacement.
- The only other hits of the scan are prose (`jnp.linal.norm` in a docstring of brax/math.py,
  `jax.Arrays` in docstrings of brax/io/torch.py), not code.
mjxmimic's own trainer (`mjxmimic.learn.ppo`) does not use `pmap` or `device_put_replicated` at all: it
shards with `jax.sharding` under `jit`. The patch matters for code that calls Brax's own
`ppo.train` (baselines, comparisons).
"""

from __future__ import annotations

from typing import Any, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

_AXIS = "replica"


def device_put_replicated(x: Any, devices: Sequence[jax.Device]) -> Any:
    """Replacement for the removed `jax.device_put_replicated` (see the module docstring).

    Each leaf is stacked on a new leading axis of size len(devices), slice i placed on devices[i],
    as one global array with a `NamedSharding` over a 1-D mesh of `devices`.
    """
    devices = list(devices)
    if not devices:
        raise ValueError("device_put_replicated: `devices` must not be empty")
    sharding = NamedSharding(Mesh(np.array(devices), (_AXIS,)), PartitionSpec(_AXIS))

    def put(leaf: Any) -> jax.Array:
        arr = leaf if isinstance(leaf, jax.Array) else jnp.asarray(leaf)
        one = arr[None]  # shape (1, *S), same dtype
        shards = [jax.device_put(one, d) for d in devices]
        return jax.make_array_from_single_device_arrays((len(devices),) + arr.shape, sharding, shards)

    return jax.tree_util.tree_map(put, x)


def _cholesky_small(a: jax.Array) -> jax.Array:
    """Lower Cholesky factor of (..., n, n), vectorised over the batch: a left-looking column loop
    (one masked matrix-vector product per column). NaN where `a` is not positive definite,
    like the LAPACK path."""
    n = a.shape[-1]
    idx = jnp.arange(n)

    def column(j, factor):
        row = jax.lax.dynamic_index_in_dim(factor, j, axis=-2, keepdims=False)  # L[j, :j], zeros after
        v = jax.lax.dynamic_index_in_dim(a, j, axis=-1, keepdims=False) - jnp.einsum("...ik,...k->...i", factor, row)
        d = jnp.sqrt(jax.lax.dynamic_index_in_dim(v, j, axis=-1, keepdims=False))
        col = jnp.where(idx >= j, v / d[..., None], 0.0)
        return jax.lax.dynamic_update_index_in_dim(factor, col[..., :, None], j, axis=-1)

    return jax.lax.fori_loop(0, n, column, jnp.zeros_like(a))


def _triangular_solve_small(a, b, *, left_side, lower, transpose_a, conjugate_a, unit_diagonal):
    """Solve op(a) x = b (left_side) or x op(a) = b, op = transpose if transpose_a, vectorised
    over the batch: substitution, one masked matrix-vector product per row."""
    if conjugate_a:
        a = jnp.conj(a)
    m = jnp.swapaxes(a, -1, -2) if transpose_a else a
    m_lower = lower != transpose_a
    c = b
    if not left_side:  # x op(a) = b  <=>  op(a)^T x^T = b^T
        m, c, m_lower = jnp.swapaxes(m, -1, -2), jnp.swapaxes(b, -1, -2), not m_lower
    if not m_lower:  # reverse rows and columns: an upper system becomes a lower one
        m, c = m[..., ::-1, ::-1], c[..., ::-1, :]
    n = m.shape[-1]
    diag = jnp.ones(m.shape[:-1], m.dtype) if unit_diagonal else jnp.diagonal(m, axis1=-2, axis2=-1)

    def row(i, x):
        mi = jax.lax.dynamic_index_in_dim(m, i, axis=-2, keepdims=False)  # (..., n)
        ci = jax.lax.dynamic_index_in_dim(c, i, axis=-2, keepdims=False)  # (..., k)
        di = jax.lax.dynamic_index_in_dim(diag, i, axis=-1, keepdims=False)
        mi = jnp.where(jnp.arange(n) < i, mi, 0.0)  # rows >= i of x are still 0; drop the diagonal
        xi = (ci - jnp.einsum("...n,...nk->...k", mi, x)) / di[..., None]
        return jax.lax.dynamic_update_index_in_dim(x, xi[..., None, :], i, axis=-2)

    x = jax.lax.fori_loop(0, n, row, jnp.zeros_like(c))
    if not m_lower:
        x = x[..., ::-1, :]
    return jnp.swapaxes(x, -1, -2) if not left_side else x


def patch_jax_cpu_lapack_deadlock() -> bool:
    """jaxlib 0.10.x CPU: Cholesky and triangular solves without the LAPACK kernels that deadlock.

    In jaxlib 0.10.x every batched LAPACK FFI kernel (potrf, trsm, getrf, geqrf, syevd, gesdd,
    ...) splits its batch with `ParallelBatchMap` onto XLA:CPU's intra-op thread pool and blocks
    until the pieces finish. When the thunk executor runs as many such kernels concurrently as
    the pool has threads (the pool is sized from the CPU affinity: 2 threads on the 2-core
    machines), every pool thread blocks waiting for sub-tasks that no thread is free to run:
    the process hangs at 0% CPU. MJX's Newton solver (Cholesky + cho_solve under vmap) hits it
    within a few PPO iterations (gdb: both "tf_XLAEigen" threads in
    `lapack_spotrf_ffi -> CholeskyFactorization -> ParallelBatchMap -> BlockingCounter::Wait`).
    jaxlib 0.11 compiles that parallel path out of open-source builds, so this patch applies
    only for jaxlib < 0.11, and only to the CPU lowerings (GPU is untouched).

    `cholesky_p` and `triangular_solve_p` are lowered on CPU to the small, batch-vectorised JAX
    loops above (plain HLO: no custom call, no thread pool). They suit MJX's 34 x 34 systems:
    a 16-step rollout of 32 humanoid envs (cpu preset) took 0.099 s with them, 0.109 s with
    LAPACK (when it did not hang) and 0.57 s with XLA's own HLO `cholesky`/`triangular_solve`
    expanders. Other LAPACK-backed ops (lu, qr, eigh, svd) are left
    alone: MJX's step does not use them. Must run before the first jit that uses these ops
    (mjxmimic.learn.ppo calls it at import). Returns True if it patched.
    """
    import jaxlib

    major_minor = tuple(int(p) for p in jaxlib.__version__.split(".")[:2])
    if major_minor >= (0, 11):
        return False
    from jax._src.interpreters import mlir
    from jax._src.lax import linalg

    mlir.register_lowering(linalg.cholesky_p, mlir.lower_fun(_cholesky_small, multiple_results=False),
                           platform="cpu")
    mlir.register_lowering(linalg.triangular_solve_p,
                           mlir.lower_fun(_triangular_solve_small, multiple_results=False), platform="cpu")
    return True


def patch_jax_for_brax() -> bool:
    """Install `device_put_replicated` on `jax` if this JAX lacks it. Returns True if it patched.

    Idempotent; never replaces a function that JAX itself provides.
    """
    if hasattr(jax, "device_put_replicated"):
        return False
    jax.device_put_replicated = device_put_replicated
    return True


def patch_all() -> dict[str, bool]:
    """Every patch of this module (each one a no-op where JAX does not need it)."""
    return {"device_put_replicated": patch_jax_for_brax(),
            "cpu_lapack_deadlock": patch_jax_cpu_lapack_deadlock()}
