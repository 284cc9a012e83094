"""NR of a run folder's checkpoint, outside training (`mjxmimic eval`, physics studies), or of
an exported policy file on MJX.

The NR protocol itself is mjxmimic.runs.evaluate's; this reads the run (mjxmimic.runs.folder),
builds its env unless given one, and records the result beside the checkpoint it measured
(RUN/eval_<checkpoint>.json). A policy file needs no run folder: whoever has the file can
measure it again on MJX, with other seeds and more episodes.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.runs import folder


def load_run_policy(run_dir: Path, env: Any = None, which: str = "latest",
                    progress: Callable[[str], None] | None = None) -> tuple[Any, Any, Any, dict[str, Any], int]:
    """(config, env, deterministic policy fn, checkpoint metadata, checkpoint step) of one of RUN's
    checkpoints (folder.select_checkpoint); the env is the run's own unless given."""
    config = folder.load_config(run_dir)
    step, best = folder.select_checkpoint(run_dir, which)  # before the slow env build
    if progress is not None:
        progress(f"checkpoint {step:,}{' (the best)' if best else ''}: building the env")

    from mjxmimic.learn.ppo import make_networks, make_policy_fn

    if env is None:
        from mjxmimic.envs.mjx_env import make_env

        env = make_env(config_lib.evaluation_config(config), run_dir=run_dir)
    params, meta = folder.load_policy_params(run_dir, env.observation_size, env.action_size, step, best)
    networks = make_networks(env.observation_size, env.action_size, config)
    return config, env, make_policy_fn(networks, params, deterministic=True), meta, step


def _check_starts(episodes: int | None, grid: float | None) -> None:
    if episodes is not None and episodes < 1:
        raise UserError(f"--episodes {episodes}: must be at least 1")
    if grid is not None and episodes is not None:
        raise UserError("--grid sets the episodes itself (a start every SECONDS); leave out --episodes")


def _episodes_text(episodes: int, grid: float | None) -> str:
    return f"{episodes} episodes" if grid is None else f"episodes from a start every {grid:g} s"


def evaluate_run(run_dir: Path, episodes: int | None = None, seed: int | None = None, env: Any = None,
                 write: bool = True, which: str = "latest",
                 progress: Callable[[str], None] | None = None, grid: float | None = None) -> dict[str, Any]:
    """NR of one of RUN's checkpoints (the latest by default), in `env` if given (e.g. other
    physics settings), else in the run's own; seed defaults to run.seed + 1, as in training;
    `grid` (seconds) starts an episode every `grid` over the clip instead of the seeded draw.
    `write`: also save it as RUN/eval_<checkpoint>.json (eval_<checkpoint>_grid_<grid>.json; the
    training's own eval.json stays). `progress(text)` hears what is happening."""
    _check_starts(episodes, grid)
    say = progress or (lambda text: None)
    config, env, policy, meta, step = load_run_policy(run_dir, env, which, progress)

    from mjxmimic.runs.evaluate import evaluate

    say(f"compiling and running {_episodes_text(episodes or config.run.eval_episodes, grid)}")
    result = evaluate(env, policy, config, config.run.seed + 1 if seed is None else seed, episodes=episodes,
                      grid=grid, samples=meta["env_steps"], train_seconds=meta["elapsed_seconds"])
    if meta.get("time_to_skill_s") is not None:
        result["time_to_skill_s"] = meta["time_to_skill_s"]
    result["checkpoint"] = step
    result["clip"] = config.clip.name
    if write:
        folder.write_json_atomic(folder.eval_path_of(run_dir, step, grid), result)
    return result


def load_file_policy(path: Path, progress: Callable[[str], None] | None = None,
                     overrides: dict[str, Any] | None = None) -> tuple[Any, Any, Any]:
    """(evaluation config, env, deterministic policy fn) of an exported policy file on MJX, in the
    conditions of its run's evaluations (its config, character and clips; `overrides`, config keys,
    change them). The network runs in jax.numpy as mjxmimic.portable.policy_numpy computes it;
    terrain policies (a heightmap encoder) need their run folder."""
    pf = folder.load_policy_file(path)
    if "conv_0" in pf.params["policy"]:
        raise UserError(f"{path}: a terrain policy; evaluate its run folder instead")
    config = config_lib.apply_overrides(config_lib.evaluation_config(pf.config()), overrides or {})
    if progress is not None:
        progress("building the env")

    import jax.numpy as jnp

    from mjxmimic.envs.mjx_env import ImitationEnv
    from mjxmimic.portable.policy_numpy import deterministic_action, mlp, network_arrays

    env = ImitationEnv(config, pf.character(), pf.clips(), pf.weights())
    mean, std, layers = network_arrays(pf.params, "policy", jnp)

    def policy(obs: Any, key: Any) -> Any:
        return deterministic_action(mlp(obs, mean, std, layers, jnp), env.action_size, jnp)

    return config, env, policy


def evaluate_policy_file(path: Path, episodes: int | None = None, seed: int | None = None,
                         progress: Callable[[str], None] | None = None, grid: float | None = None) -> dict[str, Any]:
    """NR of an exported policy file (`mjxmimic export`) on MJX (load_file_policy), with the
    training's start times by default (seed run.seed + 1), or a start every `grid` seconds."""
    _check_starts(episodes, grid)
    say = progress or (lambda text: None)
    config, env, policy = load_file_policy(path, say)

    from mjxmimic.runs.evaluate import evaluate

    say(f"compiling and running {_episodes_text(episodes or config.run.eval_episodes, grid)}")
    result = evaluate(env, policy, config, config.run.seed + 1 if seed is None else seed, episodes=episodes,
                      grid=grid)
    return {**result, "policy": str(path), "clip": config.clip.name}
