"""Where a training run's first seconds go: each start-up phase timed on its own, in order.

The training loop overlaps some of these (the train step and the env reset compile side by side
in threads, the evaluator beside them under MuJoCo Warp, elsewhere while training starts);
`mjxmimic train` prints the overlapped total ("first iteration done ... since the start"). This
script runs them one after another so that each has its own figure, and also times the
kinematics alone: the array-code forward kinematics that the env uses against MJX's general
kinematics (mj_kinematics, mj_comPos, mj_comVel), which it replaced.

    python benchmarks/startup.py --preset gpu --clip walk --out benchmarks/results/startup_gpu.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

T0 = time.time()
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from mjxmimic.core import config as config_lib  # noqa: E402
from mjxmimic.envs.mjx_env import make_env  # noqa: E402
from mjxmimic.learn.ppo import export_params, make_trainer  # noqa: E402
from mjxmimic.ops.bench import environment_info  # noqa: E402
from mjxmimic.runs.evaluate import Evaluator  # noqa: E402

IMPORTED = time.time()


def timed(phases: dict, name: str, fn, *args):
    start = time.time()
    out = jax.block_until_ready(fn(*args))
    phases[name] = round(time.time() - start, 2)
    print(f"{name:32s} {phases[name]:7.2f} s", flush=True)
    return out


def mjx_kinematics(env):
    """MJX's general kinematics of a pose, as the env computed it before (for comparison)."""
    from mujoco import mjx

    model = mjx.put_model(env.scene.model, impl="jax")
    data0 = mjx.make_data(model)

    def kin(qpos, qvel):
        d = mjx.com_vel(model, mjx.com_pos(model, mjx.kinematics(model, data0.replace(qpos=qpos, qvel=qvel))))
        return d.xipos, d.xmat, d.cvel, d.subtree_com

    return kin


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="gpu")
    parser.add_argument("--clip", default="walk")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    overrides = dict(o.split("=", 1) for o in args.overrides)
    config = config_lib.make_config(args.preset, {"clip.name": args.clip, **overrides})
    phases = {"import": round(IMPORTED - T0, 2)}
    print(f"{'import':32s} {phases['import']:7.2f} s", flush=True)
    env = timed(phases, "build env", make_env, config)
    trainer = timed(phases, "build trainer", make_trainer, env, config)
    n = config.ppo.num_envs
    q, v = jnp.zeros((n, env.model.nq)), jnp.zeros((n, env.model.nv))
    q = q.at[:, 3].set(1.0)
    lower = lambda f, *a: jax.jit(f).lower(*a).compile()  # noqa: E731
    timed(phases, "compile kinematics (own)", lower, jax.vmap(env.physics.kinematics), q, v)
    timed(phases, "compile kinematics (MJX)", lower, jax.vmap(mjx_kinematics(env)), q, v)
    step = timed(phases, "compile train step", trainer.compile_train_step)
    timed(phases, "compile reset", trainer.compile_reset)
    evaluator = Evaluator(env, config, trainer.make_policy)
    timed(phases, "compile evaluator", evaluator.compile, export_params(trainer.abstract_state))
    ts = timed(phases, "init (draw starts)", trainer.init, config.run.seed)
    ts, _ = timed(phases, "first iteration (compiled)", step, ts)
    ts, _ = timed(phases, "second iteration", step, ts)
    timed(phases, "one evaluation (compiled)", evaluator, export_params(ts))
    phases["total"] = round(time.time() - T0, 2)
    print(f"{'total':32s} {phases['total']:7.2f} s", flush=True)
    if args.out:
        record = {"preset": args.preset, "clip": args.clip, "overrides": overrides, "num_envs": n,
                  "backend": env.backend, "phases_s": phases, **environment_info()}
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(record, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
