"""A new run that starts from a trained policy (`run.init_from`, `mjxmimic train --init-from`).

It takes the policy and value networks and the observation normaliser of an exported policy file
or of a run folder (its policy.npz, else its best checkpoint), so that a skill learnt once can go
on learning under other settings: with pushes, on terrain, with a task, or for longer. The
optimiser, the learning-rate schedule and the sample count start afresh, as in any new run. The
normaliser keeps the statistics of the samples the source was trained on, so it moves no faster
than it would have in the source.

The source must fit the run: the same observation (character, observation terms, heading frame,
task, terrain), the same actions, the same network sizes. Anything else is a one-line error
before training.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import jax.numpy as jnp
import numpy as np
from brax.training import types as brax_types

from mjxmimic.core import config as config_lib
from mjxmimic.core.errors import UserError
from mjxmimic.portable.policy_file import PolicyFile, observation_layout
from mjxmimic.runs import folder

KEY = "run.init_from"


def _parts(layout: list[dict[str, Any]]) -> list[tuple]:
    return [(p["name"], p["size"], tuple(p.get("bodies") or ())) for p in layout]


def _shapes(layers: dict) -> dict[str, dict[str, tuple]]:
    return {name: {k: tuple(np.shape(v)) for k, v in layer.items()} for name, layer in layers.items()}


def _described(shapes: dict[str, tuple] | None) -> str:
    return ", ".join(f"{k} {v}" for k, v in sorted(shapes.items())) if shapes else "missing"


def _check_networks(pf: PolicyFile, config: config_lib.Config, observation_size: int, action_size: int,
                    source: Path) -> None:
    """The file's layers against the shapes this run's networks will have (traced, not built)."""
    import jax

    from mjxmimic.learn.ppo import make_networks

    networks = make_networks(observation_size, action_size, config)
    key = jax.random.PRNGKey(0)
    for net, init, setting in (("policy", networks.policy_network.init, "ppo.policy_hidden"),
                               ("value", networks.value_network.init, "ppo.value_hidden")):
        want = _shapes(jax.eval_shape(init, key)["params"])
        have = _shapes(pf.params[net])
        if have != want:
            name = next(n for n in sorted(set(have) | set(want)) if have.get(n) != want.get(n))
            raise UserError(f"{KEY} {source}: the {net} network's layer {name} is {_described(have.get(name))} "
                            f"there, {_described(want.get(name))} here (set {setting} as the source was trained)")


def read_start(config: config_lib.Config, character: Any, clip_names: list[str]) -> PolicyFile:
    """The policy file that `run.init_from` names, checked against this run's observation, actions
    and network sizes (a one-line UserError where it does not fit)."""
    source = Path(config.run.init_from)
    if not source.exists():
        raise UserError(f"{KEY} {source}: no such policy file or run folder")
    pf = folder.load_policy_file(source, export_if_missing=True)
    if not pf.has_value():
        raise UserError(f"{KEY} {source}: the file lacks the value network (exported before it was carried); "
                        f"re-export it with `mjxmimic export RUN`")
    layout = observation_layout(character, config, clip_names)
    have, want = _parts(pf.manifest["observation"]["layout"]), _parts(layout)
    if have != want:
        i = next((i for i, (a, b) in enumerate(zip(have, want)) if a != b), min(len(have), len(want)))
        theirs = f"'{have[i][0]}' ({have[i][1]})" if i < len(have) else "nothing"
        ours = f"'{want[i][0]}' ({want[i][1]})" if i < len(want) else "nothing"
        raise UserError(f"{KEY} {source}: its observation does not fit this run's: part {i + 1} is {theirs} "
                        f"there, {ours} here (the same character, env.observations, task and terrain are needed)")
    theirs, ours = pf.config().env.observation_heading, config.env.observation_heading
    if theirs != ours:
        raise UserError(f"{KEY} {source}: it observes in the {theirs!r} heading frame, this run in the {ours!r} one "
                        f"(set env.observation_heading as the source was trained)")
    if pf.manifest["character"]["action_size"] != character.action_size:
        raise UserError(f"{KEY} {source}: its policy gives {pf.manifest['character']['action_size']} actions, "
                        f"this run's character takes {character.action_size}")
    _check_networks(pf, config, sum(p["size"] for p in layout), character.action_size, source)
    return pf


def _as_run_arrays(run_params: dict, layers: dict) -> dict:
    ours = run_params["params"]
    return {**run_params, "params": {name: {k: jnp.asarray(layers[name][k], v.dtype) for k, v in layer.items()}
                                     for name, layer in ours.items()}}


def apply_start(ts: Any, pf: PolicyFile, config: config_lib.Config) -> Any:
    """`ts` (a fresh TrainState) with the networks and normaliser of `pf` (from `read_start`)."""
    policy = _as_run_arrays(ts.params.policy, pf.params["policy"])
    value = _as_run_arrays(ts.params.value, pf.params["value"])
    norm = ts.normalizer
    # the source's sample count (one iteration's worth for a file that lacks it)
    count = int(pf.manifest.get("training", {}).get("samples") or config.ppo.num_envs * config.ppo.unroll_length)
    std = jnp.asarray(pf.params["normalizer"]["std"], norm.std.dtype)
    normalizer = norm.replace(
        mean=jnp.asarray(pf.params["normalizer"]["mean"], norm.mean.dtype), std=std,
        summed_variance=std * std * float(count),
        count=brax_types.UInt64(hi=jnp.asarray(count >> 32, norm.count.hi.dtype),
                                lo=jnp.asarray(count & 0xFFFFFFFF, norm.count.lo.dtype)))
    return ts.replace(params=ts.params.replace(policy=policy, value=value), normalizer=normalizer)
