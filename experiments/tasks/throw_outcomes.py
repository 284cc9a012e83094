"""Which throws miss: a throw policy's episodes on MuJoCo C (`mjxmimic play POLICY --episodes N`'s
starts and goals), their success by start time, by the target's bearing from the character's
heading at the start, and by its distance; how far from the target's edge the misses landed.

    python experiments/tasks/throw_outcomes.py runs/NAME/policy.npz N
"""
import sys
from pathlib import Path

import numpy as np

from mjxmimic.core import quat
from mjxmimic.core.config import evaluation_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.runs.folder import load_policy_file
from mjxmimic.task import goals

pf = load_policy_file(Path(sys.argv[1]))
env = CpuEnv(evaluation_config(pf.config()), pf.character(), pf.clips()[0])
policy = pf.policy()
starts = pf.manifest["training"]["eval"]["start_times"][: int(sys.argv[2])]
t0s, bearings, distances, hits, missed_by = [], [], [], [], []
for i, t0 in enumerate(starts):
    seen = {}

    def on_step(e, s):
        landed, d = e.motion.goal[2], e.motion.goal[3]  # the goal state (goals.throw)
        seen["landed_d"] = float(d) if landed > 0 else np.inf
        if "bearing" not in seen:
            yaw = quat.heading(e.data.qpos[3:7], np)
            g = e.motion.goal
            seen["bearing"] = np.arctan2(g[1] - e.data.qpos[1], g[0] - e.data.qpos[0]) - yaw
            seen["distance"] = float(np.hypot(g[0] - e.data.qpos[0], g[1] - e.data.qpos[1]))

    episode = env.episode(policy, float(t0), on_step=on_step, event_seed=(i * goals.PLASTIC) % 1.0)
    t0s.append(t0)
    bearings.append(abs(np.degrees((seen["bearing"] + np.pi) % (2 * np.pi) - np.pi)))
    distances.append(seen["distance"])
    hits.append(episode["task"]["task/hit"] > 0)
    missed_by.append(seen["landed_d"] - pf.config().task.target_radius_m)  # inf: never landed
t0s, bearings, distances, hits, missed_by = map(np.array, (t0s, bearings, distances, hits, missed_by))
print(f"{hits.mean():.0%} of {len(hits)} episodes hit; target distance {distances.min():.2f} to {distances.max():.2f} m")
for name, x, edges in (("start time (s)", t0s, (0, 0.4, 0.8, 1.2)), ("bearing (deg)", bearings, (0, 45, 90, 135, 181)),
                       ("distance (m)", distances, np.quantile(distances, [0, 1 / 3, 2 / 3, 1]) + [0, 0, 0, 1e-6])):
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (x >= lo) & (x < hi)
        print(f"  {name} {lo:.2f} to {hi:.2f}: {hits[m].mean():.0%} of {m.sum()}")
misses = missed_by[~hits]
if len(misses):
    q = np.quantile(misses, [0.25, 0.5, 0.75])
    print(f"  misses landed {q[0]:.2f} / {q[1]:.2f} / {q[2]:.2f} m beyond the target's edge (quartiles of "
          f"{len(misses)}; inf: the ball never landed)")
