"""The velocity error that a character on the reference pose would still pay in the paper form as
written. The reference's joint velocities are the clip's forward differences, one per frame,
blended between frames (`mjxmimic.motion.library.sample`); between two frames the reference pose
is a slerp, whose derivative is that segment's forward difference alone. E_vel (plain sum over
the joints) of the reference's velocity against its pose's derivative, mean over one cycle of
each (cyclic) clip of the policy file, beside the same with central differences blended
instead.

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
    for c, clip in enumerate(env.clips):
        start, n = int(lib.clip_start[c]), int(lib.clip_frames[c])
        times, forward = lib.times[start:start + n], lib.qvel[start:start + n]
        central = forward.copy()
        central[1:-1] = 0.5 * (forward[:-2] + forward[1:-1])
        central[0] = 0.5 * (forward[-2] + forward[0])  # the cycle's last segment leads into its first frame
        errors = {"forward": [], "central": []}
        for t in np.linspace(2 * H, float(lib.duration[c]) - 2 * H, samples):
            q, v = L.sample(lib, c, np.float32(t), np)
            before, _ = L.sample(lib, c, np.float32(t - H), np)
            after, _ = L.sample(lib, c, np.float32(t + H), np)
            pose_rate = kin(q, L._segment_velocity(layout, before[None], after[None], np.array([2 * H]))[0])
            i = min(int(np.searchsorted(times, t, side="right")) - 1, n - 2)
            a = (t - times[i]) / (times[i + 1] - times[i])
            v_central = (1 - a) * central[i] + a * central[i + 1]
            for name, vel in (("forward", v), ("central", v_central)):
                errors[name].append(float(velocity.error(layout, kin(q, vel), pose_rate, np)))
        out["clips"][clip.name] = {
            name: {"e_vel": round(float(np.mean(e)), 2), "term": round(float(np.mean(np.exp(-velocity.scale * np.array(e)))), 3)}
            for name, e in errors.items()}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
