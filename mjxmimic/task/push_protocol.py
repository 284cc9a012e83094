"""DeepMimic's Table 6 push test (EVALUATION.md, "Push robustness"), the parts that do not depend
on a simulator: when and where a trial pushes, which force it pushes with, which trials count as
survived, and the search for the largest force that 90 % of the trials survive. `mjxmimic eval
--push` runs the trials on MJX (mjxmimic.runs.push_eval), `mjxmimic play --push` on MuJoCo C.

A trial starts from the reference state at a random clip time (RSI), tracks for `LEAD_S`, then a
horizontal force pushes the root (pelvis) for `PUSH_S`, along the character's current facing
(forward) or 90 degrees to its left (sideways); it survives if no fall-contact termination fires
within `AFTER_S` of the push's end. A non-looping clip may end before that: a trial that reaches
the clip's end standing survives. All trials of one search share their start times, so that the
survival rate depends on the force alone.
"""

from __future__ import annotations

import math
import time
from typing import Any, Callable

from mjxmimic.core import quat
from mjxmimic.core.kinematics import ROOT_BODY

LEAD_S = 1.0
PUSH_S = 0.2
AFTER_S = 5.0
TRIALS = 32
SURVIVAL = 0.9
RESOLUTION_N = 10.0
MAX_FORCE_N = 5000.0
DIRECTIONS = {"forward": 0.0, "sideways": 0.5 * math.pi}  # turn from the facing, counter-clockwise


def steps(control_dt: float) -> tuple[int, int, int]:
    """(first push step, push steps, trial steps) at the control rate."""
    lead, push, after = (int(round(s / control_dt)) for s in (LEAD_S, PUSH_S, AFTER_S))
    return lead, push, lead + push + after


def start_time_range(duration: float, loop: bool) -> float:
    """Trials start in [0, this): anywhere in a looping clip; early enough in a non-looping one
    that the push ends before the clip does."""
    return duration if loop else max(duration - LEAD_S - PUSH_S, 0.0)


def root_force(yaw: Any, force_n: Any, active: Any, nbody: int, xp: Any) -> Any:
    """(nbody, 6) world-frame force and torque: `force_n` on the root horizontally along the world
    angle `yaw`, where `active`."""
    zero = xp.zeros_like(yaw)
    f = force_n * active * xp.stack([xp.cos(yaw), xp.sin(yaw), zero, zero, zero, zero])
    on_root = xp.arange(nbody) == ROOT_BODY
    return xp.where(on_root[:, None], f[None, :], 0.0).astype(xp.float32)


def wrench(qpos: Any, force_n: Any, turn: Any, active: Any, nbody: int, xp: Any) -> Any:
    """`root_force` along the character's facing turned by `turn`."""
    return root_force(quat.heading(qpos[3:7], xp) + turn, force_n, active, nbody, xp)


def scheduled(qpos: Any, push: tuple[float, float, float], step: int, control_dt: float, nbody: int,
              xp: Any) -> tuple[Any, bool]:
    """(wrench, acting) at control step `step` of one scheduled `push` (force N, start time s, turn
    from the facing), which acts for PUSH_S as the test's does (render --push, play --push-once)."""
    newtons, at, turn = push
    acting = at - 1e-6 <= step * control_dt < at + PUSH_S - 1e-6
    return wrench(qpos, newtons, turn, float(acting), nbody, xp), acting


def largest_survived_force(survival_rate: Callable[[float], float], resolution: float = RESOLUTION_N,
                           max_force: float = MAX_FORCE_N) -> tuple[float, list[tuple[float, float]]]:
    """The largest force (N) whose survival rate is at least SURVIVAL, to within `resolution`:
    doubling from 100 N until a force fails, then bisection. Returns it and every (force, rate)
    tried. 0 when even an unpushed trial set does not survive; `max_force` when nothing fails."""
    tried: list[tuple[float, float]] = []

    def ok(force: float) -> bool:
        rate = float(survival_rate(force))
        tried.append((force, rate))
        return rate >= SURVIVAL

    if not ok(0.0):
        return 0.0, tried
    low, high = 0.0, 100.0
    while ok(high):
        low = high
        if high >= max_force:
            return max_force, tried
        high = min(2.0 * high, max_force)
    while high - low > resolution:
        mid = 0.5 * (low + high)
        if ok(mid):
            low = mid
        else:
            high = mid
    return low, tried


def search(survival_rate: Callable[[float, float], float], trials: int,
           progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """push_forward_n and push_sideways_n, with every (force, survival rate) tried, from
    `survival_rate(force_n, turn)` of a simulator's trial set."""
    start = time.time()
    result: dict[str, Any] = {"push_trials": trials, "push_seconds_each": PUSH_S}
    for name, turn in DIRECTIONS.items():
        def rate(force: float) -> float:
            value = survival_rate(force, turn)
            if progress is not None:
                progress(f"push {name} {force:.0f} N: {value:.0%} survive")
            return value

        result[f"push_{name}_n"], result[f"push_{name}_tried"] = largest_survived_force(rate)
    result["push_eval_seconds"] = time.time() - start
    return result
