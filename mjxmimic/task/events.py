"""Episode events: small pure functions that, from the motion state, return an external force on
the character for the coming control step ((nbody, 6): force and torque at each body's centre of
mass, world frame), summed over the events that `env.events` names. Off by default.

push: every `env.push_interval_s` of an episode, a horizontal force of `env.push_force_n` on the
root for `env.push_duration_s` (DeepMimic's Table 6 pushes are 0.2 s on the pelvis). Its direction
comes from the episode's event seed and the push's index by a golden-ratio sequence, so the step
needs no random numbers and MJX and the CPU env push alike: any compass direction, or with
`env.push_directions=table6` forward or sideways of the character's facing (the sideways ones
scaled by `env.push_sideways_scale`). With `env.push_force_max_n` each
push's force lies in [push_force_n, push_force_max_n], and with `env.push_interval_jitter_s` it
starts up to that long after its interval's start, each by a sequence of its own of the same
kind (`sequence`). With `env.push_ramp_samples` the trainer scales every push by its
curriculum's factor (`scale`), from 0 at the start of training (or at `env.push_start_samples`)
to 1, and back to 0 at `env.push_stop_samples`. With `env.push_episode_share` below 1 only that
share of the episodes is pushed at all, picked by the event seed.
"""

from __future__ import annotations

from typing import Any, Callable

from mjxmimic.core.config import EnvConfig, names_in
from mjxmimic.core.errors import UserError
from mjxmimic.physics import randomise
from mjxmimic.task import push_protocol
from mjxmimic.task.goals import PLASTIC

# the push curriculum's factor (env.push_ramp_samples) in an env state's info: set by the trainer
# before each iteration's rollout, kept through the episodes' restarts
PUSH_SCALE = "push_scale"
GOLDEN = 0.6180339887498949
# (seed multiplier, step) of each push quantity's sequence frac(multiplier * seed + step * k): the
# steps are the R2 sequence's (the plastic number's powers, as the goals use), irrational and
# unlike the golden ratio; the multipliers make push k's force and delay vary between episodes
# apart from its direction (with one multiplier all three would move together with the seed).
DIRECTION = (1.0, GOLDEN)
FORCE = (11.0, PLASTIC)
DELAY = (13.0, PLASTIC * PLASTIC)
# whether an episode is pushed at all (env.push_episode_share): one draw of the event seed's stream
# (randomise.uniform), independent of the pushes' sequences; just before envs.starts' START_BANK_DRAWS
PUSHED_DRAW = (1 << 20) - 4


def sequence(which: tuple[float, float], event_seed: Any, k: Any) -> Any:
    """Push k's number in [0, 1) for one quantity: a low-discrepancy sequence over k, shifted by
    the episode's event seed; smooth in the seed between its wraps, so float32 (MJX) and float64
    (numpy) agree to rounding."""
    multiplier, step = which
    return (multiplier * event_seed + step * k) % 1.0


def push(env: EnvConfig, episode_time: Any, event_seed: Any, nbody: int, xp: Any, qpos: Any = None,
         scale: Any = 1.0) -> Any:
    """The push force for a control step that starts `episode_time` seconds into the episode, the
    character in `qpos` (needed by env.push_directions=table6), times the curriculum's `scale`."""
    k = xp.floor(episode_time / env.push_interval_s)
    since = episode_time - k * env.push_interval_s - env.push_interval_jitter_s * sequence(DELAY, event_seed, k)
    active = (k >= 1) & (since > -1e-6) & (since < env.push_duration_s - 1e-6)  # none in the first interval
    force = env.push_force_n
    if env.push_force_max_n > 0:
        force = force + (env.push_force_max_n - env.push_force_n) * sequence(FORCE, event_seed, k)
    force = force * scale
    if env.push_episode_share < 1.0:  # a config constant: no work in the step when every episode is pushed
        force = force * (randomise.uniform(event_seed, 1, xp, first=PUSHED_DRAW)[0] < env.push_episode_share)
    u = sequence(DIRECTION, event_seed, k)
    if env.push_directions == "table6":  # forward half the time, else to the left or to the right
        turn = xp.where(u < 0.5, 0.0, xp.where(u < 0.75, 0.5, -0.5) * xp.pi)
        if env.push_sideways_scale != 1.0:  # a config constant: no work in the step when unscaled
            force = force * xp.where(u < 0.5, 1.0, env.push_sideways_scale)
        return push_protocol.wrench(qpos, force, turn, active, nbody, xp)
    return push_protocol.root_force(2.0 * xp.pi * u, force, active, nbody, xp)


TERMS: dict[str, Callable[[EnvConfig, Any, Any, int, Any, Any, Any], Any]] = {"push": push}


def parse(names: str) -> tuple[str, ...]:
    out = names_in(names)
    unknown = [n for n in out if n not in TERMS]
    if unknown:
        raise UserError(f"config key 'env.events': {unknown[0]!r} is not an event (events: {', '.join(TERMS)})")
    twice = [n for n in out if out.count(n) > 1]
    if twice:  # the forces add up: push,push would push twice as hard
        raise UserError(f"config key 'env.events': {twice[0]!r} is listed twice")
    return out


def external_force(names: tuple[str, ...], env: EnvConfig, episode_time: Any, event_seed: Any, nbody: int,
                   xp: Any, qpos: Any = None, scale: Any = 1.0) -> Any:
    """The summed force of the named events (each times the curriculum's `scale`), or None when
    there are none."""
    if not names:
        return None
    total = 0.0
    for name in names:
        total = total + TERMS[name](env, episode_time, event_seed, nbody, xp, qpos, scale)
    return total
