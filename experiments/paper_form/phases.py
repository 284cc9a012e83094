"""Where in its clip's cycle a policy loses NR in the paper form as written: the steps the character
is up on MuJoCo C (as `terms.py` plays them), binned by the phase of the clip they grade, with
each bin's mean per-step reward, each term's mean, the bin's share of the whole shortfall
(1 - reward, summed), and the reference root's mean height with the character's below or above
it (how high a jump goes). So a miss spread over the cycle reads apart from one that a flight, a
landing or a turn makes.

    python experiments/paper_form/phases.py POLICY.npz [EPISODES] [BINS] > phases.json
"""

import json
import sys

import numpy as np

from mjxmimic.motion import library as L
from mjxmimic.task import reward as R
from terms import policy_env, steps_up


def main() -> None:
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    bins = int(sys.argv[3]) if len(sys.argv) > 3 else 10
    env, policy = policy_env(sys.argv[1])
    terms = R.terms("paper")
    rewards = [[] for _ in range(bins)]
    values = [{t.name: [] for t in terms} for _ in range(bins)]
    heights = [[] for _ in range(bins)]  # (reference root height, the character's minus it)
    for _, sim, ref in steps_up(env, policy, episodes):
        b = min(int(L.phase(env.spec.lib, env.motion.clip, env.time) * bins), bins - 1)
        heights[b].append((float(ref.qpos[2]), float(sim.qpos[2] - ref.qpos[2])))
        total, metrics = R.reward(terms, env.spec.layout, sim, ref, np)
        rewards[b].append(float(total))
        for t in terms:
            values[b][t.name].append(float(metrics[f"reward/{t.name}"]))
    shortfall = sum(len(r) - sum(r) for r in rewards)
    rows = [{"phase": f"{b / bins:.2f}-{(b + 1) / bins:.2f}", "steps": len(rewards[b]),
             "reward": round(float(np.mean(rewards[b])), 4),
             "share_of_shortfall": round((len(rewards[b]) - sum(rewards[b])) / shortfall, 3),
             **{name: round(float(np.mean(v)), 4) for name, v in values[b].items()},
             "reference_root_height_m": round(float(np.mean([h[0] for h in heights[b]])), 3),
             "root_height_offset_m": round(float(np.mean([h[1] for h in heights[b]])), 3)}
            for b in range(bins) if rewards[b]]
    print(json.dumps({"policy": sys.argv[1], "clip": env.clip.name, "episodes": episodes,
                      "cycle_s": round(env.clip_duration, 4), "steps_up": sum(len(r) for r in rewards),
                      "reward": round(sum(sum(r) for r in rewards) / sum(len(r) for r in rewards), 4),
                      "bins": rows}, indent=1))


if __name__ == "__main__":
    main()
