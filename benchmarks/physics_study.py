"""Physics rate x solver iterations: stability, tracking quality and speed.

The quality side: plain PD tracking of the reference (residual action 0, no learning) from RSI
starts; a rate or solver setting under which the reference cannot even be held for a few seconds
makes learning harder. And a trained policy's NR (`mjxmimic eval`'s protocol) when its physics
settings are changed: a cheaper solver that leaves it unchanged is as good for that skill.
The speed side: env-step and physics-only samples/s.

    python benchmarks/physics_study.py --part tracking --clips-dir ../shared/deepmimic/motions
    python benchmarks/physics_study.py --part throughput --num-envs 16384
    python benchmarks/physics_study.py --part policy --runs runs/walk8k --rates 240 --solvers 4x8 4x4
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from mjxmimic.ops import bench
from mjxmimic.core.config import make_config
from mjxmimic.envs.mjx_env import ImitationEnv, load_env_inputs

RATES = (120, 240, 480)
SOLVERS = ("1x4", "4x8")  # Newton iterations x line-search iterations


def parse_solver(text: str) -> tuple[int, int]:
    try:
        iters, ls = (int(part) for part in text.split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected ITERSxLS, e.g. 4x8") from None
    return iters, ls


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=("tracking", "throughput", "policy"), required=True)
    parser.add_argument("--clips", nargs="+", default=["walk", "backflip"])
    parser.add_argument("--clips-dir", default=None, help="folder of DeepMimic clips (else MJXMIMIC_CLIPS)")
    parser.add_argument("--num-envs", type=int, nargs="+", default=[256])
    parser.add_argument("--rates", type=int, nargs="+", default=list(RATES))
    parser.add_argument("--solvers", type=parse_solver, nargs="+", default=[parse_solver(s) for s in SOLVERS],
                        help="Newton x line-search iterations, e.g. 4x8 4x4")
    parser.add_argument("--runs", type=Path, nargs="+", default=[], help="run folders (--part policy)")
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    if args.clips_dir:
        import os

        os.environ["MJXMIMIC_CLIPS"] = args.clips_dir

    if args.part == "policy":
        rows = policy_rows(args)
        print_table(rows, args.part)
        return 0
    rows = []
    for clip in args.clips:
        base = make_config("gpu", {"clip.name": clip, "env.action_mode": "residual"})
        character, clips, _ = load_env_inputs(base)
        for hz in args.rates:
            for iters, ls in args.solvers:
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


def policy_rows(args: argparse.Namespace) -> list[dict]:
    """Each run's latest checkpoint evaluated under every rate x solver setting."""
    from mjxmimic.runs import folder
    from mjxmimic.runs.evaluate_run import evaluate_run

    rows = []
    for run_dir in args.runs:
        config = folder.load_config(run_dir)
        character, clips, _ = load_env_inputs(config)
        for hz in args.rates:
            for iters, ls in args.solvers:
                env = ImitationEnv(bench.with_settings(config, hz, iters, ls), character, clips)
                result = evaluate_run(run_dir, env=env, write=False)
                row = {"run": str(run_dir), "clip": config.clip.name, "physics_hz": hz, "solver_iterations": iters,
                       "ls_iterations": ls, "trained_with": f"{config.env.physics_hz} Hz "
                       f"{config.env.solver_iterations}x{config.env.ls_iterations}", **result}
                rows.append(row)
                print(json.dumps(row), flush=True)
                write(args, rows)
    return rows


def write(args: argparse.Namespace, rows: list[dict]) -> None:
    """Rewrite the results after every row, so a run cut short still leaves what it measured."""
    if args.out:
        result = {"info": bench.environment_info(), "command": " ".join(sys.argv), "rows": rows}
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(result, indent=1))


def print_table(rows: list[dict], part: str) -> None:
    if part == "policy":
        print(f"{'clip':10} {'hz':>4} {'solver':>6} {'NR':>6} {'fall':>5} {'pose rad':>8} {'ee m':>6}  trained with")
        for r in rows:
            print(f"{r['clip']:10} {r['physics_hz']:>4} {bench.solver_label(r):>6} {r['nr']:>6.3f} {r['fall_rate']:>5.2f} "
                  f"{r['pose_error_rad']:>8.3f} {r['end_effector_error_m']:>6.3f}  {r['trained_with']}")
    elif part == "tracking":
        print(f"{'clip':10} {'hz':>4} {'iters':>5} {'survival s':>10} {'all 4 s':>8} {'reward':>7} {'exploded':>8}")
        for r in rows:
            print(f"{r['clip']:10} {r['physics_hz']:>4} {r['solver_iterations']:>5} {r['survival_s']:>10.2f} "
                  f"{r['survived_fraction']:>8.2f} {r['reward_while_alive']:>7.3f} {r['exploded_fraction']:>8.3f}")
    else:
        print(f"{'envs':>6} {'hz':>4} {'solver':>6} {'env samples/s':>14} {'physics samples/s':>18} {'ratio':>6} "
              f"{'compile s':>9}")
        for r in rows:
            e, p = r["env_step"], r["physics_only"]
            print(f"{r['num_envs']:>6} {r['physics_hz']:>4} {bench.solver_label(r):>6} {e['samples_per_s']:>14,.0f} "
                  f"{p['samples_per_s']:>18,.0f} {e['samples_per_s'] / p['samples_per_s']:>6.2f} "
                  f"{e['compile_s']:>9.1f}")


if __name__ == "__main__":
    sys.exit(main())
