"""A composite policy on MJX (`mjxmimic eval COMPOSITE --knockdowns N`): the knock-down trials of
mjxmimic.task.recovery vmapped over a batch, with the gate of mjxmimic.envs.composite (the
function the CPU player runs) deciding every step of every trial, compiled once.

The trials are those the CPU player runs for the same seed (start times, push directions and the
gate's uniform numbers come from numpy, mjxmimic.task.recovery.draw_trials), so the two differ
only by the simulators. Batches run until N trials were knocked down (or `max_trials`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from mjxmimic.envs import composite as gate_lib
from mjxmimic.envs import step as step_lib
from mjxmimic.envs.mjx_env import ImitationEnv
from mjxmimic.portable.composite import COMPOSITE_TERMINATIONS, Composite, Player
from mjxmimic.portable.policy_numpy import deterministic_action, mlp, network_arrays
from mjxmimic.task import push_protocol
from mjxmimic.task import recovery as protocol


def _networks(c: Composite) -> tuple[Callable[[Any], Any], Callable[[Any], Any]]:
    """(values_of, actions_of): (E, obs) -> (E,) values and (E, act) deterministic actions, each
    expert's networks on its own row (jax.numpy; the numpy player's function)."""
    nets = []
    for pf in c.experts:
        mean, std, policy = network_arrays(pf.params, "policy", jnp)
        layers = {"policy": policy, "value": network_arrays(pf.params, "value", jnp)[2]}
        nets.append((mean, std, layers, pf.policy().action_size))

    def values_of(obs: Any) -> Any:
        return jnp.stack([mlp(obs[e], mean, std, layers["value"], jnp)[0]
                          for e, (mean, std, layers, _) in enumerate(nets)])

    def actions_of(obs: Any) -> Any:
        return jnp.stack([deterministic_action(mlp(obs[e], mean, std, layers["policy"], jnp), act, jnp)
                          for e, (mean, std, layers, act) in enumerate(nets)])

    return values_of, actions_of


def make_trials(c: Composite, batch: int, first: int, temperature: float | None = None,
                env: ImitationEnv | None = None) -> Callable:
    """jitted fn(start_time (B,), turn (B,), u (B, steps), force_n) -> per-trial arrays: up_at_push,
    down_step, recovered_step (mjxmimic.task.recovery.State) and expert_steps (B, E)."""
    cpu = Player(c, temperature)  # the gate's constants come from the numpy side, as the player's
    env = env or ImitationEnv(cpu.env.config, cpu.env.character, cpu.env.clips, max_worlds=batch)
    spec, physics = env.spec, env.physics
    gate = gate_lib.to_xp(cpu.gate, jnp)
    n = protocol.steps(env.control_dt)
    count, nbody = len(c.experts), env.model.nbody
    values_of, actions_of = _networks(c)

    def trial(t0: Any, turn: Any, u: Any, force_n: Any) -> dict[str, Any]:
        data, motion, _ = step_lib.reset(spec, physics, jnp.int32(first), t0)

        def body(carry, k):
            data, motion, rule, counts, alive = carry
            qpos, qvel = physics.qpos_qvel(data)
            locomotion = gate.loop[motion.clip]
            d = gate_lib.decide(spec, gate, physics, qpos, qvel, motion, values_of, u[k])
            chosen = gate_lib.switch(spec, motion, d, qpos, jnp)
            action = actions_of(d.obs)[d.choice]
            pushing = ((k >= n.lead) & (k < n.lead + n.push)).astype(jnp.float32)
            force = push_protocol.wrench(qpos, force_n, turn, pushing, nbody, jnp)
            out = step_lib.control_step(spec, physics, data, chosen, action, COMPOSITE_TERMINATIONS, force)
            new_rule = protocol.update(rule, k, d.root_height, locomotion, d.pose_error, gate.stand_height, n, jnp)
            rule = jax.tree_util.tree_map(lambda a, b: jnp.where(alive, a, b), new_rule, rule)
            counts = counts + (alive & (jnp.arange(count) == d.choice)).astype(jnp.int32)
            alive = alive & ~out.failed  # a state the simulator lost ends the trial where it was
            data = physics.where(alive, out.state, data)
            motion = jax.tree_util.tree_map(lambda a, b: jnp.where(alive, a, b), out.motion, motion)
            return (data, motion, rule, counts, alive), None

        start = (data, motion, protocol.start((), jnp), jnp.zeros(count, jnp.int32), jnp.ones((), bool))
        (_, _, rule, counts, _), _ = jax.lax.scan(body, start, jnp.arange(n.total))
        return {**rule._asdict(), "expert_steps": counts}

    return jax.jit(jax.vmap(trial, in_axes=(0, 0, 0, None)))


def recovery_rate(c: Composite, knockdowns: int = 50, force_n: float = protocol.DEFAULT_FORCE_N,
                  direction: str = "random", seed: int = 0, batch: int = 64, max_trials: int | None = None,
                  expert: str | None = None, temperature: float | None = None,
                  progress: Callable[[int, int, int], Any] | None = None) -> dict[str, Any]:
    """The recovery rate over the first `knockdowns` knock-downs (mjxmimic.task.recovery), trials
    in batches of `batch` on MJX (at most `max_trials`, default 4 per knock-down asked)."""
    started = time.time()
    first = c.start_expert(expert)
    run = make_trials(c, batch, first, temperature)
    control_dt = 1.0 / c.config().env.control_hz
    n = protocol.steps(control_dt)
    duration = float(c.experts[first].clip().duration)
    limit = max_trials or 4 * knockdowns
    parts: list[dict[str, np.ndarray]] = []
    done = 0
    while done < limit:
        trials = protocol.draw_trials(seed, done, batch, duration, direction, n.total)
        out = jax.device_get(run(jnp.asarray(trials.start_time), jnp.asarray(trials.turn), jnp.asarray(trials.u),
                                 jnp.float32(force_n)))
        parts.append({k: np.asarray(v) for k, v in out.items()})
        done += batch
        knocked = int(sum(np.sum(p["down_step"] >= 0) for p in parts))
        if progress is not None:
            progress(done - 1, knocked, int(sum(np.sum(p["recovered_step"] >= 0) for p in parts)))
        if knocked >= knockdowns:
            break
    cols = {k: np.concatenate([p[k] for p in parts])[:limit] for k in parts[0]}
    out = protocol.summarize(cols["up_at_push"], cols["down_step"], cols["recovered_step"], cols["expert_steps"],
                             c.names, knockdowns, control_dt)
    gate_t = c.temperature if temperature is None else temperature
    return {"composite": str(c.path), "simulator": f"MJX ({jax.default_backend()})", "force_n": force_n,
            "direction": direction, "seed": seed, "start_expert": c.names[first], "temperature": gate_t,
            "batch": batch, "eval_seconds": time.time() - started, **out}
