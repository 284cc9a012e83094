"""NR of a run folder's latest checkpoint, outside training (`mjxmimic eval`, physics studies).

The NR protocol itself is mjxmimic.runs.evaluate's; this reads the run (mjxmimic.runs.folder),
builds its env unless given one, and records the result beside the checkpoint it measured.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from mjxmimic.core.errors import UserError
from mjxmimic.runs import folder


def load_run_policy(run_dir: Path, env: Any = None,
                    which: str = "latest") -> tuple[Any, Any, Any, dict[str, Any], int]:
    """(config, env, deterministic policy fn, checkpoint metadata, checkpoint step) of one of RUN's
    checkpoints (folder.select_checkpoint); the env is the run's own unless given."""
    config = folder.load_config(run_dir)
    step, best = folder.select_checkpoint(run_dir, which)  # before the slow env build

    from mjxmimic.learn.ppo import make_networks, make_policy_fn

    if env is None:
        from mjxmimic.envs.mjx_env import make_env

        env = make_env(config)
    params, meta = folder.load_policy_params(run_dir, env.observation_size, env.action_size, step, best)
    networks = make_networks(env.observation_size, env.action_size, config)
    return config, env, make_policy_fn(networks, params, deterministic=True), meta, step


def evaluate_run(run_dir: Path, episodes: int | None = None, seed: int | None = None, env: Any = None,
                 write: bool = True, which: str = "latest") -> dict[str, Any]:
    """NR of RUN's latest checkpoint, in `env` if given (e.g. other physics settings), else in
    the run's own; seed defaults to run.seed + 1, as in training. `write`: also save it as
    RUN/eval.json."""
    if episodes is not None and episodes < 1:
        raise UserError(f"--episodes {episodes}: must be at least 1")
    config, env, policy, meta, step = load_run_policy(run_dir, env, which)

    from mjxmimic.runs.evaluate import evaluate

    result = evaluate(env, policy, config, config.run.seed + 1 if seed is None else seed,
                      episodes=episodes, samples=meta["env_steps"], train_seconds=meta["elapsed_seconds"])
    if meta.get("time_to_skill_s") is not None:
        result["time_to_skill_s"] = meta["time_to_skill_s"]
    result["checkpoint"] = step
    result["clip"] = config.clip.name
    if write:
        folder.write_eval(run_dir, result)
    return result
