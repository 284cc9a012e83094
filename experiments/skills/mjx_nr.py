"""NR of an exported policy on MJX impl='jax' (on whatever JAX runs on, e.g. a CPU), with the
training evaluation's start times (its seed; N = 64 gives exactly its episodes): a third
simulator beside MJX-Warp (the training's evaluation) and MuJoCo C (`mjxmimic play`), to tell
which one a sim-to-sim gap comes from.

    python experiments/skills/mjx_nr.py POLICY.npz N
"""
import json
import sys
from pathlib import Path

from mjxmimic.core import config as config_lib
from mjxmimic.envs.mjx_env import make_env
from mjxmimic.learn.ppo import make_networks, make_policy_fn
from mjxmimic.portable import policy_file
from mjxmimic.runs.evaluate import evaluate

path, n = Path(sys.argv[1]), int(sys.argv[2])
pf = policy_file.read(path)
config = pf.config()
config = config_lib.apply_overrides(config, {"physics.backend": "jax"})
env = make_env(config_lib.evaluation_config(config))
nets = make_networks(env.observation_size, env.action_size, config)
policy = make_policy_fn(nets, pf.params, deterministic=True)
seed = config.run.seed + 1
res = evaluate(env, policy, config, seed, episodes=n)
print(json.dumps({k: v for k, v in res.items() if not isinstance(v, (list, dict))}))
