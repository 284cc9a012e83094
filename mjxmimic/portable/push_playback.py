"""The Table 6 push test on MuJoCo's CPU simulator (`mjxmimic play POLICY --push`), numpy only:
the protocol of mjxmimic.task.push_protocol on the CPU env, its trials spread over `workers`
forked processes (each with its own copy of the env; a trial depends on its start time alone, so
the result is the same for any number of workers)."""

from __future__ import annotations

import contextlib
import multiprocessing
from typing import Any, Callable, Iterator

import numpy as np

from mjxmimic.task import push_protocol as protocol

_FORKED: tuple[Any, Callable] | None = None  # the (env, policy) that forked workers inherit


def survives(env: Any, policy: Callable[[np.ndarray], np.ndarray], force_n: float, turn: float,
             t0: float) -> bool:
    """Whether the trial that starts at clip time `t0` stays up through a push of `force_n`
    turned by `turn` from the facing."""
    lead, push, total = protocol.steps(env.control_dt)
    obs = env.reset_at(float(t0))
    for i in range(total):
        force = protocol.wrench(env.data.qpos, force_n, turn, float(lead <= i < lead + push),
                                env.model.nbody, np)
        s = env.step(policy(obs), external_force=force)
        if s.failed:
            return False
        if s.clip_end:  # a non-looping clip ended with the character standing
            return True
        obs = s.obs
    return True


def _forked_trial(args: tuple[float, float, float]) -> bool:
    env, policy = _FORKED
    return survives(env, policy, *args)


@contextlib.contextmanager
def trial_pool(env: Any, policy: Callable[[np.ndarray], np.ndarray], workers: int) -> Iterator[Any]:
    """Processes forked with `env` and `policy` for `survival_rate`'s trials; None (one trial
    after another here) for one worker or where processes cannot be forked."""
    global _FORKED
    if workers <= 1 or "fork" not in multiprocessing.get_all_start_methods():
        yield None
        return
    _FORKED = (env, policy)
    try:
        with multiprocessing.get_context("fork").Pool(workers) as pool:
            yield pool
    finally:
        _FORKED = None


def survival_rate(env: Any, policy: Callable[[np.ndarray], np.ndarray], force_n: float, turn: float,
                  starts: np.ndarray, pool: Any = None) -> float:
    """The share of trials, one per start time, that a push of `force_n` turned by `turn` from
    the facing does not knock down (in `pool`'s workers, from `trial_pool`, when given)."""
    if pool is None:
        survived = [survives(env, policy, force_n, turn, t0) for t0 in starts]
    else:
        survived = pool.map(_forked_trial, [(force_n, turn, float(t0)) for t0 in starts], chunksize=1)
    return sum(survived) / len(starts)


def push_test(env: Any, policy: Callable[[np.ndarray], np.ndarray], trials: int = protocol.TRIALS,
              seed: int = 0, progress: Callable[[str], None] | None = None, workers: int = 1) -> dict[str, Any]:
    """push_forward_n and push_sideways_n on the CPU env, with every (force, survival rate) tried
    and the simulator that made them."""
    lib = env.spec.lib
    start_range = protocol.start_time_range(float(lib.duration[0]), bool(lib.loop[0]))
    starts = np.random.default_rng(seed).uniform(0.0, start_range, size=trials)
    with trial_pool(env, policy, min(workers, trials)) as pool:
        return {"simulator": env.physics.simulator,
                **protocol.search(lambda force, turn: survival_rate(env, policy, force, turn, starts, pool),
                                  trials, progress)}
