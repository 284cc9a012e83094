"""`mjxmimic eval RUN`: normalised return (NR, EVALUATION.md) of a run's latest checkpoint.

Loads RUN/config.json and the latest checkpoint, runs the NR protocol (mjxmimic.runs.evaluate),
writes RUN/eval.json and prints a short table (or the JSON with --json).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mjxmimic.core.errors import UserError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_dir", type=Path, metavar="RUN", help="run folder")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument("--episodes", type=int, help="evaluation episodes (default: run.eval_episodes)")
    parser.add_argument("--seed", type=int, help="seed of the start times (default: run.seed + 1, as in training)")


def evaluate_run(run_dir: Path, episodes: int | None = None, seed: int | None = None, env=None,
                 write: bool = True) -> dict:
    """NR of the run's latest checkpoint, in `env` if given (e.g. other physics settings), else
    in the run's own; `write`: also save it as RUN/eval.json."""
    from mjxmimic.runs import checkpoint
    from mjxmimic.core import config as config_lib

    if not run_dir.is_dir():
        raise UserError(f"{run_dir}: run folder not found")
    config = config_lib.load(run_dir / "config.json")
    if episodes is not None and episodes < 1:
        raise UserError(f"--episodes {episodes}: must be at least 1")
    step = checkpoint.latest_checkpoint(run_dir)
    if step is None:
        raise UserError(f"{run_dir}: no checkpoint found in {checkpoint.checkpoint_dir(run_dir)}")

    from mjxmimic.runs.evaluate import evaluate
    from mjxmimic.learn.ppo import export_params, make_trainer

    if env is None:
        from mjxmimic.envs.mjx_env import make_env

        env = make_env(config)
    trainer = make_trainer(env, config)
    ts, meta = checkpoint.restore(run_dir, trainer.init(config.run.seed), step)
    policy = trainer.make_policy(export_params(ts), deterministic=True)
    result = evaluate(env, policy, config, config.run.seed + 1 if seed is None else seed,
                      episodes=episodes, samples=meta["env_steps"], train_seconds=meta["elapsed_seconds"])
    if meta.get("time_to_skill_s") is not None:
        result["time_to_skill_s"] = meta["time_to_skill_s"]
    result["checkpoint"] = step
    result["clip"] = config.clip.name
    if write:
        (run_dir / "eval.json").write_text(json.dumps(result, indent=2) + "\n")
    return result


_ROWS = [
    ("nr", "normalised return (NR)", "{:.4f}"),
    ("fall_rate", "fall rate", "{:.3f}"),
    ("survival_s", "mean survival (s)", "{:.2f}"),
    ("pose_error_rad", "pose error (rad)", "{:.4f}"),
    ("end_effector_error_m", "end-effector error (m)", "{:.4f}"),
    ("episodes", "episodes", "{}"),
    ("samples", "training samples", "{:,}"),
    ("train_seconds", "training wall-clock (s)", "{:.0f}"),
    ("time_to_skill_s", "time to skill (s)", "{:.0f}"),
]


def run(args: argparse.Namespace) -> int:
    result = evaluate_run(args.run_dir, args.episodes, args.seed)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    width = max(len(label) for _, label, _ in _ROWS)
    print(f"{args.run_dir} ({result['clip']}, checkpoint {result['checkpoint']:,})", file=sys.stdout)
    for key, label, fmt in _ROWS:
        if key in result:
            print(f"  {label:<{width}}  {fmt.format(result[key])}")
    return 0
