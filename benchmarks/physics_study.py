"""Physics rate x solver iterations: stability, tracking quality and speed.

The quality side: plain PD tracking of the reference (residual action 0, no learning) from RSI
starts; a rate or solver setting under which the reference cannot even be held for a few seconds
makes learning harder. The speed side: env-step and physics-only samples/s.

    python benchmarks/physics_study.py --part tracking --clips-dir ../shared/deepmimic/motions
    python benchmarks/physics_study.py --part throughput --num-envs 16384
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from mjxmimic import bench
from mjxmimic.config import make_config
from mjxmimic.env import ImitationEnv, load_env_inputs

RATES = (120, 240, 480)
SOLVERS = ((1, 4), (4, 8))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("tracking", "throughput"), required=True)
    parser.add_argument("--clips", nargs="+", default=["walk", "backflip"])
    parser.add_argument("--clips-dir", default=None, help="folder of DeepMimic clips (else MJXMIMIC_CLIPS)")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[256])
    parser.add_argument("--rates", type=int, nargs="+", default=list(RATES))
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    if args.clips_dir:
        import os

        os.environ["MJXMIMIC_CLIPS"] = args.clips_dir

    rows = []
    for clip in args.clips:
        base = make_config("gpu", {"clip.name": clip, "env.action_mode": "residual"})
        character, clips = load_env_inputs(base)
        for hz in args.rates:
            for iters, ls in SOLVERS:
                env = ImitationEnv(bench.with_settings(base, hz, iters, ls), character, clips)
                for n in args.num_envs:
                    row = {"clip": clip, "physics_hz": hz, "solver_iterations": iters, "ls_iterations": ls,
                           "num_envs": n}
                    if args.part == "tracking":
                        row.update(bench.tracking(env, n, args.seconds))
                    else:
                        row["env_step"] = dataclasses.asdict(bench.env_step(env, n))
                        row["physics_only"] = dataclasses.asdict(bench.physics_only(env, n))
                    rows.append(row)
                    print(json.dumps(row), flush=True)
                    write(args, rows)
            if args.part == "throughput":
                break  # throughput does not depend on the clip
        if args.part == "throughput":
            break
    print_table(rows, args.part)
    return 0


def write(args: argparse.Namespace, rows: list[dict]) -> None:
    """Rewrite the results after every row, so a run cut short still leaves what it measured."""
    if args.out:
        result = {"info": bench.environment_info(), "command": " ".join(sys.argv), "rows": rows}
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1))


def print_table(rows: list[dict], part: str) -> None:
    if part == "tracking":
        print(f"{'clip':10} {'hz':>4} {'iters':>5} {'survival s':>10} {'all 4 s':>8} {'reward':>7} {'exploded':>8}")
        for r in rows:
            print(f"{r['clip']:10} {r['physics_hz']:>4} {r['solver_iterations']:>5} {r['survival_s']:>10.2f} "
                  f"{r['survived_fraction']:>8.2f} {r['reward_while_alive']:>7.3f} {r['exploded_fraction']:>8.3f}")
    else:
        print(f"{'envs':>6} {'hz':>4} {'iters':>5} {'env samples/s':>14} {'physics samples/s':>18} {'ratio':>6} "
              f"{'compile s':>9}")
        for r in rows:
            e, p = r["env_step"], r["physics_only"]
            print(f"{r['num_envs']:>6} {r['physics_hz']:>4} {r['solver_iterations']:>5} {e['samples_per_s']:>14,.0f} "
                  f"{p['samples_per_s']:>18,.0f} {e['samples_per_s'] / p['samples_per_s']:>6.2f} "
                  f"{e['compile_s']:>9.1f}")


if __name__ == "__main__":
    sys.exit(main())
