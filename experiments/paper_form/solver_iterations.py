"""An exported policy's NR on MuJoCo C with other solver iterations than it trained with (Newton,
and line search alike unless LS_ITERATIONS is given), from the start times of its `mjxmimic play
--json` output (the MJX evaluation's), to tell whether a sim-to-sim gap comes from where the
solvers stop.

    python experiments/paper_form/solver_iterations.py POLICY.npz PLAY.json ITERATIONS [LS_ITERATIONS]

With one count for both, `mjxmimic play POLICY.npz --episodes N --json --solver-iterations
ITERATIONS` measures the same (since 2026-11-29); this script remains for split counts.
"""

import json
import sys

from terms import policy_env

from mjxmimic.portable.playback import evaluate
from mjxmimic.runs.folder import load_policy_file


def main() -> None:
    path, play_json, iterations = sys.argv[1], sys.argv[2], int(sys.argv[3])
    ls_iterations = int(sys.argv[4]) if len(sys.argv) > 4 else iterations
    env, policy = policy_env(path, {"env.solver_iterations": iterations, "env.ls_iterations": ls_iterations})
    trained = load_policy_file(path).config().env
    play = json.loads(open(play_json).read())
    result = evaluate(env, policy, [float(t) for t in play["start_times"]])
    print(json.dumps({"policy": path, "iterations": iterations, "ls_iterations": ls_iterations,
                      "episodes": len(play["start_times"]),
                      "nr_paper": result["nr_paper"], "fall_rate": result["fall_rate"], "mjx_nr": play["mjx_nr"],
                      "ratio": result["nr_paper"] / play["mjx_nr"],
                      "trained_iterations": [trained.solver_iterations, trained.ls_iterations],
                      "nr_paper_at_trained": play["nr_paper"]}, indent=1))


if __name__ == "__main__":
    main()
