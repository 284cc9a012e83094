"""falls.py's question asked of MJX instead of MuJoCo C: from which start times an exported policy
falls, in its run's evaluation conditions (MJX-Warp on a GPU, MJX-JAX on a CPU), every start an
evaluation episode (`mjxmimic.runs.evaluate.rollout`), all of them in one batch; and the NR over
them (`nr_paper`).

    python experiments/paper_form/mjx_falls.py POLICY.npz START:STOP:STEP|T0,T1,...
"""

import json
import sys

import jax
import jax.numpy as jnp
from falls import start_times

from mjxmimic.core import jax_setup
from mjxmimic.runs.evaluate import rollout, summarize
from mjxmimic.runs.evaluate_run import load_file_policy


def main() -> None:
    jax_setup.prepare()
    _, env, policy = load_file_policy(sys.argv[1])
    starts = start_times(sys.argv[2], 0)
    t0 = jnp.asarray(starts, jnp.float32)
    acc = jax.device_get(jax.jit(lambda key: rollout(env, policy, key, len(starts), 0, t0))(jax.random.PRNGKey(0)))
    falls = [{"start_s": round(t, 3), "fell_after_s": round(float(steps) * env.control_dt, 2)}
             for t, steps, failed in zip(starts, acc["steps"], acc["failed"]) if failed]
    print(json.dumps({"policy": sys.argv[1], "simulator": env.physics.simulator, "episodes": len(starts),
                      "starts": starts, "nr_paper": round(summarize(acc, env.control_dt)["nr_paper"], 4),
                      "falls": falls}, indent=1))


if __name__ == "__main__":
    main()
