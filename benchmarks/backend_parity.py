"""Warp-vs-JAX parity of the MJX env: the same starts and the same actions on both backends.

    python benchmarks/backend_parity.py [--envs 256] [--steps 60] [--preset gpu] [--out FILE]

Both envs start from the same RSI states and take the same random residual actions (no resets:
`transition`), so every difference is the solvers'. Reports, per control step, the largest
observation and reward gaps and whether both flag the same falls. Runs wherever warp-lang does
(a CUDA GPU, or the CPU, slowly).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import jax
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from mjxmimic.core import config as config_lib  # noqa: E402
from mjxmimic.envs.mjx_env import ImitationEnv, load_env_inputs  # noqa: E402
from mjxmimic.ops.bench import environment_info  # noqa: E402


def compare(config: config_lib.Config, envs: int, steps: int, action_scale: float = 0.2, seed: int = 0) -> dict:
    character, clips, _ = load_env_inputs(config)
    out: dict = {"envs": envs, "steps": steps, "action_scale": action_scale, "per_step": []}
    rollouts = {}
    for backend in ("jax", "warp"):
        cfg = config_lib.apply_overrides(config, {"physics.backend": backend})
        env = ImitationEnv(cfg, character, clips, max_worlds=envs)
        trans = jax.jit(jax.vmap(lambda s, a: env.transition(s, a, evaluation=True)))
        state = jax.jit(jax.vmap(env.reset))(jax.random.split(jax.random.PRNGKey(seed), envs))
        actions = jax.random.uniform(jax.random.PRNGKey(seed + 1), (steps, envs, env.action_size),
                                     minval=-action_scale, maxval=action_scale)
        obs, rew, fell = [], [], []
        for k in range(steps):
            state = trans(state, actions[k])
            obs.append(np.asarray(state.obs))
            rew.append(np.asarray(state.reward))
            fell.append(np.asarray(state.info["failed"]) > 0)
        rollouts[backend] = (np.stack(obs), np.stack(rew), np.stack(fell))
    (oj, rj, fj), (ow, rw, fw) = rollouts["jax"], rollouts["warp"]
    alive = np.cumsum(fj | fw, axis=0) == 0  # compare only while neither has failed
    for k in range(steps):
        a = alive[k]
        out["per_step"].append({
            "step": k + 1, "alive": int(a.sum()),
            "obs_max_abs": float(np.abs(oj[k][a] - ow[k][a]).max()) if a.any() else None,
            "reward_max_abs": float(np.abs(rj[k][a] - rw[k][a]).max()) if a.any() else None,
            "fall_agreement": float(np.mean(fj[k] == fw[k])),
        })
    first = out["per_step"][0]
    out["summary"] = {"first_step_obs_max_abs": first["obs_max_abs"], "first_step_reward_max_abs": first["reward_max_abs"],
                      "mean_reward_jax": float(rj.mean()), "mean_reward_warp": float(rw.mean()),
                      "failed_jax": float(fj.any(axis=0).mean()), "failed_warp": float(fw.any(axis=0).mean()),
                      "nan_jax": int(np.isnan(oj).sum()), "nan_warp": int(np.isnan(ow).sum())}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--envs", type=int, default=256)
    parser.add_argument("--steps", type=int, default=60)
    parser.add_argument("--preset", default="gpu")
    parser.add_argument("--clip", default="slow_walk")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="SECTION.KEY=VALUE")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    overrides = {"clip.name": args.clip, **config_lib.parse_set_args(args.overrides)}
    config = config_lib.make_config(args.preset, overrides)
    result = {"info": environment_info(), "preset": args.preset, "overrides": overrides,
              **compare(config, args.envs, args.steps)}
    for row in result["per_step"][:: max(1, args.steps // 10)]:
        print(json.dumps(row))
    print(json.dumps(result["summary"]))
    if args.out:
        args.out.write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    main()
