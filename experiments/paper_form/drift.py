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
from terms import policy_env, steps_up

from mjxmimic.core import quat
from mjxmimic.task import reward as R


def main() -> None:
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    env, policy = policy_env(sys.argv[1])
    duration, layout = env.clip_duration, env.spec.layout
    by_time: dict[int, list] = {}
    by_phase: dict[int, list] = {}
    for k, sim, ref in steps_up(env, policy, episodes):
        turn = quat.wrap_angle(quat.heading(sim.qpos[3:7]) - quat.heading(ref.qpos[3:7]))
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
