"""Sweeps: a spec file expands into training runs, each a normal run folder; run them one after
another (or one per GPU at the same time), keep their state, resume them, and report.

Spec (JSON; one object; unknown fields are errors):

    {
      "name": "walk_action_mode",            # default: the file's stem; [A-Za-z0-9._-]
      "description": "free text for the report",
      "preset": "gpu",                       # default "gpu"
      "clips": ["walk"],                     # or "clip": "walk"; NAME or PATH as `train --clip`
      "grid": {"ppo.learning_rate": [1e-4, 3e-4], "ppo.num_envs": [2048, 8192]},
      "runs": [{"env.action_mode": "residual"}, {}],   # a list of override sets
      "seeds": [0, 1],                       # default [0] (or one integer)
      "set": {"run.max_seconds": 240},      # overrides common to every run
      "out": "runs/sweeps/NAME",             # default runs/sweeps/NAME (relative to the cwd)
      "ray": {"scheduler": "asha", "grace_period": 2000000}   # --executor ray only (below)
    }

Runs = clips x grid (the Cartesian product of its value lists) x runs entries x seeds. A config
key may appear in only one of `set`, `grid` and the `runs` entries; `clip.name` and `run.seed` come
from `clips` and `seeds`. Values are JSON scalars (or lists for tuple keys such as
ppo.policy_hidden) or strings as `--set` takes them. Every run's config is built with
`config.make_config` before anything starts, so a bad key or value is one error line naming the
spec file and the key; clip names must resolve (`clip.resolve_clip`); a malformed clip file is
only found by its run (which then fails alone).

Run names are derived from the clip, the run's own grid/runs overrides and the seed, e.g.
`walk-action_mode=residual-s0` (the full key where two keys share a last part; a short hash
where names would collide or grow past 100 characters). A runs entry of many keys may name
itself instead: `{"label": "pushes", "env.events": "push", ...}` gives `run-pushes-s0`.

Folder OUT/ holds:
    NAME-OF-RUN/    a normal `mjxmimic train` run folder per run
    logs/RUN.log    each run's stdout and stderr (appended per attempt)
    sweep.json      the sweep's state: per run its status, attempts, exit code, seconds, log tail
    sweep.lock      held (flock) while a sweep runs here, so two cannot run in one folder
    report.md, report.csv, curves.png   the results (see `write_report`)

Each run is one subprocess `python -m mjxmimic.cli train ...`, so a crash or an out-of-memory
kill takes only that run down (recorded as failed with its exit code and the last lines of its
log); a training whose sweep (or Ray trial) dies outright checkpoints and stops
(`folder.STOP_WITH_PARENT`), so that the next call can resume it; with --max-seconds every
training stops at the sweep's deadline (`folder.SWEEP_DEADLINE`), also one that a Ray or Slurm
queue started late. With two or more GPUs visible (CUDA_VISIBLE_DEVICES, else `nvidia-smi -L`; override with
--gpus or MJXMIMIC_SWEEP_GPUS) runs go one per GPU at the same time, each subprocess seeing one
GPU; otherwise one after another. Running the same spec again skips finished runs (eval.json
with run.total_samples reached, or the target NR reached), resumes interrupted or time-stopped
ones from their checkpoint (`train --resume`, with the spec's run.* values), and starts afresh
the runs that never started or failed before their first checkpoint (their folder is removed
first). A run folder whose config.json disagrees with the spec (other than run.* keys) is an
error before anything starts.

With --executor ray each run is a Ray Tune trial (`ray_executor`). The optional "ray" block picks
a Tune scheduler that compares the runs' evaluations as they appear: "scheduler" (asha), "metric"
(eval/nr, default, or eval/fall_rate), "grace_period" (samples a run trains before it may be
stopped; required), "max_t" (default: the largest run.total_samples) and "reduction_factor"
(default 4). A run it stops has checkpointed; it is recorded "pruned", and later calls skip it
(remove its folder to train it again).

This package does not import JAX; the parent process only reads and writes files.

Modules: `spec` (the spec file and its expansion into runs), `runner` (plan, subprocesses, GPUs,
signals), `executors` (local, Slurm), `ray_executor` (Ray Tune), `state` (OUT/sweep.json),
`report` (tables and curves).
"""

from mjxmimic.ops.sweep.report import write_report, write_tables
from mjxmimic.ops.sweep.runner import GPU_ENV_VAR, Runner, detect_gpus, plan, train_args
from mjxmimic.ops.sweep.spec import RunSpec, Spec, load_spec, select_runs

__all__ = ["GPU_ENV_VAR", "RunSpec", "Runner", "Spec", "detect_gpus", "load_spec", "plan", "select_runs",
           "train_args", "write_report", "write_tables"]
