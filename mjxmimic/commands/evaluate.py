"""`mjxmimic eval RUN`: normalised return (NR, EVALUATION.md) of a run's best checkpoint, or of
an exported policy file (`mjxmimic eval POLICY.npz`, on MJX; mjxmimic.runs.evaluate_run).

Evaluates one of the run's checkpoints (the best evaluation's, as export, play and render use,
unless --checkpoint) by the NR protocol
(mjxmimic.runs.evaluate_run), which writes RUN/eval_<checkpoint>.json (the training's eval.json
stays), and prints a short table (or the JSON with --json). With --push it runs
DeepMimic's Table 6 push test instead (mjxmimic.runs.push_eval) and writes RUN/push.json.
Given a composite file (`mjxmimic compose`), it measures the composite's recovery rate over
--knockdowns N knock-downs on MJX (mjxmimic.runs.composite_eval, mjxmimic.task.recovery).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mjxmimic.commands import arg_types, character_option
from mjxmimic.runs import folder


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run_dir", type=arg_types.path, metavar="RUN", help="run folder, or an exported policy file (on MJX)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    character_option.add_option(parser)
    parser.add_argument("--episodes", type=int, help="evaluation episodes (default: run.eval_episodes)")
    parser.add_argument("--seed", type=arg_types.seed, help="seed of the start times (default: run.seed + 1, as in training)")
    parser.add_argument("--grid", type=arg_types.at_least(1e-3, float), default=None, metavar="SECONDS",
                        help="an episode from a start every SECONDS over the clip instead of a random draw: the NR "
                             "apart from the draw, and where in the clip the policy falls")
    parser.add_argument("--checkpoint", metavar="best|latest|N",
                        help="which checkpoint: the best evaluation's (default; the latest for a run "
                             "that kept none), the latest, or N samples")
    parser.add_argument("--push", action="store_true",
                        help="the push test instead of NR: the largest 0.2 s pelvis push, forward and "
                             "sideways, that 90%% of the trials survive (EVALUATION.md)")
    parser.add_argument("--trials", type=int, default=32, help="trials per force of the push test (default 32)")
    composite = parser.add_argument_group("composite files (mjxmimic compose): the recovery rate on MJX")
    composite.add_argument("--knockdowns", type=int, default=50, help="knock-downs to measure over (default 50)")
    composite.add_argument("--force", type=float, default=None,
                           help="the knock-down push in newtons (default mjxmimic.task.recovery.DEFAULT_FORCE_N)")
    composite.add_argument("--push-direction", choices=["forward", "sideways", "backward", "random"], default=None,
                           help="of the knock-down pushes, from the character's facing (default random)")
    composite.add_argument("--batch", type=int, default=64, help="trials vmapped at once (default 64)")
    composite.add_argument("--expert", metavar="NAME", default=None,
                           help="the expert the trials start in (default: the first looping one)")
    composite.add_argument("--temperature", type=float, default=None, help="override the file's gate temperature")

# DeepMimic's Table 6 (N, forward / sideways), policies trained without pushes.
PAPER_PUSH_N = {"walk": (240, 300), "run": (720, 300), "backflip": (440, 100), "spinkick": (690, 600),
                "cartwheel": (200, 470)}


def fall_windows_text(windows: list[list[float]]) -> str:
    """'0.590 .. 0.660 s (8), 1.200 s' from mjxmimic.task.nr.fall_windows ('-' for none)."""
    return ", ".join(f"{a:.3f} s" if n == 1 else f"{a:.3f} .. {b:.3f} s ({n:g})" for a, b, n in windows) or "-"


# (result key, label, format string or function)
_ROWS = [
    ("nr", "NR, the run's reward form (released: five terms)", "{:.4f}"),
    ("nr_paper", "NR, the paper's four-term reward", "{:.4f}"),
    ("nr_paper_discounted", "the same, discounted by 0.95", "{:.4f}"),
    ("success_rate", "task success rate", "{:.3f}"),
    ("task_return", "task return (mean r_task per step)", "{:.4f}"),
    ("speed_ratio", "heading: speed along the goal / commanded", "{:.3f}"),
    ("fall_rate", "fall rate", "{:.3f}"),
    ("fall_windows", "fell from (start times)", fall_windows_text),
    ("survival_s", "mean survival (s)", "{:.2f}"),
    ("pose_error_rad", "pose error (rad)", "{:.4f}"),
    ("end_effector_error_m", "end-effector error (m)", "{:.4f}"),
    ("episodes", "episodes", "{}"),
    ("samples", "training samples", "{:,}"),
    ("train_seconds", "training wall-clock (s)", "{:.0f}"),
    ("time_to_skill_s", "time to skill (s)", "{:.0f}"),
]


def _run_push(args: argparse.Namespace, policy_file: bool) -> int:
    from mjxmimic.core.errors import UserError
    from mjxmimic.runs.push_eval import push_test_run

    if args.trials < 1:
        raise UserError(f"--trials {args.trials}: must be at least 1")
    say = None if args.json else (lambda line: print(f"  {line}", flush=True))
    result = push_test_run(args.run_dir, args.seed, args.trials, progress=say, which=args.checkpoint or "best")
    if not policy_file:  # a run folder keeps its grades; a policy file's stay on the terminal, as its NR's do
        folder.write_json_atomic(args.run_dir / "push.json", result)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    what = result["simulator"] if policy_file else f"checkpoint {result['checkpoint']:,}, {result['simulator']}"
    print_push_table(f"{args.run_dir} ({result['clip']}, {what})", result)
    return 0


def print_push_table(title: str, result: dict) -> None:
    """The two forces, beside DeepMimic's Table 6 for a clip of that name."""
    paper = PAPER_PUSH_N.get(Path(result["clip"]).stem.removeprefix("humanoid3d_"))
    print(f"{title}: largest push survived by 90% of {result['push_trials']} trials, 0.2 s on the pelvis")
    for i, name in enumerate(("forward", "sideways")):
        beside = f"   (paper, Table 6: {paper[i]} N)" if paper else ""
        print(f"  {name:<9} {result[f'push_{name}_n']:7.0f} N{beside}")


def _run_composite(args: argparse.Namespace) -> int:
    from mjxmimic.commands.composite_report import check_knockdowns, print_recovery
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable import composite
    from mjxmimic.runs.composite_eval import recovery_rate

    force, direction = check_knockdowns(args)
    if args.batch < 1:
        raise UserError(f"--batch {args.batch}: must be at least 1")
    say = None if args.json else (lambda i, k, r: print(f"mjxmimic eval: {i + 1} trials, {k} knock-downs, "
                                                        f"{r} recovered", file=sys.stderr, flush=True))
    result = recovery_rate(composite.read(args.run_dir), args.knockdowns, force, direction,
                           0 if args.seed is None else args.seed, args.batch, expert=args.expert,
                           temperature=args.temperature, progress=say)
    print_recovery(result, args.json)
    return 0


def run(args: argparse.Namespace) -> int:
    character_option.check(args.character, args.run_dir)
    from mjxmimic.core.errors import UserError
    from mjxmimic.portable.composite import is_composite

    if args.grid is not None and (args.push or is_composite(args.run_dir)):
        raise UserError("--grid is for the NR of a run or policy file; leave it out of --push and composites")
    if is_composite(args.run_dir):
        return _run_composite(args)
    policy_file = folder.names_policy_file(args.run_dir)
    if policy_file and args.checkpoint is not None:
        raise UserError(f"--checkpoint is for run folders; {args.run_dir} holds one policy")
    if args.push:
        return _run_push(args, policy_file)
    from mjxmimic.runs.evaluate_run import evaluate_policy_file, evaluate_run

    say = None if args.json else (lambda text: print(f"mjxmimic eval: {text}", file=sys.stderr, flush=True))
    if policy_file:
        result = evaluate_policy_file(args.run_dir, args.episodes, args.seed, progress=say, grid=args.grid)
        title = f"{args.run_dir} ({result['clip']}, {result['simulator']})"
    else:
        result = evaluate_run(args.run_dir, args.episodes, args.seed, which=args.checkpoint or "best", progress=say,
                              grid=args.grid)
        title = f"{args.run_dir} ({result['clip']}, checkpoint {result['checkpoint']:,}, {result['simulator']})"
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    width = max(len(label) for _, label, _ in _ROWS)
    print(title, file=sys.stdout)
    for key, label, fmt in _ROWS:
        if key in result:
            value = fmt(result[key]) if callable(fmt) else fmt.format(result[key])
            print(f"  {label:<{width}}  {value}")
    return 0
