"""`mjxmimic sweep`: a spec file of training runs, run (or resumed) and reported.

    mjxmimic sweep SPEC [--dry-run] [--out DIR] [--gpus auto|none|N|ID,ID] [--max-seconds S]
                        [--executor local|slurm [--partition P] [--time-limit MIN] [--gpus-per-job N]]
                        [--executor ray [--address ADDR] [--gpus-per-trial N] [--cpus-per-trial N]]
    mjxmimic sweep SPEC --report

SPEC is a JSON file (format: mjxmimic/sweep.py; examples in experiments/sweeps/). Each run is a
normal run folder OUT/RUN (OUT: the spec's "out", default runs/sweeps/NAME), trained by a
subprocess `mjxmimic train`, one after another, or one per GPU at the same time when two or more
are visible; with --executor slurm, by a Slurm job per run (mjxmimic.ops.sweep.executors); with --executor
ray, by a Ray Tune trial per run, whose scheduler (the spec's "ray" block) may prune weak runs
(mjxmimic.ops.sweep.ray_executor). A failed run is recorded (OUT/sweep.json, its log in OUT/logs/) and the others go on.
Running the same spec again skips finished runs, resumes interrupted or time-stopped ones and
retries failed ones. At the end (or with --report alone) OUT/report.md, OUT/report.csv and
OUT/curves.png (needs matplotlib) are written.

--dry-run: check the spec and print each run with what would happen (start, resume, skip) and
its `mjxmimic train` arguments; nothing is written.
--only PATTERN[,PATTERN]: run only the runs whose names match one of these shell patterns
(`--dry-run` lists the names); the report still covers every run of the spec.
--max-seconds S: a wall-clock budget for this call: each run gets run.max_seconds of at most what
is left (it stops with a checkpoint, and the next call resumes it), and no run starts with less
than a minute left.

Exit status: 0 when no run failed (some may have stopped at their time limit: run the sweep
again to continue them; pruned runs stay as they are), 1 when a run failed, 2 for a bad spec, 130 on Ctrl-C (the running
trainings checkpoint first).
"""

from __future__ import annotations

import argparse
import os
import shlex

from mjxmimic.commands import arg_types
from mjxmimic.core.errors import UserError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("spec", type=arg_types.path, help="sweep spec (JSON), e.g. experiments/sweeps/walk_action_mode.json")
    parser.add_argument("--dry-run", action="store_true", help="print the runs and what would happen; run nothing")
    parser.add_argument("--report", action="store_true", help="only (re)write the report from the run folders")
    parser.add_argument("--out", type=arg_types.path, help="sweep folder (default: the spec's \"out\", else runs/sweeps/NAME)")
    parser.add_argument("--gpus", default=None,
                        help="auto (default; or $MJXMIMIC_SWEEP_GPUS): one run per visible GPU at a time; "
                             "none: one after another; N: the first N GPUs; 0,2: those GPU ids")
    parser.add_argument("--max-seconds", type=arg_types.at_least(0, float), default=None, metavar="S",
                        help="wall-clock budget of this call (runs stop with a checkpoint; run again to go on)")
    parser.add_argument("--only", metavar="PATTERN[,PATTERN]", default=None,
                        help="run only the runs whose names match one of these shell patterns (e.g. 'walk-*')")
    parser.add_argument("--runs-per-gpu", type=arg_types.at_least(1), default=1, metavar="N",
                        help="local: N runs share each GPU at a time, each with its share of the GPU's memory")
    parser.add_argument("--wandb", metavar="PROJECT", default=None,
                        help="every run also logs to this Weights & Biases project, grouped by the sweep's name "
                             "(train --wandb; the wandb extra)")
    parser.add_argument("--executor", choices=("local", "slurm", "ray"), default="local",
                        help="where runs execute: subprocesses here (default), a Slurm job per run "
                             "through submitit (pip install 'mjxmimic[slurm]'), or a Ray Tune trial per run "
                             "(pip install 'mjxmimic[ray]')")
    parser.add_argument("--partition", default=None, help="slurm: the partition to submit to")
    parser.add_argument("--time-limit", type=arg_types.at_least(1), default=60, metavar="MIN",
                        help="slurm: minutes per job; a job that reaches it is requeued and resumes (default 60)")
    parser.add_argument("--gpus-per-job", type=arg_types.at_least(0), default=1, help="slurm: GPUs per job (default 1)")
    parser.add_argument("--max-jobs", type=arg_types.at_least(1), default=None, help="slurm: jobs in flight at once (default: all runs)")
    parser.add_argument("--cluster", choices=("auto", "local"), default="auto",
                        help="slurm: auto = the Slurm cluster this machine submits to; local = submitit's "
                             "local stand-in, the same jobs as processes on this machine (to try a sweep)")
    parser.add_argument("--address", default=None,
                        help="ray: the Ray cluster to run on (as `ray start` prints it; default: start a local one)")
    parser.add_argument("--gpus-per-trial", type=arg_types.at_least(0, float), default=None, metavar="N",
                        help="ray: GPUs per run (default 1 when the cluster has GPUs, else 0)")
    parser.add_argument("--cpus-per-trial", type=arg_types.at_least(0, float), default=1, metavar="N", help="ray: CPUs per run (default 1)")


def _echo(text: str) -> None:
    print(text, flush=True)


def run(args: argparse.Namespace) -> int:
    from mjxmimic.ops import sweep

    if args.report and args.dry_run:
        raise UserError("--report and --dry-run cannot be combined")
    if args.max_seconds is not None and args.max_seconds <= 0:
        raise UserError("--max-seconds must be positive")
    spec = sweep.load_spec(args.spec, out=args.out)
    chosen = sweep.select_runs(spec, args.only) if args.only else spec

    if args.report:
        for path in sweep.write_report(spec, echo=lambda s: _echo(f"mjxmimic sweep: {s}")):
            _echo(str(path))
        return 0

    gpus = sweep.detect_gpus(args.gpus)
    mode = (f"one run per GPU at a time on GPUs {','.join(gpus)}" if len(gpus) >= 2
            else f"one run after another{' on GPU ' + gpus[0] if gpus else ''}")

    if args.dry_run:
        from mjxmimic.ops.sweep.runner import PRUNED

        plans = sweep.plan(chosen)
        counts = {a: sum(p.action == a for p in plans) for a in ("start", "resume", "skip")}
        pruned = sum(p.why == PRUNED for p in plans)
        skipped = f"{counts['skip'] - pruned} finished" + (f", {pruned} pruned" if pruned else "")
        _echo(f"sweep {chosen.name}: {len(plans)} runs in {chosen.out} ({counts['start']} to start, "
              f"{counts['resume']} to resume, {skipped}); {mode}")
        for p in sorted(plans, key=lambda p: p.run.order):
            _echo(f"  {p.run.name}: {p.action} ({p.why})")
            if p.action != "skip":
                _echo(f"    mjxmimic train {shlex.join(sweep.train_args(chosen, p, args.max_seconds))}")
        return 0

    from mjxmimic.ops.sweep.executors import LocalExecutor

    executor = LocalExecutor(args.runs_per_gpu)
    if len(gpus) * args.runs_per_gpu >= 2 and args.runs_per_gpu > 1:
        mode = f"{args.runs_per_gpu} runs per GPU at a time on GPUs {','.join(gpus)}"
    if args.executor == "slurm":
        from mjxmimic.ops.sweep.executors import SlurmExecutor

        executor = SlurmExecutor(spec.out, partition=args.partition, time_limit_min=args.time_limit,
                                 gpus_per_job=args.gpus_per_job, max_jobs=args.max_jobs,
                                 cluster=None if args.cluster == "auto" else args.cluster)
        mode = f"a job per run on the {executor.where}"
    if args.executor == "ray":
        from mjxmimic.ops.sweep.executors import ray_executor

        executor = ray_executor(spec.out, spec.ray, address=args.address, gpus_per_trial=args.gpus_per_trial,
                                cpus_per_trial=args.cpus_per_trial)
        mode = f"a Tune trial per run on a {executor.where}"
        if spec.ray:
            mode += f", {spec.ray['scheduler']} on {spec.ray['metric']} from {spec.ray['grace_period']:,} samples"
    elif spec.ray:
        _echo("note: the spec's \"ray\" block applies to --executor ray only")
    _echo(f"sweep {spec.name}: {len(chosen.runs)} runs in {spec.out}; {mode}")
    train_command = None
    if args.wandb:
        from mjxmimic.ops.sweep.runner import default_train_command
        from mjxmimic.runs.wandb_log import check_available

        check_available()
        os.environ.setdefault("WANDB_RUN_GROUP", spec.name)  # W&B reads it in every run
        train_command = [*default_train_command(), "--wandb", args.wandb]
    runner = sweep.Runner(chosen, gpus=gpus, max_seconds=args.max_seconds, echo=_echo, executor=executor,
                          train_command=train_command)
    try:
        results = runner.run()
    except KeyboardInterrupt:
        # the running trainings have checkpointed; the report shows where every run stands
        sweep.write_report(spec, echo=lambda s: _echo(f"mjxmimic sweep: {s}"))
        raise
    paths = sweep.write_report(spec, echo=lambda s: _echo(f"mjxmimic sweep: {s}"))
    statuses = list(results.values())
    counts = {s: statuses.count(s) for s in ("finished", "pruned", "stopped", "interrupted", "failed", "pending")}
    summary = ", ".join(f"{n} {s}" for s, n in counts.items() if n)
    _echo(f"sweep {spec.name}: {summary}; report: {', '.join(str(p) for p in paths)}")
    if counts["stopped"] or counts["pending"] or counts["interrupted"]:
        again = shlex.join(["mjxmimic", "sweep", str(args.spec)] + (["--out", str(args.out)] if args.out else [])
                           + (["--only", args.only] if args.only else []))
        _echo(f"run `{again}` again to continue the unfinished runs")
    return 1 if counts["failed"] else 0
