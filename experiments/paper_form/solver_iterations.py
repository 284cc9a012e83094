"""An exported policy's NR on MuJoCo C with other solver iterations than it trained with (Newton
and line search alike), from the start times of its `mjxmimic play --json` output (the MJX
evaluation's), to tell whether a sim-to-sim gap comes from where the solvers stop.

    python experiments/paper_form/solver_iterations.py POLICY.npz PLAY.json ITERATIONS
"""

import json
import sys

from mjxmimic.core.config import apply_overrides, evaluation_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.portable.playback import evaluate
from mjxmimic.runs.folder import load_policy_file


def main() -> None:
    path, play_json, iterations = sys.argv[1], sys.argv[2], int(sys.argv[3])
    pf = load_policy_file(path)
    config = apply_overrides(evaluation_config(pf.config()),
                             {"env.solver_iterations": iterations, "env.ls_iterations": iterations})
    env = CpuEnv(config, pf.character(), pf.clips()[0])
    play = json.loads(open(play_json).read())
    result = evaluate(env, pf.policy(), [float(t) for t in play["start_times"]])
    print(json.dumps({"policy": path, "iterations": iterations, "episodes": len(play["start_times"]),
                      "nr_paper": result["nr_paper"], "fall_rate": result["fall_rate"], "mjx_nr": play["mjx_nr"],
                      "ratio": result["nr_paper"] / play["mjx_nr"],
                      "trained_iterations": [pf.config().env.solver_iterations, pf.config().env.ls_iterations],
                      "nr_paper_at_trained": play["nr_paper"]}, indent=1))


if __name__ == "__main__":
    main()
