"""Episode events: small pure functions that, from the motion state, return an external force on
the character for the coming control step ((nbody, 6): force and torque at each body's centre of
mass, world frame), summed over the events that `env.events` names. Off by default.

push: every `env.push_interval_s` of an episode, a horizontal force of `env.push_force_n` on the
root for `env.push_duration_s` (DeepMimic's Table 6 pushes are 0.2 s on the pelvis). Its direction
comes from the episode's event seed and the push's index by a golden-ratio sequence, so the step
needs no random numbers and MJX and the CPU env push alike.
"""

from __future__ import annotations

from typing import Any, Callable

from mjxmimic.core.config import EnvConfig
from mjxmimic.core.errors import UserError
from mjxmimic.core.kinematics import ROOT_BODY

GOLDEN = 0.6180339887498949


def push(env: EnvConfig, episode_time: Any, event_seed: Any, nbody: int, xp: Any) -> Any:
    """The push force for a control step that starts `episode_time` seconds into the episode."""
    k = xp.floor(episode_time / env.push_interval_s)
    since = episode_time - k * env.push_interval_s
    active = (k >= 1) & (since < env.push_duration_s - 1e-6)  # no push in the first interval
    turn = 2.0 * xp.pi * ((event_seed + GOLDEN * k) % 1.0)
    zero = xp.zeros_like(turn)
    wrench = env.push_force_n * active * xp.stack([xp.cos(turn), xp.sin(turn), zero, zero, zero, zero])
    on_root = xp.arange(nbody) == ROOT_BODY
    return xp.where(on_root[:, None], wrench[None, :], 0.0).astype(xp.float32)


TERMS: dict[str, Callable[[EnvConfig, Any, Any, int, Any], Any]] = {"push": push}


def parse(names: str) -> tuple[str, ...]:
    out = tuple(n.strip() for n in names.split(",") if n.strip())
    unknown = [n for n in out if n not in TERMS]
    if unknown:
        raise UserError(f"config key 'env.events': {unknown[0]!r} is not an event (events: {', '.join(TERMS)})")
    return out


def external_force(names: tuple[str, ...], env: EnvConfig, episode_time: Any, event_seed: Any, nbody: int,
                   xp: Any) -> Any:
    """The summed force of the named events, or None when there are none."""
    if not names:
        return None
    total = 0.0
    for name in names:
        total = total + TERMS[name](env, episode_time, event_seed, nbody, xp)
    return total
