"""Which joints make a policy's pose and velocity errors in the paper form as written (plain sums
over the joints, no weights): per joint (the root's orientation first), the mean squared angle
and angular-velocity error over the steps the character is up on MuJoCo C (as `terms.py` plays
them), and the same velocity error of the reference's own pose (the derivative of the
interpolated pose against the clip's velocities, which no policy can remove), the largest
velocity error first.

    python experiments/paper_form/joints.py POLICY.npz [EPISODES] > joints.json
"""

import json
import sys

import mujoco
import numpy as np

from mjxmimic.motion import library as L
from mjxmimic.task import reward as R
from reference_velocity import pose_rate
from terms import policy_env, steps_up


def main() -> None:
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    env, policy = policy_env(sys.argv[1])
    layout, model = env.spec.layout, env.model
    dofs = [int(v[0]) for v in layout.v_ang] + [int(v) for v in layout.v_scalar[3:]]
    names = ["root"] + [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, int(model.dof_jntid[d])) for d in dofs[1:]]
    pose, velocity, own = [], [], []
    for _, sim, ref in steps_up(env, policy, episodes):
        quat_angle, hinge_angle = R.joint_angles(layout, sim, ref, np)
        pose.append(np.concatenate([quat_angle, hinge_angle]) ** 2)
        velocity.append(np.concatenate(R.joint_velocity_errors(layout, sim, ref, np)))
        # the reference pose's own rate of change against the velocities the reward grades with, as
        # reference_velocity.py takes it
        lib, clip, t = env.spec.lib, env.motion.clip, env.time
        v = L.sample(lib, clip, np.float32(t), np)[1]
        own.append(np.concatenate(R.joint_velocity_errors(layout, ref._replace(qvel=pose_rate(lib, layout, clip, t)),
                                                          ref._replace(qvel=v), np)))
    pose, velocity, own = (np.mean(a, axis=0) for a in (pose, velocity, own))
    order = np.argsort(-velocity)
    print(json.dumps({
        "policy": sys.argv[1], "clip": env.clip.name, "episodes": episodes,
        "e_pose": round(float(pose.sum()), 4), "e_vel": round(float(velocity.sum()), 2),
        "e_vel_reference_own": round(float(own.sum()), 2),
        "joints": [{"joint": names[i], "pose_rad2": round(float(pose[i]), 4), "velocity_rad2_s2": round(float(velocity[i]), 2),
                    "reference_own_rad2_s2": round(float(own[i]), 2)} for i in order]}, indent=1))


if __name__ == "__main__":
    main()
