"""Where an episode starts and how long an evaluation episode runs, for every backend and both
array modules: RSI's reference state (with the reset noise, the reset velocity factor and a
terrain's start pad), a state of the start bank instead (env.start_states), the range that start
times are drawn from, and the NR horizon from a start time (EVALUATION.md)."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from mjxmimic.core import terrain as terrain_lib
from mjxmimic.core.config import Config
from mjxmimic.core.layout import join_qpos
from mjxmimic.motion import library as motion_lib
from mjxmimic.physics import randomise
from mjxmimic.physics.pd import action_to_targets

if TYPE_CHECKING:  # step builds the Spec and calls these
    from mjxmimic.envs.step import Spec


def start_state(spec: Spec, clip: Any, t: Any, event_seed: Any, xp: Any) -> tuple[Any, Any]:
    """RSI's (qpos, qvel): the reference at time t, on a terrain placed on the start pad of the
    lane that the event seed picks (mjxmimic.core.terrain.start_pose)."""
    qpos, qvel = motion_lib.sample(spec.lib, clip, t, xp)
    if spec.config.env.reset_noise_rad > 0:
        qpos = perturbed_pose(spec, qpos, event_seed, xp)
    lo, hi = spec.config.env.reset_velocity_range
    if (lo, hi) != (1.0, 1.0):
        u = randomise.uniform(event_seed, 1, xp, first=RESET_VELOCITY_DRAW)[0]
        qvel = qvel * (lo + (hi - lo) * u).astype(qvel.dtype)
    if spec.terrain is not None:
        qpos, qvel = terrain_lib.start_pose(spec.terrain, qpos, qvel, event_seed, xp)
    return qpos, qvel


RESET_NOISE_DRAWS = 1 << 20  # where the reset noise's draws start in the event seed's stream (randomise.uniform)
RESET_VELOCITY_DRAW = (1 << 20) - 1  # the reset velocity factor's draw, before the noise's
START_BANK_DRAWS = (1 << 20) - 3  # whether, and which, start state of the bank: two draws before that
# task.events.PUSHED_DRAW, (1 << 20) - 4, is whether an episode is pushed at all


def from_bank(spec: Spec, clip: Any, t: Any, qpos: Any, qvel: Any, event_seed: Any, xp: Any) -> tuple[Any, ...]:
    """(clip, t, qpos, qvel): a state of env.start_states in env.start_states_fraction of the
    episodes (by the event seed), else the RSI state given."""
    bank = spec.start_bank
    u = randomise.uniform(event_seed, 2, xp, first=START_BANK_DRAWS)
    use = u[0] < spec.config.env.start_states_fraction
    i = xp.minimum((u[1] * bank.time.shape[0]).astype(xp.int32), bank.time.shape[0] - 1)
    return (xp.where(use, bank.clip[i], clip).astype(xp.int32), xp.where(use, bank.time[i], t).astype(xp.float32),
            xp.where(use, bank.qpos[i], qpos).astype(qpos.dtype), xp.where(use, bank.qvel[i], qvel).astype(qvel.dtype))


def perturbed_pose(spec: Spec, qpos: Any, event_seed: Any, xp: Any) -> Any:
    """`qpos` with every actuated joint turned by uniform noise of up to env.reset_noise_rad, drawn
    from the event seed (so the CPU env starts where MJX does): a residual action of uniform
    entries in [-1, 1] at that scale, applied to the pose as the PD targets apply one."""
    layout = spec.layout
    noise = 2.0 * randomise.uniform(event_seed, spec.action_size, xp, first=RESET_NOISE_DRAWS) - 1.0
    turned = action_to_targets(layout, noise, qpos, "residual", spec.config.env.reset_noise_rad, xp)
    scalars = xp.concatenate([qpos[layout.q_scalar[:3]], turned.hinge.astype(qpos.dtype)])
    quats = xp.concatenate([qpos[layout.q_quat[:1]], turned.ball.astype(qpos.dtype)])
    return join_qpos(layout, scalars, quats, xp)


def start_time_range(spec: Spec, clip: Any, xp: Any) -> Any:
    """RSI draws t in [0, this): the clip's duration, less one control step for a non-looping clip
    (so that at least one step remains); under the throw task only up to the release, so that every
    episode throws (and every evaluation trial is a throw)."""
    dur = spec.lib.duration[clip]
    return start_limit(spec.config, xp.where(spec.lib.loop[clip], dur, xp.maximum(dur - spec.control_dt, 0.0)), xp)


def start_limit(config: Config, limit: Any, xp: Any = np) -> Any:
    """`limit` (the end of a clip's start times), under the throw task no later than the release,
    so that every episode and every evaluation trial throws (EVALUATION.md, "Task success")."""
    return limit if config.task.name != "throw" else xp.minimum(limit, config.task.release_s)


def eval_start_limits(spec: Spec, xp: Any) -> Any:
    """Per clip, evaluation start times are drawn in [0, this): the clip's duration (`start_limit`)."""
    return start_limit(spec.config, spec.lib.duration, xp)


def eval_horizon(spec: Spec, clip: Any, t: Any, xp: Any) -> Any:
    """Steps of the NR horizon from start time t: the time limit for a looping clip, to the clip's
    end otherwise, at least 1 (EVALUATION.md)."""
    to_end = xp.ceil((spec.lib.duration[clip] - t) / spec.control_dt - 1e-4).astype(xp.int32)
    return xp.where(spec.lib.loop[clip], spec.max_steps, xp.maximum(to_end, 1))


def max_eval_horizon(spec: Spec) -> int:
    """The longest NR horizon over the library's clips (the evaluation scan's length)."""
    lib = spec.lib
    bounds = [spec.max_steps if bool(lib.loop[c]) else int(np.ceil(float(lib.duration[c]) / spec.control_dt))
              for c in range(len(lib.duration))]
    return max(bounds)
