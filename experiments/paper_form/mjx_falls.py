"""falls.py's question asked of MJX instead of MuJoCo C: from which start times an exported policy
falls, in its run's evaluation conditions (MJX-Warp on a GPU, MJX-JAX on a CPU), each start run for
SECONDS (3 unless given), all of them in one vmapped batch.

    python experiments/paper_form/mjx_falls.py POLICY.npz START:STOP:STEP|T0,T1,... [SECONDS]
"""

import json
import sys

import jax
import jax.numpy as jnp
from falls import start_times

from mjxmimic.core import jax_setup
from mjxmimic.runs.evaluate_run import load_file_policy


def main() -> None:
    path, spec = sys.argv[1], sys.argv[2]
    seconds = float(sys.argv[3]) if len(sys.argv) > 3 else 3.0
    jax_setup.prepare()
    _, env, policy = load_file_policy(path)
    starts = start_times(spec, 0)
    steps = int(round(seconds / env.control_dt))
    transition = jax.vmap(lambda s, a: env.transition(s, a, evaluation=True))

    @jax.jit
    def fell_after(key: jax.Array) -> jax.Array:
        """Control steps until each start's first fall, -1 where it did not fall."""
        t0 = jnp.asarray(starts, jnp.float32)
        state = jax.vmap(lambda k, t: env.reset_at(k, t, 0))(jax.random.split(key, len(starts)), t0)

        def body(carry, k):
            state, fell = carry
            nxt = transition(state, policy(state.obs, key))
            fell = jnp.where((fell < 0) & (nxt.info["failed"] > 0), k + 1, fell)
            return (jax.vmap(env.select)(fell < 0, nxt, state), fell), None

        fell = -jnp.ones(len(starts), jnp.int32)
        return jax.lax.scan(body, (state, fell), jnp.arange(steps))[0][1]

    fell = jax.device_get(fell_after(jax.random.PRNGKey(0)))
    print(json.dumps({"policy": path, "simulator": env.physics.simulator, "seconds": seconds,
                      "starts": starts,
                      "falls": [{"start_s": t, "fell_after_s": round(float(k) * env.control_dt, 2)}
                                for t, k in zip(starts, fell) if k >= 0]}, indent=1))


if __name__ == "__main__":
    main()
