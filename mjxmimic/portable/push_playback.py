"""The Table 6 push test on MuJoCo's CPU simulator (`mjxmimic play POLICY --push`), numpy only:
the protocol of mjxmimic.task.push_protocol, one trial after another on the CPU env."""

from __future__ import annotations

from typing import Any, Callable

import numpy as np

from mjxmimic.task import push_protocol as protocol


def survival_rate(env: Any, policy: Callable[[np.ndarray], np.ndarray], force_n: float, turn: float,
                  starts: np.ndarray) -> float:
    """The share of trials, one per start time, that a push of `force_n` turned by `turn` from
    the facing does not knock down."""
    lead, push, total = protocol.steps(env.control_dt)
    survived = 0
    for t0 in starts:
        obs = env.reset_at(float(t0))
        fell = False
        for i in range(total):
            force = protocol.wrench(env.data.qpos, force_n, turn, float(lead <= i < lead + push),
                                    env.model.nbody, np)
            s = env.step(policy(obs), external_force=force)
            if s.failed:
                fell = True
                break
            if s.clip_end:  # a non-looping clip ended with the character standing
                break
            obs = s.obs
        survived += not fell
    return survived / len(starts)


def push_test(env: Any, policy: Callable[[np.ndarray], np.ndarray], trials: int = protocol.TRIALS,
              seed: int = 0, progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """push_forward_n and push_sideways_n on the CPU env, with every (force, survival rate) tried."""
    lib = env.spec.lib
    start_range = protocol.start_time_range(float(lib.duration[0]), bool(lib.loop[0]))
    starts = np.random.default_rng(seed).uniform(0.0, start_range, size=trials)
    return protocol.search(lambda force, turn: survival_rate(env, policy, force, turn, starts), trials, progress)
