"""Does data-parallel stepping give the same physics as one device? (issue 20)

Steps one batch of envs from the same states with the same random actions twice: split over all
local devices (`Trainer.step_envs`, each device stepping its slice) and whole on the first device.
Reports, for each device's slice, the largest differences of qpos, observation and reward after
each step, and whether any slice came back all zeros or non-finite (the failure to look for: a
device whose foreign physics call wrote nothing). Differences of float rounding are expected
(the two compile to different programs); a wrong slice shows up as differences of order one.

    python benchmarks/multi_gpu_parity.py --preset gpu --clip walk --num-envs 1024 --steps 8 --out parity.json
CPU check: XLA_FLAGS=--xla_force_host_platform_device_count=2 JAX_PLATFORMS=cpu python ... --preset cpu
"""

from __future__ import annotations

import argparse
import json
import sys

import jax
import numpy as np

from mjxmimic.core.config import make_config
from mjxmimic.envs.mjx_env import make_env
from mjxmimic.learn.ppo import make_trainer
from mjxmimic.ops.bench import environment_info


def _slices(x: np.ndarray, devices: int) -> list[np.ndarray]:
    return np.split(np.asarray(x, np.float64), devices)


def compare(preset: str, clip: str, num_envs: int, steps: int, seed: int = 0) -> dict:
    devices = jax.local_devices()
    if len(devices) < 2:
        raise SystemExit(f"multi_gpu_parity: needs at least 2 local devices, found {len(devices)}")
    config = make_config(preset, {"clip.name": clip, "ppo.num_envs": num_envs, "ppo.num_minibatches": 1})
    env = make_env(config)
    split = make_trainer(env, config)
    whole = make_trainer(env, config, devices[:1])
    state_split = split.reset_envs(jax.random.PRNGKey(seed))
    state_whole = jax.device_put(jax.device_get(state_split), devices[0])
    step_split, step_whole = jax.jit(split.step_envs), jax.jit(whole.step_envs)
    d = len(devices)
    rows = []
    for t in range(steps):
        action = jax.random.uniform(jax.random.PRNGKey(seed * 1000 + t), (num_envs, env.action_size),
                                    minval=-1.0, maxval=1.0)
        state_split = step_split(state_split, jax.device_put(action, split.batch_sharded))
        state_whole = step_whole(state_whole, jax.device_put(action, devices[0]))
        a, b = jax.device_get((state_split, state_whole))
        slices = [{"device": str(device)} for device in devices]
        for name, x, y in (("qpos", a.pipeline_state.qpos, b.pipeline_state.qpos), ("obs", a.obs, b.obs),
                           ("reward", a.reward, b.reward)):
            for out, xs, ys in zip(slices, _slices(x, d), _slices(y, d)):
                out[f"{name}_max_abs_diff"] = float(np.max(np.abs(xs - ys)))
                out[f"{name}_finite"] = bool(np.all(np.isfinite(xs)))
                out[f"{name}_all_zero"] = bool(not np.any(xs))
        rows.append({"step": t + 1, "slices": slices})
    return {"environment": environment_info(), "preset": preset, "clip": clip, "num_envs": num_envs,
            "backend": env.backend, "steps": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="gpu")
    parser.add_argument("--clip", default="walk")
    parser.add_argument("--num-envs", type=int, default=1024)
    parser.add_argument("--steps", type=int, default=8)
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    result = compare(args.preset, args.clip, args.num_envs, args.steps)
    for row in result["steps"]:
        print(f"step {row['step']}: " + "; ".join(
            f"{s['device']} qpos {s['qpos_max_abs_diff']:.2e} obs {s['obs_max_abs_diff']:.2e} "
            f"reward {s['reward_max_abs_diff']:.2e}" + (" NON-FINITE" if not s["qpos_finite"] else "")
            + (" ALL-ZERO" if s["qpos_all_zero"] else "") for s in row["slices"]))
    if args.out:
        with open(args.out, "w") as f:
            json.dump(result, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
