"""Export from a run folder: one of its checkpoints (the best evaluation's by default) as one
portable policy file.

The file format is mjxmimic.portable.policy_file's (JAX-free); this side reads the run (config,
checkpoint, eval.json through mjxmimic.runs.folder) and imports JAX (orbax) when it does.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mjxmimic.core import config as config_lib
from mjxmimic.portable import policy_file
from mjxmimic.portable.policy_file import PolicyFile
from mjxmimic.runs import folder


def mjx_eval_start_times(seed: int, episodes: int, clip_duration: float) -> np.ndarray:
    """The start times of `mjxmimic.runs.evaluate`'s episodes for a seed (needs JAX).
    tests/test_export_playback.py checks this against mjxmimic.runs.evaluate itself."""
    import jax

    from mjxmimic.runs.evaluate import start_times

    return np.asarray(start_times(jax.random.PRNGKey(seed), episodes, clip_duration), np.float32)


def _training_eval(run_dir: Path, config: config_lib.Config, clips: list[Any], checkpoint: int,
                   best: bool) -> dict[str, Any] | None:
    """The manifest's training.eval (None without one): the evaluation of the best checkpoint from
    RUN/best.json, else RUN/eval.json, with the start times of its episodes so that CPU playback
    starts where the MJX evaluation did; for a dataset, each clip's NR and start times too (MJX
    evaluates every clip from the same key)."""
    clip = clips[0]
    kept = folder.read_best(run_dir) if best else None
    ev = dict(kept["eval"], checkpoint=kept["checkpoint"]) if kept else folder.read_eval(run_dir)
    if ev is None:
        return None
    episodes = int(ev.get("episodes", config.run.eval_episodes))
    seed = int(ev.get("seed", config.run.seed + 1))
    from mjxmimic.envs.starts import start_limit

    duration = float(start_limit(config, clip.duration))
    starts = ev.get("start_times")
    if starts is None:
        starts = mjx_eval_start_times(seed, episodes, duration).tolist()
    out = {
        "nr": ev.get("nr"), "fall_rate": ev.get("fall_rate"), "survival_s": ev.get("survival_s"),
        "pose_error_rad": ev.get("pose_error_rad"), "end_effector_error_m": ev.get("end_effector_error_m"),
        "episodes": episodes, "seed": seed, "checkpoint": ev.get("checkpoint", ev.get("samples")),
        "start_times": [float(t) for t in starts],
    }
    if len(clips) > 1:
        out["clips"] = {c.name: {"nr": ev.get(f"clip/{c.name}/nr"), "nr_paper": ev.get(f"clip/{c.name}/nr_paper"),
                                 "start_times": mjx_eval_start_times(seed, episodes, c.duration).tolist()}
                        for c in clips}
    of = out["checkpoint"]
    if of is not None and int(of) != checkpoint:
        out["note"] = f"{folder.EVAL} is of checkpoint {of}, the exported policy of {checkpoint}"
    return out


def policy_file_from_run(run_dir: Path, which: str = "best") -> PolicyFile:
    """The portable contents of one of RUN's checkpoints (folder.select_checkpoint: "best",
    "latest" or env_steps), in memory; imports JAX."""
    from mjxmimic.envs.mjx_env import load_env_inputs

    run_dir = Path(run_dir)
    config = folder.load_config(run_dir)
    character, clips, weights = load_env_inputs(config, run_dir)
    step, best = folder.select_checkpoint(run_dir, which)
    params, meta = folder.load_policy_params(run_dir, step=step, best=best)

    training: dict[str, Any] = {"run": str(run_dir.resolve()), "checkpoint": meta["checkpoint"],
                                "best": best, "samples": int(meta.get("env_steps", meta["checkpoint"])),
                                "train_seconds": meta.get("elapsed_seconds")}
    ev = _training_eval(run_dir, config, clips, meta["checkpoint"], best)
    if ev is not None:
        training["eval"] = ev
    pf = policy_file.make_policy_file(config, character, clips, params, training, weights)
    pf.path = run_dir
    return pf


def export_run(run_dir: Path, out: Path | None = None, fmt: str = "npz",
               which: str = "best") -> tuple[Path, PolicyFile]:
    """Write one of RUN's checkpoints (the best by default) as one portable file (default
    RUN/policy.<fmt>)."""
    policy_file.check_format(fmt)  # fail before the slow part
    pf = policy_file_from_run(run_dir, which)
    out = Path(out) if out is not None else folder.policy_path(run_dir, fmt)
    policy_file.write(pf, out, fmt)
    pf.path = out
    return out, pf
