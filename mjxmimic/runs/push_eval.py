"""The Table 6 push test on MJX (`mjxmimic eval RUN --push`): the protocol of
mjxmimic.task.push_protocol, its trials vmapped and compiled once, the force and direction traced
so that the whole search reuses one compilation."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import jax
import jax.numpy as jnp

from mjxmimic.task import push_protocol as protocol


def make_trials(env: Any, policy_fn: Callable, trials: int, clip: int = 0) -> Callable:
    """jitted fn(key, force_n, turn) -> survival rate of `trials` pushed trials of `policy_fn`."""
    lead, push, total = protocol.steps(env.control_dt)
    lib = env.spec.lib
    start_range = protocol.start_time_range(float(lib.duration[clip]), bool(lib.loop[clip]))
    nbody = env.model.nbody
    transition = jax.vmap(lambda s, a, f: env.transition(s, a, evaluation=True, external_force=f))

    def run(key: jax.Array, force_n: jax.Array, turn: jax.Array) -> jax.Array:
        k_time, k_reset, k_policy = jax.random.split(key, 3)
        t0 = jax.random.uniform(k_time, (trials,), maxval=start_range)
        state = jax.vmap(lambda k, t: env.reset_at(k, t, clip))(jax.random.split(k_reset, trials), t0)

        def body(carry, i):
            state, alive, failed = carry
            qpos = jax.vmap(lambda d: env.physics.qpos_qvel(d)[0])(state.pipeline_state)
            active = ((i >= lead) & (i < lead + push)).astype(jnp.float32)
            force = jax.vmap(lambda q: protocol.wrench(q, force_n, turn, active, nbody, jnp))(qpos)
            nxt = transition(state, policy_fn(state.obs, jax.random.fold_in(k_policy, i)), force)
            fell = nxt.info["failed"] > 0
            failed = failed | (alive & fell)
            alive = alive & ~fell & (nxt.info["clip_end"] == 0)  # the time limit does not end a trial
            return (jax.vmap(env.select)(alive, nxt, state), alive, failed), None

        start = (state, jnp.ones(trials, bool), jnp.zeros(trials, bool))
        (_, _, failed), _ = jax.lax.scan(body, start, jnp.arange(total))
        return 1.0 - jnp.mean(failed.astype(jnp.float32))

    return jax.jit(run)


def push_test(env: Any, policy_fn: Callable, seed: int = 0, trials: int = protocol.TRIALS,
              progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """push_forward_n and push_sideways_n (the largest forces that 90 % of the trials survive),
    with every (force, survival rate) tried and the simulator that made them."""
    run = make_trials(env, policy_fn, trials)
    key = jax.random.PRNGKey(seed)
    return {"simulator": env.physics.simulator,
            **protocol.search(lambda force, turn: float(run(key, jnp.float32(force), jnp.float32(turn))),
                              trials, progress)}


def push_test_run(run_dir: Path, seed: int | None = None, trials: int = protocol.TRIALS, env: Any = None,
                  progress: Callable[[str], None] | None = None, which: str = "latest") -> dict[str, Any]:
    """The push test of one of RUN's checkpoints (the latest by default) in its own env (or `env`),
    or of an exported policy file (RUN a file; then `env` and `which` do not apply)."""
    from mjxmimic.runs import folder
    from mjxmimic.runs.evaluate_run import load_file_policy, load_run_policy

    if folder.names_policy_file(run_dir):
        config, env, policy = load_file_policy(run_dir)
        where: dict[str, Any] = {"policy": str(run_dir)}
    else:
        config, env, policy, _, step = load_run_policy(run_dir, env, which)
        where = {"checkpoint": step}
    result = push_test(env, policy, config.run.seed + 1 if seed is None else seed, trials, progress)
    return {"clip": config.clip.name, **where, **result}
