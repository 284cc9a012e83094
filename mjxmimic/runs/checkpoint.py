"""Orbax checkpoints of everything a resume needs, except the env state (re-drawn by RSI).

Layout of RUN/checkpoints/<env_steps>/ (orbax CheckpointManager, the last 2 kept):
    params/     policy and value parameters          (PyTree, OCDBT)
    optimizer/  adam state (count, mu, nu)             (PyTree, OCDBT)
    learner/    normaliser state, rng key, env_steps   (PyTree, OCDBT)
    meta/       JSON: env_steps, iterations, elapsed wall-clock seconds, time_to_skill, ...
Every array item is written with an OCDBT target data file size of 8 MiB, so no file of a
checkpoint exceeds 16 MB whatever the network size (GPU runs are resumed across 10-minute
calls by carrying the run folder back; large files do not travel). A single array larger
than the target still lands whole in one file: with [1024, 512] layers the largest array is
1024 x 512 floats = 2 MiB.

Saves are synchronous (a checkpoint is small) so that a process may exit right after `save`.
RUN/best/<env_steps>/ holds the checkpoint of the run's best evaluation in the same layout (one
kept; `save(..., best=True)`), which export, play and render use by default.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import shutil
import sys
from pathlib import Path
from typing import Any

import jax
import numpy as np
import orbax.checkpoint as ocp
from brax.training import types as brax_types
from brax.training.acme import running_statistics

from mjxmimic.core.errors import UserError
from mjxmimic.runs.folder import best_dir, checkpoint_dir, require_checkpoint

TARGET_FILE_BYTES = 8 * 1024 * 1024
KEEP = 2
_ARRAY_ITEMS = ("params", "optimizer", "learner")


def _manager(run_dir: Path, create: bool = True, best: bool = False) -> ocp.CheckpointManager:
    options = ocp.CheckpointManagerOptions(max_to_keep=1 if best else KEEP, create=create,
                                           enable_async_checkpointing=False)
    root = best_dir(run_dir) if best else checkpoint_dir(run_dir)
    return ocp.CheckpointManager(root, options=options, item_names=_ARRAY_ITEMS + ("meta",))


def latest_checkpoint(run_dir: Path, best: bool = False) -> int | None:
    """env_steps of the newest complete checkpoint in RUN/checkpoints (RUN/best), or None."""
    if not (best_dir(run_dir) if best else checkpoint_dir(run_dir)).is_dir():
        return None
    with _manager(run_dir, create=False, best=best) as mngr:
        return mngr.latest_step()


def kept_checkpoints(run_dir: Path) -> list[int]:
    """env_steps of every complete checkpoint in RUN/checkpoints, oldest first."""
    if not checkpoint_dir(run_dir).is_dir():
        return []
    with _manager(run_dir, create=False) as mngr:
        return sorted(mngr.all_steps())


def _split(ts) -> dict[str, Any]:
    return {
        "params": {"policy": ts.params.policy, "value": ts.params.value},
        "optimizer": ts.optimizer_state,
        "learner": {"normalizer": ts.normalizer, "key": ts.key, "env_steps": ts.env_steps},
    }


def save(run_dir: Path, ts, *, iterations: int, elapsed_seconds: float, extra: dict | None = None,
         best: bool = False) -> int:
    """Write a checkpoint of TrainState `ts` named by its env_steps (into RUN/best with `best`);
    returns env_steps."""
    env_steps = int(ts.env_steps)
    items = jax.device_get(_split(ts))
    meta = {"env_steps": env_steps, "iterations": int(iterations),
            "elapsed_seconds": float(elapsed_seconds), **(extra or {})}
    args = {name: ocp.args.PyTreeSave(items[name], ocdbt_target_data_file_size=TARGET_FILE_BYTES)
            for name in _ARRAY_ITEMS}
    _require_space(run_dir, sum(np.asarray(x).nbytes for x in jax.tree_util.tree_leaves(items)))
    with _manager(run_dir, best=best) as mngr, _library_errors_raised_not_logged():
        if env_steps in mngr.all_steps():  # e.g. Ctrl-C right after a periodic save
            mngr.delete(env_steps)
        mngr.save(env_steps, args=ocp.args.Composite(meta=ocp.args.JsonSave(meta), **args), force=True)
        mngr.wait_until_finished()
    return env_steps


def _require_space(run_dir: Path, nbytes: int) -> None:
    """Refuse a checkpoint that the disk cannot hold before writing any of it: a write that fails
    halfway leaves orbax's writer threads printing tracebacks after the run has stopped."""
    free = shutil.disk_usage(run_dir if run_dir.exists() else run_dir.parent).free
    needed = int(nbytes * 1.2) + (1 << 20)  # the arrays, orbax's metadata and some slack
    if free < needed:
        raise OSError(errno.ENOSPC, f"No space left on device: {free / 2**20:.1f} MiB free, a checkpoint "
                                    f"needs about {needed / 2**20:.1f} MiB")


@contextlib.contextmanager
def _library_errors_raised_not_logged():
    """Orbax's writer threads log a failed write (a full disk) with its traceback through absl,
    then raise it in the caller, which reports it in one line: only the raise gets through."""
    logger = logging.getLogger("absl")
    level = logger.level
    logger.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        logger.setLevel(level)


def restore(run_dir: Path, template, step: int | None = None):
    """(TrainState, meta) from RUN's latest (or given) checkpoint. `template` is a TrainState of
    the same structure (e.g. `trainer.init(seed)`); its env_state is kept (not checkpointed).
    A latest checkpoint that cannot be read (cut short, corrupted) is reported on stderr and the
    one before it is used."""
    steps = [step] if step is not None else sorted(kept_checkpoints(run_dir), reverse=True)
    if not steps:
        require_checkpoint(run_dir)  # the one-line error
    targets = jax.device_get(_split(template))
    for i, step in enumerate(steps):
        try:
            out = _restore_as_numpy(run_dir, step, targets)
            break
        except Exception as err:  # noqa: BLE001 (orbax and tensorstore raise many types)
            why = _first_line(err)
            if i + 1 == len(steps):
                raise UserError(f"{run_dir}: checkpoint {step} cannot be read ({why}), and no older one "
                                f"can") from None
            print(f"mjxmimic: {run_dir}: checkpoint {step} cannot be read ({why}); using checkpoint "
                  f"{steps[i + 1]}", file=sys.stderr)
    learner = out["learner"]
    ts = template.replace(
        params=template.params.replace(policy=out["params"]["policy"], value=out["params"]["value"]),
        optimizer_state=out["optimizer"],
        normalizer=learner["normalizer"],
        key=learner["key"],
        env_steps=learner["env_steps"],
    )
    return ts, dict(out["meta"])


def _first_line(err: BaseException) -> str:
    """Why a read failed, in a few words (orbax and tensorstore messages run over many lines)."""
    return str(err).splitlines()[0][:200] if str(err) else type(err).__name__


def _restore_as_numpy(run_dir: Path, step: int, targets: dict[str, Any], best: bool = False) -> dict[str, Any]:
    """The named array items (shaped as `targets`) and meta of checkpoint `step`, restored as numpy
    arrays wherever they were written (a GPU run's checkpoint restores on a CPU)."""
    targets = jax.tree_util.tree_map(np.asarray, targets)
    args = {name: ocp.args.PyTreeRestore(tree, restore_args=jax.tree_util.tree_map(
                lambda _: ocp.RestoreArgs(restore_type=np.ndarray), tree))
            for name, tree in targets.items()}
    with _manager(run_dir, create=False, best=best) as mngr:
        return mngr.restore(step, args=ocp.args.Composite(meta=ocp.args.JsonRestore(), **args))


def restore_policy(run_dir: Path, networks, observation_size: int, step: int,
                   best: bool = False) -> tuple[dict, dict]:
    """(`mjxmimic.learn.ppo.export_params`-style numpy params plus the value network under
    "value" (a composite's gate reads it), meta with "checkpoint") of checkpoint
    `step`: only the "params" and "learner" items, restored into a template of `networks` (Brax
    PPO networks), so no environment, trainer or optimiser state is built."""
    key = jax.random.PRNGKey(0)
    targets = {
        "params": {"policy": networks.policy_network.init(key), "value": networks.value_network.init(key)},
        "learner": {"normalizer": running_statistics.init_state(
                        jax.ShapeDtypeStruct((observation_size,), np.float32)),
                    "key": key, "env_steps": brax_types.UInt64(hi=0, lo=0)},
    }
    try:
        out = _restore_as_numpy(run_dir, step, targets, best)
    except Exception as err:  # noqa: BLE001 (orbax and tensorstore raise many types)
        why = _first_line(err)
        raise UserError(f"{run_dir}: checkpoint {step} cannot be read ({why}); "
                        f"--checkpoint picks another") from None
    try:
        normalizer = out["learner"]["normalizer"]
        params = {"normalizer": {"mean": np.asarray(normalizer.mean), "std": np.asarray(normalizer.std)},
                  **{net: {name: {k: np.asarray(v) for k, v in layer.items()}
                           for name, layer in out["params"][net]["params"].items()}
                     for net in ("policy", "value")}}
    except (KeyError, TypeError) as err:
        raise UserError(f"{run_dir}: checkpoint {step} does not hold a policy and normaliser where "
                        f"expected ({err})") from None
    meta = dict(out["meta"] or {})
    meta["checkpoint"] = int(step)
    meta["best"] = best
    return params, meta


def file_sizes(run_dir: Path, step: int) -> dict[str, int]:
    """Bytes of every file of one checkpoint (relative path -> size)."""
    root = checkpoint_dir(run_dir) / str(step)
    return {str(p.relative_to(root)): p.stat().st_size for p in root.rglob("*") if p.is_file()}
