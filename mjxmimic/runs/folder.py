"""The run folder, owned here: every command that takes a run takes this folder and finds its
parts through these names, so the layout is written down once.

    RUN/config.json    the resolved config (mjxmimic.core.config), written before training starts
    RUN/metrics.jsonl  one line per iteration and per evaluation (mjxmimic.runs.metrics_log)
    RUN/tb/            the same scalars for TensorBoard
    RUN/checkpoints/   orbax checkpoints named by env_steps (mjxmimic.runs.checkpoint)
    RUN/best/          the checkpoint of the best evaluation so far (runs.train_loop.best_score)
    RUN/best.json      that evaluation: {"metric", "value", "checkpoint", "eval"}
    RUN/eval.json      the latest NR evaluation (mjxmimic.runs.evaluate) with the run's summary
    RUN/eval_<N>.json  `mjxmimic eval`'s evaluation of checkpoint N
    RUN/policy.npz     the exported policy (mjxmimic.portable.policy_file), or policy.onnx
    RUN/clips/         copies of the clip files the run trained on (a dataset's as kept_dataset.json of
                       them), read instead of the clip's name, so that evaluations, exports and resumes
                       see the same motion wherever the folder goes and whatever becomes of the originals
    RUN/.lock          held (flock) by the process training the run, so that no second one writes it

Paths, config, eval and policy files need no JAX (sweeps and `mjxmimic play` use them); the
checkpoint functions import it when called.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError

if TYPE_CHECKING:
    from mjxmimic.portable.policy_file import PolicyFile

CONFIG = "config.json"
METRICS = "metrics.jsonl"
TENSORBOARD = "tb"
CHECKPOINTS = "checkpoints"
BEST = "best"
EVAL = "eval.json"
POLICY = "policy"  # RUN/policy.<format>
CLIPS = "clips"
KEPT_DATASET = "kept_dataset.json"  # in RUN/clips/: the dataset's clips (by file name) and weights

# Orbax writes one of these into a checkpoint's folder when the checkpoint is complete.
_COMMIT_MARKERS = ("_CHECKPOINT_METADATA", "commit_success.txt")


# ---- paths ---------------------------------------------------------------------------------------

def config_path(run_dir: Path) -> Path:
    return Path(run_dir) / CONFIG


def metrics_path(run_dir: Path) -> Path:
    return Path(run_dir) / METRICS


def tensorboard_dir(run_dir: Path) -> Path:
    return Path(run_dir) / TENSORBOARD


def checkpoint_dir(run_dir: Path) -> Path:
    """Absolute, as orbax requires."""
    return Path(run_dir).resolve() / CHECKPOINTS


def eval_path_of(run_dir: Path, step: int, grid: float | None = None) -> Path:
    """Where `mjxmimic eval` records its evaluation of checkpoint `step` (`--grid`'s apart)."""
    return Path(run_dir) / (f"eval_{step}.json" if grid is None else f"eval_{step}_grid_{grid:g}.json")


def best_dir(run_dir: Path) -> Path:
    """Absolute, as orbax requires."""
    return Path(run_dir).resolve() / BEST


def best_path(run_dir: Path) -> Path:
    return Path(run_dir) / f"{BEST}.json"


def eval_path(run_dir: Path) -> Path:
    return Path(run_dir) / EVAL


def policy_path(run_dir: Path, fmt: str = "npz") -> Path:
    """Where `mjxmimic export` writes by default and `play`/`render` look first."""
    return Path(run_dir) / f"{POLICY}.{fmt}"


def names_policy_file(source: Path) -> bool:
    """Whether a command's RUN|POLICY argument means an exported policy file (a missing one too,
    so that its error says "policy file not found") rather than a run folder."""
    return Path(source).is_file() or Path(source).suffix in (".npz", ".onnx")


# ---- the folder and its files --------------------------------------------------------------------

def require(run_dir: Path) -> Path:
    """RUN as a Path; a one-line error when it is not a folder."""
    run_dir = Path(run_dir)
    if run_dir.is_file():  # an exported policy, say, where a run is needed (`export POLICY.npz`)
        raise UserError(f"{run_dir}: a file, not a run folder")
    if not run_dir.is_dir():
        raise UserError(f"{run_dir}: run folder not found")
    return run_dir


# Set by sweeps for the trainings they start: a training whose parent (the sweep, a Ray trial, a
# Slurm job) has died checkpoints and stops as if terminated, rather than train on unwatched while
# holding its run's lock (the next sweep call would find the run taken).
STOP_WITH_PARENT = "MJXMIMIC_STOP_WITH_PARENT"
# Set by a sweep with a wall-clock budget (--max-seconds): when (Unix time, s) its trainings stop
# with a checkpoint, so that one that a Ray or Slurm queue started late still ends within the budget.
SWEEP_DEADLINE = "MJXMIMIC_SWEEP_DEADLINE"


def refuse_non_folder(run_dir: Path) -> None:
    """A one-line error when RUN names something that is not a folder (a new run's --out may not
    exist yet)."""
    if Path(run_dir).exists() and not Path(run_dir).is_dir():
        raise UserError(f"{run_dir}: exists and is not a folder")


@contextlib.contextmanager
def writer_lock(run_dir: Path) -> Iterator[None]:
    """Hold RUN/.lock while this process writes the run: a second writer gets a one-line error
    instead of mixing its metrics and checkpoints in. The OS drops the lock when the holder dies
    (kill -9 included), so a stale file never blocks a resume."""
    import fcntl

    run_dir = Path(run_dir)
    refuse_non_folder(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    handle = (run_dir / ".lock").open("a+")
    try:
        fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        handle.seek(0)
        holder = handle.read().strip() or "another process"
        handle.close()
        raise UserError(f"{run_dir}: {holder} is training this run; wait for it, or use another folder") from None
    handle.truncate(0)
    handle.write(f"process {os.getpid()}")
    handle.flush()
    try:
        yield
    finally:
        fcntl.flock(handle, fcntl.LOCK_UN)
        handle.close()


def holds_run(run_dir: Path) -> bool:
    """A run was started here (its config is written before anything else)."""
    return config_path(run_dir).exists()


def load_config(run_dir: Path) -> config_lib.Config:
    """RUN's resolved config; a one-line error when the folder or its config is missing."""
    path = config_path(require(run_dir))
    if not path.is_file():
        raise UserError(f"{run_dir}: not a run folder (no {CONFIG})")
    return config_lib.load(path)


def write_config(run_dir: Path, config: config_lib.Config) -> None:
    """Create RUN if need be and write its config."""
    Path(run_dir).mkdir(parents=True, exist_ok=True)
    config_lib.save(config, config_path(run_dir))


def keep_clips(run_dir: Path, clips: list[Any], weights: list[float] | None = None) -> None:
    """Copy the files of a run's `clips` (mjxmimic.motion.clip.Clip) into RUN/clips/, with a
    dataset's `weights` as RUN/clips/kept_dataset.json; whole or not at all."""
    import shutil

    dest = Path(run_dir) / CLIPS
    tmp = dest.with_name(CLIPS + ".tmp")
    try:
        shutil.rmtree(tmp, ignore_errors=True)
        tmp.mkdir(parents=True)
        for clip in clips:
            shutil.copyfile(clip.path, tmp / Path(clip.path).name)
        if weights is not None:
            entries = [{"clip": Path(c.path).name, "weight": w} for c, w in zip(clips, weights, strict=True)]
            (tmp / KEPT_DATASET).write_text(json.dumps({"clips": entries}, indent=1))
        shutil.rmtree(dest, ignore_errors=True)
        tmp.rename(dest)
    except OSError as err:
        shutil.rmtree(tmp, ignore_errors=True)
        raise UserError(f"{dest}: cannot keep the run's clips there ({err.strerror or err})") from None


def clip_source(config: config_lib.Config, run_dir: Path | None) -> str | Path:
    """What a run trains on: its copy in RUN/clips/ (a clip file or the kept dataset), else
    clip.name (no run folder, or a run from before folders kept their clips)."""
    dest = Path(run_dir) / CLIPS if run_dir is not None else None
    if dest is None or not dest.is_dir():
        return config.clip.name
    if (dest / KEPT_DATASET).is_file():
        return dest / KEPT_DATASET
    files = sorted(p for p in dest.iterdir() if not p.name.startswith("."))  # not a desktop's .DS_Store
    if len(files) != 1:  # not graded silently on whatever the clip's name finds now
        raise UserError(f"{dest}: holds {len(files)} files, not the one clip the run trained on (or "
                        f"{KEPT_DATASET}); put it back, or remove the folder to read the clip by its name")
    return files[0]


def _read_json(path: Path) -> dict[str, Any] | None:
    """A JSON object file of the run, or None when there is none; a one-line error when it is not
    a JSON object."""
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise UserError(f"{path}: not valid JSON ({err.msg} at line {err.lineno})") from None
    if not isinstance(data, dict):
        raise UserError(f"{path}: expected a JSON object, got {type(data).__name__}")
    return data


def read_eval(run_dir: Path) -> dict[str, Any] | None:
    """RUN/eval.json, or None when there is none."""
    return _read_json(eval_path(run_dir))


def write_json_atomic(path: Path, data: Any) -> Path:
    """Write a JSON file whole (a temporary file renamed into place): a reader such as a sweep's
    report never sees half of it."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(path)
    return path


def write_eval(run_dir: Path, result: dict[str, Any]) -> Path:
    """Write RUN/eval.json whole."""
    return write_json_atomic(eval_path(run_dir), result)


# ---- checkpoints ---------------------------------------------------------------------------------

def has_checkpoint(run_dir: Path) -> bool:
    """A complete checkpoint is there (RUN/checkpoints/<steps>/ with orbax's commit marker);
    reads the folder only, no JAX."""
    root = checkpoint_dir(run_dir)
    if not root.is_dir():
        return False
    return any(p.is_dir() and p.name.isdigit() and any((p / m).exists() for m in _COMMIT_MARKERS)
               for p in root.iterdir())


def require_checkpoint(run_dir: Path) -> int:
    """env_steps of RUN's latest checkpoint; a one-line error when there is none (imports JAX)."""
    from mjxmimic.runs import checkpoint

    step = checkpoint.latest_checkpoint(run_dir)
    if step is None:
        raise UserError(f"{run_dir}: no checkpoint found in {checkpoint_dir(run_dir)}")
    return step


def read_best(run_dir: Path) -> dict[str, Any] | None:
    """RUN/best.json, or None when the run has kept no best evaluation yet."""
    return _read_json(best_path(run_dir))


CHECKPOINT_CHOICES = "best, latest or a number of samples"


def select_checkpoint(run_dir: Path, which: str = "best") -> tuple[int, bool]:
    """(env_steps, whether it is RUN/best's) of the checkpoint that `which` names: "best" (the
    latest when no best was kept, e.g. a run from before best checkpoints), "latest", or the
    env_steps of a kept checkpoint. Imports JAX."""
    from mjxmimic.runs import checkpoint

    best = checkpoint.latest_checkpoint(run_dir, best=True)
    if which == "best" and best is not None:  # a folder may hold its best alone (copied back from a GPU)
        return best, True
    latest = require_checkpoint(run_dir)
    if which == "best":
        return latest, False
    if which == "latest":
        return latest, False
    if not which.isdigit():
        raise UserError(f"--checkpoint {which!r}: expected {CHECKPOINT_CHOICES}")
    step = int(which)
    if step == best:
        return step, True
    kept = checkpoint.kept_checkpoints(run_dir)
    if step not in kept:
        raise UserError(f"--checkpoint {step}: not in {run_dir} (kept: {', '.join(map(str, sorted(kept)))}"
                        f"{'' if best is None else f'; best {best}'})")
    return step, False


def load_policy_params(run_dir: Path, observation_size: int | None = None, action_size: int | None = None,
                       step: int | None = None, best: bool = False) -> tuple[dict[str, Any], dict[str, Any]]:
    """(policy params of RUN's latest (or given) checkpoint, laid out as
    `mjxmimic.learn.ppo.export_params` gives them, as numpy; the checkpoint's meta, with
    "checkpoint" = its env_steps).

    Builds the run's networks only, no environment, so a checkpoint written on a GPU loads on a
    CPU. The sizes default to those of the run's character; an env of other sizes (a stand-in)
    passes its own. Imports JAX.
    """
    config = load_config(run_dir)
    step = require_checkpoint(run_dir) if step is None else step
    from mjxmimic.learn.ppo import make_networks
    from mjxmimic.runs import checkpoint

    if observation_size is None or action_size is None:
        from mjxmimic.core.character import load_character, resolve_xml
        from mjxmimic.envs.step import observation_size as observation_size_of
        from mjxmimic.motion import dataset

        character = load_character(resolve_xml(config.character.xml))
        source = clip_source(config, run_dir)
        nclips = len(dataset.load_dataset(source, character).clips) if dataset.is_dataset(source) else 1
        observation_size = observation_size_of(config, character.model.nbody, nclips)
        action_size = character.action_size
    networks = make_networks(observation_size, action_size, config)
    return checkpoint.restore_policy(run_dir, networks, observation_size, step, best)


def load_policy_file(source: Path, *, export_if_missing: bool = False, checkpoint: str = "best") -> PolicyFile:
    """An exported policy from a file (.npz or .onnx) or a run folder: its policy.npz, else, with
    `export_if_missing`, its `checkpoint` (select_checkpoint) exported in memory (that path
    imports JAX)."""
    from mjxmimic.portable import policy_file

    source = Path(source)
    if not source.is_dir():
        return policy_file.read(source)
    path = policy_path(source)
    if path.is_file():
        return policy_file.read(path)
    if not export_if_missing:
        raise UserError(f"{source}: a run folder without {path.name} "
                        f"(write it with `mjxmimic export {source}`)")
    if not has_checkpoint(source):
        raise UserError(f"{source}: neither a policy file nor a run folder with checkpoints")
    from mjxmimic.core import jax_setup

    jax_setup.prepare()
    from mjxmimic.runs.export import policy_file_from_run

    return policy_file_from_run(source, checkpoint)
