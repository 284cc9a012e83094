"""`mjxmimic eval RUN`: normalised return (NR, EVALUATION.md) of a run's latest checkpoint.

Evaluates the run's latest checkpoint by the NR protocol (mjxmimic.runs.evaluate_run), which
writes RUN/eval.json, and prints a short table (or the JSON with --json).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_dir", type=Path, metavar="RUN", help="run folder")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument("--episodes", type=int, help="evaluation episodes (default: run.eval_episodes)")
    parser.add_argument("--seed", type=int, help="seed of the start times (default: run.seed + 1, as in training)")


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
    from mjxmimic.runs.evaluate_run import evaluate_run

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
