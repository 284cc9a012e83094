"""Domain randomisation of the physics (`env.friction_range`, `env.mass_range`; off by default).

Per episode, one factor scales the sliding friction of every geom (floor, terrain and character
alike: a contact's friction is the larger of its two geoms', so only scaling them all scales every
contact), and one factor per body scales its mass and its rotational inertia together (a denser or
lighter body of the same shape; scaling the mass alone would give it an inertia no mass
distribution has). Constants that MuJoCo derives from the masses once, at compile time (the
constraint solver's `body_invweight0`, `dof_invweight0`), keep their nominal values on every
backend, and so do the reward's and the observation's kinematics, which grade the pose, not the
mass (the whole-body centre of mass there uses the nominal masses).

The factors are drawn per episode, not once per env as Brax's and MuJoCo Playground's
`randomization_fn` do (there the batched model is built once, before training): here they are a
pure function of the episode's event seed, which every reset draws anyway, so each episode meets
another body and floor at no cost, and the CPU env applies the same factors as MJX for the same
event seed (playback and evaluation parity) without JAX. The draw is a counter-based integer hash
of (seed, index) in uint32 arithmetic, whose bits numpy and JAX compute alike; the pushes'
low-discrepancy sequences would tie the bodies' factors to one another.
"""

from __future__ import annotations

from typing import Any, NamedTuple

from mjxmimic.core.config import EnvConfig


class Scales(NamedTuple):
    """One episode's factors."""

    friction: Any  # () every geom's sliding friction
    mass: Any  # (nbody,) each body's mass and inertia


def enabled(env: EnvConfig) -> bool:
    """Whether any range differs from (1, 1): off leaves the model untouched, bit for bit."""
    return tuple(env.friction_range) != (1.0, 1.0) or tuple(env.mass_range) != (1.0, 1.0)


def _mix(x: Any, xp: Any) -> Any:
    """A 32-bit integer hash (Wellons' lowbias32): every input bit changes about half the output's."""
    x = x ^ (x >> 16)
    x = x * xp.asarray(0x7FEB352D, xp.uint32)
    x = x ^ (x >> 15)
    x = x * xp.asarray(0x846CA68B, xp.uint32)
    return x ^ (x >> 16)


def uniform(event_seed: Any, count: int, xp: Any, first: Any = 0) -> Any:
    """`count` numbers in [0, 1), float32, independent-looking, from the event seed alone (the
    seed's stream from index `first` on: disjoint ranges are independent draws); the seed is taken
    as float32 (as MJX holds it), so numpy and JAX give the same bits."""
    seed = xp.floor(xp.asarray(event_seed, xp.float32) * xp.asarray(2.0**24, xp.float32)).astype(xp.uint32)
    seed = xp.reshape(seed, (1,))  # numpy wraps uint32 arrays silently, not 0-d scalars
    salt = xp.asarray(0x9E3779B9, xp.uint32)  # so that seed 0 does not hash to 0
    index = xp.arange(count, dtype=xp.uint32) + xp.asarray(first).astype(xp.uint32)  # `first` may be traced
    bits = _mix(_mix(seed ^ salt, xp) + index, xp)
    return (bits >> 8).astype(xp.float32) * xp.asarray(2.0**-24, xp.float32)


def draw(env: EnvConfig, event_seed: Any, nbody: int, xp: Any) -> Scales | None:
    """The episode's factors, uniform in each range; None when randomisation is off."""
    if not enabled(env):
        return None
    u = uniform(event_seed, nbody + 1, xp)
    (f_lo, f_hi), (m_lo, m_hi) = env.friction_range, env.mass_range
    return Scales(friction=f_lo + (f_hi - f_lo) * u[0], mass=m_lo + (m_hi - m_lo) * u[1:])


def metrics(scales: Scales | None, xp: Any) -> dict[str, Any]:
    """What a run logs of the draw: the friction factor and the mean mass factor (over bodies
    with mass; the world body has none)."""
    if scales is None:
        return {}
    return {"randomise/friction": scales.friction, "randomise/mass": xp.mean(scales.mass[1:])}


def scaled_fields(body_mass: Any, body_inertia: Any, geom_friction: Any, scales: Scales,
                  xp: Any) -> dict[str, Any]:
    """The model's three randomised fields under `scales`, by name (MJX's Model and MuJoCo's
    MjModel both call them so)."""
    friction = xp.concatenate([geom_friction[:, :1] * scales.friction, geom_friction[:, 1:]], axis=1)
    extra = body_mass.shape[0] - scales.mass.shape[0]  # bodies after the character's (a ball) keep theirs
    mass = xp.concatenate([scales.mass, xp.ones(extra, scales.mass.dtype)]) if extra else scales.mass
    return {"body_mass": body_mass * mass, "body_inertia": body_inertia * mass[:, None],
            "geom_friction": friction}

