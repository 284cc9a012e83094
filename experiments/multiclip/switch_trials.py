"""Does a skill selector survive its switches? For every ordered pair of its skills, 10 trials on
MuJoCo C: play skill A from its start for 1 s plus 0 to 36 control steps (every 4th), ask for B
(`CpuEnv.switch`, the rule of `mjxmimic play --skill-sequence` and of training with
env.skill_switch_s: at once between cyclic clips, else where A's cycle ends), then count the control
steps from the switch until a fall (120 = still up 4 s after it; -1 = fell before it). With
`nearest`, B is entered at its reference pose nearest the character's instead of the same phase
(env.skill_switch_entry=nearest).

    python experiments/multiclip/switch_trials.py runs/NAME/policy.npz [nearest]
"""
import sys

from mjxmimic.core.config import apply_overrides, evaluation_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.runs.folder import load_policy_file

pf = load_policy_file(sys.argv[1])
entry = {"env.skill_switch_entry": "nearest"} if sys.argv[2:] == ["nearest"] else {}
clips = pf.clips()
names = [c.name for c in clips]
env = CpuEnv(evaluation_config(apply_overrides(pf.config(), entry)), pf.character(), clips, pf.weights())
policy = pf.policy()
UP = 120


def trial(a: int, b: int, extra: int) -> int:
    obs = env.reset_at(0.0, clip=a)
    for _ in range(int(1.0 / env.control_dt) + extra):
        s = env.step(policy(obs))
        obs = s.obs
        if s.failed:
            return -1
    obs = env.switch(b)
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
