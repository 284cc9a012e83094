"""A policy's NR in the paper form as written, graded against the reference's velocities from
forward differences (the released code's way, the default) and from central differences
(`clip.velocity=central`), from the same episodes on MuJoCo C. A run trained and evaluated with
one of the two reports its NR under that one only; this gives both, so that a run trained with
central differences can be set beside Table 2 under the grading that every other run used.

    python experiments/paper_form/velocity_grade.py POLICY.npz PLAY.json > velocity_grade.json

PLAY.json is `mjxmimic play POLICY.npz --json` output: its start times are replayed, and the NR
under the policy's own setting must come out as that file's per-episode NR (checked, to 1e-6;
that NR is the training reward's, so the policy must have trained on the paper form, as the `gpu`
preset does).
"""

import json
import sys
from typing import Any

import numpy as np

from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.motion import library as L
from mjxmimic.task import reward as R
from terms import policy_env

MODES = ("forward", "central")


def main() -> None:
    env, policy = policy_env(sys.argv[1])
    played = json.loads(open(sys.argv[2]).read())
    terms = R.terms("paper")
    own = env.config.clip.velocity
    libs = {mode: L.build_motion_lib(env.clips, env.character, velocity=mode) for mode in MODES}
    nr = {mode: [] for mode in MODES}
    for t0 in played["start_times"]:
        sums = dict.fromkeys(MODES, 0.0)

        def grade(env: CpuEnv, _step: Any) -> None:  # after every step that the NR counts
            sim = env.physics.kinematics(env.data.qpos.copy(), env.data.qvel.copy())
            ref_q, _ = env.reference(env.time)  # the graded pose; only the velocities differ by mode
            for mode in MODES:
                ref_v = L.sample(libs[mode], env.motion.clip, np.float32(env.time), np)[1]
                sums[mode] += float(R.reward(terms, env.spec.layout, sim, env.physics.kinematics(ref_q, ref_v), np)[0])

        episode = env.episode(policy, float(t0), on_step=grade)
        for mode in MODES:
            nr[mode].append(sums[mode] / episode["horizon"])
    check = float(np.max(np.abs(np.array(nr[own]) - np.array(played["per_episode_nr"]))))
    if check > 1e-6:
        sys.exit(f"velocity_grade.py: the NR under the policy's own setting ({own}) differs from "
                 f"{sys.argv[2]}'s by up to {check:.2g} per episode")
    print(json.dumps({"policy": sys.argv[1], "play": sys.argv[2], "trained_with": own,
                      "episodes": len(played["start_times"]), "max_difference_to_play": check,
                      **{f"nr_paper_{mode}": round(float(np.mean(nr[mode])), 4) for mode in MODES}}, indent=1))


if __name__ == "__main__":
    main()
