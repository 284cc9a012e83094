"""The velocity error that a character on the reference pose would still pay in the paper form as
written. The reference's joint velocities are the clip's forward differences, one per frame,
blended between frames (`mjxmimic.motion.library.sample`); between two frames the reference pose
is a slerp, whose derivative is that segment's forward difference alone. E_vel (plain sum over
the joints) of the reference's velocity against its pose's derivative, mean over one cycle of
each clip of the policy file, beside the same with central differences blended instead
(`clip.velocity=central`).

    python experiments/paper_form/reference_velocity.py POLICY.npz [SAMPLES] > reference_velocity.json
"""

import json
import sys

import numpy as np

from mjxmimic.core.config import evaluation_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.motion import library as L
from mjxmimic.runs.folder import load_policy_file
from mjxmimic.task import reward as R

H = 1.0 / 480  # half the step of the pose's numerical derivative


def main() -> None:
    pf = load_policy_file(sys.argv[1])
    samples = int(sys.argv[2]) if len(sys.argv) > 2 else 600
    env = CpuEnv(evaluation_config(pf.config()), pf.character(), pf.clips(), pf.weights())
    lib, layout, kin = env.spec.lib, env.spec.layout, env.physics.kinematics
    velocity = next(t for t in R.terms("paper") if t.name == "velocity")
    out = {"policy": sys.argv[1], "samples_per_clip": samples, "clips": {}}
    central = L.build_motion_lib(env.clips, pf.character(), velocity="central")  # clip.velocity=central
    for c, clip in enumerate(env.clips):
        errors = {"forward": [], "central": []}
        for t in np.linspace(2 * H, float(lib.duration[c]) - 2 * H, samples):
            q, v = L.sample(lib, c, np.float32(t), np)
            before, _ = L.sample(lib, c, np.float32(t - H), np)
            after, _ = L.sample(lib, c, np.float32(t + H), np)
            pose_rate = kin(q, L._segment_velocity(layout, before[None], after[None], np.array([2 * H]))[0])
            v_central = L.sample(central, c, np.float32(t), np)[1]
            for name, vel in (("forward", v), ("central", v_central)):
                errors[name].append(float(velocity.error(layout, kin(q, vel), pose_rate, np)))
        out["clips"][clip.name] = {
            name: {"e_vel": round(float(np.mean(e)), 2), "term": round(float(np.mean(np.exp(-velocity.scale * np.array(e)))), 3)}
            for name, e in errors.items()}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
