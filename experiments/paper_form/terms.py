"""Each term of the imitation reward, as a policy meets it on MuJoCo C: the paper's four terms as
the paper writes them (`reward.kind=paper`), the mixed form that `nr_paper` computed before the
tenth session of 2026-11-26 (the same terms and scales with the released code's per-joint
weights and heading-frame end effectors), and the released code's five. Mean error E and mean
exp(-scale E) per clip over the steps the character is up.

    python experiments/paper_form/terms.py POLICY.npz [EPISODES] [SECONDS] > terms.json
"""

import json
import sys
from typing import Callable, Iterator

import numpy as np

from mjxmimic.core.config import apply_overrides, playback_config
from mjxmimic.core.kinematics import Kin
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.runs.folder import load_policy_file
from mjxmimic.task import reward as R

MIXED = (R.Term("pose", R.pose_error, 0.65, 2.0), R.Term("velocity", R.velocity_error, 0.1, 0.1),
         R.Term("end_effector", R.end_effector_error, 0.15, 40.0), R.Term("com", R.com_position_error, 0.1, 10.0))
FORMS = {"paper": R.terms("paper"), "mixed": MIXED, "released": R.terms("released")}


def policy_env(path: str, overrides: dict | None = None) -> tuple[CpuEnv, Callable[[np.ndarray], np.ndarray]]:
    """A policy file's env on MuJoCo C as `mjxmimic play` builds it (its config with `overrides`),
    and its policy."""
    pf = load_policy_file(path)
    config = apply_overrides(playback_config(pf.config()), overrides or {})
    return CpuEnv(config, pf.character(), pf.clips(), pf.weights()), pf.policy()


def steps_up(env: CpuEnv, policy: Callable, episodes: int, clip: int = 0,
             seconds: float = 20.0) -> Iterator[tuple[int, Kin, Kin]]:
    """Each control step of the evaluation's first `episodes` starts while the character is up:
    (steps since the start, its kinematics, the graded reference's)."""
    for t0 in env.start_times(episodes, seed=0, clip=clip):
        obs = env.reset_at(float(t0), clip=clip)
        for k in range(min(env.eval_horizon(float(t0), clip), round(seconds / env.control_dt))):
            s = env.step(policy(obs))
            if s.failed:
                break
            obs = s.obs
            yield (k, env.physics.kinematics(env.data.qpos.copy(), env.data.qvel.copy()),
                   env.physics.kinematics(*env.reference(env.time)))


def main() -> None:
    episodes = int(sys.argv[2]) if len(sys.argv) > 2 else 4
    seconds = float(sys.argv[3]) if len(sys.argv) > 3 else 20.0
    env, policy = policy_env(sys.argv[1])
    out = {"policy": sys.argv[1], "episodes": episodes, "seconds": seconds, "clips": {}}
    for c, clip in enumerate(env.clips):
        sums = {f: {t.name: np.zeros(2) for t in terms} for f, terms in FORMS.items()}
        totals, steps = {f: 0.0 for f in FORMS}, 0
        for _, sim, ref in steps_up(env, policy, episodes, c, seconds):
            steps += 1
            for f, terms in FORMS.items():
                for t in terms:
                    e = float(t.error(env.spec.layout, sim, ref, np))
                    sums[f][t.name] += (e, np.exp(-t.scale * e))
                totals[f] += float(R.reward(terms, env.spec.layout, sim, ref, np)[0])
        out["clips"][clip.name] = {
            "steps_up": steps,
            **{f: {"reward": round(totals[f] / steps, 4),
                   **{name: {"error": round(v[0] / steps, 4), "term": round(v[1] / steps, 4)}
                      for name, v in sums[f].items()}} for f in FORMS}}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
