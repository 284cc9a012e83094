"""How much of a policy's world-position error in the paper form as written is height: for the
end effectors and the centre of mass, the mean squared error split into its vertical and
horizontal parts, their terms with and without the vertical part, and what the NR would gain per
step if heights were not graded; and for each body, the lowest point of its geoms above the
ground, the character's against the reference's (mean and 5th percentile), with how often each
is within 1 cm of the ground. Over the steps the character is up on MuJoCo C, as `terms.py`.

    python experiments/paper_form/heights.py POLICY.npz [EPISODES] > heights.json
"""

import json
import sys

import mujoco
import numpy as np

from mjxmimic.motion.clip import lowest_points
from mjxmimic.task import reward as R
from terms import policy_env, steps_up

GROUND_CM = 1.0  # a geom's lowest point this close to the ground counts as on it


def _term(errors: list[float], name: str) -> float:
    scale = next(t.scale for t in R.terms("paper") if t.name == name)
    return float(np.mean(np.exp(-scale * np.array(errors))))


def main() -> None:
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    env, policy = policy_env(sys.argv[1])
    ee = np.asarray(env.spec.layout.end_effectors)
    errors = {k: [] for k in ("ee", "ee_horizontal", "com", "com_horizontal")}
    sim_q, ref_q = [], []
    for _, sim, ref in steps_up(env, policy, episodes):
        d_ee = np.asarray(sim.xipos)[ee] - np.asarray(ref.xipos)[ee]
        d_com = np.asarray(sim.com) - np.asarray(ref.com)
        errors["ee"].append(float(np.sum(d_ee**2)))
        errors["ee_horizontal"].append(float(np.sum(d_ee[:, :2] ** 2)))
        errors["com"].append(float(np.sum(d_com**2)))
        errors["com_horizontal"].append(float(np.sum(d_com[:2] ** 2)))
        sim_q.append(np.asarray(sim.qpos))
        ref_q.append(np.asarray(ref.qpos))
    terms = {"end_effector": _term(errors["ee"], "end_effector"),
             "end_effector_horizontal": _term(errors["ee_horizontal"], "end_effector"),
             "com": _term(errors["com"], "com"), "com_horizontal": _term(errors["com_horizontal"], "com")}
    weight = {t.name: t.weight for t in R.terms("paper")}
    gain = (weight["end_effector"] * (terms["end_effector_horizontal"] - terms["end_effector"])
            + weight["com"] * (terms["com_horizontal"] - terms["com"]))
    model, character = env.character.model, env.character
    bodies = {}
    for b in range(1, model.nbody):
        low = {who: 100 * lowest_points(character, np.array(q)[::5], (b,)) for who, q in (("sim", sim_q), ("ref", ref_q))}
        bodies[mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b)] = {
            f"{who}_cm": {"mean": round(float(v.mean()), 2), "p5": round(float(np.percentile(v, 5)), 2),
                          "on_ground": round(float(np.mean(v < GROUND_CM)), 2)} for who, v in low.items()}
    print(json.dumps({
        "policy": sys.argv[1], "episodes": episodes, "steps_up": len(sim_q),
        "e_ee": round(float(np.mean(errors["ee"])), 5), "e_ee_vertical": round(float(np.mean(errors["ee"]) - np.mean(errors["ee_horizontal"])), 5),
        "e_com": round(float(np.mean(errors["com"])), 5), "e_com_vertical": round(float(np.mean(errors["com"]) - np.mean(errors["com_horizontal"])), 5),
        "terms": {k: round(v, 3) for k, v in terms.items()}, "nr_gain_without_heights": round(gain, 4),
        "lowest_point_by_body": bodies}, indent=1))


if __name__ == "__main__":
    main()
