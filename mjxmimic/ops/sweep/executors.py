"""Where a sweep's runs execute: "start run R and wait for it", the one step that differs between
engines; the spec, run names, resume-on-rerun, failure isolation and the report stay the runner's.

local: a subprocess per run on this machine (one per GPU at a time when several are visible).
slurm: a Slurm job per run through submitit (the `slurm` extra). A job that reaches its time
    limit (or is preempted) is requeued and resumes from the run's checkpoint; the runner keeps
    as many jobs in flight as the spec has runs unless told fewer. submitit's local cluster runs
    the same jobs on this machine, which tests and a laptop can use.
ray: a Ray Tune trial per run on a Ray cluster (the `ray` extra; mjxmimic.ops.sweep.ray_executor),
    so that a Tune scheduler from the spec's "ray" block can stop weak runs early.

Each returns a handle with the part of subprocess.Popen's interface the runner uses: poll, wait,
send_signal, kill, returncode.
"""

from __future__ import annotations

import signal
import subprocess
import time
from pathlib import Path
from typing import Any

from mjxmimic.core.errors import UserError
from mjxmimic.runs import folder


# Of a GPU, split between the runs that share it. The rest is for what XLA allocates outside its
# pool (autotuning buffers, CUDA contexts): at 0.9, runs compiling side by side ran out of it.
MEMORY_FRACTION = 0.8


def gpu_share_env(env: dict[str, str], share: float) -> dict[str, str]:
    """A run that holds `share` of a GPU may take that share of the GPU's memory (JAX would
    otherwise take 75 % of it for the first run alone); a share set by the user stays."""
    if not 0 < share < 1 or "XLA_PYTHON_CLIENT_MEM_FRACTION" in env:
        return env
    return dict(env, XLA_PYTHON_CLIENT_MEM_FRACTION=f"{MEMORY_FRACTION * share:.2f}")


class LocalExecutor:
    """`runs_per_gpu` runs share each GPU at a time, each limited to its share of the GPU's memory."""

    name = "local"
    where = "this machine"

    def __init__(self, runs_per_gpu: int = 1):
        if runs_per_gpu < 1:
            raise UserError(f"--runs-per-gpu {runs_per_gpu}: must be at least 1")
        self.runs_per_gpu = runs_per_gpu

    def slots(self, gpus: list[str], runs: int) -> list[str | None]:
        """A worker per GPU and run it holds, when that makes two or more; else one."""
        ids = [g for g in gpus for _ in range(self.runs_per_gpu)]
        return ids if len(ids) >= 2 else [gpus[0] if gpus else None]

    def start(self, start_cmd: list[str], resume_cmd: list[str], env: dict[str, str], log: Any,
              run_dir: Path) -> subprocess.Popen:
        env = gpu_share_env(env, 1 / self.runs_per_gpu)
        # own session: a terminal's Ctrl-C reaches only the sweep, which forwards one SIGINT
        return subprocess.Popen(start_cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                env=env, start_new_session=True)


class TrainJob:
    """What a Slurm job runs: the run's `mjxmimic train` command, or its resume once the run has a
    checkpoint (so a requeued job continues), output appended to the run's log. submitit calls
    `checkpoint` when the job reaches its time limit or is preempted: the job is submitted again."""

    def __init__(self, start_cmd: list[str], resume_cmd: list[str], env: dict[str, str], log_path: Path,
                 run_dir: Path):
        self.start_cmd, self.resume_cmd = start_cmd, resume_cmd
        self.env, self.log_path, self.run_dir = env, Path(log_path), Path(run_dir)

    def __call__(self) -> int:
        cmd = self.resume_cmd if folder.has_checkpoint(self.run_dir) else self.start_cmd
        with self.log_path.open("ab") as log:
            proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                    env=self.env)
            forward = lambda signum, frame: proc.send_signal(signum)  # noqa: E731 (the run checkpoints)
            previous = {s: signal.signal(s, forward) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGUSR2)}
            try:
                return proc.wait()
            finally:
                for s, handler in previous.items():
                    signal.signal(s, handler)

    def checkpoint(self, *args: Any, **kwargs: Any) -> Any:
        import submitit

        return submitit.helpers.DelayedSubmission(self)


class PolledHandle:
    """A handle whose `poll` says when the run ended; `wait` polls it."""

    def __init__(self):
        self.returncode: int | None = None

    def poll(self) -> int | None:
        raise NotImplementedError

    def wait(self, timeout: float | None = None) -> int:
        end = None if timeout is None else time.time() + timeout
        while self.poll() is None:
            if end is not None and time.time() > end:
                raise subprocess.TimeoutExpired(repr(self), timeout)
            time.sleep(0.5)
        return self.returncode


class _JobHandle(PolledHandle):
    """A submitit job seen as a subprocess: its return code is the training's exit status."""

    def __init__(self, job: Any):
        super().__init__()
        self.job = job

    def poll(self) -> int | None:
        if self.returncode is None and self.job.done():
            try:
                self.returncode = int(self.job.result())
            except Exception:  # noqa: BLE001 (the job itself failed: node, scheduler, pickling)
                self.returncode = 1
        return self.returncode

    def send_signal(self, sig: int) -> None:
        self.job.cancel(check=False)  # Slurm sends SIGTERM first: the training checkpoints

    def kill(self) -> None:
        self.job.cancel(check=False)


class SlurmExecutor:
    name = "slurm"

    def __init__(self, out: Path, *, partition: str | None = None, time_limit_min: int = 60,
                 gpus_per_job: int = 1, max_jobs: int | None = None, cluster: str | None = None,
                 requeues: int = 10):
        try:
            import submitit
        except ImportError:
            raise UserError("--executor slurm needs submitit: pip install 'mjxmimic[slurm]'") from None
        if time_limit_min < 1:
            raise UserError(f"--time-limit {time_limit_min}: must be at least 1 minute")
        self.max_jobs = max_jobs
        self.executor = submitit.AutoExecutor(folder=Path(out) / "slurm", cluster=cluster)
        params: dict[str, Any] = {"timeout_min": time_limit_min, "gpus_per_node": gpus_per_job,
                                  "nodes": 1, "tasks_per_node": 1}
        if self.executor.cluster == "slurm":
            params["slurm_max_num_timeout"] = requeues
            if partition:
                params["slurm_partition"] = partition
        elif partition:
            raise UserError("--partition applies to Slurm, but no Slurm cluster was found (sbatch is missing)")
        self.executor.update_parameters(**params)
        self.where = f"{self.executor.cluster} cluster" + (f", partition {partition}" if partition else "")

    def slots(self, gpus: list[str], runs: int) -> list[str | None]:
        """As many jobs in flight as runs (or --max-jobs): the cluster schedules them."""
        return [None] * max(1, min(self.max_jobs or runs, runs))

    def start(self, start_cmd: list[str], resume_cmd: list[str], env: dict[str, str], log: Any,
              run_dir: Path) -> _JobHandle:
        log.flush()
        return _JobHandle(self.executor.submit(TrainJob(start_cmd, resume_cmd, env, Path(log.name), run_dir)))


def ray_executor(out: Path, scheduler: dict | None = None, **options: Any) -> Any:
    """The Ray executor (mjxmimic.ops.sweep.ray_executor.RayExecutor), imported only when chosen."""
    try:
        import ray.tune  # noqa: F401
    except ImportError:
        raise UserError('--executor ray needs Ray Tune: pip install -e ".[ray]"') from None
    from mjxmimic.ops.sweep.ray_executor import RayExecutor

    return RayExecutor(out, scheduler=scheduler, **options)
