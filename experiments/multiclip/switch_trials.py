"""Does a skill selector survive its switches? For every ordered pair of its skills, 10 trials on
MuJoCo C: play skill A from its start for 1 s plus 0 to 36 control steps (every 4th), ask for B
(`CpuEnv.switch`, the rule of `mjxmimic play --skill-sequence` and of training with
env.skill_switch_s: at once between cyclic clips, else where A's cycle ends), then count the control
steps from the switch until a fall (120 = still up 4 s after it; -1 = fell before it). With
`nearest`, B is entered at once at its reference pose nearest the character's (the composite gate's
rule) instead.

    python experiments/multiclip/switch_trials.py runs/NAME/policy.npz [nearest]
"""
import sys

import numpy as np

from mjxmimic.core.config import evaluation_config
from mjxmimic.envs import composite as gate_lib
from mjxmimic.envs import step as step_lib
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.runs.folder import load_policy_file

pf = load_policy_file(sys.argv[1])
nearest = sys.argv[2:] == ["nearest"]
clips = pf.clips()
names = [c.name for c in clips]
env = CpuEnv(evaluation_config(pf.config()), pf.character(), clips, pf.weights())
policy = pf.policy()
gate = gate_lib.make_gate(env.spec, env.physics.kinematics, 0.0)
UP = 120


def enter_nearest(b: int) -> np.ndarray:
    qpos, qvel = env.data.qpos.copy(), env.data.qvel.copy()
    t = np.float32(gate_lib.entry_times(gate, env.physics.kinematics(qpos, qvel), np)[b])
    env.motion = env.motion._replace(clip=b, time=t, root_offset=step_lib.root_under(env.spec, b, t, qpos, np))
    return env._observe(env.motion)


def trial(a: int, b: int, extra: int) -> int:
    obs = env.reset_at(0.0, clip=a)
    for _ in range(int(1.0 / env.control_dt) + extra):
        s = env.step(policy(obs))
        obs = s.obs
        if s.failed:
            return -1
    obs = enter_nearest(b) if nearest else env.switch(b)
    after = None
    for _ in range(10 * UP):
        after = 0 if after is None and env.motion.clip == b else after
        s = env.step(policy(obs))
        obs = s.obs
        if s.failed:
            return -1 if after is None else after
        if after is not None:
            after += 1
            if after == UP:
                return UP
    return -1


total = 0
for a in range(len(names)):
    for b in range(len(names)):
        if a != b:
            steps = [trial(a, b, extra) for extra in range(0, 40, 4)]
            up = sum(x == UP for x in steps)
            total += up
            print(f"{names[a]} -> {names[b]} {steps} up 4 s after the switch: {up} of 10", flush=True)
print(f"all pairs: {total} of {10 * len(names) * (len(names) - 1)}")
