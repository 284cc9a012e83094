"""Does a skill selector survive its switches? For every ordered pair of its skills, 10 trials on
MuJoCo C: play skill A for 2 s plus 0 to 36 control steps (every 4th), switch to B, count the
control steps until a fall (120 = still up after 4 s). Two entry rules for B: the same phase as
A's (`mjxmimic play --skill-sequence`'s) and the composite gate's nearest reference pose.

    python experiments/multiclip/switch_trials.py runs/sel300/policy.npz
"""
import sys

import numpy as np

from mjxmimic.core.config import evaluation_config
from mjxmimic.envs import composite as gate_lib
from mjxmimic.envs import step as step_lib
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.runs.folder import load_policy_file

pf = load_policy_file(sys.argv[1])
clips = pf.clips()
names = [c.name for c in clips]
env = CpuEnv(evaluation_config(pf.config()), pf.character(), clips, pf.weights())
policy = pf.policy()
gate = gate_lib.make_gate(env.spec, env.physics.kinematics, 0.0)
UP = 120


def trial(a: int, b: int, extra: int, rule: str) -> int:
    obs = env.reset_at(0.0, clip=a)
    for _ in range(int(2.0 / env.control_dt) + extra):
        s = env.step(policy(obs))
        obs = s.obs
        if s.failed:
            return -1
    if rule == "phase":
        obs = env.switch(b)
    else:
        qpos, qvel = env.data.qpos.copy(), env.data.qvel.copy()
        t = np.float32(gate_lib.entry_times(gate, env.physics.kinematics(qpos, qvel), np)[b])
        env.motion = env.motion._replace(clip=b, time=t, root_offset=step_lib.root_under(env.spec, b, t, qpos, np))
        obs = env._observe(env.motion)
    for k in range(UP):
        s = env.step(policy(obs))
        obs = s.obs
        if s.failed:
            return k
    return UP


for a in range(len(names)):
    for b in range(len(names)):
        if a != b:
            for rule in ("phase", "nearest"):
                steps = [trial(a, b, extra, rule) for extra in range(0, 40, 4)]
                print(f"{names[a]} -> {names[b]} {rule:<8} {steps} up after 4 s: {sum(x == UP for x in steps)} of 10",
                      flush=True)
