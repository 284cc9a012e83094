"""The switches a selector does not hold directly, asked for through a third skill instead: for
A -> B, play A for 1 s plus 0, 4, 8, ... control steps (as `mjxmimic play --switch-trials`), then
VIA for `via_s` seconds, then B for 4 s plus VIA's cycle (B may wait for that cycle's end); a
trial holds when the character is still up at the end, so at least 4 s after B began. MuJoCo C,
no JAX.

    python experiments/multiclip/routed_switches.py POLICY.npz FROM TO VIA [VIA_S] [MOMENTS]
"""

import json
import sys

from mjxmimic.core.config import evaluation_config
from mjxmimic.envs.cpu_env import CpuEnv
from mjxmimic.portable.skills import play_sequence
from mjxmimic.runs.folder import load_policy_file


def main() -> None:
    path, a, b, via = sys.argv[1:5]
    via_s = float(sys.argv[5]) if len(sys.argv) > 5 else 1.0
    moments = int(sys.argv[6]) if len(sys.argv) > 6 else 10
    pf = load_policy_file(path)
    env = CpuEnv(evaluation_config(pf.config()), pf.character(), pf.clips(), pf.weights())
    names, policy = [c.name for c in env.clips], pf.policy()
    rows = []
    for k in range(moments):
        lead = 1.0 + 4 * k * env.control_dt
        last_s = 4.0 + float(env.clip_durations[names.index(via)])
        sequence = [(names.index(a), lead), (names.index(via), via_s), (names.index(b), last_s)]
        out = play_sequence(env, policy, sequence)
        last = out["segments"][-1]
        rows.append({"lead_s": round(lead, 4), "held": not out["fell"], "survived_s": round(out["survived_s"], 3),
                     "fell_in": last["skill"] if out["fell"] else None,
                     "after_switch_s": None if last["switched_after_s"] is None
                     else round(last["survived_s"] - last["switched_after_s"], 3)})
    print(json.dumps({"policy": path, "route": f"{a} -> {via} ({via_s} s) -> {b}",
                      "held": sum(r["held"] for r in rows), "trials": moments, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
