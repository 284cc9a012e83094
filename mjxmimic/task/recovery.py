"""The composite's knock-down and recovery protocol (issue 14, part 5), the parts that do not
depend on a simulator: trial timing and parameters, and the per-step rule that says when a trial
was knocked down and whether it recovered. `mjxmimic eval COMPOSITE --knockdowns N` runs the
trials on MJX (mjxmimic.runs.composite_eval), `mjxmimic play COMPOSITE --knockdowns N` on MuJoCo C
(mjxmimic.portable.composite); both draw the same trials from the same seed.

A trial: the reference state of the start expert's (a locomotion clip's) clip at a random time;
the composite runs (the gate chooses every step) for LEAD_S; a horizontal force of FORCE newtons
pushes the pelvis for PUSH_S (push_protocol.wrench: along the facing turned by the trial's
direction); falls do not end anything.

- Valid trial: the character is still up (root at least UP_FRACTION of the standing height) when
  the push starts; one that fell before is counted apart and not as a knock-down.
- Knocked down: the root (pelvis centre of mass) drops below DOWN_FRACTION of the standing height
  (the mean root height of the looping experts' references, about 0.93 m for the humanoid) within
  DOWN_WITHIN_S of the push's start. A trial that stays up is no knock-down and is not counted.
- Recovered: within RECOVER_S of the knock-down (its first low step), the character has been, for
  HOLD_S without a break, up (root at least UP_FRACTION of the standing height) and tracking a
  locomotion clip: a looping expert active and its mean joint angle from its reference (turned and
  moved to the character) at most POSE_TOLERANCE_RAD.

The recovery rate is the share of the first N knock-downs (in trial order) that recovered.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

LEAD_S = 2.0
PUSH_S = 0.2
DOWN_WITHIN_S = 2.0
RECOVER_S = 5.0
HOLD_S = 0.5
DOWN_FRACTION = 0.5
UP_FRACTION = 0.8
POSE_TOLERANCE_RAD = 0.4
DEFAULT_FORCE_N = 600.0
DIRECTIONS = {"forward": 0.0, "sideways": 0.5 * math.pi, "backward": math.pi}  # and "random"


class Steps(NamedTuple):
    lead: int  # first push step
    push: int  # push steps
    down_within: int  # steps after the push's start in which a knock-down counts
    recover: int  # steps after the knock-down to recover in
    hold: int  # steps the recovered state must last
    total: int  # steps of a trial


def steps(control_dt: float) -> Steps:
    lead, push, within, recover, hold = (round(s / control_dt)
                                         for s in (LEAD_S, PUSH_S, DOWN_WITHIN_S, RECOVER_S, HOLD_S))
    return Steps(lead, push, within, recover, hold, lead + within + recover)


class Trials(NamedTuple):
    """Trial parameters, numpy: start time, push direction (turn from the facing) and the gate's
    uniform numbers, one per step."""

    start_time: np.ndarray  # (T,)
    turn: np.ndarray  # (T,)
    u: np.ndarray  # (T, steps)


def draw_trials(seed: int, first: int, count: int, duration: float, direction: str, total_steps: int) -> Trials:
    """Trials first .. first + count - 1 of a seed: each from its own generator (seed, index), so
    a trial is the same whatever the batch it runs in, on MJX and on the CPU."""
    t0, turn, u = [], [], []
    for i in range(first, first + count):
        rng = np.random.default_rng([seed, i])
        t0.append(rng.uniform(0.0, duration))
        turn.append(rng.uniform(0.0, 2 * math.pi) if direction == "random" else DIRECTIONS[direction])
        u.append(rng.uniform(size=total_steps))
    return Trials(np.asarray(t0, np.float32), np.asarray(turn, np.float32), np.asarray(u, np.float32).reshape(count, -1))


class State(NamedTuple):
    """Per trial: whether it was up when the push started (-1: not there yet), the step of the
    knock-down (-1: none yet), the run of good steps, the step at which the recovery held (-1: none)."""

    up_at_push: Any
    down_step: Any
    hold: Any
    recovered_step: Any


def start(shape: Any, xp: Any) -> State:
    minus = xp.full(shape, -1, xp.int32)
    return State(up_at_push=minus, down_step=minus, hold=xp.zeros(shape, xp.int32), recovered_step=minus)


def update(s: State, k: Any, root_height: Any, locomotion: Any, pose_error: Any, stand_height: float,
           n: Steps, xp: Any) -> State:
    """The rule after measuring the state at the start of step k (module docstring)."""
    low = root_height < DOWN_FRACTION * stand_height
    up = root_height >= UP_FRACTION * stand_height
    up_at_push = xp.where(k == n.lead, xp.where(up, 1, 0), s.up_at_push).astype(xp.int32)
    in_window = (k >= n.lead) & (k < n.lead + n.down_within) & (up_at_push == 1)
    down_step = xp.where((s.down_step < 0) & low & in_window, k, s.down_step).astype(xp.int32)
    good = up & locomotion & (pose_error <= POSE_TOLERANCE_RAD)
    hold = xp.where((down_step >= 0) & good, s.hold + 1, 0).astype(xp.int32)
    done_now = (down_step >= 0) & (s.recovered_step < 0) & (hold >= n.hold) & (k - down_step <= n.recover)
    recovered_step = xp.where(done_now, k, s.recovered_step).astype(xp.int32)
    return State(up_at_push=up_at_push, down_step=down_step, hold=hold, recovered_step=recovered_step)


def summarize(up_at_push: np.ndarray, down_step: np.ndarray, recovered_step: np.ndarray, expert_steps: np.ndarray,
              names: list[str], knockdowns: int, control_dt: float) -> dict[str, Any]:
    """The rate over the first `knockdowns` knocked-down trials (trial order), with recovery
    times and each expert's share of the steps of those trials."""
    knocked = np.flatnonzero(down_step >= 0)[:knockdowns]
    rec = recovered_step[knocked] >= 0
    times = (recovered_step[knocked] - down_step[knocked])[rec] * control_dt
    steps_used = expert_steps[knocked].sum(axis=0)
    upto = slice(0, (knocked[-1] + 1) if len(knocked) and len(knocked) >= knockdowns else len(down_step))
    return {
        "knockdowns": len(knocked),
        "knockdowns_asked": int(knockdowns),
        "trials": len(down_step),
        "trials_used": int(upto.stop),
        "fell_before_push": int(np.sum(up_at_push[upto] != 1)),
        "not_knocked_down": int(np.sum((up_at_push[upto] == 1) & (down_step[upto] < 0))),
        "recovered": int(rec.sum()),
        "recovery_rate": float(rec.mean()) if len(knocked) else None,
        "recovery_s_mean": float(times.mean()) if len(times) else None,
        "expert_share": {n: float(s) / max(float(steps_used.sum()), 1.0) for n, s in zip(names, steps_used)},
        "knocked_trials": [int(i) for i in knocked],
    }
