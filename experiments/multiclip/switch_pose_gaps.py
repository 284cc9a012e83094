"""Why a selector's switches fall: after each switch of `mjxmimic play --switch-trials` (MuJoCo C),
the control step at which training's pose rule (a body more than env.pose_termination_m from the
reference) would have ended the episode, beside the step of the fall at play time.

    python experiments/multiclip/switch_pose_gaps.py POLICY.npz [MOMENTS] > gaps.json
"""

import json
import sys

import numpy as np

from mjxmimic.core.config import evaluation_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.runs.folder import load_policy_file


def trial(env: CpuEnv, policy, a: int, b: int, lead: int, limit_m: float, hold: int = 120) -> dict:
    obs = env.reset_at(0.0, clip=a)
    for _ in range(lead):
        obs = env.step(policy(obs)).obs
    obs, started, rule, fall, gaps = env.switch(b), None, None, None, []
    for i in range(hold + env.max_steps):
        if started is None and env.motion.clip == b:
            started = i
        s = env.step(policy(obs))
        obs = s.obs
        if started is not None:
            sim = env.physics.kinematics(env.data.qpos.copy(), env.data.qvel.copy())
            ref = env.physics.kinematics(*env.reference(env.time))
            gaps.append(float(np.max(np.linalg.norm(sim.xipos[1:] - ref.xipos[1:], axis=-1))))
            if rule is None and gaps[-1] > limit_m:
                rule = i - started
            if i - started + 1 >= hold:
                break
        if s.failed:
            fall = i - (started or 0)
            break
    return {"rule_step": rule, "fall_step": fall, "largest_gap_first_s_m": round(max(gaps[:30], default=-1.0), 3)}


def main() -> None:
    pf = load_policy_file(sys.argv[1])
    moments = int(sys.argv[2]) if len(sys.argv) > 2 else 6
    env = CpuEnv(evaluation_config(pf.config()), pf.character(), pf.clips(), pf.weights())
    policy, names = pf.policy(), [c.name for c in env.clips]
    limit = pf.config().env.pose_termination_m
    lead = round(1.0 / env.control_dt)
    out = {"policy": sys.argv[1], "pose_termination_m": limit, "control_hz": 1.0 / env.control_dt, "pairs": {}}
    for a in range(len(names)):
        for b in range(len(names)):
            if a != b:
                rows = [trial(env, policy, a, b, lead + 4 * k, limit) for k in range(moments)]
                out["pairs"][f"{names[a]} -> {names[b]}"] = rows
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
