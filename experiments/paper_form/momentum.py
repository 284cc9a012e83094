"""Where a policy's take-off differs from its clip's: for each control step of one episode from
start time T0 on MuJoCo C (as `mjxmimic play` plays it), the character's and the graded
reference's centre-of-mass height and vertical velocity and whole-body angular momentum about the
centre of mass (world axes). A start state whose angular momentum falls short of what the flight
after it needs, with too little ground contact left to build it, cannot turn the flip.

    python experiments/paper_form/momentum.py POLICY.npz T0 STEPS
"""

import json
import sys

import mujoco
import numpy as np
from terms import policy_env

from mjxmimic.motion.flight import whole_body_motion


def body_momentum(model: mujoco.MjModel, scratch: mujoco.MjData, qpos: np.ndarray, qvel: np.ndarray) -> dict:
    com, velocity, momentum = whole_body_motion(model, scratch, qpos, qvel)
    return {"com_z": round(float(com[2]), 3), "com_vz": round(float(velocity[2]), 2),
            "ang_momentum": [round(float(x), 1) for x in momentum]}


def main() -> None:
    env, policy = policy_env(sys.argv[1])
    t0, steps = float(sys.argv[2]), int(sys.argv[3])
    scratch = mujoco.MjData(env.model)
    obs = env.reset_at(float(np.float32(t0)))
    for _ in range(steps):
        row = {"t": round(env.time, 3),
               "policy": body_momentum(env.model, scratch, env.data.qpos, env.data.qvel),
               "reference": body_momentum(env.model, scratch, *env.reference(env.time))}
        print(json.dumps(row))
        step = env.step(policy(obs))
        if step.failed:
            print(json.dumps({"t": round(env.time, 3), "fell": True}))
            break
        obs = step.obs


if __name__ == "__main__":
    main()
