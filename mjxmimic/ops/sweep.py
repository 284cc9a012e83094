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
      "out": "runs/sweeps/NAME"              # default runs/sweeps/NAME (relative to the cwd)
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
where names would collide or grow past 100 characters).

Folder OUT/ holds:
    NAME-OF-RUN/    a normal `mjxmimic train` run folder per run
    logs/RUN.log    each run's stdout and stderr (appended per attempt)
    sweep.json      the sweep's state: per run its status, attempts, exit code, seconds, log tail
    sweep.lock      held (flock) while a sweep runs here, so two cannot run in one folder
    report.md, report.csv, curves.png   the results (see `write_report`)

Each run is one subprocess `python -m mjxmimic.cli train ...`, so a crash or an out-of-memory
kill takes only that run down (recorded as failed with its exit code and the last lines of its
log). With two or more GPUs visible (CUDA_VISIBLE_DEVICES, else `nvidia-smi -L`; override with
--gpus or MJXMIMIC_SWEEP_GPUS) runs go one per GPU at the same time, each subprocess seeing one
GPU; otherwise one after another. Running the same spec again skips finished runs (eval.json
with run.total_samples reached, or the target NR reached), resumes interrupted or time-stopped
ones from their checkpoint (`train --resume`, with the spec's run.* values), and starts afresh
the runs that never started or failed before their first checkpoint (their folder is removed
first). A run folder whose config.json disagrees with the spec (other than run.* keys) is an
error before anything starts.

This module does not import JAX; the parent process only reads and writes files.
"""

from __future__ import annotations

import csv
import dataclasses
import fcntl
import hashlib
import io
import itertools
import json
import math
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
from mjxmimic.motion.clip import clip_label
from mjxmimic.core.errors import UserError
from mjxmimic.runs import folder
from mjxmimic.runs.metrics_log import read as read_metrics

SPEC_FIELDS = ("name", "description", "preset", "clip", "clips", "grid", "runs", "seeds", "set", "out")
GPU_ENV_VAR = "MJXMIMIC_SWEEP_GPUS"
STATE_FILE = "sweep.json"
MAX_NAME = 100
LOG_TAIL_LINES = 12
MIN_START_SECONDS = 60.0  # with a sweep time budget, do not start a run with less than this left
_SAFE = re.compile(r"[^A-Za-z0-9._=+-]+")


# ---- the spec ---------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class RunSpec:
    name: str
    clip: str
    seed: int
    overrides: dict[str, Any]  # this run's own grid/runs overrides (spec values)
    args: dict[str, str]  # every --set of the run (set + grid + runs entry) as command-line strings
    config: config_lib.Config  # the resolved config the run will have
    order: tuple[int, ...]  # (clip, grid combination, runs entry, seed): the report's row order


@dataclasses.dataclass(frozen=True)
class Spec:
    path: Path
    name: str
    description: str
    preset: str
    clips: list[str]
    seeds: list[int]
    common: dict[str, Any]
    grid: dict[str, list]
    entries: list[dict[str, Any]]
    out: Path
    runs: list[RunSpec]  # in execution order: seeds outermost, then clips, grid, runs entries
    raw: dict

    @property
    def varying_keys(self) -> list[str]:
        keys = list(self.grid)
        for entry in self.entries:
            keys += [k for k in entry if k not in keys]
        return keys

    def run_dir(self, run: RunSpec) -> Path:
        return self.out / run.name

    def log_path(self, run: RunSpec) -> Path:
        return self.out / "logs" / f"{run.name}.log"


def cli_value(value: Any) -> str:
    """A spec value as `--set key=VALUE` takes it (what config._coerce parses back)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isfinite(value) and value.is_integer() and abs(value) < 1e15:
            return str(int(value))
        return repr(value)
    if isinstance(value, str):
        return value
    if isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                for v in value):
        return ",".join(cli_value(v) for v in value)
    raise ValueError(f"{json.dumps(value)} is not a config value (a number, string, boolean or list of numbers)")


def _label_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, (list, tuple)):
        return "x".join(_label_value(v) for v in value)
    text = str(value)
    return Path(text).stem if "/" in text else text


def _short_hash(obj: Any) -> str:
    return hashlib.sha1(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:8]


class _SpecError(Exception):
    """A problem with the spec; load_spec turns it into a UserError naming the file."""


def _check_key(key: Any, where: str) -> str:
    if not isinstance(key, str) or key.count(".") != 1:
        raise _SpecError(f"{where}: config key {key!r}: expected section.key")
    if key == "clip.name":
        raise _SpecError(f"{where}: config key 'clip.name': give clips with \"clips\"")
    if key == "run.seed":
        raise _SpecError(f"{where}: config key 'run.seed': give seeds with \"seeds\"")
    return key


def _overrides(obj: Any, where: str) -> dict[str, Any]:
    if not isinstance(obj, dict):
        raise _SpecError(f"{where}: expected an object of section.key: value")
    out = {}
    for key, value in obj.items():
        _check_key(key, where)
        try:
            cli_value(value)
        except ValueError as err:
            raise _SpecError(f"{where}: config key {key!r}: {err}") from None
        out[key] = value
    return out


def _origin(message: str, common: dict, grid: dict, index: int, entry: dict) -> str:
    """"set: " / "grid: " / "runs[i]: " for the key a config error names, else ""."""
    m = re.search(r"config key '([^']+)'", message)
    if m is None:
        return ""
    key = m.group(1)
    if key in common:
        return "set: "
    if key in grid:
        return "grid: "
    if key in entry:
        return f"runs[{index}]: "
    return ""


def load_spec(path: str | Path, out: str | Path | None = None, check_clips: bool = True) -> Spec:
    """Read, validate and expand a spec; every problem is a UserError naming the file."""
    path = Path(path)
    if not path.is_file():
        raise UserError(f"{path}: sweep spec not found" if not path.exists() else f"{path}: not a file")
    try:
        raw = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: not valid JSON ({err.msg} at line {err.lineno})") from None
    except UnicodeDecodeError:
        raise UserError(f"{path}: not valid JSON (not UTF-8 text)") from None
    try:
        return _expand(path, raw, out, check_clips)
    except (_SpecError, UserError) as err:
        raise UserError(f"{path}: {err}") from None


def _expand(path: Path, raw: Any, out: str | Path | None, check_clips: bool) -> Spec:
    if not isinstance(raw, dict):
        raise _SpecError("expected a JSON object at the top level")
    unknown = [k for k in raw if k not in SPEC_FIELDS]
    if unknown:
        raise _SpecError(f"unknown field {unknown[0]!r} (fields: {', '.join(SPEC_FIELDS)})")

    name = raw.get("name", path.stem)
    if not isinstance(name, str) or not re.fullmatch(r"[A-Za-z0-9._-]+", name) or name in (".", ".."):
        raise _SpecError(f"name {name!r}: use letters, digits, '.', '_' and '-' only")
    description = raw.get("description", "")
    if not isinstance(description, str):
        raise _SpecError("description: expected a string")
    preset = raw.get("preset", "gpu")
    if preset not in config_lib.PRESETS:
        raise _SpecError(f"preset {preset!r} does not exist (presets: {', '.join(config_lib.PRESETS)})")

    if "clip" in raw and "clips" in raw:
        raise _SpecError("give either \"clip\" or \"clips\", not both")
    if "clip" in raw:
        clips = [raw["clip"]]
    elif "clips" in raw:
        clips = raw["clips"]
        if not isinstance(clips, list) or not clips:
            raise _SpecError("clips: expected a non-empty list of clip names or paths")
    else:
        clips = [config_lib.make_config(preset).clip.name]
    for clip in clips:
        if not isinstance(clip, str) or not clip.strip():
            raise _SpecError(f"clips: {json.dumps(clip)} is not a clip name or path")
    if len(set(clips)) != len(clips):
        raise _SpecError("clips: a clip is listed twice")

    seeds = raw.get("seeds", [0])
    if isinstance(seeds, int) and not isinstance(seeds, bool):
        seeds = [seeds]
    if (not isinstance(seeds, list) or not seeds
            or not all(isinstance(s, int) and not isinstance(s, bool) and s >= 0 for s in seeds)):
        raise _SpecError("seeds: expected a non-empty list of non-negative integers")
    if len(set(seeds)) != len(seeds):
        raise _SpecError("seeds: a seed is listed twice")

    common = _overrides(raw.get("set", {}), "set")

    grid: dict[str, list] = {}
    if "grid" in raw:
        if not isinstance(raw["grid"], dict):
            raise _SpecError("grid: expected an object of section.key: [values]")
        if not raw["grid"]:
            raise _SpecError("grid is empty (leave it out, or give at least one key with values)")
        for key, values in raw["grid"].items():
            _check_key(key, "grid")
            if not isinstance(values, list) or not values:
                raise _SpecError(f"grid: config key {key!r}: expected a non-empty list of values")
            for v in values:
                _overrides({key: v}, "grid")
            if len({cli_value(v) for v in values}) != len(values):
                raise _SpecError(f"grid: config key {key!r}: a value is listed twice")
            if key in common:
                raise _SpecError(f"config key {key!r} is in both \"set\" and \"grid\"")
            grid[key] = values

    entries: list[dict[str, Any]] = [{}]
    if "runs" in raw:
        if not isinstance(raw["runs"], list) or not raw["runs"]:
            raise _SpecError("runs: expected a non-empty list of override objects")
        entries = [_overrides(e, f"runs[{i}]") for i, e in enumerate(raw["runs"])]
        for i, entry in enumerate(entries):
            for key in entry:
                if key in common:
                    raise _SpecError(f"config key {key!r} is in both \"set\" and runs[{i}]")
                if key in grid:
                    raise _SpecError(f"config key {key!r} is in both \"grid\" and runs[{i}]")

    out_dir = out if out is not None else raw.get("out", f"runs/sweeps/{name}")
    if not isinstance(out_dir, (str, Path)) or not str(out_dir).strip():
        raise _SpecError("out: expected a folder path")

    if check_clips:
        from mjxmimic.motion.clip import resolve_clip

        for clip in clips:
            try:
                resolve_clip(clip)
            except UserError as err:
                raise _SpecError(f"clips: {err}") from None

    keys = list(grid)
    combos = list(itertools.product(*(grid[k] for k in keys))) if keys else [()]
    # Which keys vary (named in run names), and which of them share a last part (then: full key).
    varying = list(dict.fromkeys(keys + [k for e in entries for k in e]))
    last = [k.split(".")[1] for k in varying]
    label_key = {k: (k.split(".")[1] if last.count(k.split(".")[1]) == 1 else k) for k in varying}

    runs: list[RunSpec] = []
    seen: dict[str, str] = {}
    for si, seed in enumerate(seeds):
        for ci, clip in enumerate(clips):
            for gi, combo in enumerate(combos):
                for ei, entry in enumerate(entries):
                    own = {**dict(zip(keys, combo)), **entry}
                    args = {k: cli_value(v) for k, v in {**common, **own}.items()}
                    label = "-".join([clip_label(clip)] + [f"{label_key[k]}={_label_value(v)}"
                                                            for k, v in own.items()] + [f"s{seed}"])
                    label = _SAFE.sub("_", label).strip("._") or "run"
                    identity = json.dumps([clip, sorted(args.items()), seed])
                    if identity in seen:
                        raise _SpecError(f"run {label} comes twice (a grid value or runs entry is repeated)")
                    seen[identity] = label
                    try:
                        cfg = config_lib.make_config(preset, {**args, "clip.name": clip, "run.seed": str(seed)})
                    except UserError as err:
                        raise _SpecError(f"{_origin(str(err), common, grid, ei, entry)}{err} (in run {label})") from None
                    except (TypeError, ValueError) as err:
                        raise _SpecError(f"a config value has the wrong type: {err} (in run {label})") from None
                    runs.append(RunSpec(name=label, clip=clip, seed=seed, overrides=own, args=args,
                                        config=cfg, order=(ci, gi, ei, si)))

    # Unique, bounded names: a short hash where names collide or are too long.
    counts: dict[str, int] = {}
    for r in runs:
        counts[r.name] = counts.get(r.name, 0) + 1
    fixed = []
    for r in runs:
        name_ = r.name
        if counts[name_] > 1 or len(name_) > MAX_NAME:
            h = _short_hash([r.clip, sorted(r.args.items()), r.seed])
            name_ = f"{name_[:MAX_NAME - 9]}-{h}"
        fixed.append(dataclasses.replace(r, name=name_))

    return Spec(path=path, name=name, description=description, preset=preset, clips=clips, seeds=seeds,
                common=common, grid=grid, entries=entries if "runs" in raw else [], out=Path(out_dir),
                runs=fixed, raw=raw)


# ---- run folders ------------------------------------------------------------------------------

def _read_json(path: Path) -> dict | None:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def is_finished(run_dir: Path, cfg: config_lib.Config) -> bool:
    """eval.json is there and the run reached its run.total_samples (or stopped at the target NR)."""
    final = _read_json(folder.eval_path(run_dir))
    if final is None:
        return False
    if final.get("reason") == "target":
        return True
    return int(final.get("samples", -1)) >= cfg.run.total_samples


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
    """What each run needs, from its folder; a folder that holds another config is an error."""
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

class State:
    """OUT/sweep.json: {"name", "spec", "spec_content", "updated", "runs": {name: record}}."""

    def __init__(self, spec: Spec):
        self.path = spec.out / STATE_FILE
        self.lock = threading.Lock()
        data = _read_json(self.path) or {}
        self.data = {"name": spec.name, "spec": str(spec.path), "spec_content": spec.raw,
                     "runs": data.get("runs", {}) if isinstance(data.get("runs"), dict) else {}}

    def record(self, name: str) -> dict:
        return self.data["runs"].get(name, {})

    def update(self, name: str, **values: Any) -> None:
        with self.lock:
            self.data["runs"].setdefault(name, {}).update(values)
            self._write()

    def _write(self) -> None:
        self.data["updated"] = _now()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps(self.data, indent=2) + "\n")
        os.replace(tmp, self.path)

    def save(self) -> None:
        with self.lock:
            self._write()


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
    max_seconds: the whole sweep's wall-clock budget (runs are bounded by it and stop with a
    checkpoint; runs that would get less than MIN_START_SECONDS are not started).
    """

    def __init__(self, spec: Spec, *, gpus: list[str] | None = None, max_seconds: float | None = None,
                 train_command: list[str] | None = None, echo: Callable[[str], None] = print):
        self.spec = spec
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
                state.update(p.run.name, **rec, status="finished")
                results[p.run.name] = "finished"
                self.echo(f"[{i}/{total}] {p.run.name}: finished already, skipped")
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
            if len(self.gpus) >= 2:
                self._run_parallel(todo, total, results)
            else:
                gpu = self.gpus[0] if self.gpus else None
                for i, p in todo:
                    if self._stop.is_set():
                        break
                    results[p.run.name] = self._execute(i, total, p, gpu)
        except KeyboardInterrupt:
            self._interrupt()
            raise
        finally:
            if previous_term is not None:
                signal.signal(signal.SIGTERM, previous_term)
            state.save()
            lock_file.close()
        for _, p in todo:
            results.setdefault(p.run.name, state.record(p.run.name).get("status", "pending"))
        return results

    def _run_parallel(self, todo, total, results) -> None:
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

        threads = [threading.Thread(target=worker, args=(g,), daemon=True) for g in self.gpus]
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
            self.state.update(name, status="interrupted", exit_code=proc.returncode, ended=_now())

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
        args = train_args(spec, p, budget)
        cmd = self.train_command + args
        env = dict(os.environ)
        env["PYTHONUNBUFFERED"] = "1"
        package_root = str(Path(__file__).resolve().parent.parent)
        env["PYTHONPATH"] = os.pathsep.join([package_root] + [x for x in env.get("PYTHONPATH", "").split(os.pathsep) if x])
        where = "the default device"
        if gpu is not None:
            env["CUDA_VISIBLE_DEVICES"] = gpu
            where = f"GPU {gpu}"
        attempts = int(state.record(run.name).get("attempts", 0)) + 1
        verb = "resuming" if p.action == "resume" else "starting"
        self.echo(f"[{i}/{total}] {run.name}: {verb} on {where} -> {run_dir}")
        log_path.parent.mkdir(parents=True, exist_ok=True)
        with log_path.open("ab") as log:
            log.write(f"== attempt {attempts} ({p.action}) at {_now()}: {' '.join(cmd)}\n".encode())
            log.flush()
            start_offset = log.tell()
            t0 = time.time()
            state.update(run.name, status="running", action=p.action, attempts=attempts, started=_now(),
                         gpu=gpu, command=cmd, log=str(log_path.relative_to(spec.out)), exit_code=None,
                         ended=None, log_tail=[])
            with self._procs_lock:
                if self._stop.is_set():
                    state.update(run.name, status="pending")
                    return "pending"
                # own session: a terminal's Ctrl-C reaches only the sweep, which forwards one SIGINT
                proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
                                        env=env, start_new_session=True)
                self._procs[run.name] = proc
            rc = proc.wait()
            with self._procs_lock:
                self._procs.pop(run.name, None)
        seconds = time.time() - t0
        tail = _log_tail(log_path, start_offset)
        if is_finished(run_dir, run.config):
            status = "finished"
        elif rc == 0:
            status = "stopped"  # run.max_seconds (or the sweep budget): resumed by the next sweep call
        elif rc == 130 or self._stop.is_set():
            status = "interrupted"
        else:
            status = "failed"
        state.update(run.name, status=status, exit_code=rc, ended=_now(), seconds=round(seconds, 1), log_tail=tail)
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


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S")


# ---- the report -------------------------------------------------------------------------------

def run_row(spec: Spec, run: RunSpec, record: dict) -> dict:
    """One results row: status, NR (the final evaluation, else the latest one), fall rate, samples,
    wall-clock and steady-state samples/s (eval.json, else metrics.jsonl)."""
    run_dir = spec.run_dir(run)
    row: dict[str, Any] = {"run": run.name, "clip": run.clip, "seed": run.seed, "nr": None, "fall_rate": None,
                           "nr_at_samples": None, "samples": None, "wall_s": None, "samples_per_s": None}
    status = record.get("status") or "pending"
    if is_finished(run_dir, run.config):
        status = "finished"
    metrics = read_metrics(run_dir)
    final = _read_json(folder.eval_path(run_dir)) if status == "finished" else None
    if final is not None:
        row.update(nr=final.get("nr"), fall_rate=final.get("fall_rate"), nr_at_samples=final.get("samples"),
                   samples=final.get("samples"), wall_s=final.get("train_seconds"),
                   samples_per_s=final.get("samples_per_s_steady"))
    elif metrics:
        evals = [m for m in metrics if "eval/nr" in m]
        if evals:
            row.update(nr=evals[-1]["eval/nr"], fall_rate=evals[-1].get("eval/fall_rate"),
                       nr_at_samples=evals[-1]["step"])
        row.update(samples=max(m.get("step", 0) for m in metrics), wall_s=max(m.get("wall", 0.0) for m in metrics))
        steady = [m["run/samples_per_s_steady"] for m in metrics if "run/samples_per_s_steady" in m]
        if steady:
            row["samples_per_s"] = steady[-1]
    if status == "failed" and record.get("exit_code") is not None:
        rc = record["exit_code"]
        status = f"failed ({'signal ' + str(-rc) if rc < 0 else 'exit ' + str(rc)})"
    row["status"] = status
    return row


def _config_value(cfg: config_lib.Config, key: str) -> Any:
    section, name = key.split(".")
    value = getattr(getattr(cfg, section), name)
    return list(value) if isinstance(value, tuple) else value


def _rows(spec: Spec, state: dict) -> tuple[list[str], list[dict]]:
    keys = spec.varying_keys
    rows = []
    for run in sorted(spec.runs, key=lambda r: r.order):
        row = run_row(spec, run, state.get("runs", {}).get(run.name, {}))
        row["overrides"] = {k: _config_value(run.config, k) for k in keys}
        rows.append(row)
    return keys, rows


def _fmt(value: Any, kind: str) -> str:
    if value is None:
        return "-"
    if kind == "nr":
        return f"{value:.3f}"
    if kind == "fall":
        return f"{value:.2f}"
    if kind == "int":
        return f"{int(value):,}"
    if kind == "s":
        return f"{value:,.0f}"
    if isinstance(value, list):
        return "x".join(str(v) for v in value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


CSV_COLUMNS = ("nr", "fall_rate", "nr_at_samples", "samples", "wall_s", "samples_per_s")


def write_tables(spec: Spec, state: dict) -> tuple[Path, Path]:
    """OUT/report.md and OUT/report.csv: one row per run of the spec, in clip/grid/runs/seed order."""
    keys, rows = _rows(spec, state)
    out = spec.out
    out.mkdir(parents=True, exist_ok=True)

    buf = io.StringIO()
    writer = csv.writer(buf)
    writer.writerow(["run", "clip", *keys, "seed", "status", *CSV_COLUMNS])
    for r in rows:
        writer.writerow([r["run"], r["clip"],
                         *[(";".join(str(x) for x in v) if isinstance(v, list) else v)
                           for v in r["overrides"].values()],
                         r["seed"], r["status"], *["" if r[c] is None else r[c] for c in CSV_COLUMNS]])
    csv_path = out / "report.csv"
    csv_path.write_text(buf.getvalue())

    lines = [f"# Sweep {spec.name}", ""]
    if spec.description:
        lines += [spec.description, ""]
    common = ", ".join(f"`{k}={cli_value(v)}`" for k, v in spec.common.items()) or "none"
    lines += [f"Spec `{spec.path}`; preset `{spec.preset}`; common overrides: {common}.",
              (f"Written {_now()}. NR and fall rate are the final evaluation's (EVALUATION.md) for finished "
               "runs, else the latest periodic evaluation's, at the samples in column 'NR at'. Wall-clock is "
               "the training's (compilation included, summed over resumed calls); samples/s is the steady "
               "state of the run's last call."), ""]
    devices = sorted({d for r in spec.runs if (d := (_read_json(folder.eval_path(spec.run_dir(r))) or {}).get('device'))})
    if devices:
        lines += [f"Device: {', '.join(devices)}.", ""]
    header = ["run", "clip", *[f"`{k}`" for k in keys], "seed", "status", "NR", "fall rate", "NR at",
              "samples", "wall-clock s", "samples/s"]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        cells = [r["run"], r["clip"], *[_fmt(v, "") for v in r["overrides"].values()], str(r["seed"]), r["status"],
                 _fmt(r["nr"], "nr"), _fmt(r["fall_rate"], "fall"), _fmt(r["nr_at_samples"], "int"),
                 _fmt(r["samples"], "int"), _fmt(r["wall_s"], "s"), _fmt(r["samples_per_s"], "s")]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    failures = [(r, state.get("runs", {}).get(r["run"], {})) for r in rows if r["status"].startswith("failed")]
    if failures:
        lines += ["", "## Failed runs", ""]
        for r, rec in failures:
            last = (rec.get("log_tail") or ["(no output)"])[-1]
            lines.append(f"- `{r['run']}`: {r['status']}: `{last}` (log: `{rec.get('log', '')}`)")
    lines += ["", "Learning curves: `curves.png`.", ""]
    md_path = out / "report.md"
    md_path.write_text("\n".join(lines))
    return md_path, csv_path


def write_curves(spec: Spec) -> Path | None:
    """OUT/curves.png: evaluation NR against samples and against wall-clock, and training reward
    (mean per step) against samples; one line per run, one colour per configuration, one line
    style per seed. Returns None (and says why) when matplotlib is missing or nothing was logged."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise _NoPlot("matplotlib is not installed, so no curves.png (pip install matplotlib)") from None
    series = []
    for run in sorted(spec.runs, key=lambda r: r.order):
        metrics = read_metrics(spec.run_dir(run))
        if metrics:
            series.append((run, metrics))
    if not series:
        raise _NoPlot("no run has logged metrics yet, so no curves.png")
    configs = []
    for run, _ in series:
        key = (run.order[0], run.order[1], run.order[2])
        if key not in configs:
            configs.append(key)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = ["-", "--", ":", "-."]
    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    for run, metrics in series:
        ci = configs.index((run.order[0], run.order[1], run.order[2]))
        style = {"color": colors[ci % len(colors)], "linestyle": styles[run.order[3] % len(styles)],
                 "label": run.name}
        evals = [m for m in metrics if m.get("eval/nr") is not None]
        if evals:
            axes[0].plot([m["step"] for m in evals], [m["eval/nr"] for m in evals], marker="o", ms=3, **style)
            axes[1].plot([m["wall"] for m in evals], [m["eval/nr"] for m in evals], marker="o", ms=3, **style)
        train = [m for m in metrics if m.get("reward") is not None]
        if train:
            axes[2].plot([m["step"] for m in train], [m["reward"] for m in train], **style)
    titles = [("evaluation NR", "samples"), ("evaluation NR", "wall-clock s (compilation included)"),
              ("training reward per step", "samples")]
    for ax, (title, xlabel) in zip(axes, titles):
        ax.set_title(title)
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
        if not ax.lines:
            ax.text(0.5, 0.5, "no data yet", ha="center", va="center", transform=ax.transAxes)
    for ax in axes:
        ax.set_xlim(left=0)
    axes[0].set_ylim(0, 1)
    axes[1].set_ylim(0, 1)
    handles, labels = axes[2].get_legend_handles_labels()
    if not handles:
        handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=min(4, max(1, len(labels))), fontsize=8)
    fig.suptitle(f"sweep {spec.name}")
    fig.tight_layout(rect=(0, 0.05 + 0.03 * ((len(labels) - 1) // 4), 1, 1))
    path = spec.out / "curves.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


class _NoPlot(Exception):
    pass


def write_report(spec: Spec, echo: Callable[[str], None] = print) -> list[Path]:
    """report.md, report.csv and (with matplotlib) curves.png in OUT; returns the paths written."""
    state = _read_json(spec.out / STATE_FILE) or {}
    paths = list(write_tables(spec, state))
    try:
        png = write_curves(spec)
    except _NoPlot as why:
        echo(f"note: {why}")
    else:
        paths.append(png)
    return paths
