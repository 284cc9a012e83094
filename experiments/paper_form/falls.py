"""Where an exported policy falls on MuJoCo C: for each start that ends in a fall, the start time,
the seconds into the episode and the clip cycle's phase there; and the NR over the starts
(`nr_paper`, as `mjxmimic play` counts it).

    python experiments/paper_form/falls.py POLICY.npz PLAY.json [EPISODES]
    python experiments/paper_form/falls.py POLICY.npz START:STOP:STEP|T0,T1,...

PLAY.json is `mjxmimic play POLICY --json`'s output, whose start times are the MJX evaluation's
(its first EPISODES, 32 unless given); the other form names clip times of one's own, a grid
(STOP excluded) or a list, to look between the evaluation's random starts.
"""

import json
import sys

import numpy as np
from terms import policy_env

from mjxmimic.portable.playback import summarize


def start_times(spec: str, episodes: int) -> list[float]:
    if spec.endswith(".json"):
        return [float(t) for t in json.loads(open(spec).read())["start_times"][:episodes]]
    if ":" in spec:
        start, stop, step = (float(x) for x in spec.split(":"))
        return [round(float(t), 6) for t in np.arange(start, stop - 1e-9, step)]
    return [float(t) for t in spec.split(",")]


def main() -> None:
    env, policy = policy_env(sys.argv[1])
    starts = start_times(sys.argv[2], int(sys.argv[3]) if len(sys.argv) > 3 else 32)
    episodes, falls = [], []
    for t0 in starts:
        episode = env.episode(policy, float(np.float32(t0)))  # ends at the fall, where env.time then is
        episodes.append(episode)
        if episode["failed"]:
            falls.append({"start_s": round(t0, 3), "fell_after_s": round(episode["steps"] * env.control_dt, 2),
                          "phase": round(env.time % env.clip_duration / env.clip_duration, 3)})
    print(json.dumps({"policy": sys.argv[1], "episodes": len(starts), "starts": starts,
                      "nr_paper": round(summarize(episodes, env.control_dt)["nr_paper"], 4), "falls": falls},
                     indent=1))


if __name__ == "__main__":
    main()
