"""An exported policy's NR on MJX (MJX-Warp on a GPU) under other solver iterations than it
trained with, each setting evaluated twice (the second time already compiled, for its seconds), to
tell whether MJX-Warp honours `env.solver_iterations` and `env.ls_iterations` (solver_iterations.py
asks the same of MuJoCo C).

    python experiments/paper_form/mjx_iterations.py POLICY.npz NEWTONxLINESEARCH ...   # e.g. 1x1 4x4 16x16
"""

import json
import sys
import time

from mjxmimic.runs.evaluate import evaluate
from mjxmimic.runs.evaluate_run import load_file_policy


def main() -> None:
    path, rows = sys.argv[1], []
    for setting in sys.argv[2:]:
        newton, line_search = (int(n) for n in setting.split("x"))
        config, env, policy = load_file_policy(path, overrides={"env.solver_iterations": newton,
                                                                "env.ls_iterations": line_search})
        seconds = []
        for _ in range(2):
            start = time.time()
            result = evaluate(env, policy, config, config.run.seed + 1)
            seconds.append(round(time.time() - start, 1))
        rows.append({"solver_iterations": newton, "ls_iterations": line_search, "backend": env.backend,
                     "nr_paper": result["nr_paper"], "nr": result["nr"], "fall_rate": result["fall_rate"],
                     "episodes": config.run.eval_episodes, "seconds_first_and_compiled": seconds})
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    print(json.dumps({"policy": path, "settings": rows}, indent=1))


if __name__ == "__main__":
    main()
