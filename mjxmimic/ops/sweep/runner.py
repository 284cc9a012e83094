"""Running a sweep: plan (skip, resume or start each run from its folder), one `mjxmimic train`
per run through an executor (mjxmimic.ops.sweep.executors: local subprocesses, one per GPU when
several are visible, Slurm jobs or Ray Tune trials), the state file, signals."""

from __future__ import annotations

import dataclasses
import fcntl
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.runs import folder
from mjxmimic.ops.sweep.executors import LocalExecutor
from mjxmimic.ops.sweep.report import run_row, write_tables
from mjxmimic.ops.sweep.spec import RunSpec, Spec, cli_value
from mjxmimic.ops.sweep.state import STATE_FILE, State, now, is_finished, read_json

GPU_ENV_VAR = "MJXMIMIC_SWEEP_GPUS"
LOG_TAIL_LINES = 12
MIN_START_SECONDS = 60.0  # with a sweep time budget, do not start a run with less than this left
PRUNED = "pruned by the scheduler"  # a Ray Tune scheduler stopped it early; later calls leave it so


def _config_mismatch(recorded: config_lib.Config, expected: config_lib.Config) -> str | None:
    a, b = config_lib.to_dict(recorded), config_lib.to_dict(expected)
    for section, values in b.items():
        for key, value in values.items():
            if section == "run" and key != "seed":
                continue  # run.* (budgets, eval cadence) may change between calls
            if a.get(section, {}).get(key) != value:
                return f"{section}.{key} is {a.get(section, {}).get(key)!r} there, {value!r} in the spec"
    return None


@dataclasses.dataclass
class Plan:
    run: RunSpec
    action: str  # "skip" (finished), "resume", "start"
    why: str


def plan(spec: Spec) -> list[Plan]:
    """What each run needs, from its folder (and sweep.json for pruned runs); a folder that holds
    another config is an error."""
    records = (read_json(spec.out / STATE_FILE) or {}).get("runs", {})
    plans = []
    for run in spec.runs:
        run_dir = spec.run_dir(run)
        cfg_path = folder.config_path(run_dir)
        if not cfg_path.is_file():
            why = "half-written folder, start afresh" if run_dir.exists() else "new"
            plans.append(Plan(run, "start", why))
            continue
        try:
            recorded = config_lib.load(cfg_path)
        except UserError as err:
            raise UserError(f"{spec.path}: run {run.name}: {err} (remove {run_dir} to start it afresh)") from None
        diff = _config_mismatch(recorded, run.config)
        if diff is not None:
            raise UserError(f"{spec.path}: run folder {run_dir} holds a different config ({diff}); "
                            f"remove it or give the sweep another name or out folder")
        if is_finished(run_dir, run.config):
            plans.append(Plan(run, "skip", "finished"))
        elif isinstance(records, dict) and records.get(run.name, {}).get("status") == "pruned":
            plans.append(Plan(run, "skip", PRUNED))
        elif folder.has_checkpoint(run_dir):
            plans.append(Plan(run, "resume", "has a checkpoint"))
        else:
            plans.append(Plan(run, "start", "no checkpoint yet, start afresh"))
    return plans


def train_args(spec: Spec, p: Plan, max_seconds: float | None = None) -> list[str]:
    """The `mjxmimic train` arguments for a planned run. `max_seconds`: the sweep's budget bound."""
    run, run_dir = p.run, spec.run_dir(p.run)
    budget = []
    if max_seconds is not None:
        spec_limit = run.config.run.max_seconds
        limit = max_seconds if spec_limit <= 0 else min(spec_limit, max_seconds)
        budget = ["--set", f"run.max_seconds={limit:.0f}"]
    if p.action == "resume":
        # the spec's run.* values (budgets may have changed), everything else from config.json
        out = ["--resume", str(run_dir)]
        for f in dataclasses.fields(run.config.run):
            if f.name != "seed" and not (budget and f.name == "max_seconds"):
                out += ["--set", f"run.{f.name}={cli_value(getattr(run.config.run, f.name))}"]
        return out + budget
    out = ["--out", str(run_dir), "--preset", spec.preset, "--clip", run.clip, "--seed", str(run.seed)]
    for key, value in run.args.items():
        if not (budget and key == "run.max_seconds"):
            out += ["--set", f"{key}={value}"]
    return out + budget


# ---- GPUs -------------------------------------------------------------------------------------

def detect_gpus(setting: str | None = None) -> list[str]:
    """GPU ids to pin runs to, one run per id ([] = one after another, unpinned).

    setting (--gpus, else $MJXMIMIC_SWEEP_GPUS, else "auto"): "auto" = the ids in
    CUDA_VISIBLE_DEVICES when it is set, else those `nvidia-smi -L` lists; "none" or "0" = run
    one after another; N = the first N of the auto ids (0..N-1 where fewer are found); "0,2" = those ids.
    """
    if setting is None:
        setting = os.environ.get(GPU_ENV_VAR, "auto")
    setting = setting.strip().lower()
    if setting in ("none", "0", ""):
        return []
    if "," in setting:
        ids = [s.strip() for s in setting.split(",") if s.strip()]
        if not ids:
            raise UserError(f"--gpus {setting!r}: no GPU ids")
        return ids
    found = _visible_gpus()
    if setting == "auto":
        return found
    if not setting.isdigit():
        raise UserError(f"--gpus {setting!r}: expected auto, none, a count or a comma-separated list of ids")
    n = int(setting)
    return found[:n] if len(found) >= n else [str(i) for i in range(n)]


def _visible_gpus() -> list[str]:
    visible = os.environ.get("CUDA_VISIBLE_DEVICES")
    if visible is not None:
        ids = []
        for part in visible.split(","):
            part = part.strip()
            if not part or part.startswith("-"):
                break  # CUDA stops at the first invalid id
            ids.append(part)
        return ids
    try:
        out = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, timeout=20, check=False)
    except (OSError, subprocess.SubprocessError):
        return []
    if out.returncode != 0:
        return []
    return [str(i) for i, _ in enumerate(l for l in out.stdout.splitlines() if l.startswith("GPU "))]


# ---- the state file ---------------------------------------------------------------------------

def _log_tail(path: Path, since: int, lines: int = LOG_TAIL_LINES) -> list[str]:
    try:
        with path.open("rb") as f:
            f.seek(since)
            text = f.read().decode(errors="replace")
    except OSError:
        return []
    rows = [r.rstrip() for r in re.split(r"[\r\n]+", text) if r.strip()]
    return rows[-lines:]


# ---- running ----------------------------------------------------------------------------------

def default_train_command() -> list[str]:
    return [sys.executable, "-m", "mjxmimic.cli", "train"]


class Runner:
    """Runs a spec's unfinished runs as subprocesses and keeps OUT/sweep.json.

    train_command: the command that takes `mjxmimic train` arguments (tests pass a stand-in).
    gpus: ids to pin runs to, one run per id at a time (two or more: parallel); [] = sequential.
    executor: where runs execute (mjxmimic.ops.sweep.executors; local subprocesses by default).
    max_seconds: the whole sweep's wall-clock budget (runs are bounded by it and stop with a
    checkpoint; runs that would get less than MIN_START_SECONDS are not started).
    """

    def __init__(self, spec: Spec, *, gpus: list[str] | None = None, max_seconds: float | None = None,
                 train_command: list[str] | None = None, echo: Callable[[str], None] = print,
                 executor: Any = None):
        self.spec = spec
        self.executor = executor or LocalExecutor()
        self.gpus = list(gpus or [])
        self.max_seconds = max_seconds
        self.train_command = list(train_command or default_train_command())
        self.echo = echo
        self._procs: dict[str, subprocess.Popen] = {}
        self._procs_lock = threading.Lock()
        self._stop = threading.Event()
        self._report_lock = threading.Lock()

    def run(self) -> dict[str, str]:
        """Run everything that is not finished; returns {run name: status}. Ctrl-C (or SIGTERM)
        asks the running trainings to checkpoint and stop, records them, then raises
        KeyboardInterrupt."""
        spec = self.spec
        plans = plan(spec)
        spec.out.mkdir(parents=True, exist_ok=True)
        lock_file = (spec.out / "sweep.lock").open("w")
        try:
            fcntl.flock(lock_file, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            lock_file.close()
            raise UserError(f"{spec.out}: another sweep is running in this folder") from None
        self._deadline = None if self.max_seconds is None else time.time() + self.max_seconds
        state = self.state = State(spec)
        (spec.out / "logs").mkdir(exist_ok=True)
        results: dict[str, str] = {}
        todo = []
        total = len(plans)
        for i, p in enumerate(plans, 1):
            rec = {"dir": p.run.name, "clip": p.run.clip, "seed": p.run.seed, "overrides": p.run.overrides}
            if p.action == "skip":
                status = "pruned" if p.why == PRUNED else "finished"
                state.update(p.run.name, **rec, status=status)
                results[p.run.name] = status
                self.echo(f"[{i}/{total}] {p.run.name}: {status} already, skipped")
            else:
                if state.record(p.run.name).get("status") in (None, "running"):
                    rec["status"] = "pending"
                state.update(p.run.name, **rec)
                todo.append((i, p))
        state.save()

        previous_term = None
        if threading.current_thread() is threading.main_thread():
            previous_term = signal.signal(signal.SIGTERM, _raise_interrupt)
        try:
            slots = self.executor.slots(self.gpus, len(todo))
            if len(slots) >= 2:
                self._run_parallel(todo, total, results, slots)
            else:
                for i, p in todo:
                    if self._stop.is_set():
                        break
                    results[p.run.name] = self._execute(i, total, p, slots[0])
        except KeyboardInterrupt:
            self._interrupt()
            raise
        finally:
            if previous_term is not None:
                signal.signal(signal.SIGTERM, previous_term)
            if hasattr(self.executor, "close"):
                self.executor.close()  # waits for what the executor still runs (the Ray trials' ends)
            state.save()
            lock_file.close()
        for _, p in todo:
            results.setdefault(p.run.name, state.record(p.run.name).get("status", "pending"))
        return results

    def _run_parallel(self, todo, total, results, slots: list[str | None]) -> None:
        queue = list(todo)
        queue_lock = threading.Lock()
        errors: list[BaseException] = []

        def worker(gpu: str) -> None:
            while not self._stop.is_set():
                with queue_lock:
                    if not queue:
                        return
                    i, p = queue.pop(0)
                try:
                    results[p.run.name] = self._execute(i, total, p, gpu)
                except BaseException as err:  # noqa: BLE001 - reported by the main thread
                    errors.append(err)
                    self._stop.set()
                    return

        threads = [threading.Thread(target=worker, args=(g,), daemon=True) for g in slots]
        for t in threads:
            t.start()
        try:
            for t in threads:
                while t.is_alive():
                    t.join(timeout=0.5)  # wake up for Ctrl-C
        except KeyboardInterrupt:
            self._interrupt()
            for t in threads:
                t.join(timeout=60)
            raise
        if errors:
            raise errors[0]

    def _interrupt(self) -> None:
        """Ask each running training to stop (one SIGINT: it checkpoints and exits 130); wait."""
        self._stop.set()
        with self._procs_lock:
            procs = dict(self._procs)
        for name, proc in procs.items():
            if proc.poll() is None:
                self.echo(f"{name}: interrupting (the run checkpoints and stops)")
                try:
                    proc.send_signal(signal.SIGINT)
                except OSError:
                    pass
        for name, proc in procs.items():
            try:
                proc.wait(timeout=300)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
            self.state.update(name, status="interrupted", exit_code=proc.returncode, ended=now())

    def _execute(self, i: int, total: int, p: Plan, gpu: str | None) -> str:
        spec, run, state = self.spec, p.run, self.state
        run_dir, log_path = spec.run_dir(run), spec.log_path(run)
        budget = None
        if self._deadline is not None:
            budget = self._deadline - time.time()
            if budget < MIN_START_SECONDS:
                self.echo(f"[{i}/{total}] {run.name}: not started (sweep budget: {max(budget, 0):.0f} s left)")
                state.update(run.name, status=state.record(run.name).get("status") or "pending")
                return state.record(run.name).get("status", "pending")
        if p.action == "start" and run_dir.exists():
            shutil.rmtree(run_dir)
        cmd = self.train_command + train_args(spec, p, budget)
        resume_cmd = self.train_command + train_args(spec, Plan(run, "resume", "requeued"), budget)
        env = dict(os.environ)
        env["PYTHONUNBUFFERED"] = "1"
        env[folder.STOP_WITH_PARENT] = "1"
        if self._deadline is not None:
            env[folder.SWEEP_DEADLINE] = f"{self._deadline:.1f}"
        package_root = str(Path(__file__).resolve().parents[3])  # the folder that holds mjxmimic/
        env["PYTHONPATH"] = os.pathsep.join([package_root] + [x for x in env.get("PYTHONPATH", "").split(os.pathsep) if x])
        where = "the default device" if self.executor.name == "local" else f"{self.executor.name} ({self.executor.where})"
        if gpu is not None:
            env["CUDA_VISIBLE_DEVICES"] = gpu
            where = f"GPU {gpu}"
        attempts = int(state.record(run.name).get("attempts", 0)) + 1
        verb = "resuming" if p.action == "resume" else "starting"
        self.echo(f"[{i}/{total}] {run.name}: {verb} on {where} -> {run_dir}")
        log_path.parent.mkdir(parents=True, exist_ok=True)
        with log_path.open("ab") as log:
            log.write(f"== attempt {attempts} ({p.action}) at {now()}: {' '.join(cmd)}\n".encode())
            log.flush()
            start_offset = log.tell()
            t0 = time.time()
            state.update(run.name, status="running", action=p.action, attempts=attempts, started=now(),
                         gpu=gpu, command=cmd, log=str(log_path.relative_to(spec.out)), exit_code=None,
                         ended=None, log_tail=[])
            with self._procs_lock:
                if self._stop.is_set():
                    state.update(run.name, status="pending")
                    return "pending"
                proc = self.executor.start(cmd, resume_cmd, env, log, run_dir)
                self._procs[run.name] = proc
            rc = proc.wait()
            with self._procs_lock:
                self._procs.pop(run.name, None)
        seconds = time.time() - t0
        tail = _log_tail(log_path, start_offset)
        if is_finished(run_dir, run.config):
            status = "finished"
        elif getattr(proc, "pruned", False):
            status = "pruned"  # a Ray Tune scheduler stopped it (its training checkpoints and exits)
        elif rc == 0:
            status = "stopped"  # run.max_seconds (or the sweep budget): resumed by the next sweep call
        elif rc == 130 or self._stop.is_set():
            status = "interrupted"
        else:
            status = "failed"
        state.update(run.name, status=status, exit_code=rc, ended=now(), seconds=round(seconds, 1), log_tail=tail)
        line = f"[{i}/{total}] {run.name}: {status}"
        if status == "failed":
            why = f"killed by signal {-rc}" if rc < 0 else f"exit {rc}"
            line += f" ({why}) after {seconds:.0f} s" + (f": {tail[-1]}" if tail else "")
            line += f"  [log: {log_path}]"
        else:
            row = run_row(spec, run, state.record(run.name))
            line += f" after {seconds:.0f} s"
            if row["nr"] is not None:
                line += f"; NR {row['nr']:.3f}, fall rate {row['fall_rate']:.2f} at {row['nr_at_samples']:,} samples"
        self.echo(line)
        with state.lock:
            snapshot = json.loads(json.dumps(state.data))
        with self._report_lock:
            try:
                write_tables(spec, snapshot)
            except OSError:
                pass
        return status


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt
