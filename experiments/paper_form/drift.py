"""How a policy of a looping clip drifts from its reference on MuJoCo C, by time since the episode's
start and by phase within the cycle: the mean heading difference between the character's root
and the reference's (degrees), and the paper form's world-position errors E_ee and E_com (m²).
The reference root moves under the character at each new cycle (reward.sync_root_position), its
heading does not, and no default observation term shows either.

    python experiments/paper_form/drift.py POLICY.npz [EPISODES] > drift.json
"""

import json
import sys

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.config import evaluation_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.runs.folder import load_policy_file
from mjxmimic.task import reward as R


def main() -> None:
    pf = load_policy_file(sys.argv[1])
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    env = CpuEnv(evaluation_config(pf.config()), pf.character(), pf.clips(), pf.weights())
    policy, duration, layout = pf.policy(), env.clip_duration, env.spec.layout
    by_time: dict[int, list] = {}
    by_phase: dict[int, list] = {}
    for t0 in env.start_times(episodes, seed=0, clip=0):
        obs = env.reset_at(float(t0))
        for k in range(env.eval_horizon(float(t0), 0)):
            s = env.step(policy(obs))
            if s.failed:
                break
            obs = s.obs
            ref_qpos, ref_qvel = env.reference(env.time)
            sim = env.physics.kinematics(env.data.qpos.copy(), env.data.qvel.copy())
            ref = env.physics.kinematics(ref_qpos, ref_qvel)
            turn = quat.wrap_angle(quat.heading(env.data.qpos[3:7]) - quat.heading(ref_qpos[3:7]))
            row = (abs(np.degrees(turn)), float(R.world_end_effector_error(layout, sim, ref, np)),
                   float(R.com_position_error(layout, sim, ref, np)))
            by_time.setdefault(int((k + 1) * env.control_dt) // 2 * 2, []).append(row)
            by_phase.setdefault(int(10 * (env.time % duration) / duration), []).append(row)

    def table(rows: dict[int, list]) -> dict[str, list[float]]:
        return {str(key): [round(float(x), 3) for x in np.mean(v, axis=0)] for key, v in sorted(rows.items())}

    print(json.dumps({"policy": sys.argv[1], "episodes": episodes, "columns": ["heading_deg", "E_ee", "E_com"],
                      "by_seconds_since_start": table(by_time), "by_tenth_of_cycle": table(by_phase)}, indent=1))


if __name__ == "__main__":
    main()
