"""The velocity error that a character on the reference pose would still pay in the paper form as
written. The reference's joint velocities are the clip's forward differences, one per frame,
blended between frames (`mjxmimic.motion.library.sample`); between two frames the reference pose
is a slerp, whose derivative is that segment's forward difference alone. E_vel (plain sum over
the joints) of the reference's velocity against its pose's derivative, mean over one cycle of
each clip of the policy file, beside the same with central differences blended instead
(`clip.velocity=central`).

    python experiments/paper_form/reference_velocity.py POLICY.npz [SAMPLES] > reference_velocity.json
    python experiments/paper_form/reference_velocity.py --clips walk,run,... [SAMPLES]   # the humanoid's clips

With a velocity term of v on average and every other term perfect, an episode that follows the
reference pose exactly scores 0.9 + 0.1 v in the paper form as written: the `bound` of each clip.
"""

import json
import sys

import numpy as np

from mjxmimic.core.character import load_character, resolve_xml
from mjxmimic.core.config import evaluation_config, make_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.motion import library as L
from mjxmimic.motion.clip import load_clip_source
from mjxmimic.runs.folder import load_policy_file
from mjxmimic.task import reward as R

H = 1.0 / 480  # half the step of the pose's numerical derivative


def _env(args: list[str]) -> tuple[CpuEnv, dict, list[str]]:
    """The env of a policy file's clips, or of the humanoid with the clips that --clips names; what
    it was made from; the arguments after those."""
    if args[0] == "--clips":
        character = load_character(resolve_xml("humanoid"))
        clips = [load_clip_source(name, character) for name in args[1].split(",")]
        return CpuEnv(evaluation_config(make_config("gpu")), character, clips), {"clips_given": args[1]}, args[2:]
    pf = load_policy_file(args[0])
    env = CpuEnv(evaluation_config(pf.config()), pf.character(), pf.clips(), pf.weights())
    return env, {"policy": args[0]}, args[1:]


def pose_rate(lib: L.MotionLib, layout, clip: int, t: float) -> np.ndarray:
    """The reference pose's rate of change at time t of clip number `clip` (a qvel), by central
    differences over 2 H."""
    before, after = (L.sample(lib, clip, np.float32(t + d), np)[0] for d in (-H, H))
    return L._segment_velocity(layout, before[None], after[None], np.array([2 * H]))[0]


def main() -> None:
    env, source, rest = _env(sys.argv[1:])
    samples = int(rest[0]) if rest else 600
    lib, layout, kin = env.spec.lib, env.spec.layout, env.physics.kinematics
    velocity = next(t for t in R.terms("paper") if t.name == "velocity")
    out = {**source, "samples_per_clip": samples, "clips": {}}
    central = L.build_motion_lib(env.clips, env.character, velocity="central")  # clip.velocity=central
    for c, clip in enumerate(env.clips):
        errors = {"forward": [], "central": []}
        for t in np.linspace(2 * H, float(lib.duration[c]) - 2 * H, samples):
            q, v = L.sample(lib, c, np.float32(t), np)
            rate = kin(q, pose_rate(lib, layout, c, float(t)))
            v_central = L.sample(central, c, np.float32(t), np)[1]
            for name, vel in (("forward", v), ("central", v_central)):
                errors[name].append(float(velocity.error(layout, kin(q, vel), rate, np)))
        out["clips"][clip.name] = {
            name: {"e_vel": round(float(np.mean(e)), 2), "term": round(term, 3), "bound": round(0.9 + 0.1 * term, 3)}
            for name, e in errors.items() for term in [float(np.mean(np.exp(-velocity.scale * np.array(e))))]}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
