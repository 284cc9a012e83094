"""Where an exported policy falls on MuJoCo C: for each of the evaluation's first starts that
ends in a fall, the start time, the seconds into the episode and the clip cycle's phase there.

    python experiments/paper_form/falls.py POLICY.npz PLAY.json [EPISODES]

PLAY.json is `mjxmimic play POLICY --json`'s output, whose start times are the MJX evaluation's.
"""

import json
import sys

from terms import policy_env


def main() -> None:
    episodes = int(sys.argv[3]) if len(sys.argv) > 3 else 32
    env, policy = policy_env(sys.argv[1])
    starts = json.loads(open(sys.argv[2]).read())["start_times"][:episodes]
    falls = []
    for t0 in starts:
        episode = env.episode(policy, float(t0))  # ends at the fall, where env.time then is
        if episode["failed"]:
            falls.append({"start_s": round(t0, 3), "fell_after_s": round(episode["steps"] * env.control_dt, 2),
                          "phase": round(env.time % env.clip_duration / env.clip_duration, 3)})
    print(json.dumps({"policy": sys.argv[1], "episodes": len(starts), "falls": falls}, indent=1))


if __name__ == "__main__":
    main()
