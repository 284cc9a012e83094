"""The one place where mjxmimic papers over version skew between Brax and JAX.

brax 0.14.2 (the newest release) was written against a JAX that still had
`jax.device_put_replicated`; JAX removed it in 0.10 (the CPU machines run jax 0.10.x, the GPU
machine 0.11.2). `patch_jax_for_brax()` installs a faithful replacement, built on
`jax.device_put` with a `NamedSharding` over the given devices, but only when JAX lacks the
function, so on an older JAX nothing changes. A second, unrelated JAX problem, a deadlock of
batched LAPACK calls on jaxlib 0.10.x CPU that hangs MJX training, is fixed by
`patch_jax_cpu_lapack_deadlock()` (see its docstring). `patch_all()` applies both;
`mjxmimic.ppo` calls it at import.

Semantics of the old function (and of the replacement): `device_put_replicated(x, devices)` maps
over the pytree `x`; each leaf of shape S becomes one array of shape (len(devices), *S) whose
slice i lives on devices[i] (all slices equal), i.e. the layout that `jax.pmap` expects for a
replicated argument. Weak types and dtypes of the leaves are kept.

What else was checked in brax 0.14.2 against jax 0.10.2 (a scan of every `jax.<attr>` and
`jnp.<attr>` that brax references outside its tests, plus `brax.training.agents.ppo.train.train`
run end to end on the 'fast' env in tests/test_compat.py):
- `jax.device_put_replicated` is the only missing attribute that brax calls. It is used by
  `brax/training/pmap.py` (`bcast_local_devices`) and by the ppo, apg and sac `train` functions.
- `jax.device_put_sharded` is also gone from JAX; brax 0.14.2 does not call it, so it is not patched.
- Removed aliases such as `jax.tree_map` / `jax.tree_leaves` are not used by brax 0.14.2 (it uses
  `jax.tree_util.*` and `jax.tree.*`).
- `jax.pmap` still exists (in JAX >= 0.8 it is implemented on top of `shard_map`); brax's
  `_unpmap` reads `addressable_shards[0]`, which works with arrays placed by the replacement.
- The only other hits of the scan are prose (`jnp.linal.norm` in a docstring of brax/math.py,
  `jax.Arrays` in docstrings of brax/io/torch.py), not code.
mjxmimic's own trainer (`mjxmimic.ppo`) does not use `pmap` or `device_put_replicated` at all: it
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
        one = arr[None]  # shape (1, *S), keeps dtype and weak type
        shards = [jax.device_put(one, d) for d in devices]
        return jax.make_array_from_single_device_arrays((len(devices),) + arr.shape, sharding, shards)

    return jax.tree_util.tree_map(put, x)


def patch_jax_cpu_lapack_deadlock() -> bool:
    """jaxlib 0.10.x CPU: lower Cholesky and triangular solves to XLA's own HLO ops, not LAPACK.

    In jaxlib 0.10.x every batched LAPACK FFI kernel (potrf, trsm, getrf, geqrf, syevd, gesdd,
    ...) splits its batch with `ParallelBatchMap` onto XLA:CPU's intra-op thread pool and blocks
    until the pieces finish. When the thunk executor runs as many such kernels concurrently as
    the pool has threads (the pool is sized from the CPU affinity: 2 threads on the 2-core
    machines), every pool thread blocks waiting for sub-tasks that no thread is free to run:
    the process hangs at 0% CPU. MJX's Newton solver (Cholesky + cho_solve under vmap) hits it
    within a few PPO iterations (seen: gdb shows both "tf_XLAEigen" threads in
    `lapack_spotrf_ffi -> CholeskyFactorization -> ParallelBatchMap -> BlockingCounter::Wait`).
    jaxlib 0.11 compiles that parallel path out of open-source builds, so this patch is applied
    only for jaxlib < 0.11, and only to the CPU lowering (GPU lowerings are untouched). The HLO
    `cholesky` / `triangular_solve` ops are expanded by XLA into plain loops (no custom call, no
    thread pool); they are slower per call than LAPACK for large matrices but fine for MJX's
    ~35 x 35 systems. Must run before the first jit that uses them (mjxmimic.ppo calls it at
    import). Returns True if it patched.
    """
    import jaxlib

    major_minor = tuple(int(p) for p in jaxlib.__version__.split(".")[:2])
    if major_minor >= (0, 11):
        return False
    from jax._src.interpreters import mlir
    from jax._src.lax import linalg

    mlir.register_lowering(linalg.cholesky_p, linalg._cholesky_lowering, platform="cpu")
    mlir.register_lowering(linalg.triangular_solve_p, linalg._triangular_solve_lowering, platform="cpu")
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
