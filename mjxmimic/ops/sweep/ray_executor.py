"""The Ray executor (`--executor ray`, the `ray` extra): each sweep run is a Ray Tune trial, so a
Tune scheduler (the spec's "ray" block, e.g. ASHA on eval/nr) can stop the weaker runs early.

Design. The runner still decides everything per run (plan, names, resume, failure isolation, the
report) and calls `start` once per run, all at once (Ray queues what does not fit). Those calls
feed one Tune experiment, run by a thread of the sweep process: a searcher hands Tune each started
run as a trial, Ray places the trial where its CPUs and GPUs are free, and a callback turns the
trial's end into the handle's return code. One experiment, not one per run, because a scheduler
compares the runs with each other.

A trial (TrainTrial) runs the run's `mjxmimic train` command (its resume once the run folder has a
checkpoint, as the runner and a requeued Slurm job decide) and reports each new evaluation in
RUN/metrics.jsonl (eval/nr, eval/fall_rate at `samples`), with an empty result at least every
HEARTBEAT_S so that Tune can stop it between evaluations. Tune ends a stopped trial with its
`cleanup`, which sends the training one SIGINT and waits: it checkpoints and exits, as on Ctrl-C.
It is a class trainable because Tune calls `cleanup` before it ends the actor; a function
trainable's thread would die with the actor and leave the training running.

Ends: the training's exit status when it ends by itself; `pruned` when the scheduler stopped it
(the runner records status "pruned", and later sweep calls leave the run as it is); 130 when the
sweep is interrupted (every trial is stopped); 1 when the trial itself failed (a worker died,
mjxmimic not importable there), with Ray's error in the run's log.

Workers run the train command as the sweep process would: the same Python and working directory,
the sweep folder on a filesystem they share (as Slurm jobs do); the environment is the worker's
own (Ray sets CUDA_VISIBLE_DEVICES to the trial's GPUs) plus what the runner sets.
"""

from __future__ import annotations

import logging
import os
import queue
import signal
import subprocess
import threading
import time
from pathlib import Path
from typing import Any

import ray
from ray import tune
from ray.tune.schedulers import ASHAScheduler
from ray.tune.search import Searcher
from ray.tune.stopper import Stopper

from mjxmimic.core.errors import UserError
from mjxmimic.ops.sweep.executors import PolledHandle, gpu_share_env
from mjxmimic.runs import folder
from mjxmimic.runs.metrics_log import read as read_metrics

RunConfig = getattr(tune, "RunConfig", None) or ray.train.RunConfig  # in tune from Ray 2.41
CheckpointConfig = getattr(tune, "CheckpointConfig", None) or ray.train.CheckpointConfig
HEARTBEAT_S = 5.0  # a result at least this often, so that a stop does not wait for an evaluation
POLL_S = 0.5
STOP_WAIT_S = 300  # for the training's checkpoint after its SIGINT
START_WAIT_S = 120  # for Ray to start or answer at --address (it retries a wrong address forever)


class TrainTrial(tune.Trainable):
    """One run: its `mjxmimic train` subprocess; each new evaluation is a result."""

    def setup(self, config: dict) -> None:
        job = config["job"]
        self.run_dir = Path(job["run_dir"])
        cmd = job["resume_cmd"] if folder.has_checkpoint(self.run_dir) else job["start_cmd"]
        self.log = open(job["log"], "ab")  # noqa: SIM115 (closed by cleanup)
        # own session: only cleanup's SIGINT reaches it; Ray's worker thread blocks SIGINT, and a
        # child inherits the mask, so it is unblocked while the training starts
        blocked = signal.pthread_sigmask(signal.SIG_UNBLOCK, [signal.SIGINT])
        try:
            self.proc = subprocess.Popen(cmd, stdout=self.log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                         cwd=job["cwd"], env={**os.environ, **job["env"]}, start_new_session=True)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
        self.reported = -1

    def step(self) -> dict:
        deadline = time.time() + HEARTBEAT_S
        while True:
            rc = self.proc.poll()
            evals = [m for m in read_metrics(self.run_dir)
                     if m.get("eval/nr") is not None and m.get("step", 0) > self.reported]
            if evals:
                self.reported = evals[0]["step"]
                return {"samples": evals[0]["step"], "eval/nr": evals[0]["eval/nr"],
                        "eval/fall_rate": evals[0].get("eval/fall_rate")}
            if rc is not None:
                return {"exit_code": rc, "done": True}
            if time.time() > deadline:
                return {}
            time.sleep(POLL_S)

    def cleanup(self) -> None:
        if self.proc.poll() is None:  # stopped by Tune: the training checkpoints and exits
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=STOP_WAIT_S)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()


class _Live:
    """Tune pickles its searcher, stopper and callbacks into the experiment folder (to restore an
    experiment); these hold the sweep's live state (a queue, an event), which is not saved: a
    sweep resumes from its run folders instead."""

    def __getstate__(self) -> dict:
        return {}

    def __setstate__(self, state: dict) -> None:
        pass


class _Feed(_Live, Searcher):
    """Hands Tune the runs the runner starts, a trial each, until the executor is closed."""

    def __init__(self):
        super().__init__()
        self.queue: queue.Queue = queue.Queue()
        self.closed = False

    def suggest(self, trial_id: str) -> dict | str | None:
        try:
            return self.queue.get_nowait()
        except queue.Empty:
            return Searcher.FINISHED if self.closed else None

    def on_trial_complete(self, trial_id: str, result: dict | None = None, error: bool = False) -> None:
        pass

    def save(self, checkpoint_path: str) -> None:
        pass  # nothing to save (see _Live)


class _Interrupt(_Live, Stopper):
    def __init__(self):
        self.event = threading.Event()

    def __call__(self, trial_id: str, result: dict) -> bool:
        return False

    def stop_all(self) -> bool:
        return self.event.is_set()


class _Ends(_Live, tune.Callback):
    """Each trial's end by run name: (return code, pruned, error text)."""

    def __init__(self, interrupt: _Interrupt):
        self.interrupt = interrupt
        self.ends: dict[str, tuple[int, bool, str | None]] = {}

    def on_trial_complete(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
        rc = (trial.last_result or {}).get("exit_code")
        if rc is not None:
            self.ends[trial.config["run"]] = (int(rc), False, None)
        else:  # stopped by Tune: its cleanup interrupts the training (exit 130)
            self.ends[trial.config["run"]] = (130, not self.interrupt.event.is_set(), None)

    def on_trial_error(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
        path = trial.error_file
        text = Path(path).read_text(errors="replace").strip() if path and Path(path).is_file() else ""
        last = text.splitlines()[-1] if text else "(no error text)"
        self.ends[trial.config["run"]] = (1, False, f"the trial failed: {last} (Tune's error file: {path})")


def _trial_dirname(trial: Any) -> str:
    return trial.config["run"]


class _TrialHandle(PolledHandle):
    """A run's Tune trial seen as a subprocess; `pruned` when the scheduler stopped it."""

    def __init__(self, executor: RayExecutor, run: str, log_path: Path):
        super().__init__()
        self.executor, self.run, self.log_path = executor, run, log_path
        self.pruned = False

    def poll(self) -> int | None:
        if self.returncode is not None:
            return self.returncode
        end = self.executor.ends.ends.get(self.run)
        if end is None and not self.executor.alive():  # an interrupt ends trials without a callback
            end = ((130, False, None) if self.executor.interrupt.event.is_set() else
                   (1, False, f"the Tune experiment ended: {self.executor.error or 'without this trial'}"))
        if end is not None:
            rc, self.pruned, error = end
            if error:
                with self.log_path.open("a") as log:
                    log.write(f"ray: {error}\n")
            self.returncode = rc
        return self.returncode

    def send_signal(self, sig: int) -> None:
        self.executor.interrupt.event.set()  # Tune stops every trial; each training checkpoints

    def kill(self) -> None:
        self.executor.interrupt.event.set()


class RayExecutor:
    """A Tune trial per run on a Ray cluster (`address`), else on a local one started here."""

    name = "ray"

    def __init__(self, out: Path, *, address: str | None = None, gpus_per_trial: float | None = None,
                 cpus_per_trial: float = 1, scheduler: dict | None = None):
        for flag, value in (("--gpus-per-trial", gpus_per_trial), ("--cpus-per-trial", cpus_per_trial)):
            if value is not None and value < 0:
                raise UserError(f"{flag} {value:g}: must be 0 or more")
        self.out, self.address, self.scheduler = Path(out), address, dict(scheduler or {})
        self.gpus_per_trial, self.cpus_per_trial = gpus_per_trial, cpus_per_trial
        self.where = f"Ray cluster at {address}" if address else "local Ray cluster"
        self.interrupt = _Interrupt()
        self.ends = _Ends(self.interrupt)
        self.error: str | None = None
        self._feed = _Feed()
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None

    def slots(self, gpus: list[str], runs: int) -> list[str | None]:
        """Every run at once: Ray queues the trials that do not fit."""
        return [None] * max(1, runs)

    def start(self, start_cmd: list[str], resume_cmd: list[str], env: dict[str, str], log: Any,
              run_dir: Path) -> _TrialHandle:
        with self._lock:
            if self._thread is None:
                self._launch()
        log.flush()
        env = gpu_share_env(env, self.gpus_per_trial or 1)
        job = {"start_cmd": start_cmd, "resume_cmd": resume_cmd, "cwd": os.getcwd(),
               "env": {k: v for k, v in env.items() if os.environ.get(k) != v},
               "log": str(Path(log.name).resolve()), "run_dir": str(Path(run_dir).resolve())}
        self._feed.queue.put({"run": Path(run_dir).name, "job": job})
        return _TrialHandle(self, Path(run_dir).name, Path(log.name))

    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def close(self) -> None:
        """No more runs: wait for Tune to end the trials (their trainings' checkpoints) and Ray."""
        if self._thread is None:
            return
        self._feed.closed = True
        if self._thread.ident is not None:
            self._thread.join()

    def _launch(self) -> None:
        # Ray, when it starts here, ties its processes to the thread that starts it (they get
        # SIGKILL when it ends): the Tune thread, which lives until close.
        ready: queue.Queue = queue.Queue()
        self._thread = threading.Thread(target=self._fit, args=(ready,), daemon=True)
        self._thread.start()
        where = f"--address {self.address}" if self.address else "a local Ray cluster"
        try:
            error = ready.get(timeout=START_WAIT_S)
        except queue.Empty:
            self._thread = threading.Thread()  # left behind in ray.init: nothing to wait for in close
            raise UserError(f"{where}: no Ray cluster answered within {START_WAIT_S} s") from None
        if isinstance(error, str):
            raise UserError(f"{where}: Ray did not start ({error})")
        if error is not None:
            raise error

    def _fit(self, ready: queue.Queue) -> None:
        started = not ray.is_initialized()
        try:
            try:
                ray.init(address=self.address, include_dashboard=False, logging_level=logging.WARNING,
                         ignore_reinit_error=True)
            except (ConnectionError, RuntimeError, ValueError) as err:  # the cluster, the address
                ready.put(str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__)
                return
            try:
                tuner = self._tuner()
            except Exception as err:  # noqa: BLE001 (raised by start)
                ready.put(err)
                return
            ready.put(None)
            try:
                tuner.fit()
            except Exception as err:  # noqa: BLE001 (the handles report it as their runs' failure)
                self.error = f"{type(err).__name__}: {err}"
        finally:
            if started and ray.is_initialized():
                ray.shutdown()

    def _tuner(self) -> Any:
        gpus = self.gpus_per_trial
        if gpus is None:
            gpus = 1 if ray.cluster_resources().get("GPU", 0) > 0 else 0
        scheduler = None
        if self.scheduler:
            s = self.scheduler
            scheduler = ASHAScheduler(time_attr="samples", metric=s["metric"],
                                      mode="max" if s["metric"] == "eval/nr" else "min",
                                      grace_period=s["grace_period"], max_t=s["max_t"],
                                      reduction_factor=s["reduction_factor"], stop_last_trials=False)
            os.environ["TUNE_DISABLE_STRICT_METRIC_CHECKING"] = "1"  # results between evaluations lack it
        os.environ.setdefault("RAY_AIR_NEW_OUTPUT", "0")  # its tables at verbose=0 too; the sweep prints its own
        return tune.Tuner(
            tune.with_resources(TrainTrial, {"cpu": self.cpus_per_trial, "gpu": gpus}),
            tune_config=tune.TuneConfig(search_alg=self._feed, scheduler=scheduler, num_samples=-1,
                                        trial_dirname_creator=_trial_dirname),
            run_config=RunConfig(name=time.strftime("%Y%m%d-%H%M%S"), storage_path=str((self.out / "ray").resolve()),
                                 stop=self.interrupt, callbacks=[self.ends], verbose=0,
                                 checkpoint_config=CheckpointConfig(checkpoint_at_end=False)))
